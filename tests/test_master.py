"""Master: feedthrough ordering, algebraic loops, clear errors."""

import numpy as np
import pytest

from ujfmu import battery
from ujfmu.master import (Component, Connection, Cosimulation, CosimulationError, CouplingInstabilityError,
                          cosimulate)
from ujfmu.scenario import Scenario


def chain(fmu_dir):
    return [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=0, omega_set=50.0)),
            Component("joint", fmu_dir / "CardanJoint.fmu", {}),
            Component("load", fmu_dir / "Load.fmu", dict(T0=0.3))]


CONNECTIONS = [Connection("motor.omega", "joint.omega_in"), Connection("joint.tau_in", "motor.tau_load"),
               Connection("joint.omega_out", "load.omega"), Connection("load.tau", "joint.tau_load")]


def test_feedthrough_is_consistent_at_every_communication_point(fmu_dir):
    """Ordered transfers: load.tau = f(joint.omega_out) and joint.tau_in = r * load.tau at the same instant."""
    table = cosimulate(chain(fmu_dir), CONNECTIONS[::-1], 0.2, 1e-3,
                       ["joint.omega_out", "load.tau", "joint.tau_in", "joint.M_z", "motor.tau_motor"])
    w = table["joint.omega_out"]
    np.testing.assert_allclose(table["load.tau"], 0.3 * w / np.sqrt(w * w + 0.01), rtol=1e-14)
    np.testing.assert_allclose(table["joint.M_z"], table["load.tau"], rtol=1e-14)
    np.testing.assert_allclose(table["motor.tau_motor"], table["joint.tau_in"], rtol=1e-14)


def test_algebraic_loop_is_reported(fmu_dir):
    comps = [Component("a", fmu_dir / "CardanJoint.fmu", {}), Component("b", fmu_dir / "CardanJoint.fmu", {})]
    loop = [Connection("a.omega_out", "b.omega_in"), Connection("b.omega_out", "a.omega_in")]   # both feed through
    with pytest.raises(CosimulationError, match="algebraic loop"):
        cosimulate(comps, loop, 0.01, 1e-3, ["a.tau"])


def test_missing_fmu_and_bad_step_are_clear_errors(fmu_dir, tmp_path):
    with pytest.raises(CosimulationError, match="not found"):
        cosimulate([Component("m", tmp_path / "Nope.fmu", {})], [], 0.01, 1e-3, [])
    with pytest.raises(CosimulationError, match="whole number"):
        cosimulate(chain(fmu_dir), CONNECTIONS, 0.0105, 1e-3, [])
    with pytest.raises(CosimulationError, match=r"stop_time = nan s must be a finite number"):
        cosimulate(chain(fmu_dir), CONNECTIONS, float("nan"), 1e-3, [])   # had been a bare ValueError from int()
    with pytest.raises(CosimulationError, match=r"stop_time = 0.0 s must be after start_time = 0.5 s"):
        cosimulate(chain(fmu_dir), CONNECTIONS, 0.0, 1e-3, [], start_time=0.5)
    with pytest.raises(CosimulationError, match=r"more than the 1e\+09 a run may take"):   # an OverflowError from int()
        cosimulate(chain(fmu_dir), CONNECTIONS, 1.0, 1e-320, [])
    with pytest.raises(CosimulationError, match=r"no variable 'omega_ot' \(did you mean 'joint.omega_out'\?\)"):
        cosimulate(chain(fmu_dir), CONNECTIONS, 0.01, 1e-3, ["joint.omega_ot"])   # a record set from Python


def test_invalid_parameter_surfaces_with_fmu_log(fmu_dir):
    comps = chain(fmu_dir)
    comps[1].parameters["J2"] = -1.0
    with pytest.raises(CosimulationError, match="J2"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, [])


