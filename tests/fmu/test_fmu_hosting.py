"""What a system simulator does that our master does not: varying communication steps, and many instances of one
FMU in one process with different parameters, stepped interleaved."""

import math
import random

import pytest
from fmu_helpers import INPUTS, inputs_of, open_instance, outputs_of

#: one parameter per FMU to vary across instances: name, value for instance i
VARIED = {
    "CardanJoint": ("bend_angle", lambda i: math.radians(5.0 + 0.5 * i)),
    "Motor": ("accel", lambda i: 20.0 + i),
    "Load": ("T0", lambda i: 0.1 * i),
    "DoubleCardanDriveline": ("k_theta", lambda i: 60.0 + 2.0 * i),
    "TwinJeffcottRotor": ("beta", lambda i: math.radians(0.3 * i)),
    "RingCoupling": ("e", lambda i: 1e-3 * (1 + i)),
}


def step_all(insts, times):
    """Step every instance over the given communication points, interleaved; the outputs after each step."""
    names = outputs_of(insts[0])
    inputs = inputs_of(insts[0])
    rows = [[] for _ in insts]
    for t0, t1 in zip(times[:-1], times[1:]):
        for inst, out in zip(insts, rows):
            inst.set(**{n: INPUTS[n](t0) for n in inputs})
            inst.slave.doStep(t0, t1 - t0)
            out.append(tuple(inst.get(*names)))
    return rows


@pytest.mark.parametrize("name", list(VARIED))
def test_fifty_interleaved_instances_each_match_a_lone_instance(fmu_dir, name):
    par, value = VARIED[name]
    log, times = [], [k * 1e-3 for k in range(31)]
    many = [open_instance(fmu_dir, name, log, f"{name.lower()}{i}") for i in range(50)]
    try:
        for i, inst in enumerate(many):
            inst.initialize({par: value(i)})
        together = step_all(many, times)
    finally:
        for inst in many:
            inst.free()
    assert not [m for m in log if "[error]" in m or "[fatal]" in m]
    assert len({rows[-1] for rows in together}) == 50 or name == "Load"   # the parameters do matter
    for i in range(50):
        lone = open_instance(fmu_dir, name, log, "lone")
        try:
            lone.initialize({par: value(i)})
            assert step_all([lone], times)[0] == together[i], f"instance {i}"
        finally:
            lone.free()


def random_grid(stop, h, seed):
    """Communication points with steps drawn uniformly in [h/2, 3h/2], ending exactly at stop."""
    rng = random.Random(seed)
    times = [0.0]
    while stop - times[-1] > 1.5 * h:
        times.append(times[-1] + h * rng.uniform(0.5, 1.5))
    times.append(stop)
    return times


@pytest.mark.parametrize("name", ["CardanJoint", "Motor", "DoubleCardanDriveline", "TwinJeffcottRotor",
                                  "RingCoupling"])
def test_randomly_varying_steps_converge_to_the_fixed_step_result(fmu_dir, name):
    """Inputs held over each step make the result first order in the step: the error at the end against a
    fine fixed-step run falls at least 3x when the mean step falls 4x."""
    stop, log = 0.3, []

    def final(times):
        inst = open_instance(fmu_dir, name, log, "run")
        try:
            inst.initialize()
            return step_all([inst], times)[0][-1]
        finally:
            inst.free()

    fine = final([k * 5e-5 for k in range(int(round(stop / 5e-5)) + 1)])
    scale = [max(abs(v), 1e-9) for v in fine]
    errors = []
    for h in (4e-3, 1e-3):
        result = final(random_grid(stop, h, seed=7))
        errors.append(max(abs(a - b) / s for a, b, s in zip(result, fine, scale)))
    assert all(math.isfinite(e) for e in errors)
    assert errors[1] < errors[0] / 3, errors
