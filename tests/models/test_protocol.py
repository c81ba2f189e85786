"""Every model implements the protocol of ujfmu.models.protocol, and its FMU module is its declaration only."""

import dataclasses
import inspect

import pytest

from ujfmu.build import FMUS, fmu_class
from ujfmu.fmu.base import ModelSlave, PrescribedInputSlave, drive_derivatives, model_parameters
from ujfmu.models.protocol import Drive

MODEL_FMUS = [name for name in FMUS if issubclass(fmu_class(name), ModelSlave)]


def test_every_model_fmu_is_a_protocol_fmu():
    assert sorted(MODEL_FMUS) == ["CardanJoint", "CardanJointTorqueDriven", "DoubleCardanDriveline",
                                  "DoubleCardanDrivelineTorqueDriven", "Load", "Motor", "MotorController",
                                  "RingCoupling", "RingCouplingTorqueDriven", "TwinJeffcottRotor",
                                  "TwinJeffcottRotorTorqueDriven"]


@pytest.mark.parametrize("name", MODEL_FMUS)
def test_lateral_states_are_state_fields_and_every_variant_of_a_bending_model_declares_them(name):
    """LATERAL_STATES names fields of the model's State (a misspelt one would silently make every mode torsional),
    and a torque-driven variant declares the same as its speed-driven model (a variant without them had called the
    twin rotor's Jeffcott modes torsional)."""
    model = fmu_class(name).MODEL
    lateral = getattr(model, "LATERAL_STATES", ())
    assert set(lateral) <= set(model.State._fields)
    speed_driven = name.removesuffix("TorqueDriven")
    if speed_driven != name:
        assert lateral == getattr(fmu_class(speed_driven).MODEL, "LATERAL_STATES", ())


@pytest.mark.parametrize("name", MODEL_FMUS)
def test_parameters_are_the_fmu_parameters_by_name(name):
    cls = fmu_class(name)
    fields = {f.name for f in dataclasses.fields(cls.MODEL.Parameters) if f.init}
    assert fields == {v.name for v in cls.VARIABLES if v.causality == "parameter"}


@pytest.mark.parametrize("name", MODEL_FMUS)
def test_outputs_are_the_declared_outputs_by_name(name):
    """At the declared defaults and some inputs: outputs() gives every declared output (the input shaft's angle and
    acceleration come from the base), initial_state() is a State, derivatives() one rate per state entry."""
    cls = fmu_class(name)
    model = cls.MODEL
    defaults = type("Defaults", (), {v.name: v.start for v in cls.VARIABLES})()
    p = model_parameters(model, defaults)
    assert model.check(p) == []
    u = Drive(0.3, 20.0, 5.0, 1.5) if issubclass(cls, PrescribedInputSlave) else model.Inputs(
        *(1.5 for _ in model.Inputs._fields))
    y = model.initial_state(p, 0.0, u)
    assert isinstance(y, model.State) and len(model.derivatives(p, 0.0, y, u)) == len(y)
    declared = {v.name for v in cls.VARIABLES if v.causality == "output"}
    from_base = {"phi_in", "alpha_in"} if issubclass(cls, PrescribedInputSlave) else set()
    assert set(model.outputs(p, 0.0, y, u)) == declared - from_base
    assert model.rate_bound(p, y, 20.0) >= 0.0


@pytest.mark.parametrize("name", MODEL_FMUS)
def test_fmu_module_is_a_declaration(name):
    """The FMU class holds the model, its variables and default experiment, and at most how it reads its inputs:
    no physics, no stepping, no output assignment of its own. Its model is its folder's model.py, or a variant's
    protocol class in it."""
    cls = fmu_class(name)
    methods = {k for k, v in vars(cls).items() if inspect.isfunction(v)}
    assert methods <= {"model_inputs"}, methods
    assert {k for k in vars(cls) if not k.startswith("_")} <= {"MODEL", "VARIABLES", "DEFAULT_EXPERIMENT", "PHYSICS",
                                                              "STATE", "ACCELERATION_ORDER", "model_inputs"}
    assert inspect.getmodule(cls.MODEL).__name__ == cls.__module__.rsplit(".", 1)[0] + ".model"