def test_recorded_time_and_columns_align_with_the_closed_form(fmu_dir):
    """An ideal ramp from t0 = 0.25 s: every row is the state at its own time, t_k = t0 + k h, with
    omega = a t, phi = a (t^2 - t0^2)/2, theta1 = the same, and the Hooke joint's omega_out = r(theta1) omega (bend
    phi only). A time column or a recorded column shifted by one step is off by a h (or more) and fails."""
    a, h, t0, phi = 40.0, 1e-3, 0.25, np.radians(30)
    comps = [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=1, accel=a,
                                                            omega_set=1e3, tau_load=0.0)),
             Component("joint", fmu_dir / "CardanJoint.fmu", dict(error_angle_beta=0.0, error_angle_gamma=0.0,
                                                                  tau_load=0.0))]
    record = ["joint.omega_out", "motor.omega", "joint.phi_in", "motor.phi", "joint.phi_out"]
    table = cosimulate(comps, [Connection("motor.omega", "joint.omega_in")], 0.75, h, record, start_time=t0)
    assert set(table.dtype.names) == {"time", *record} and len(table) == 501
    t = table["time"]
    np.testing.assert_allclose(t, t0 + h * np.arange(501), rtol=0, atol=1e-15)
    np.testing.assert_allclose(table["motor.omega"], a * t, rtol=1e-13)
    np.testing.assert_allclose(table["motor.phi"], 0.5 * a * (t ** 2 - t0 ** 2), rtol=1e-12, atol=1e-15)
    theta1 = table["joint.phi_in"]
    # the joint estimates alpha from the input's history (zero before its first step): exact from the second step
    np.testing.assert_allclose(theta1[2:], 0.5 * a * (t[2:] ** 2 - t0 ** 2), rtol=0, atol=a * h * h)
    ratio = np.cos(phi) / (1 - np.sin(phi) ** 2 * np.cos(theta1) ** 2)
    np.testing.assert_allclose(table["joint.omega_out"], ratio * a * t, rtol=1e-12)
    theta2 = np.unwrap(np.arctan2(np.sin(theta1), np.cos(theta1) * np.cos(phi)))
    np.testing.assert_allclose(table["joint.phi_out"], theta2, rtol=0, atol=1e-12)


def test_output_interval_records_every_nth_step_and_the_last_bitwise(fmu_dir):
    """output_interval n: the rows at steps 0, n, 2n, ... and the last, each bitwise the row of the full record
    (same FMU calls, only fewer copies); the recorded time of a row is its own step's time."""
    record = ["joint.omega_out", "load.tau", "joint.tau_in", "joint.M_z", "motor.tau_motor", "motor.omega"]
    full = cosimulate(chain(fmu_dir), CONNECTIONS, 0.2, 1e-3, record)
    sparse = cosimulate(chain(fmu_dir), CONNECTIONS, 0.2, 1e-3, record, output_interval=7)
    steps = list(range(0, 201, 7)) + [200]
    assert len(sparse) == 30 and sparse.dtype == full.dtype
    assert sparse.tobytes() == full[steps].tobytes()
    np.testing.assert_allclose(sparse["time"], 1e-3 * np.array(steps), rtol=1e-15)
    with pytest.raises(CosimulationError, match="output interval"):
        cosimulate(chain(fmu_dir), CONNECTIONS, 0.2, 1e-3, record, output_interval=0)


def test_a_diverging_run_keeps_its_sparse_record_up_to_the_failure(fmu_dir):
    """The explicit heavy set-up diverges within a few steps: with output_interval 2 the partial result is every
    other row of the partial full record, the last recorded step included (rows are gathered in blocks: none may be
    lost)."""
    s = Scenario(battery.BATTERY_DIR / "battery_04.toml")
    partial = {}
    for every in (1, 2):
        with pytest.raises(CouplingInstabilityError) as failure:
            cosimulate(s.master_components(fmu_dir), s.connections, s.stop_time, 1e-3, s.record, coupling="explicit",
                       output_interval=every)
        partial[every] = failure.value.partial
    assert len(partial[1]) % 2 == 1 and len(partial[1]) >= 5
    assert partial[2].tobytes() == partial[1][::2].tobytes()


