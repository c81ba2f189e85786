"""FMU state, for every FMU: get state, step on, set state, step again gives bitwise the same outputs; the same
through serialize / deserialize into a fresh instance; fmi2Reset returns to the initial state."""

import pytest
from fmpy.fmi1 import FMICallException
from fmu_helpers import INPUTS, inputs_of, outputs_of

from ujfmu.build import FMUS, fmu_class

H = 1e-3


def run(inst, k0, n, h=H):
    """n steps from communication point k0; the outputs read after every step, as a list of tuples."""
    names = outputs_of(inst)
    inputs = inputs_of(inst)
    rows = []
    for k in range(k0, k0 + n):
        t = k * h
        inst.set(**{name: INPUTS[name](t) for name in inputs})
        inst.slave.doStep(t, h)
        rows.append(tuple(inst.get(*names)))
    return rows


@pytest.mark.parametrize("name", list(FMUS))
def test_declares_state_capabilities(open_fmu, name):
    cs = open_fmu(name).md.coSimulation
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate


@pytest.mark.parametrize("name", list(FMUS))
def test_get_set_state_repeats_the_steps_bitwise(open_fmu, name):
    inst = open_fmu(name, "original")
    inst.initialize()
    run(inst, 0, 40)
    state = inst.slave.getFMUstate()
    first = run(inst, 40, 60)
    inst.slave.setFMUstate(state)
    assert run(inst, 40, 60) == first
    inst.slave.setFMUstate(state)          # the same saved state, restored a second time
    assert run(inst, 40, 60) == first
    inst.slave.freeFMUstate(state)


@pytest.mark.parametrize("in_initialization", [False, True], ids=["after_initialization", "in_initialization"])
@pytest.mark.parametrize("name", list(FMUS))
def test_serialized_state_continues_in_a_fresh_instance(open_fmu, name, in_initialization):
    """A serialized state restored into a fresh instance continues bitwise: after its initialization, or in
    initialization mode, the restart sequence setupExperiment, enterInitializationMode, setFMUstate,
    exitInitializationMode (FMI 2.0 allows fmi2SetFMUstate there), whose exit does not start the model again from
    its start values."""
    inst = open_fmu(name, "original")
    inst.initialize()
    run(inst, 0, 40)
    state = inst.slave.getFMUstate()
    data = inst.slave.serializeFMUstate(state)
    inst.slave.freeFMUstate(state)
    first = run(inst, 40, 60)
    fresh = open_fmu(name, "fresh")
    if in_initialization:
        fresh.slave.setupExperiment(startTime=0.0)
        fresh.slave.enterInitializationMode()
    else:
        fresh.initialize()
    restored = fresh.slave.deSerializeFMUstate(data)
    fresh.slave.setFMUstate(restored)
    fresh.slave.freeFMUstate(restored)
    if in_initialization:
        fresh.slave.exitInitializationMode()
    assert run(fresh, 40, 60) == first


@pytest.mark.parametrize("name", ["DoubleCardanDrivelineTorqueDriven", "Motor"])
def test_a_step_from_a_state_saved_before_initialization_is_refused_naming_the_remedy(open_fmu, name):
    """A state saved in initialization mode holds no model state; restored into a stepping instance, a step from it
    is refused (fmi2Discard) with the reason and the remedy, where it had stepped on from what the instance held
    before; so is a step before fmi2ExitInitializationMode, also after an output read there (which computes the
    start: a host's trial had been told of a restored state saved after fmi2Terminate)."""
    inst = open_fmu(name, "rewound")
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    early = inst.slave.getFMUstate()
    inst.slave.exitInitializationMode()
    run(inst, 0, 20)
    inst.slave.setFMUstate(early)
    with pytest.raises(FMICallException):
        inst.slave.doStep(20 * H, H)
    assert any("not initialized" in m and "restore one saved after it" in m for m in inst._log), inst._log
    never = open_fmu(name, "uninitialized")
    never.slave.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException):
        never.slave.doStep(0.0, H)
    assert any("call fmi2ExitInitializationMode before fmi2DoStep" in m for m in never._log), never._log
    read = open_fmu(name, "read")
    read.slave.setupExperiment(startTime=0.0)
    read.get(outputs_of(read)[0])
    with pytest.raises(FMICallException):
        read.slave.doStep(0.0, H)
    assert any("call fmi2ExitInitializationMode before fmi2DoStep" in m for m in read._log), read._log
    assert not any("fmi2Terminate" in m for m in read._log), read._log
    rewound = open_fmu(name, "rewound_in_init")   # a state restored before the run started: still not started
    rewound.slave.setupExperiment(startTime=0.0)
    rewound.slave.enterInitializationMode()
    kept = rewound.slave.getFMUstate()
    rewound.slave.setFMUstate(kept)
    rewound.get(outputs_of(rewound)[0])
    with pytest.raises(FMICallException):
        rewound.slave.doStep(0.0, H)
    assert any("call fmi2ExitInitializationMode before fmi2DoStep" in m for m in rewound._log), rewound._log
    rewound.slave.freeFMUstate(kept)


