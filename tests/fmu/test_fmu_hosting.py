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


@pytest.mark.parametrize("name", ["CardanJoint", "DoubleCardanDriveline", "TwinJeffcottRotor", "RingCoupling"])
def test_outputs_read_before_the_next_input_are_at_the_motion_the_step_ended_with(fmu_dir, name):
    """A host that reads the outputs after a step and only then sets the next input (fmpy's simulate_fmu,
    libcosim) under a ramp omega_in = 40 + 30 t: the outputs are those at the input motion the step ended with,
    alpha_in = 30 and omega = omega_in + 30 h, which is what a host that sets omega_in first reads (the same
    motion): equal to round-off, step after step; not the held speed at alpha 0, which drops J alpha from
    tau_in."""
    log, h = [], 1e-3
    ramp = lambda t: 40.0 + 30.0 * t   # noqa: E731
    first, ordered = open_instance(fmu_dir, name, log, "reads_first"), open_instance(fmu_dir, name, log, "sets_first")
    try:
        names = outputs_of(first)
        for inst in (first, ordered):
            inst.initialize({})
            inst.set(omega_in=ramp(0.0), tau_load=0.2)
        for k in range(20):
            t0, t1 = k * h, (k + 1) * h
            for inst in (first, ordered):
                inst.set(omega_in=ramp(t0))
                inst.slave.doStep(t0, h)
            ordered.set(omega_in=ramp(t1))
            read_first, set_first = first.get(*names), ordered.get(*names)
            if k >= 2:   # the acceleration estimate has its history
                assert read_first[names.index("alpha_in")] == pytest.approx(30.0, rel=1e-9)
                for n, a, b in zip(names, read_first, set_first):
                    assert a == pytest.approx(b, rel=1e-9, abs=1e-12), (k, n)
    finally:
        first.free()
        ordered.free()
    assert not [m for m in log if "[error]" in m or "[fatal]" in m]


def test_a_straight_joint_read_first_gives_the_inertia_torque(fmu_dir):
    """The closed form through plain fmpy (``simulate_fmu`` reads the outputs before it sets the next input): a
    straight CardanJoint with J2 = 0.01 kg.m^2 under omega_in ramping at 30 rad/s^2 needs tau_in = (J1 + J2) 30
    and turns omega_out = omega_in."""
    import numpy as np
    from fmpy import read_model_description, simulate_fmu
    path = fmu_dir / "CardanJoint.fmu"
    j1 = next(float(v.start) for v in read_model_description(path).modelVariables if v.name == "J1")
    inputs = np.array([(0.0, 0.0, 0.0), (1.0, 30.0, 0.0)],
                      dtype=[("time", float), ("omega_in", float), ("tau_load", float)])
    result = simulate_fmu(path, stop_time=1.0, output_interval=1e-3, input=inputs, output=["tau_in", "alpha_in"],
                          start_values={"bend_angle": 0.0, "error_angle_beta": 0.0, "error_angle_gamma": 0.0,
                                        "J2": 0.01})
    assert result["time"][-1] == 1.0
    assert np.allclose(result["alpha_in"][3:], 30.0, rtol=1e-9)
    assert np.allclose(result["tau_in"][3:], (j1 + 0.01) * 30.0, rtol=1e-9)


@pytest.mark.parametrize("name, start", [("CardanJoint", {}), ("DoubleCardanDriveline", {}),
                                         ("RingCoupling", {}), ("TwinJeffcottRotor", {}),
                                         ("CardanJointTorqueDriven", {"omega_in_start": 50 * math.pi})])