def test_steps_that_record_nothing_leave_read_and_run_where_a_recording_run_is(fmu_dir):
    """advance() without rows reads only what the connections need; read() afterwards and a following run() give
    bitwise the rows of one recording run at the same steps (no stale recorded signal)."""
    record = ["joint.omega_out", "load.tau", "joint.tau_in", "joint.M_z", "motor.tau_motor", "motor.omega"]
    full = cosimulate(chain(fmu_dir), CONNECTIONS, 0.2, 1e-3, record, coupling="explicit")
    with Cosimulation(chain(fmu_dir), CONNECTIONS, 1e-3, record, coupling="explicit") as cosim:
        cosim.advance(150)
        row = np.empty(len(record))
        cosim.read(row)
        rest, columns = cosim.run(50), cosim.columns
    assert row.tobytes() == np.array([full[150][name] for name in columns]).tobytes()
    assert all(rest[name].tobytes() == full[name][150:].tobytes() for name in columns)
    np.testing.assert_allclose(rest["time"], full["time"][150:], rtol=1e-15)


def test_values_of_the_wrong_type_are_refused_not_read_as_truthy(fmu_dir):
    """A Motor's ideal_speed_source = "false" had run as True (any non-empty string is truthy), a different drive:
    a Boolean takes True or False (or 0, 1), a Real a number; each refusal names the component, the variable and
    what it takes. 0 and 1 still set a Boolean, and an int a Real."""
    def motor(**values):
        return [Component("motor", fmu_dir / "Motor.fmu", dict(profile=0, omega_set=50.0, **values)),
                Component("load", fmu_dir / "Load.fmu", dict(T0=0.3))]
    wiring = [Connection("motor.omega", "load.omega"), Connection("load.tau", "motor.tau_load")]
    for value in ("false", "no", 0.5, None):
        with pytest.raises(CosimulationError, match=rf"component 'motor' \(Motor\): ideal_speed_source = "
                                                    rf"{value!r} must be True or False"):
            cosimulate(motor(ideal_speed_source=value), wiring, 0.01, 1e-3, ["motor.omega"])
    with pytest.raises(CosimulationError, match=r"omega_set = '50rpm' must be a real number \[rad/s\]"):
        cosimulate([Component("motor", fmu_dir / "Motor.fmu", dict(profile=0, omega_set="50rpm"))] + motor()[1:],
                   wiring, 0.01, 1e-3, ["motor.omega"])
    ideal = cosimulate(motor(ideal_speed_source=1), wiring, 0.01, 1e-3, ["motor.omega"])
    pi = cosimulate(motor(ideal_speed_source=False), wiring, 0.01, 1e-3, ["motor.omega"])
    assert ideal["motor.omega"][-1] == 50.0 and pi["motor.omega"][-1] != 50.0


def test_the_master_names_what_is_wrong_with_its_arguments(fmu_dir):
    """Zero step (had been a ZeroDivisionError), a recorded signal given as one string (had been read letter by
    letter: "no component 'j'"), the same component name twice (had been an error about a fixed parameter); a
    (source, target) pair is taken as a Connection, with the same results."""
    comps = chain(fmu_dir)
    for step in (0.0, -1e-3, float("nan")):
        with pytest.raises(CosimulationError, match="communication step size .* must be finite and > 0"):
            cosimulate(comps, CONNECTIONS, 0.01, step, ["joint.omega_out"])
    with pytest.raises(CosimulationError, match=r"record = 'joint.omega_out' is one string: give a list"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, "joint.omega_out")
    with pytest.raises(CosimulationError, match="component name 'load' used more than once"):
        cosimulate(comps + [comps[-1]], CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])
    with pytest.raises(CosimulationError, match="record names 'joint.omega_out' more than once"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out", "joint.omega_out"])
    with pytest.raises(CosimulationError, match=r"\('load'\): parameters = None must be a dict"):
        cosimulate(comps[:2] + [Component("load", comps[2].fmu, None)], CONNECTIONS, 0.01, 1e-3, [])
    pairs = cosimulate(comps, [(c.source, c.target) for c in CONNECTIONS], 0.01, 1e-3, ["joint.omega_out"])
    objects = cosimulate(comps, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])
    assert np.array_equal(pairs["joint.omega_out"], objects["joint.omega_out"])