@pytest.mark.parametrize("name", ["CardanJoint", "TwinJeffcottRotorTorqueDriven"])
def test_a_step_after_terminate_is_refused_and_reset_runs_again(open_fmu, name):
    """After fmi2Terminate the outputs stay readable (the run's last values) and a step is refused (fmi2Discard)
    naming fmi2Reset, also after restoring a state saved while stepping (FMI's state machine allows no step after
    fmi2Terminate); fmi2Reset and initialization run the same steps again."""
    inst = open_fmu(name, "ended")
    inst.initialize()
    first = run(inst, 0, 10)
    state = inst.slave.getFMUstate()
    inst.slave.terminate()
    assert tuple(inst.get(*outputs_of(inst))) == first[-1]
    for restore in (False, True):
        if restore:
            inst.slave.setFMUstate(state)
        with pytest.raises(FMICallException):
            inst.slave.doStep(10 * H, H)
    assert sum("the instance is terminated" in m and "fmi2Reset" in m for m in inst._log) == 2, inst._log
    ended = inst.slave.getFMUstate()   # saved after fmi2Terminate, restored into another, running instance
    other = open_fmu(name, "other")
    other.initialize()
    other.slave.setFMUstate(ended)
    with pytest.raises(FMICallException):
        other.slave.doStep(10 * H, H)
    assert any("was saved while no run was under way (after fmi2Terminate" in m and "fmi2Reset" in m
               for m in other._log), other._log
    inst.slave.freeFMUstate(ended)
    inst.slave.freeFMUstate(state)
    inst.slave.reset()
    inst.initialize()
    assert run(inst, 0, 10) == first


@pytest.mark.parametrize("name", list(FMUS))
def test_reset_returns_to_the_initial_state(open_fmu, name):
    inst = open_fmu(name)
    inst.initialize()
    first = run(inst, 0, 30)
    inst.slave.reset()
    inst.initialize()
    assert run(inst, 0, 30) == first


def test_state_includes_parameters_set_after_the_snapshot(open_fmu):
    """Restoring a state taken before a parameter change brings the old parameter back with it."""
    inst = open_fmu("Load")
    inst.initialize({"T0": 1.0})
    state = inst.slave.getFMUstate()
    before = run(inst, 0, 5)
    inst.slave.reset()
    inst.initialize({"T0": 2.0})
    assert run(inst, 0, 5) != before
    inst.slave.setFMUstate(state)
    assert run(inst, 0, 5) == before


def test_restore_rederives_when_a_parameter_changed_since_the_save(open_fmu):
    """A restore skips recomputing the parameters object only for a state saved under the derivation in place: the
    parameters a restored state brings (here another instance's, T0 = 2) must take effect, and a restore of this
    instance's own earlier state (T0 = 1) afterwards must bring its parameter back. Oracles: the run taken right
    after each save. A fixed parameter set while stepping is refused, the value kept."""
    inst = open_fmu("Load", "changed")
    inst.initialize({"T0": 1.0})
    run(inst, 0, 5)
    saved_with_1 = inst.slave.getFMUstate()
    with_1 = run(inst, 5, 5)
    with pytest.raises(Exception):
        inst.set(T0=2.0)
    assert inst.get("T0") == [1.0] and "parameter T0 is fixed" in "".join(inst._log)

    other = open_fmu("Load", "other")
    other.initialize({"T0": 2.0})
    run(other, 0, 5)
    saved_with_2 = other.slave.getFMUstate()
    with_2 = run(other, 5, 5)
    assert with_2 != with_1

    inst.slave.setFMUstate(saved_with_2)
    assert run(inst, 5, 5) == with_2
    inst.slave.setFMUstate(saved_with_1)
    assert run(inst, 5, 5) == with_1
    inst.slave.setFMUstate(saved_with_2)   # and back, each restore against the derivation of the one before
    assert run(inst, 5, 5) == with_2
    inst.slave.freeFMUstate(saved_with_1)
    other.slave.freeFMUstate(saved_with_2)