def test_a_step_that_aliases_the_2x_order_is_said_once_to_the_host(fmu_dir, name, start):
    """At 1500 rpm = 50 pi rad/s the 2x order has a period of 0.02 s: a host stepping 0.01 s reads the outputs twice
    a period (Nyquist), one stepping 0.02 s once (one joint angle each time). The FMU says so once, as a warning
    naming the order, its frequency and a step that reads it 10 times a period, and keeps stepping; at 4 reads a
    period (0.005 s) and at 1 ms nothing is said. A torque-driven FMU checks its own input speed."""
    for h, said in ((0.001, False), (0.005, False), (0.01, True), (0.02, True)):
        log = []
        inst = open_instance(fmu_dir, name, log, f"alias{int(h * 1e3)}")
        try:
            inst.initialize(start)
            inputs = inputs_of(inst)
            for k in range(5):
                inst.set(**({"omega_in": 50 * math.pi} if "omega_in" in inputs else {}), tau_load=0.0)
                inst.slave.doStep(k * h, h)
            warnings = [m for m in log if m.startswith("[warning]") and "2x order" in m]
            assert len(warnings) == (1 if said else 0), (h, log)
            if said:
                text = warnings[0]
                assert "(50 Hz at 157.08 rad/s)" in text and "a step of at most 0.002 s reads it 10 times" in text
                assert f"reads the outputs {'twice' if h == 0.01 else 'once'} a period" in text
            assert not [m for m in log if "[error]" in m or "[fatal]" in m], log
        finally:
            inst.free()


@pytest.mark.parametrize("name", ["CardanJoint", "DoubleCardanDriveline", "Motor"])
def test_a_fixed_parameter_or_an_output_set_while_stepping_is_refused(fmu_dir, name):
    """FMI 2.0 lets a host set a fixed parameter only before fmi2ExitInitializationMode, and an output never: such a
    call while stepping fails with the reason in the log, the parameter keeps the value the model runs with (it
    would otherwise read back as set while the model ignored it), and setting a parameter to its current value
    stays harmless (hosts that re-send every start value)."""
    par, value = VARIED[name]
    log = []
    inst = open_instance(fmu_dir, name, log, "fixed")
    try:
        inst.initialize({par: value(1)})
        inputs = inputs_of(inst)
        for k in range(3):
            inst.set(**{n: INPUTS[n](k * 1e-3) for n in inputs})
            inst.slave.doStep(k * 1e-3, 1e-3)
        inst.set(**{par: value(1)})
        with pytest.raises(Exception):
            inst.set(**{par: value(2)})
        assert inst.get(par) == [value(1)]
        assert any(f"parameter {par} is fixed" in m for m in log), log
        output = outputs_of(inst)[0]
        with pytest.raises(Exception):
            inst.set(**{output: 1.0})
        assert any(f"{output} is an output" in m for m in log), log
    finally:
        inst.free()


@pytest.mark.parametrize("name", ["Motor", "DoubleCardanDriveline", "TwinJeffcottRotor",
                                  "TwinJeffcottRotorTorqueDriven"])
def test_steps_computed_as_differences_of_times_are_the_constant_step(fmu_dir, name):
    """A host that steps t_(k+1) - t_k with t_k = k dt (fmpy's simulate_fmu) passes steps that differ from dt in
    their last bits. The FMUs whose step operators or multistep history are made for a step length take such a step
    as the one before (``rk4.kept_substep``): the run is the constant-step run to 1e-10 of each output's size
    (measured 1.7e-12 at most). They had restarted their history at every such step (2660 restarts in 5000 steps
    of a stiff twin rotor, its dissipated energy 2% off; here 6e-6 to 1.3e-4 of an output's size)."""
    log, dt, n = [], 1e-3, 300
    exact = [k * dt for k in range(n + 1)]
    assert len({round((b - a) / dt - 1.0, 20) for a, b in zip(exact, exact[1:])}) > 1   # the steps do vary

    def run(steps):
        inst = open_instance(fmu_dir, name, log, "run")
        names, inputs = outputs_of(inst), inputs_of(inst)
        try:
            inst.initialize()
            rows = []
            for t0, h in zip(exact, steps):
                inst.set(**{v: INPUTS[v](t0) for v in inputs})
                inst.slave.doStep(t0, h)
                rows.append(inst.get(*names))
            return rows
        finally:
            inst.free()
    constant = run([dt] * n)
    jittered = run([b - a for a, b in zip(exact, exact[1:])])
    scale = [max(max(abs(row[i]) for row in constant), 1e-9) for i in range(len(constant[0]))]
    worst = max(abs(a - b) / s for r1, r2 in zip(constant, jittered) for a, b, s in zip(r1, r2, scale))
    assert worst < 1e-10, worst