def test_the_master_refuses_wiring_a_scenario_file_refuses(fmu_dir):
    """Connections given in code are checked as a scenario file's are (they had run silently): an input fed twice
    (the first connection had won), an angle wired into a speed (units differ), an output as a target, an input
    both connected and set in the component's parameters (the set value had been dropped), a name without a
    component; each a CosimulationError naming the connection."""
    comps = chain(fmu_dir)
    bad = {"is already fed by connections\\[0\\]": CONNECTIONS + [Connection("motor.omega", "joint.omega_in")],
           "motor.phi \\[rad\\] cannot feed joint.omega_in \\[rad/s\\]: units differ":
               [Connection("motor.phi", "joint.omega_in")] + CONNECTIONS[1:],
           "joint.tau_in is an output, not an input": CONNECTIONS + [Connection("load.tau", "joint.tau_in")],
           "connections\\[0\\].source = 'motoromega'": [Connection("motoromega", "joint.omega_in")] + CONNECTIONS[1:]}
    for message, connections in bad.items():
        with pytest.raises(CosimulationError, match=message):
            cosimulate(comps, connections, 0.01, 1e-3, ["joint.omega_out"])
    comps[2] = Component("load", fmu_dir / "Load.fmu", dict(T0=0.3, omega=5.0))
    with pytest.raises(CosimulationError, match="feeds load.omega, which the component's parameters also set"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])


def test_an_fmus_warning_reaches_a_python_caller(fmu_dir):
    """cosimulate had returned the run of a joint whose default error angles change its 2x swing by a quarter
    (the FMU's warning, in the log only) without a word: it is an FmuWarning, with the FMU's message."""
    import math

    from ujfmu.master import FmuWarning
    comps = chain(fmu_dir)
    comps[1] = Component("joint", fmu_dir / "CardanJoint.fmu", {"bend_angle": math.radians(2.0)})
    with pytest.warns(FmuWarning, match=r"\[warning\] joint: .*error_angle_beta = error_angle_gamma = 0.3 deg"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])


def test_a_flexible_shaft_left_at_the_laboratory_rig_warns_under_a_trucks_torque(fmu_dir):
    """The flexible double Cardan shaft at its defaults (Omar's laboratory rig, 92.2 N.m/rad) under a 1000 N.m
    load (linear in the speed, 160 rad/s) twists by over 5 rad: the run goes on (the model holds) but says once
    that the shaft is likely not the user's, naming k_theta; under the rig's own 5 N.m it says nothing of a
    twist."""
    import warnings

    from ujfmu.master import FmuWarning

    def run(load):
        comps = [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=0, omega_set=160.0)),
                 Component("driveline", fmu_dir / "DoubleCardanDriveline.fmu", {}),
                 Component("load", fmu_dir / "Load.fmu", dict(T0=0.0, c1=load / 160.0))]
        connections = [Connection("motor.omega", "driveline.omega_in"), Connection("driveline.tau_in", "motor.tau_load"),
                       Connection("driveline.omega_out", "load.omega"), Connection("load.tau", "driveline.tau_load")]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FmuWarning)
            table = cosimulate(comps, connections, 0.3, 1e-3, ["driveline.twist"])
        return table, [str(w.message) for w in caught if issubclass(w.category, FmuWarning) and "twisted" in
                       str(w.message)]
    table, said = run(1000.0)
    assert abs(table["driveline.twist"]).max() > 5.0 and len(said) == 1 and "k_theta" in said[0]
    table, said = run(5.0)
    assert abs(table["driveline.twist"]).max() < 0.2 and said == []


