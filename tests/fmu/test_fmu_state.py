"""FMU state, for every FMU: get state, step on, set state, step again gives bitwise the same outputs; the same
through serialize / deserialize into a fresh instance; fmi2Reset returns to the initial state."""

import pytest
from fmu_helpers import INPUTS, inputs_of, outputs_of

from ujfmu.build import FMUS

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


@pytest.mark.parametrize("name", list(FMUS))
def test_serialized_state_continues_in_a_fresh_instance(open_fmu, name):
    inst = open_fmu(name, "original")
    inst.initialize()
    run(inst, 0, 40)
    state = inst.slave.getFMUstate()
    data = inst.slave.serializeFMUstate(state)
    inst.slave.freeFMUstate(state)
    first = run(inst, 40, 60)
    fresh = open_fmu(name, "fresh")
    fresh.initialize()
    restored = fresh.slave.deSerializeFMUstate(data)
    fresh.slave.setFMUstate(restored)
    fresh.slave.freeFMUstate(restored)
    assert run(fresh, 40, 60) == first


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
