"""Long runs: 5 x 10^5 communication steps of 1 ms (5,000 revolutions at 600 rpm) per FMU, in ten chunks of exactly
500 revolutions. In the periodic steady state every chunk must end in the same state: the torques and
displacements repeat, the continuous angles advance by exactly 500 turns (only round-off growth allowed), the
work per step does not grow, and neither does the process's memory.

Work is counted, not timed: over one revolution after the first chunk and one after the last, the Python lines the
FMU executes and the calls it makes (sys.settrace sees the FMU's code, which runs in this interpreter) and the size
of its serialized FMU state. A per-step cost that grows with the run (a history kept and scanned, a list that
grows) changes those counts; a busy machine does not."""

import gc
import math
import sys
from pathlib import Path

import pytest
from fmpy.fmi2 import fmi2Real, fmi2ValueReference
from fmu_helpers import open_instance

from ujfmu.build import FMUS

OMEGA = 20.0 * math.pi            # 600 rpm: 10 turns per second
H, CHUNK, CHUNKS = 1e-3, 50_000, 10
TURNS_PER_CHUNK = OMEGA * CHUNK * H / (2.0 * math.pi)   # 500
EPS = 2.0 ** -52
INPUTS = {"omega_in": OMEGA, "omega": OMEGA, "tau_load": 0.2, "phi": 0.0}
#: parameters for a steady periodic state: the motor holds 600 rpm, the ring coupling is damped (10%)
PARAMETERS = {"Motor": {"omega_set": OMEGA, "tau_max": 50.0},
              "RingCoupling": {"c_d": 0.2 * math.sqrt(726.4294875418636 * 0.1)}}


STEPS_PER_TURN = int(round(2.0 * math.pi / (OMEGA * H)))   # 100


def rss_mb():
    return int(Path("/proc/self/statm").read_text().split()[1]) * 4096 / 2**20


#: the torque-driven variants and their controller have no periodic steady state under constant inputs (the
#: input shaft accelerates unless tau_in balances the load exactly); their integrated angles and states use the
#: same RK4 and plain sums as the flexible models here, and 5 x 10^5 more steps each would cost ~15 s of suite time
NO_STEADY_STATE = {"CardanJointTorqueDriven", "DoubleCardanDrivelineTorqueDriven", "TwinJeffcottRotorTorqueDriven",
                   "RingCouplingTorqueDriven", "MotorController"}


class WorkCounter:
    """Counts the Python lines executed and functions called while active (sys.settrace). The garbage collector
    is run before and paused while counting: a collection inside the window would run the weakref callbacks of
    objects other tests left behind (Python code, counted), a few lines now and then."""

    def __init__(self):
        self.counts = {"line": 0, "call": 0}

    def _trace(self, frame, event, arg):
        if event in self.counts:
            self.counts[event] += 1
        return self._trace

    def __enter__(self):
        gc.collect()
        gc.disable()
        sys.settrace(self._trace)
        return self

    def __exit__(self, *exc):
        sys.settrace(None)
        gc.enable()


@pytest.mark.parametrize("name", [n for n in FMUS if n not in NO_STEADY_STATE])
def test_half_a_million_steps_repeat_the_steady_state_without_drift_slowdown_or_growth(fmu_dir, name):
    inst = open_instance(fmu_dir, name, [], "long")
    md = inst.md
    try:
        inst.initialize(PARAMETERS.get(name, {}))
        inputs = [v for v in md.modelVariables if v.causality == "input"]
        outputs = [v for v in md.modelVariables if v.causality == "output"]
        in_vr = (fmi2ValueReference * len(inputs))(*[v.valueReference for v in inputs])
        in_val = (fmi2Real * len(inputs))(*[INPUTS[v.name] for v in inputs])
        out_vr = (fmi2ValueReference * len(outputs))(*[v.valueReference for v in outputs])
        out_val = (fmi2Real * len(outputs))()
        set_real, do_step, get_real = (inst.raw(f) for f in ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal"))
        comp = inst.slave.component
        ends, work, memory = [], [], []
        k = 0

        def steps(n):
            nonlocal k
            for _ in range(n):
                assert set_real(comp, in_vr, len(inputs), in_val) == 0
                assert do_step(comp, k * H, H, 1) == 0, inst._log[-3:]
                k += 1

        for chunk in range(CHUNKS):
            if chunk in (1, CHUNKS - 1):   # one revolution, at the same phase, counted
                with WorkCounter() as counter:
                    steps(STEPS_PER_TURN)
                state = inst.slave.getFMUstate()
                work.append((counter.counts, len(inst.slave.serializeFMUstate(state))))
                inst.slave.freeFMUstate(state)
                steps(CHUNK - STEPS_PER_TURN)
            else:
                steps(CHUNK)
            assert get_real(comp, out_vr, len(outputs), out_val) == 0
            memory.append(rss_mb())
            ends.append(list(out_val))
    finally:
        inst.free()

    names = [v.name for v in outputs]
    for i, out in enumerate(names):
        values = [end[i] for end in ends[1:]]   # from 500 turns on: steady
        assert all(math.isfinite(v) for v in values), out
        if out.startswith("phi"):
            # continuous angles: exactly 500 turns per chunk, but for round-off growth: a plain sum of 5 x 10^4
            # steps (up to 8 integrator additions each) at |phi| up to 3.1e4 rad may drift by N eps |phi|
            growth = 8 * CHUNK * EPS * max(abs(v) for v in values) / (2.0 * math.pi)
            turns = [(b - a) / (2.0 * math.pi) for a, b in zip(values, values[1:])]
            assert max(abs(t - TURNS_PER_CHUNK) for t in turns) < growth, (out, turns, growth)
        elif out not in ("dissipated_energy", "input_work"):   # accumulating by design
            # the state repeats; what differs is the round-off of 3e4 rad angles (eps |phi| = 7e-12 rad) times
            # the shaft stiffnesses: 1e-7 of the signal at most (TwinJeffcottRotor's tau_in)
            scale = max(abs(v) for v in values) or 1.0
            assert max(values) - min(values) <= 1e-6 * scale + 1e-12, (out, values)
    # no slowdown: the same work per revolution (lines, calls: the FMU's code and this loop's, nothing else runs
    # Python between the steps) on the same amount of state, 450,000 steps apart; and flat memory
    (early, early_state), (late, late_state) = work
    assert early["line"] > 20 * STEPS_PER_TURN, early   # the counter does see the FMU's code
    assert late == early, (early, late)
    # the serialized state writes floats as text, whose length varies by a few characters per value; a history
    # kept per step would add 450,000 entries
    assert abs(late_state - early_state) <= 256, (early_state, late_state)
    assert memory[-1] - memory[1] < 5.0, memory