@pytest.mark.parametrize("ramp_time", [0.0, 0.02])
def test_a_load_step_or_ramp_twists_a_straight_shaft_as_the_linear_oscillator_says(fmu_dir, ramp_time):
    """Straight double Cardan joints, flexible shaft (Omar's 92.2 N.m/rad, c = 0.1844 N.m.s/rad, J_load =
    0.0045 kg.m2), an ideal source at 50 rad/s, a Load of 0 N.m changed by 2 N.m at t = 0.05 s (at once, or over
    20 ms): the twist obeys J theta'' + c theta' + k theta = T(t), a linear oscillator driven by a piecewise-linear
    input, which scipy's lsim integrates exactly; the shaft torque k theta + c theta' follows it to 1e-6 of the
    change. The Load's torque is T(t) at every communication point, and the driveline holds it over the step (the
    load does not depend on the speed here): a step on the grid is exact, a ramp a staircase of its values."""
    from scipy import signal
    comps = [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=0, omega_set=50.0)),
             Component("driveline", fmu_dir / "DoubleCardanDriveline.fmu", dict(beta1=0.0, beta2=0.0)),
             Component("load", fmu_dir / "Load.fmu", dict(T0=0.0, T_change=2.0, t_change=0.05,
                                                          ramp_time=ramp_time, omega_smooth=1e-9))]
    connections = [Connection("motor.omega", "driveline.omega_in"), Connection("driveline.tau_in", "motor.tau_load"),
                   Connection("driveline.omega_out", "load.omega"), Connection("load.tau", "driveline.tau_load")]
    table = cosimulate(comps, connections, 0.3, 1e-3, ["driveline.shaft_torque", "load.tau"])
    k, c, j = 92.2, 0.002 * 92.2, 0.0045
    t = np.linspace(0.0, 0.3, 3001)
    def level(time):
        return 2.0 * (np.clip((time - 0.05) / ramp_time, 0.0, 1.0) if ramp_time else (time >= 0.05 - 1e-12))
    np.testing.assert_allclose(table["load.tau"], level(table["time"]), atol=1e-12)
    held = level(np.floor(t / 1e-3 + 1e-9) * 1e-3)   # each communication point's value over its step
    system = signal.StateSpace([[0.0, 1.0], [-k / j, -c / j]], [[0.0], [1.0 / j]], [[k, c]], [[0.0]])
    _, exact, _ = signal.lsim(system, held, t, interp=False)
    assert np.max(np.abs(table["driveline.shaft_torque"] - exact[::10])) < 2e-6
    assert np.max(exact) > 2.3   # it overshoots: a ringing the check would see