@pytest.mark.parametrize("name", [n for n in MODEL_FMUS if issubclass(fmu_class(n), PrescribedInputSlave)])
def test_drive_derivatives_are_the_derivatives_at_the_drive(name):
    """The plain-float form the FMU integrates (its own, or the base's from derivatives) gives exactly the
    derivatives at the same Drive, at a state off equilibrium."""
    cls = fmu_class(name)
    model = cls.MODEL
    p = model_parameters(model, type("Defaults", (), {v.name: v.start for v in cls.VARIABLES})())
    u = Drive(0.3, 20.0, 5.0, 1.5)
    y = tuple(x + 0.01 * (i + 1) for i, x in enumerate(model.initial_state(p, 0.0, u)))
    assert drive_derivatives(model)(p, 0.4, y, *u) == model.derivatives(p, 0.4, y, u)


def test_check_messages_name_the_parameters():
    """check() returns the messages for invalid combinations (the ranges of single parameters are declared)."""
    ring = fmu_class("RingCoupling").MODEL
    p = ring.Parameters(R=0.1, d=0.003, E=2.1e11, e=0.2, I1=0.0, I2=0.05, c_s=0.0, c_d=0.0)
    (message,) = ring.check(p)
    assert "e = 0.2 m" in message and "R = 0.1 m" in message


def model_at_a_state(name: str, switch: str, on: bool) -> tuple:
    """(model, p, u, y) of FMU name at its start values, with parameter ``switch`` set to ``on`` (pytest skips the
    second value of a model without it), inputs u and a state y near the initial one."""
    cls = fmu_class(name)
    model = cls.MODEL
    values = {v.name: v.start for v in cls.VARIABLES}
    if switch in values:
        values[switch] = on
    elif on:
        pytest.skip("one parameter set")
    p = model_parameters(model, type("Values", (), values)())
    prescribed = issubclass(cls, PrescribedInputSlave)
    u = Drive(0.3, 20.0, 5.0, 1.5) if prescribed else model.Inputs(*(1.5 for _ in model.Inputs._fields))
    y = tuple(x + 0.01 * (i + 1) for i, x in enumerate(model.initial_state(p, 0.0, u)))
    return model, p, u, y


@pytest.mark.parametrize("name", MODEL_FMUS)
@pytest.mark.parametrize("rigid", [False, True])
def test_output_free_inputs_change_neither_outputs_nor_start(name, rigid):
    """An input a model declares output-free (the FMU keeps its outputs when the host sets it) changes neither the
    outputs at any state nor the initial state; one that does change them is not declared (the double Cardan's
    flange torque tau_out carries tau_load, and a rigid shaft's tau_in rho tau_load)."""
    model, p, u, y = model_at_a_state(name, "rigid_intermediate_shaft", rigid)
    free = tuple(getattr(model, "output_free_inputs", lambda p: ())(p))
    for field in free:
        assert field in model.Inputs._fields and field in {v.name for v in fmu_class(name).VARIABLES
                                                           if v.causality == "input"}
        changed = u._replace(**{field: getattr(u, field) + 7.0})
        assert model.outputs(p, 0.0, y, changed) == model.outputs(p, 0.0, y, u)
        assert model.initial_state(p, 0.0, changed) == model.initial_state(p, 0.0, u)
    if name.startswith("DoubleCardanDriveline"):
        assert free == ()
        changed = u._replace(tau_load=u.tau_load + 7.0)
        assert model.outputs(p, 0.0, y, changed)["tau_out"] != model.outputs(p, 0.0, y, u)["tau_out"]