def test_a_state_of_another_instance_restores_its_parameters(open_fmu):
    """A state saved by one instance and restored into another of the same FMU with other parameters: the
    restored instance steps as the saving one (Motor: J_rotor and the PI gains set the dynamics)."""
    params = {"J_rotor": 0.05, "Kp": 0.8, "Ki": 4.0}
    first, second = open_fmu("Motor", "first"), open_fmu("Motor", "second")
    first.initialize(params)
    second.initialize({"J_rotor": 0.2, "Kp": 0.3, "Ki": 1.0})
    run(first, 0, 20)
    run(second, 0, 20)
    state = first.slave.getFMUstate()
    expected = run(first, 20, 30)
    second.slave.setFMUstate(state)
    first.slave.freeFMUstate(state)
    assert run(second, 20, 30) == expected


def test_a_restore_under_the_same_derivation_keeps_the_derived_attributes():
    """Python level: restoring a state this instance saved with its parameters unchanged keeps the parameters
    object (no recomputation); the same state through serialization is recomputed, to an equal object."""
    cls = fmu_class("Motor")
    inst = cls(instance_name="py")
    inst.exit_initialization_mode()
    assert inst.do_step(0.0, H)
    state = inst._get_fmu_state()
    derived = inst._p
    assert inst.do_step(H, H)
    inst._set_fmu_state(state)
    assert inst._p is derived
    inst._set_fmu_state(cls._fmu_state_from_bytes(cls._fmu_state_to_bytes(state)))
    assert inst._p is not derived and inst._p == derived


@pytest.mark.parametrize("name", ["TwinJeffcottRotor", "TwinJeffcottRotorTorqueDriven"])
def test_a_multistep_history_is_restored_with_the_state(name):
    """Python level: the twin rotors step with an exponential Adams method whose history of the equations' values
    is FMU state (``_history``, full after six steps). Restoring a state saved with a full history, in memory or
    through serialization into a fresh instance, repeats the next steps' model states bitwise; the same state with
    its history emptied steps differently (ETDRK4-B restarts), so the repeat is the restored history's doing."""
    cls = fmu_class(name)
    inputs = [v.name for v in cls.VARIABLES if v.causality == "input"]

    def run_py(inst, k0, n):
        """n steps from communication point k0; the model state after every step."""
        rows = []
        for k in range(k0, k0 + n):
            for input_name in inputs:
                setattr(inst, input_name, INPUTS[input_name](k * H))
            assert inst.do_step(k * H, H)
            rows.append(inst._y)
        return rows

    inst = cls(instance_name="py")
    inst.exit_initialization_mode()
    run_py(inst, 0, 40)
    assert inst._history[2] == inst.PHYSICS.HISTORY_POINTS   # the history full: the Adams steps run
    state = inst._get_fmu_state()
    first = run_py(inst, 40, 20)
    inst._set_fmu_state(state)
    assert run_py(inst, 40, 20) == first
    fresh = cls(instance_name="fresh")
    fresh.exit_initialization_mode()
    fresh._set_fmu_state(cls._fmu_state_from_bytes(cls._fmu_state_to_bytes(state)))
    assert run_py(fresh, 40, 20) == first
    inst._set_fmu_state(state)
    inst._history = inst.MODEL.NO_HISTORY
    assert run_py(inst, 40, 20) != first


def test_a_prescribed_input_fmu_without_the_input_shafts_outputs_is_refused_at_declaration():
    """A speed-driven FMU computes phi_in and alpha_in with every output; one that does not declare them could
    not save its state (fmi2GetFMUstate refuses undeclared attributes), so the class is refused where it is
    declared, naming them."""
    from ujfmu.fmu.base import PrescribedInputSlave
    from ujfmu.models.cardan_joint.fmu import CardanJoint
    variables = tuple(v for v in CardanJoint.VARIABLES if v.name not in ("phi_in", "alpha_in"))
    with pytest.raises(TypeError, match="declares the outputs phi_in, alpha_in"):
        type("Bare", (PrescribedInputSlave,), {"__module__": __name__, "VARIABLES": variables})
    type("Full", (PrescribedInputSlave,), {"__module__": __name__, "VARIABLES": CardanJoint.VARIABLES})