@pytest.mark.parametrize("ideal", [True, False])   # explicit steps (an open loop), and implicit ones
def test_ctrl_c_from_python_stops_at_the_next_communication_step(fmu_dir, ideal):
    """A Ctrl-C while cosimulate steps from Python (Python's own SIGINT handler in place, as in a script or an
    optimizer loop) had landed inside an FMU's code half the time, which reported it as the FMU's fatal error: a
    caller's ``except CosimulationError`` took it for a failed run and went on, and the interpreter could crash at
    exit. The master takes the signal (its handler only while it steps), raises KeyboardInterrupt between FMU
    calls at the next communication step, with the results up to there, and leaves Python's handler and a usable
    master behind."""
    import signal

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        seen = []

        def progress(done, total):
            seen.append(signal.getsignal(signal.SIGINT))
            if done >= 20:
                signal.raise_signal(signal.SIGINT)
        components = chain(fmu_dir)
        components[0].parameters["ideal_speed_source"] = ideal
        diagnostics = {}
        with pytest.raises(KeyboardInterrupt) as info:
            cosimulate(components, CONNECTIONS, 1.0, 1e-3, ["joint.omega_out"], progress=progress)
        assert seen[0] is not signal.default_int_handler   # the master's, while it stepped
        partial = info.value.partial   # the results up to the step it stopped at: the start of an uninterrupted run
        assert 20 <= len(partial) - 1 <= 30 and f"after {len(partial) - 1} steps" in str(info.value)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        try:   # a next run is whole (a KeyboardInterrupt escaping a test would stop the whole session)
            table = cosimulate(components, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"], diagnostics=diagnostics)
        except KeyboardInterrupt:
            pytest.fail("the Ctrl-C stopped the next run too")
        assert len(table) == 11 and diagnostics["iterates"] == (not ideal)
        assert np.array_equal(partial[:11]["joint.omega_out"], table["joint.omega_out"])
        assert np.array_equal(partial[:11]["time"], table["time"])

        def last(done, total):   # a Ctrl-C after the last step's check is this run's, not the next run's
            if done == total:
                signal.raise_signal(signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):
            cosimulate(components, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"], progress=last)
        _next_run_is_whole(components, "the Ctrl-C after the last step stopped the next run")
    finally:
        signal.signal(signal.SIGINT, previous)


def _next_run_is_whole(components, why):
    """A 10-step run of components ends whole (a KeyboardInterrupt escaping a test would stop the whole session)."""
    try:
        assert len(cosimulate(components, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])) == 11
    except KeyboardInterrupt:
        pytest.fail(why)


def _load_fmu_module(components):
    """The Load FMU's own module as pythonfmu loaded it (its runtime package), after a one-step run of components."""
    import sys
    cosimulate(components, CONNECTIONS, 1e-3, 1e-3, ["joint.omega_out"])
    return next(m for name, m in sys.modules.items() if name.startswith("ujfmu_load_")
                and name.endswith(".models.load.fmu"))


@pytest.mark.parametrize("ideal", [True, False])
def test_a_second_ctrl_c_inside_an_fmus_code_is_an_interrupt_not_a_failure(fmu_dir, monkeypatch, ideal):
    """A second Ctrl-C raises at once, but landing inside an FMU's own code (here: both inside the Load's step) it
    had made that FMU's call fail, which the master reported as the FMU refusing the step (a sweep kept it as the
    point's result and reused it on the rerun), and pythonfmu then freed the instance twice (a segfault later). It
    waits for the FMU's call to return and stops the run there, as the Interrupted it is, with the results up to
    that step; the next run is whole."""
    import signal

    from ujfmu.master import Interrupted
    components = chain(fmu_dir)
    components[0].parameters["ideal_speed_source"] = ideal
    load_fmu = _load_fmu_module(components)
    advance = load_fmu.Load.advance

    def pressed_twice(self, t, h):
        if t >= 0.0195:
            signal.raise_signal(signal.SIGINT)   # the first: stop at the next communication step
            signal.raise_signal(signal.SIGINT)   # the second: at once, here
        return advance(self, t, h)
    monkeypatch.setattr(load_fmu.Load, "advance", pressed_twice)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted) as info:
            cosimulate(components, CONNECTIONS, 0.1, 1e-3, ["joint.omega_out"])
        assert len(info.value.partial) == 22   # t = 0 ... 0.021: the step the Ctrl-Cs came in ended, then stopped
        monkeypatch.setattr(load_fmu.Load, "advance", advance)
        _next_run_is_whole(components, "the Ctrl-C stopped the next run too")
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_ctrl_c_another_handler_raises_inside_an_fmus_code_is_an_interrupt_not_a_failure(fmu_dir, monkeypatch):
    """Under a SIGINT handler of the caller's own that raises at once (the master then keeps its hands off), the
    KeyboardInterrupt lands in the Load's step: the FMU refuses it as fatal (what pythonfmu frees twice pinned, so
    the process lives on) and says why, and the master reports the Interrupted it is, not the FMU refusing the
    step; the next run is whole."""
    import signal

    from ujfmu.master import Interrupted
    components = chain(fmu_dir)
    load_fmu = _load_fmu_module(components)
    advance = load_fmu.Load.advance

    def pressed(self, t, h):
        if t >= 0.0095:
            signal.raise_signal(signal.SIGINT)
        return advance(self, t, h)

    def own_handler(signum, frame):
        raise KeyboardInterrupt
    monkeypatch.setattr(load_fmu.Load, "advance", pressed)
    previous = signal.signal(signal.SIGINT, own_handler)
    try:
        with pytest.raises(Interrupted) as info:
            cosimulate(components, CONNECTIONS, 0.1, 1e-3, ["joint.omega_out"])
        assert len(info.value.partial) == 11   # t = 0 ... 0.01: the step the Ctrl-C came in failed
        monkeypatch.setattr(load_fmu.Load, "advance", advance)
        assert len(cosimulate(components, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])) == 11
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_second_ctrl_c_in_pythonfmus_own_code_is_an_interrupt_not_a_failure(fmu_dir, monkeypatch):
    """pythonfmu's own Python methods (its log queue, read as an instance is made) run inside an FMU's call too:
    a second Ctrl-C the master's handler finds in such a method waits for the call to return (its module is
    pythonfmu's); one raised where the handler cannot tell (a caller's wrapper around such a method) still makes the
    run's end the Interrupted it is, not the FMU failing its call."""
    import signal
    import types

    import pythonfmu.fmi2slave as fmi2slave
    from ujfmu.master import Interrupted, in_fmu_code
    components = chain(fmu_dir)
    queue = fmi2slave.Fmi2Slave._get_log_queue
    calls = [0]
    source = ("def pressed_twice(self):\n"
              "    calls[0] += 1\n"
              "    if calls[0] == 2:\n"
              "        signal.raise_signal(signal.SIGINT)\n"
              "        signal.raise_signal(signal.SIGINT)\n"
              "    return queue(self)\n")
    wrappers = []
    for name in ("pythonfmu.fmi2slave", "a_callers_wrapper"):   # as pythonfmu's own code, and as a caller's
        namespace = {"__name__": name, "calls": calls, "signal": signal, "queue": queue}
        exec(source, namespace)
        wrappers.append(namespace["pressed_twice"])
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        for wrapper in wrappers:
            calls[0] = 0
            monkeypatch.setattr(fmi2slave.Fmi2Slave, "_get_log_queue", wrapper)
            with pytest.raises(Interrupted):
                cosimulate(components, CONNECTIONS, 0.1, 1e-3, ["joint.omega_out"])
            monkeypatch.setattr(fmi2slave.Fmi2Slave, "_get_log_queue", queue)
            assert len(cosimulate(components, CONNECTIONS, 0.01, 1e-3, ["joint.omega_out"])) == 11
    finally:
        signal.signal(signal.SIGINT, previous)
    frame = types.SimpleNamespace(f_globals={"__name__": "pythonfmu.fmi2slave"}, f_back=None)
    assert in_fmu_code(frame) and not in_fmu_code(types.SimpleNamespace(f_globals={"__name__": "ujfmu.master"},
                                                                         f_back=None))