@pytest.mark.parametrize("name", [n for n in MODEL_FMUS if hasattr(fmu_class(n).MODEL, "load_outputs")])
@pytest.mark.parametrize("switch", ["ideal_speed_source", "rigid_intermediate_shaft"])
@pytest.mark.parametrize("ideal", [False, True])
def test_load_outputs_are_every_output_that_moves_with_the_load_inputs(name, switch, ideal):
    """load_outputs gives exactly the outputs' values for its names (``load_output_names`` where the model gives
    them: a read of none of them computes nothing), and every output it leaves out is the same at another value of
    any of the FMU's LOAD_INPUTS (tau_load; a torque-driven FMU's tau_in and tau_load: the FMU keeps those outputs
    when only these inputs changed); the Motor's ideal source's tau_motor moves."""
    model, p, u, y = model_at_a_state(name, switch, ideal)
    if hasattr(model, "load_output_names"):
        assert set(model.load_output_names(p)) == set(model.load_outputs(p, 0.4, y, u))
    moved = set()
    for field in fmu_class(name).LOAD_INPUTS:
        changed = u._replace(**{field: getattr(u, field) + 7.0})
        for inputs in (u, changed):
            load = model.load_outputs(p, 0.4, y, inputs)
            full = model.outputs(p, 0.4, y, inputs)
            assert load == {k: full[k] for k in load}
        moved |= {k for k, v in model.outputs(p, 0.4, y, changed).items() if v != model.outputs(p, 0.4, y, u)[k]}
    assert moved <= set(model.load_outputs(p, 0.4, y, u))   # an output may stand still at these parameters
    assert ("tau_motor" in moved) == ideal if name == "Motor" else moved


@pytest.mark.parametrize("name", [n for n in MODEL_FMUS if hasattr(fmu_class(n).MODEL, "state_outputs")])
@pytest.mark.parametrize("rigid", [False, True])
def test_state_outputs_are_the_outputs_without_feedthrough_at_any_inputs(name, rigid):
    """state_outputs gives exactly the outputs' values for its STATE_OUTPUTS (the FMU computes only these on a read
    of only these), at two sets of inputs: none depends on an input, as the FMU declares them (no direct
    feedthrough); a double Cardan driveline with either shaft."""
    model, p, u, y = model_at_a_state(name, "rigid_intermediate_shaft", rigid)
    names = model.STATE_OUTPUTS
    declared = {v.name: v for v in fmu_class(name).VARIABLES if v.causality == "output"}
    assert set(names) <= set(declared) and not any(declared[k].depends_on for k in names)
    for inputs in (u, u._replace(**{field: getattr(u, field) + 7.0 for field in u._fields})):
        full = model.outputs(p, 0.4, y, inputs)
        assert model.state_outputs(p, 0.4, y) == {k: full[k] for k in names}


@pytest.mark.parametrize("name", [n for n in MODEL_FMUS if hasattr(fmu_class(n).MODEL, "light_outputs")])
def test_light_outputs_are_the_outputs_they_name_at_any_inputs(name):
    """light_outputs gives exactly the outputs' values for its LIGHT_OUTPUTS (the FMU computes only these on a read
    of only these), at two sets of inputs, and leaves out the outputs that need the joint (the twin rotor); a model
    with them has no load_outputs (the protocol's rule)."""
    model, p, u, y = model_at_a_state(name, "rigid_intermediate_shaft", False)
    names = model.LIGHT_OUTPUTS
    declared = {v.name for v in fmu_class(name).VARIABLES if v.causality == "output"}
    assert set(names) < declared and len(set(names)) == len(names)
    assert not {"secondary_shaft_torque", "stored_energy"} & set(names)
    assert not hasattr(model, "load_outputs")   # a light read before the load inputs are set would cost a full one
    for inputs in (u, u._replace(**{field: getattr(u, field) + 7.0 for field in u._fields})):
        full = model.outputs(p, 0.4, y, inputs)
        assert model.light_outputs(p, 0.4, y, inputs) == {k: full[k] for k in names}


def test_the_speed_driven_twin_rotor_has_light_outputs():
    """The speed-driven twin rotor declares light outputs (the test above would pass over a model that lost them).
    The torque-driven one does not: its host reads the input speed before it sets the torques, and a light read
    there would leave every output stale, where a full one leaves only the torques' outputs to recompute after."""
    assert hasattr(fmu_class("TwinJeffcottRotor").MODEL, "light_outputs")
    assert not hasattr(fmu_class("TwinJeffcottRotorTorqueDriven").MODEL, "light_outputs")