@pytest.mark.parametrize("name", ["TwinJeffcottRotor", "Motor", "DoubleCardanDrivelineTorqueDriven", "Load"])
def test_a_step_that_does_not_start_where_the_last_ended_is_said_once(fmu_dir, name):
    """FMI leaves the time axis to the host: a step from elsewhere, without a saved state restored, is taken and
    said once, as a warning naming both times; a host's own time arithmetic (t_k = k h, which the FMU's t + h
    differs from in its last bits) and a step from a restored state are not."""
    h, log = 1e-3, []
    inst = open_instance(fmu_dir, name, log)
    inputs = inputs_of(inst)

    def step(t):
        inst.set(**{n: INPUTS[n](t) for n in inputs})
        inst.slave.doStep(t, h)

    def warnings():
        return [m for m in log if "[warning]" in m and "from the time of the FMU's state" in m]

    try:
        inst.initialize()
        for k in range(37):
            step(k * h)   # 0.001 * k: not the FMU's accumulated t + h in the last bits
        assert not warnings()
        saved = inst.slave.getFMUstate()
        step(40 * h)
        said = warnings()
        assert len(said) == 1 and "t = 0.04 s, forward" in said[0] and "(0.037 s: where the last step ended" in said[0]
        assert "skips or repeats 0.003 s" in said[0]
        step(10 * h)   # back: said once per instance
        step(11 * h)
        assert len(warnings()) == 1
        inst.slave.setFMUstate(saved)   # the state holds its own account: nothing said yet at 0.037 s
        step(37 * h)
        assert len(warnings()) == 1
        step(38 * h + 1e-7)   # a tenth of a microsecond is no rounding
        assert len(warnings()) == 2 and "skips or repeats 1e-07 s" in warnings()[1]
        inst.slave.setFMUstate(saved)
        step(20 * h)
        assert len(warnings()) == 3 and "t = 0.02 s, back" in warnings()[2]
        inst.slave.freeFMUstate(saved)
    finally:
        inst.free()


def test_calls_with_a_wrong_type_or_an_unknown_value_reference_are_refused_without_a_crash(fmu_dir, run_wrong_calls):
    """A host's fmi2SetReal on an Integer or Boolean variable, or a value reference no variable has, each refused
    (fmi2Fatal) naming the variable, its type and the call to use. Each had been pythonfmu's own TypeError or
    KeyError, whose objects it releases twice: the second such call crashed the host (SIGSEGV) at the next log
    message. The instance stays usable and is freed cleanly (exit status 0)."""
    calls = ("lambda: slave.setReal([vr['profile']], [2.0]), lambda: slave.setReal([vr['ideal_speed_source']], [1.0]), "
             "lambda: slave.getReal([9999]), lambda: slave.setReal([9999], [1.0]), "
             "lambda: slave.getBoolean([vr['omega_set']]), lambda: slave.setInteger([vr['omega_set']], [2]), "
             "lambda: slave.getString([vr['omega_set']]),")
    run_wrong_calls("FmuInstance", fmu_dir / "Motor.fmu", calls, (
        "fmi2SetReal: profile (value reference 4) is of type Integer, not Real: use fmi2SetInteger",
        "fmi2SetReal: ideal_speed_source (value reference 9) is of type Boolean, not Real: use fmi2SetBoolean",
        "fmi2GetReal: no variable has value reference 9999", "fmi2SetReal: no variable has value reference 9999",
        "fmi2GetBoolean: omega_set (value reference 5) is of type Real, not Boolean: use fmi2GetReal",
        "fmi2SetInteger: omega_set", "fmi2GetString: omega_set"))