@pytest.mark.parametrize("at", [1.0, 1.04, 1.05])
def test_a_change_meant_at_a_communication_point_happens_there(fmu_dir, at):
    """The master's times are k h: 1.04 and 1.05 arrive as 1.0399999999999998 and 1.0499999999999998 at 1 ms, and
    a Load step (T_change) and an ideal source's speed step (profile 2, t_step) meant there had come one step late
    (0.3 rad/s of a PI motor's speed off its reference). Both happen at the communication point."""
    comps = [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=2, omega_initial=10.0,
                                                            omega_set=20.0, t_step=at, tau_load=0.0)),
             Component("load", fmu_dir / "Load.fmu", dict(T0=1.0, T_change=1.0, t_change=at, omega_smooth=1e-9))]
    table = cosimulate(comps, [Connection("motor.omega", "load.omega")], 1.1, 1e-3, ["motor.omega", "load.tau"])
    k = int(round(at / 1e-3))
    assert list(table["load.tau"][k - 1:k + 2]) == pytest.approx([1.0, 2.0, 2.0], abs=1e-12)
    assert list(table["motor.omega"][k - 1:k + 2]) == [10.0, 20.0, 20.0]


def test_a_warning_an_fmu_says_once_reaches_the_caller_once_under_the_implicit_scheme(fmu_dir):
    """The torque-driven double Cardan driven hard (100 N.m) into a linear load twists its default shaft past 0.5 rad
    at 10 ms and says so once; the implicit scheme's rollback had restored the state from before the warning, and
    the retried step said it again: the caller gets it once."""
    import warnings

    from ujfmu.master import FmuWarning
    comps = [Component("driveline", fmu_dir / "DoubleCardanDrivelineTorqueDriven.fmu",
                       dict(J_drive=0.1, tau_in=100.0, omega_in_start=100.0)),
             Component("load", fmu_dir / "Load.fmu", dict(T0=0.0, c1=1.0))]
    connections = [Connection("driveline.omega_out", "load.omega"), Connection("load.tau", "driveline.tau_load")]
    for coupling in ("implicit", "explicit"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FmuWarning)
            cosimulate(comps, connections, 0.05, 1e-3, ["driveline.twist"], coupling=coupling)
        said = [w for w in caught if "twisted" in str(w.message)]
        assert len(said) == 1, (coupling, [str(w.message)[:80] for w in said])