@pytest.mark.parametrize("name, angle", [("CardanJoint", "bend_angle"), ("CardanJointTorqueDriven", "bend_angle"),
                                         ("DoubleCardanDriveline", "beta1"), ("DoubleCardanDriveline", "beta2"),
                                         ("TwinJeffcottRotor", "beta"), ("TwinJeffcottRotorTorqueDriven", "beta")])
def test_a_joint_angle_past_45_deg_asks_whether_degrees_were_meant(name, angle):
    """bend_angle = 1.2 (meant as 1.2 deg) had run a 68.8 deg joint without a word: each joint model's advice
    names an angle past 45 deg, its speed-ratio swing cos(b) .. 1/cos(b), and the value in rad had it been
    degrees; 30 deg (Feng's joint) and -45 deg draw none."""
    import math
    cls = fmu_class(name)
    values = {v.name: v.start for v in cls.VARIABLES if v.causality == "parameter"}
    if name.startswith("CardanJoint"):
        values.update(error_angle_beta=0.0, error_angle_gamma=0.0)
    names = [f.name for f in dataclasses.fields(cls.MODEL.Parameters) if f.init]

    def p_of(value):
        return cls.MODEL.Parameters(**{n: {**values, angle: value}[n] for n in names})
    (message,) = [m for m in cls.MODEL.advice(p_of(1.2)) if m.startswith(f"{angle} = ")]
    assert "68.75 deg" in message and "between 0.362 and 2.76" in message and f"{angle} = 0.020944 rad" in message
    assert not [m for m in cls.MODEL.advice(p_of(math.radians(30.0))) if m.startswith(f"{angle} = ")]
    assert not [m for m in cls.MODEL.advice(p_of(-math.radians(45.0))) if m.startswith(f"{angle} = ")]


@pytest.mark.parametrize("name, angle", [("DoubleCardanDriveline", "yoke_phase"),
                                         ("DoubleCardanDriveline", "joint_plane_angle"),
                                         ("DoubleCardanDrivelineTorqueDriven", "yoke_phase")])
def test_a_phase_of_whole_radians_asks_whether_degrees_were_meant(name, angle):
    """yoke_phase = 3.0 (meant as 3 deg) had run yokes 172 deg apart without a word (a first-day trial): a phase
    that is a whole number of radians from 1 on names its degrees and the value had it been degrees; a phase in
    radians (0, pi/6, pi/2, -1.5) draws none."""
    import math
    cls = fmu_class(name)
    values = {v.name: v.start for v in cls.VARIABLES if v.causality == "parameter"}
    names = [f.name for f in dataclasses.fields(cls.MODEL.Parameters) if f.init]

    def p_of(value):
        return cls.MODEL.Parameters(**{n: {**values, angle: value}[n] for n in names})
    (message,) = [m for m in cls.MODEL.advice(p_of(3.0)) if m.startswith(f"{angle} = ")]
    assert "171.9 deg" in message and f"{angle} = 0.0523599 rad" in message
    for value in (0.0, math.pi / 6, math.pi / 2, -1.5):
        assert not [m for m in cls.MODEL.advice(p_of(value)) if m.startswith(f"{angle} = ")], value


def test_a_steep_joint_angle_is_said_and_a_typed_one_also_read_as_degrees():
    """A joint angle past 45 deg is valid but steep: said with its speed ratio's swing, cos(beta) to 1/cos(beta).
    A number of a few decimals (1.4) may be degrees typed as radians: it also says what 1.4 deg is; one converted
    from degrees (80deg on the command line: 1.3962634... rad) is not taken for that."""
    from ujfmu.models.protocol import joint_angle_advice
    import math
    (typed,) = joint_angle_advice("beta", 1.4)
    assert f"between {math.cos(1.4):.3g} and {1.0 / math.cos(1.4):.3g}" in typed
    assert f"if the value was meant in degrees, beta = {math.radians(1.4):.6g} rad" in typed
    for degrees in (80.0, 50.3, 80.3):   # 50.3 and 80.3 had passed a tolerance that grew with the angle
        (converted,) = joint_angle_advice("beta", math.radians(degrees))
        assert f"{degrees:g} deg" in converted and "meant in degrees" not in converted
    assert joint_angle_advice("beta", math.radians(44.0)) == []