def test_a_refused_parameter_is_named_without_the_wrappers_noise(fmu_dir):
    """A CardanJoint at 1.6 rad refuses its parameters at initialization with a message naming bend_angle and its
    range; pythonfmu's C++ layer had added "[fatal] ... Fatal py exception encountered ... unknown error" after it,
    which names nothing: the error keeps the cause and drops that line. A fatal line of its own is kept."""
    from ujfmu.master import without_wrapper_noise
    with pytest.raises(CosimulationError) as info:
        cosimulate([Component("j", fmu_dir / "CardanJoint.fmu", {"bend_angle": 1.6})], [], 0.01, 1e-3,
                   ["j.omega_out"])
    text = str(info.value)
    assert "bend_angle = 1.6 is outside its allowed range" in text and "Fatal py exception" not in text
    noise = "[fatal] j: Fatal py exception encountered: [doStep] PyObject_CallMethod\nunknown error"
    assert without_wrapper_noise(["[error] j: refused", noise]) == ["[error] j: refused"]
    assert without_wrapper_noise([noise]) == [noise]   # no cause said before it: kept


def test_the_fmu_folders_of_a_process_that_ended_without_its_exit_handlers_are_removed_by_the_next(fmu_dir,
                                                                                                  tmp_path):
    """A script that ends with os._exit (as pythonfmu's exit abort advises), a dask worker its cluster stops, a
    kill -9: the process's extraction folders stay; the next process to extract an FMU removes them: those whose
    owner file no process holds locked, not a running process's (whatever its id: another container's, another
    host's), not one a minute old and unlocked yet (its process may be about to lock it), not one without an owner
    file (an older ujfmu's), not other files."""
    import os
    import subprocess
    import sys

    from ujfmu.master import OWNER_FILE
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    extract = f"from ujfmu.master import extracted; extracted({str(fmu_dir / 'Load.fmu')!r}); import os"

    def ended():
        done = subprocess.run([sys.executable, "-c", extract + "; print(os.getpid(), flush=True); os._exit(0)"],
                              capture_output=True, text=True, check=True, env=env)
        return next(tmp_path.glob(f"ujfmu_fmu_{int(done.stdout)}_*"))
    dead, young = ended(), ended()
    assert (dead / "modelDescription.xml").exists()   # os._exit: no exit handlers ran
    old, new = 1.0e9, 4.0e9   # an owner file's times set to 2001 (long past any grace) and 2096 (within it)
    os.utime(dead / OWNER_FILE, (old, old))
    os.utime(young / OWNER_FILE, (new, new))
    running = subprocess.Popen([sys.executable, "-c", extract + "; print('ready', flush=True); import sys; "
                                "sys.stdin.read()"], env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               text=True)
    try:
        assert running.stdout.readline().strip() == "ready"
        alive = next(tmp_path.glob(f"ujfmu_fmu_{running.pid}_*"))
        os.utime(alive / OWNER_FILE, (old, old))
        unowned = tmp_path / "ujfmu_fmu_4821_kq9z"   # an older ujfmu's random name
        unowned.mkdir()
        (tmp_path / "ujfmu_fmu_17_file").write_text("not a folder")
        ended()
        assert not dead.exists()
        assert (alive / "modelDescription.xml").exists() and young.exists() and unowned.exists()
        assert (tmp_path / "ujfmu_fmu_17_file").exists()
    finally:
        running.kill()
        running.wait()


def test_a_file_that_is_no_fmu_leaves_no_folder_and_no_open_file(tmp_path):
    """Each temporary folder's owner file stays open (its lock) while the folder lives: a file that is no FMU had left
    one open per attempt (50 attempts, 50 descriptors) though its folder was removed."""
    import os

    from ujfmu import master
    bad = tmp_path / "bad.fmu"
    bad.write_bytes(b"not a zip")
    before = (len(os.listdir("/proc/self/fd")), len(master._OWNED))
    for _ in range(20):
        with pytest.raises(Exception):
            master.extracted(bad)
    assert (len(os.listdir("/proc/self/fd")), len(master._OWNED)) == before
