"""The FMI 3.0 FMUs running: the same numbers as the FMI 2.0 FMUs, scenarios against their references in
Co-Simulation (our master) and Model Exchange (fmpy's CVode), errors, FMU state. (Every scenario passes with the
FMI 3.0 FMUs: `ujfmu build --fmi 3 && ujfmu check --fmu-dir fmus/fmi3`; here one, plus bitwise equality with
FMI 2.0 for every FMU, whose scenarios tests/test_scenarios.py checks.)"""

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from ujfmu.build import FMUS
from ujfmu.fmi3_host import FmuInstance3
from ujfmu.master import Component, Connection, FmuInstance, cosimulate, extracted
from ujfmu.model_exchange import MeInstance, ModelExchangeError, simulate_me, simulate_scenario_me
from ujfmu.scenario import Scenario
from ujfmu.scenario_run import compare

#: inputs as functions of time: a ramping, wavering speed and varying torques exercise the input history
INPUTS = {
    "omega_in": lambda t: 40.0 + 30.0 * t + 3.0 * math.sin(17.0 * t),
    "tau_load": lambda t: 0.2 + 0.1 * math.cos(11.0 * t),
    "omega": lambda t: 40.0 + 30.0 * t,
    "tau_in": lambda t: 0.5 + 0.2 * math.sin(13.0 * t),
    "phi": lambda t: 40.0 * t + 15.0 * t * t,   # the Load's shaft angle (its periodic torque's)
}
H = 1e-3


def _open(kind, fmu_dir, name, log, instance_name="probe"):
    path = fmu_dir / f"{name}.fmu"
    unzip_dir, md = extracted(path)
    return kind(Component(instance_name, path), unzip_dir, md, log)


@pytest.fixture
def opened():
    instances = []
    yield instances
    for inst in instances:
        inst.free()


def _record(inst, n, t0=0.0):
    """n steps with INPUTS; the outputs read at each communication point, as an array."""
    outputs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
    inputs = [v.name for v in inst.md.modelVariables if v.causality == "input"]
    step = inst.raw("fmi2DoStep")
    rows = []
    for k in range(n):
        t = t0 + k * H
        inst.set(**{name: INPUTS[name](t) for name in inputs})
        rows.append(inst.get(*outputs))
        assert step(inst.slave.component, t, H, 1) == 0
    return np.array(rows)


@pytest.mark.parametrize("name", list(FMUS))
def test_fmi3_gives_the_fmi2_numbers_bitwise(fmu_dir, fmu3_dir, opened, name):
    """One declaration and one set of equations: the FMI 3.0 FMU's outputs equal the FMI 2.0 FMU's, bit for bit,
    over 300 steps of varying inputs."""
    fmi2 = _open(FmuInstance, fmu_dir, name, [])
    fmi3 = _open(FmuInstance3, fmu3_dir, name, [])
    opened += [fmi2, fmi3]
    fmi2.initialize()
    fmi3.initialize()
    a, b = _record(fmi2, 300), _record(fmi3, 300)
    assert np.all(np.isfinite(a)) and np.ptp(a, axis=0).max() > 0.0
    assert np.array_equal(a, b)


def test_scenario_with_fmi3_fmus_passes_and_repeats_fmi2_bitwise(fmu_dir, fmu3_dir):
    """The first 2 s of cardan_startup (PI ramp, implicit coupling: rollback through fmi3Get/SetFMUState) within
    the scenario's tolerances of its reference, and bitwise the FMI 2.0 run."""
    sc = Scenario("scenarios/cardan_startup.toml")

    def run(folder):
        return cosimulate(sc.master_components(folder), sc.connections, 2.0, sc.step_size, sc.record,
                          coupling=sc.coupling)

    fmi3 = run(fmu3_dir)
    checks = compare(fmi3, sc.read_reference(), sc.tolerances)
    assert checks and all(c.passed for c in checks), [str(c) for c in checks]
    fmi2 = run(fmu_dir)
    for name in fmi2.dtype.names:
        assert np.array_equal(fmi2[name], fmi3[name]), name


@pytest.mark.parametrize("scenario", ["cardan_heavy_torque_driven", "double_cardan_stiff_torque_driven",
                                      "twin_jeffcott_torque_driven", "ring_coupling_torque_driven"])
def test_model_exchange_under_cvode_agrees_with_the_monolithic_reference(fmu3_dir, scenario):
    """The torque-driven drivelines integrated by CVode as one system: no sampled controller, no coupling delay,
    so they agree with the monolithic reference within the tight step-halving bands of the scenario (10-50x the
    co-simulation's), where co-simulation at 1 ms is 1-4% off in torque. cardan_heavy_torque_driven is the set-up
    whose speed-driven FMI 2.0 wiring diverges at any step in an explicit host (tests/test_wiring.py); the twin
    rotor's disc displacements (tens of micrometres) are resolved through the states' nominals."""
    sc = Scenario(f"scenarios/{scenario}.toml")
    table = simulate_scenario_me(sc, fmu3_dir)
    reference = sc.read_reference()
    for check in compare(table, reference, sc.extrapolated_tolerances) + compare(table, reference, sc.tolerances):
        assert check.passed, str(check)
    # and far inside: every signal within 1e-4 of its reference range
    for name in sc.tolerances:
        span = np.ptp(reference[name])
        assert np.max(np.abs(table[name] - np.interp(table["time"], reference["time"], reference[name]))) \
            <= 1e-4 * span, name


def test_model_exchange_from_a_later_start_reads_its_first_row_there(fmu3_dir):
    """The heavy torque-driven joint from t = 1 s: its PI drive's ramp asks for 30 rad/s there against a shaft at
    rest, Kp 30 = 264 N.m, so its torque starts at the 100 N.m limit. The first row had been read before the FMUs
    were given the time (pythonfmu3 drops fmi3EnterInitializationMode's startTime): tau_motor 0 and M_z 0."""
    sc = Scenario("scenarios/cardan_heavy_torque_driven.toml")
    sc.start_time, sc.stop_time, sc.reference_file = 1.0, 1.01, None
    table = simulate_scenario_me(sc, fmu3_dir)
    assert table["time"][0] == 1.0 and table["motor.tau_motor"][0] == 100.0
    assert table["joint.M_z"][0] == pytest.approx(table["joint.M_z"][1], rel=0.01)   # no jump after the first row


def test_run_scenario_takes_the_fmi3_folder_for_model_exchange_by_default(fmu3_dir, tmp_path, monkeypatch):
    """ujfmu.run_scenario(..., model_exchange=True) with fmu_dir left at fmus/ takes fmus/fmi3/, as the command
    line's --model-exchange does (it had refused the FMI 2.0 FMUs of fmus/, an FMI 3.0 user's trial)."""
    from pathlib import Path
    from ujfmu.scenario_run import run_scenario
    scenario = Path("scenarios/cardan_heavy_torque_driven.toml").resolve()
    (tmp_path / "fmus").mkdir()
    (tmp_path / "fmus" / "fmi3").symlink_to(fmu3_dir)
    monkeypatch.chdir(tmp_path)
    assert run_scenario(scenario, model_exchange=True, out_dir=None, plot=False).passed


def test_a_ctrl_c_in_a_model_exchange_run_stops_it_at_an_output_point(fmu3_dir, monkeypatch, python_sigint):
    """A SIGINT during a Model Exchange run waits for the next output point (not raised inside CVode's callbacks,
    where it had been reported as the model's fatal error or lost) and stops the run there: Interrupted, with the
    rows so far."""
    import signal
    from ujfmu import master
    original, pressed = MeInstance.initialize, []

    def pressed_while_starting(self, *args, **kwargs):
        if not pressed:
            pressed.append(True)
            signal.raise_signal(signal.SIGINT)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(MeInstance, "initialize", pressed_while_starting)
    with pytest.raises(master.Interrupted) as info:
        simulate_scenario_me(Scenario("scenarios/cardan_heavy_torque_driven.toml"), fmu3_dir)
    assert len(info.value.partial) == 2 and info.value.partial["time"][-1] == pytest.approx(1e-3)
    assert not master.STOP[0]


def test_model_exchange_refuses_a_speed_driven_component(fmu3_dir):
    with pytest.raises(ModelExchangeError, match="CardanJoint has no Model Exchange interface.*torque-driven"):
        simulate_me([Component("joint", fmu3_dir / "CardanJoint.fmu")], [], 0.01, 1e-3, ["joint.tau_in"])


def test_invalid_parameter_fails_initialization_with_a_message_and_the_host_survives(fmu3_dir, opened):
    log = []
    bad = _open(FmuInstance3, fmu3_dir, "CardanJoint", log, "bad")
    opened.append(bad)
    with pytest.raises(FMICallException):
        bad.initialize({"J1": -1.0})
    assert any("J1 = -1.0 is outside its allowed range [0, 1000000] kg.m2" in line for line in log), log
    good = _open(FmuInstance3, fmu3_dir, "CardanJoint", [], "good")
    opened.append(good)
    good.initialize()
    assert np.all(np.isfinite(_record(good, 5)))


def test_bad_input_refuses_the_step_and_the_instance_stays_usable(fmu3_dir, opened):
    log = []
    inst = _open(FmuInstance3, fmu3_dir, "CardanJointTorqueDriven", log)
    opened.append(inst)
    inst.initialize()
    step = inst.raw("fmi2DoStep")
    inst.set(tau_in=float("nan"), tau_load=0.0)
    assert step(inst.slave.component, 0.0, H, 1) == 2          # fmi3Discard
    assert any("tau_in = nan is not a finite number (allowed range [-10000000, 10000000] N.m)" in m for m in log), log
    inst.set(tau_in=1.0)
    assert step(inst.slave.component, 0.0, H, 1) == 0
    assert inst.get("omega_in")[0] > 0.0


def test_a_fixed_parameter_or_an_output_set_while_stepping_is_refused_in_fmi3(fmu3_dir, opened):
    """As in FMI 2.0: while stepping, a fixed parameter keeps the value the model runs with and an output cannot be
    set; each call fails with the reason in the log; the parameter's current value may be sent again."""
    log = []
    inst = _open(FmuInstance3, fmu3_dir, "CardanJoint", log)
    opened.append(inst)
    inst.initialize({"bend_angle": 0.5})
    _record(inst, 3)
    inst.set(bend_angle=0.5)
    with pytest.raises(FMICallException):
        inst.set(bend_angle=0.0)
    assert inst.get("bend_angle") == [0.5] and any("parameter bend_angle is fixed" in m for m in log), log
    with pytest.raises(FMICallException):
        inst.set(omega_out=1.0)
    assert any("omega_out is an output" in m for m in log), log
    fixed = next(m for m in log if "parameter bend_angle is fixed" in m)   # in FMI 3.0's names, as every message
    assert "before fmi3ExitInitializationMode (or after fmi3Reset)" in fixed
    assert not [m for m in log if "fmi2" in m], log


def test_model_exchange_bad_input_gives_nan_derivatives_with_a_message(fmu3_dir, opened):
    """(pythonfmu3 crashes the host on an exception in fmi3GetContinuousStateDerivatives: NaN and a logged error
    instead, on which a solver stops.)"""
    log = []
    inst = _open(MeInstance, fmu3_dir, "CardanJointTorqueDriven", log)
    opened.append(inst)
    inst.initialize()
    inst.set(tau_in=float("inf"))
    inst.slave.getContinuousStateDerivatives(inst.buffer, inst.nx)
    assert all(math.isnan(x) for x in inst.buffer)
    assert any("derivatives at t = 0.0 refused: tau_in = inf is not a finite number" in m for m in log), log
    for k in range(20):   # a solver's retries, successes between them: a reason three times in full, then once
        inst.set(tau_in=float("inf") if k % 2 else 1.0)
        inst.slave.getContinuousStateDerivatives(inst.buffer, inst.nx)
    refused = [m for m in log if "refused" in m]
    assert len(refused) == 4 and "for a reason logged above; it is not logged again" in refused[-1], refused
    inst.set(tau_in=1e30)   # another reason (out of range) is logged
    inst.slave.getContinuousStateDerivatives(inst.buffer, inst.nx)
    assert len([m for m in log if "refused" in m]) == 5 and "1e+30" in log[-1], log[-1]
    inst.set(tau_in=1.0)
    inst.slave.getContinuousStateDerivatives(inst.buffer, inst.nx)
    assert inst.buffer[1] > 0.0


def test_model_exchange_run_stops_with_the_fmu_message(fmu3_dir):
    """An input out of its range stops the run with an error carrying the FMU's reason, not with numbers."""
    with pytest.raises(ModelExchangeError, match="(?s)tau_in = 100000000.0 is outside its allowed range"):
        simulate_me([Component("joint", fmu3_dir / "CardanJointTorqueDriven.fmu", {"tau_in": 1e8})],
                    [], 0.01, 1e-3, ["joint.omega_in"])


def test_model_exchange_run_stops_where_the_speed_leaves_its_range(fmu3_dir):
    """A driving torque within its range that runs the input shaft past the +-1e4 rad/s a Co-Simulation step keeps
    to (which refuses such a step): under CVode the derivatives there are refused with the reason, and the run
    stops with it instead of integrating on to 1e9 rad/s."""
    with pytest.raises(ModelExchangeError, match=r"(?s)the state omega1 = .* rad/s is outside the speed range") as err:
        simulate_me([Component("joint", fmu3_dir / "CardanJointTorqueDriven.fmu", {"tau_in": 1e6})],
                    [], 0.05, 1e-3, ["joint.omega_in"])
    message = str(err.value)   # the solver's retries are counted, each distinct FMU message said once
    assert message.count("gave non-finite derivatives") == 1 and "more failed calls" in message
    assert message.count("is outside the speed range") == 1, message


def test_model_exchange_derivatives_are_the_equations_of_motion(fmu3_dir, opened):
    """A straight joint (no bend, no error angles) is a rigid shaft: der(phi1) = omega1, der(omega1) =
    (tau_in - tau_load) / (J_drive + J1 + J2), whatever the state."""
    inst = _open(MeInstance, fmu3_dir, "CardanJointTorqueDriven", [])
    opened.append(inst)
    params = dict(bend_angle=0.0, error_angle_beta=0.0, error_angle_gamma=0.0, J_drive=0.01, J1=0.002, J2=0.03)
    inst.initialize(params)
    inst.set(tau_in=2.0, tau_load=0.5)
    inst.buffer[0], inst.buffer[1] = 3.0, 7.0
    inst.slave.setContinuousStates(inst.buffer, 2)
    inst.slave.getContinuousStateDerivatives(inst.buffer, 2)
    assert inst.buffer[0] == 7.0
    assert inst.buffer[1] == pytest.approx(1.5 / 0.042, rel=1e-12)


@pytest.mark.parametrize("name, params, output, before, after", [
    ("MotorController", {"profile": 2, "t_step": 0.3, "omega_set": 2.0, "omega_initial": 0.0}, "omega_ref", 0.0, 2.0),
    ("Load", {"T0": 1.0, "T_change": 0.3, "t_change": 0.3, "omega_smooth": 1e-6}, "tau", 1.0, 1.3),
])
def test_model_exchange_gives_the_left_limit_at_a_time_event_until_it_is_taken(fmu3_dir, opened, name, params,
                                                                            output, before, after):
    """FMI 3.0's convention: at a time event's instant in Continuous-Time Mode the outputs are the left limit;
    fmi3UpdateDiscreteStates in event mode takes the event, and they are the right limit from then on (an FMI 3.0
    user had the step's value at fmi3SetTime(0.3) already: a solver's last stage there took the new torque)."""
    inst = _open(MeInstance, fmu3_dir, name, [])
    opened.append(inst)
    inst.initialize(params)
    inst.set(**{v: 5.0 for v in ("omega",) if v in inst.variables})
    inst.slave.updateDiscreteStates()
    inst.slave.enterContinuousTimeMode()
    inst.slave.setTime(0.2)
    assert inst.get(output)[0] == pytest.approx(before)
    inst.slave.setTime(0.3)
    assert inst.get(output)[0] == pytest.approx(before)   # at the event, not yet taken: the left limit
    inst.slave.enterEventMode()
    inst.slave.updateDiscreteStates()
    assert inst.get(output)[0] == pytest.approx(after)    # taken: the right limit
    inst.slave.enterContinuousTimeMode()
    inst.slave.setTime(0.31)
    assert inst.get(output)[0] == pytest.approx(after)


@pytest.mark.parametrize("name", ["CardanJointTorqueDriven", "TwinJeffcottRotor"])
def test_state_get_set_and_serialize_round_trip_bitwise(fmu3_dir, opened, name):
    log = []
    inst = _open(FmuInstance3, fmu3_dir, name, log, "a")
    opened.append(inst)
    inst.initialize()
    _record(inst, 30)
    state = inst.slave.getFMUState()
    blob = inst.slave.serializeFMUState(state)
    first = _record(inst, 30, 30 * H)
    inst.slave.setFMUState(state)
    assert np.array_equal(_record(inst, 30, 30 * H), first)
    fresh = _open(FmuInstance3, fmu3_dir, name, [], "b")
    opened.append(fresh)
    fresh.initialize()
    fresh.slave.setFMUState(fresh.slave.deserializeFMUState(blob))
    assert np.array_equal(_record(fresh, 30, 30 * H), first)
    restarted = _open(FmuInstance3, fmu3_dir, name, [], "c")   # restored in initialization mode: it stands
    opened.append(restarted)
    restarted.slave.enterInitializationMode(startTime=0.0)
    restarted.slave.setFMUState(restarted.slave.deserializeFMUState(blob))
    restarted.slave.exitInitializationMode()
    assert np.array_equal(_record(restarted, 30, 30 * H), first)
    damaged = bytearray(blob)
    damaged[len(damaged) // 2] ^= 1
    with pytest.raises(FMICallException):
        inst.slave.deserializeFMUState(bytes(damaged))
    assert any("FMU state rejected" in m and "checksum mismatch" in m for m in log), log
    inst.slave.freeFMUState(state)
    assert np.all(np.isfinite(_record(inst, 5, 60 * H)))      # the instance stays usable


def _initialize_directly(inst, start_time):
    """fmi3EnterInitializationMode at start_time and fmi3ExitInitializationMode, past the host's refusal."""
    inst.slave.enterInitializationMode(startTime=start_time)
    inst.slave.exitInitializationMode()


def test_a_time_dependent_fmu_is_refused_a_start_other_than_0(fmu3_dir, opened):
    """A Motor ramping cannot see a start time of 1 s before its first step, so the host's first exchange would
    hand on its t = 0 values (an FMI 3.0 user's joint started 30 rad/s behind): the host refuses, naming the
    remedies. Where the outputs at the start are those at 0 it starts: a constant profile, a step still to come (a
    reviewer's step at 2 s had been refused at a start of 1 s)."""
    from ujfmu.master import CosimulationError
    ramp = _open(FmuInstance3, fmu3_dir, "Motor", [])
    opened.append(ramp)
    with pytest.raises(CosimulationError, match="cannot start at t = 1 s: its outputs there differ from those at "
                                                "t = 0.*FMI 2.0"):
        ramp.initialize(start_time=1.0)
    for name, values in (("constant", {"profile": 0}), ("later", {"profile": 2, "t_step": 2.0, "omega_set": 50.0})):
        inst = _open(FmuInstance3, fmu3_dir, "Motor", [], name)
        opened.append(inst)
        inst.initialize(values, start_time=1.0)
    taken = _open(FmuInstance3, fmu3_dir, "Motor", [], "taken")
    opened.append(taken)
    with pytest.raises(CosimulationError, match="cannot start at t = 1 s"):
        taken.initialize({"profile": 2, "t_step": 0.5, "omega_set": 50.0}, start_time=1.0)


def test_start_time_is_taken_from_the_first_step(fmu_dir, fmu3_dir, opened):
    """pythonfmu3 does not pass fmi3EnterInitializationMode's startTime on: the FMU re-starts at the first step's
    time, so from the first step on a Motor ramping from t0 = 1 s gives the FMI 2.0 numbers bitwise."""
    fmi2 = _open(FmuInstance, fmu_dir, "Motor", [])
    fmi3 = _open(FmuInstance3, fmu3_dir, "Motor", [])
    opened += [fmi2, fmi3]
    fmi2.initialize(start_time=1.0)
    _initialize_directly(fmi3, 1.0)   # the host refuses this start (below): the FMU's own rule, met directly
    a, b = _record(fmi2, 50, t0=1.0), _record(fmi3, 50, t0=1.0)
    assert a[1, 3] == pytest.approx(30.0 * 1.001)   # omega_ref: the ramp at 30 rad/s2 from rest at t = 0
    assert np.array_equal(a[1:], b[1:])


def test_a_state_saved_before_the_first_step_restores_the_start_time_rule(fmu_dir, fmu3_dir, opened):
    """An iterating host saves the state before the first step, steps, restores it and steps again: the re-step
    must again take its start time from the step (a restored state had been taken as stepped, the Motor re-stepping
    from its t = 0 state: 5 rad/s at its torque limit instead of the ramp's 30, an FMI 3.0 user's trial)."""
    fmi2 = _open(FmuInstance, fmu_dir, "Motor", [])
    fmi3 = _open(FmuInstance3, fmu3_dir, "Motor", [])
    opened += [fmi2, fmi3]
    fmi2.initialize(start_time=1.0)
    _initialize_directly(fmi3, 1.0)
    first = _record(fmi2, 3, t0=1.0)
    saved = fmi3.slave.getFMUState()
    _record(fmi3, 1, t0=1.0)
    fmi3.slave.setFMUState(saved)
    fmi3.slave.freeFMUState(saved)
    again = _record(fmi3, 3, t0=1.0)
    assert first[1, 3] == pytest.approx(30.0 * 1.001)   # omega_ref: the ramp at 30 rad/s2 from rest at t = 0
    assert np.array_equal(first[1:], again[1:])


def test_many_instances_interleaved_each_equal_to_a_lone_instance(fmu3_dir, opened):
    """Five instances of one FMI 3.0 FMU in one process, different parameters, stepped interleaved, each bitwise
    a lone instance with its parameters (pythonfmu3 imports the FMU's module once for all of them)."""
    values = [0.0, 1e-4, 1e-3, 1e-2, 0.1]
    crowd = [_open(FmuInstance3, fmu3_dir, "CardanJointTorqueDriven", [], f"i{k}") for k in range(len(values))]
    opened += crowd
    for inst, j2 in zip(crowd, values):
        inst.initialize({"J2": j2})
    rows = [[] for _ in crowd]
    for k in range(40):
        for inst, out in zip(crowd, rows):
            out.append(_record(inst, 1, k * H)[0])
    finals = [inst.get("omega_in")[0] for inst in crowd]
    assert len(set(finals)) == len(values)        # the parameters took effect per instance
    for j2, out in zip(values, rows):
        lone = _open(FmuInstance3, fmu3_dir, "CardanJointTorqueDriven", [], "lone")
        opened.append(lone)
        lone.initialize({"J2": j2})
        assert np.array_equal(_record(lone, 40), np.array(out))


def _saturating_drive(fmu3_dir):
    """MotorController (constant 100 rad/s, Kp 2, Ki 10, limit 5 N.m) on a straight torque-driven joint, a rigid
    inertia J = 0.1 kg.m2 from rest: limited at 5 N.m until Kp e = tau_max (e = 2.5 rad/s, t* = 97.5 / 50 = 1.95 s),
    then the critically damped PI loop, e = (2.5 - 25 s) exp(-10 s) with s = t - t* (closed form)."""
    components = [
        Component("motor", fmu3_dir / "MotorController.fmu", dict(profile=0, omega_set=100.0, Kp=2.0, Ki=10.0,
                                                                    tau_max=5.0)),
        Component("joint", fmu3_dir / "CardanJointTorqueDriven.fmu", dict(
            bend_angle=0.0, error_angle_beta=0.0, error_angle_gamma=0.0, J_drive=0.1, J1=0.0, J2=0.0))]
    return components, [Connection("joint.omega_in", "motor.omega"), Connection("motor.tau_motor", "joint.tau_in")]


def test_event_indicators_locate_the_pi_limit_switch_to_solver_tolerance(fmu3_dir):
    """The MotorController's event indicators (Kp e + Ki I -+ tau_max; e while limited) are CVode's root
    functions: the end of the torque limit is located at the closed form's t* = 1.95 s to 1e-7 s, and the speed
    follows the closed form to 1e-6 of its range. The speed error's zero at t* + 0.1 s, out of the limit, switches
    nothing and is no event (it had been one, as is every zero of a held speed's ripple)."""
    components, connections = _saturating_drive(fmu3_dir)
    events = []
    table = simulate_me(components, connections, 2.5, 0.01, ["joint.omega_in", "motor.tau_motor"], events=events)
    assert [name for _, name in events] == ["motor.z.upper_limit"]
    assert events[0][0] == pytest.approx(1.95, abs=1e-7)
    t = table["time"]
    s = t - 1.95
    closed = np.where(s < 0.0, 50.0 * t, 100.0 - (2.5 - 25.0 * s) * np.exp(-10.0 * np.maximum(s, 0.0)))
    assert np.max(np.abs(table["joint.omega_in"] - closed)) <= 1e-6 * 100.0
    assert np.all(table["motor.tau_motor"][s < 0.0] == 5.0) and np.all(table["motor.tau_motor"][s > 0.0] < 5.0)


def test_event_indicators_are_declared_and_read(fmu3_dir, opened):
    """Three event indicators in the modelDescription, with their closed-form values Kp e + Ki I -+ tau_max and,
    at a state past the limit, e, within it 1 (a zero of e switches nothing there)."""
    inst = _open(MeInstance, fmu3_dir, "MotorController", [])
    opened.append(inst)
    assert [u.variable.name for u in inst.md.eventIndicators] == ["z.upper_limit", "z.lower_limit", "z.speed_error"]
    inst.initialize(dict(profile=0, omega_set=100.0, Kp=2.0, Ki=10.0, tau_max=5.0))
    inst.set(omega=98.0)
    for integral, e_or_one in ((-0.1, 1.0), (0.5, 2.0)):   # v = 4 + 10 I: within the limit, past it
        inst.buffer[0] = integral
        inst.slave.setContinuousStates(inst.buffer, 1)
        inst.slave.getEventIndicators(inst.z_buffer, 3)
        v = 4.0 + 10.0 * integral
        assert list(inst.z_buffer) == pytest.approx([v - 5.0, v + 5.0, e_or_one], rel=1e-12)


def test_a_step_of_the_speed_profile_is_a_time_event(fmu3_dir):
    """The MotorController announces its profile's step (profile 2, t_step = 0.3 s) as a time event
    (fmi3UpdateDiscreteStates' nextEventTime), so a Model Exchange host's solver stops there instead of stepping
    across the jump of the torque: ``simulate_me`` lists it at 0.3 s exactly, and the speed after it follows the
    critically damped PI loop's closed form (a step of 2 rad/s within the limit, J = 0.1 kg.m2, Kp = 2, Ki = 10:
    e = (2 - 20 s) exp(-10 s), s = t - 0.3) to 1e-6 rad/s."""
    components, connections = _saturating_drive(fmu3_dir)
    components[0] = Component("motor", fmu3_dir / "MotorController.fmu", dict(
        profile=2, omega_initial=0.0, omega_set=2.0, t_step=0.3, Kp=2.0, Ki=10.0, tau_max=5.0))
    events = []
    table = simulate_me(components, connections, 1.0, 0.01, ["joint.omega_in"], events=events)
    assert events == [(0.3, "motor.time event")]
    s = table["time"] - 0.3
    closed = np.where(s < 0.0, 0.0, 2.0 - (2.0 - 20.0 * s) * np.exp(-10.0 * np.maximum(s, 0.0)))
    assert np.max(np.abs(table["joint.omega_in"] - closed)) <= 1e-6


def test_a_step_that_aliases_the_2x_order_is_said_once_in_fmi3(fmu3_dir, opened):
    """As the FMI 2.0 FMU (tests/fmu/test_fmu_hosting.py): at 1500 rpm a 0.02 s step reads the outputs once a
    period of the joint's 2x order; the FMI 3.0 FMU passes the warning to the host, once, and keeps stepping."""
    log = []
    inst = _open(FmuInstance3, fmu3_dir, "CardanJoint", log)
    opened.append(inst)
    inst.initialize()
    step = inst.raw("fmi2DoStep")
    for k in range(3):
        inst.set(omega_in=50 * math.pi, tau_load=0.0)
        assert step(inst.slave.component, k * 0.02, 0.02, 1) == 0
    warnings = [m for m in log if "2x order" in m]
    assert len(warnings) == 1 and "reads the outputs once a period" in warnings[0], log


def test_a_step_from_elsewhere_is_said_once_in_fmi3(fmu3_dir, opened):
    """As the FMI 2.0 FMU (tests/fmu/test_fmu_hosting.py): a step that does not start where the last ended, no
    state restored, is taken and said once, naming both times."""
    log = []
    inst = _open(FmuInstance3, fmu3_dir, "TwinJeffcottRotor", log)
    opened.append(inst)
    inst.initialize()
    step = inst.raw("fmi2DoStep")
    for t in (0.5, 0.5 + H, 0.5 + 2 * H, 0.5 + 9 * H, 0.5):
        inst.set(omega_in=100.0, tau_load=1.0)
        assert step(inst.slave.component, t, H, 1) == 0
    said = [m for m in log if "from the time of the FMU's state" in m]
    assert len(said) == 1 and "t = 0.509 s, forward from the time of the FMU's state (0.503 s: where" in said[0], log


def test_the_states_nominals_are_in_the_model_description_as_the_fmu_gives_them(fmu3_dir, opened):
    """The twin rotor's disc displacements and velocities carry their nominals (1e-4 m, 1e-2 m/s) in the
    modelDescription, the values fmi3GetNominalsOfContinuousStates gives, so a host that scales its solver's
    absolute tolerance from the XML resolves them as finely (a fresh-eyes host's LSODA had Y1 80x less accurate
    with the XML's default 1)."""
    inst = _open(MeInstance, fmu3_dir, "TwinJeffcottRotorTorqueDriven", [])
    opened.append(inst)
    inst.initialize()
    inst.slave.getNominalsOfContinuousStates(inst.buffer, inst.nx)
    from_xml = {v.name: v.nominal for v in inst.md.modelVariables if v.name.startswith("x.")}
    names = [v.name for v in inst.md.modelVariables if v.name.startswith("x.")]
    assert [float(from_xml[n] or 1.0) for n in names] == list(inst.buffer[:inst.nx])
    assert float(from_xml["x.Y1"]) == 1e-4 and float(from_xml["x.dY1"]) == 1e-2


def test_derivatives_read_by_value_reference_are_refused_as_the_derivative_call_is(fmu3_dir, opened):
    """der(x.*) read through fmi3GetFloat64 passes the same checks as fmi3GetContinuousStateDerivatives: a speed
    state outside the speed range or a non-finite state (also the MotorController's integral, whose derivative does
    not depend on it) gives NaN with the reason logged, where it had given a finite number silently."""
    log = []
    inst = _open(MeInstance, fmu3_dir, "CardanJointTorqueDriven", log)
    opened.append(inst)
    inst.initialize()
    inst.buffer[0], inst.buffer[1] = 0.3, 2e4
    inst.slave.setContinuousStates(inst.buffer, 2)
    assert math.isnan(inst.get("der(x.omega1)")[0])
    assert any("outside the speed range" in m for m in log), log
    controller = _open(MeInstance, fmu3_dir, "MotorController", log)
    opened.append(controller)
    controller.initialize(dict(profile=0, omega_set=10.0))
    controller.buffer[0] = math.nan
    controller.slave.setContinuousStates(controller.buffer, 1)
    controller.slave.getContinuousStateDerivatives(controller.buffer, 1)
    assert math.isnan(controller.buffer[0]) and any("x.integral" in m or "integral = nan" in m for m in log), log


def test_a_time_that_is_not_finite_is_refused_and_the_time_kept(fmu3_dir, opened):
    """fmi3SetTime(NaN) or inf is an error naming the time kept (it had been taken, and every derivative after it
    evaluated the profile at NaN); the instance goes on at the time it had."""
    log = []
    inst = _open(MeInstance, fmu3_dir, "MotorController", log)
    opened.append(inst)
    inst.initialize(dict(profile=1, accel=20.0, omega_set=100.0))
    inst.slave.enterContinuousTimeMode()
    inst.slave.setTime(0.5)
    for bad in (math.nan, math.inf):
        with pytest.raises(Exception):
            inst.slave.setTime(bad)
    assert sum("the time must be finite; the time stays at 0.5" in m for m in log) == 2, log
    assert inst.slave.getFloat64([0])[0] == 0.5 and inst.get("omega_ref")[0] == pytest.approx(10.0)


def test_the_time_read_after_a_restore_is_the_states(fmu3_dir, opened):
    """After fmi3SetFMUState the independent variable reads the time the state was saved at, the time the model
    evaluates at (it had kept the later one), and in Co-Simulation it reads the end of the last step."""
    inst = _open(MeInstance, fmu3_dir, "MotorController", [])
    opened.append(inst)
    inst.initialize(dict(profile=1, accel=20.0, omega_set=100.0))
    inst.slave.enterContinuousTimeMode()
    inst.slave.setTime(0.5)
    state = inst.slave.getFMUState()
    inst.slave.setTime(2.0)
    inst.slave.setFMUState(state)
    assert inst.slave.getFloat64([0])[0] == 0.5 and inst.get("omega_ref")[0] == pytest.approx(10.0)
    inst.slave.freeFMUState(state)
    cs = _open(FmuInstance3, fmu3_dir, "Load", [])
    opened.append(cs)
    cs.initialize()
    cs.slave.doStep(0.0, 0.25)
    assert cs.slave.getFloat64([0])[0] == 0.25


@pytest.mark.parametrize("at", [0.4, 0.35, 0.7])   # 35 * 0.01 = 0.35000000000000003: the event a few ulps short
def test_a_load_step_is_a_time_event(fmu3_dir, at):
    """The Load announces the step of its T(t) (T_change = 1 N.m at t_change) as a time event, so a Model
    Exchange host's solver stops there: ``simulate_me`` lists it at t_change (also where the output time is a few
    ulps off it, which CVode had refused as an interval "too close"), the load torque is T0 before
    and T0 + T_change from it on (the shaft far from rest: s(omega) = 1), and the speed after it bends as the
    torque balance says (its slope drops by 1 N.m / 0.1 kg.m2 = 10 rad/s^2)."""
    components = [
        Component("joint", fmu3_dir / "CardanJointTorqueDriven.fmu", dict(
            bend_angle=0.0, error_angle_beta=0.0, error_angle_gamma=0.0, J_drive=0.1, J1=0.0, J2=0.0,
            omega_in_start=10.0, tau_in=3.0)),
        Component("load", fmu3_dir / "Load.fmu", dict(T0=1.0, T_change=1.0, t_change=at, omega_smooth=1e-6))]
    connections = [Connection("joint.omega_out", "load.omega"), Connection("load.tau", "joint.tau_load")]
    events = []
    table = simulate_me(components, connections, 1.0, 0.01, ["load.tau", "joint.omega_in"], events=events)
    assert len(events) == 1 and events[0][0] == pytest.approx(at, abs=1e-15) and events[0][1] == "load.time event"
    t = table["time"]
    np.testing.assert_allclose(table["load.tau"], np.where(t < at - 1e-12, 1.0, 2.0), atol=1e-9)
    closed = 10.0 + 20.0 * t - 10.0 * np.maximum(t - at, 0.0)   # (3 - 1) / 0.1, then (3 - 2) / 0.1 rad/s^2
    assert np.max(np.abs(table["joint.omega_in"] - closed)) < 1e-6


def test_model_exchange_says_a_twist_no_real_shaft_takes(fmu3_dir):
    """The FMI 3.0 Model Exchange torque-driven double Cardan driven hard (100 N.m) into a linear load twists its
    default (laboratory) shaft past 0.5 rad: it says so once, as the Co-Simulation FMUs do from their steps, and
    simulate_me passes it on as an FmuWarning (its runs had passed on no warning at all)."""
    import warnings

    from ujfmu.master import FmuWarning
    components = [Component("driveline", fmu3_dir / "DoubleCardanDrivelineTorqueDriven.fmu",
                            dict(J_drive=0.1, tau_in=100.0, omega_in_start=100.0)),
                  Component("load", fmu3_dir / "Load.fmu", dict(T0=0.0, c1=1.0))]
    connections = [Connection("driveline.omega_out", "load.omega"), Connection("load.tau", "driveline.tau_load")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FmuWarning)
        table = simulate_me(components, connections, 0.05, 1e-3, ["driveline.twist"])
    said = [str(w.message) for w in caught if "twisted" in str(w.message)]
    assert np.max(np.abs(table["driveline.twist"])) > 0.5 and len(said) == 1 and "k_theta" in said[0]


def test_a_step_after_fmi3_terminate_is_refused_naming_the_reset(fmu3_dir, opened):
    """After fmi3Terminate the outputs stay readable and fmi3DoStep is refused (discard) naming fmi3Reset, as the
    FMI 2.0 FMUs do after fmi2Terminate."""
    log = []
    inst = _open(FmuInstance3, fmu3_dir, "CardanJoint", log)
    opened.append(inst)
    inst.initialize()
    step = inst.raw("fmi2DoStep")
    inst.set(omega_in=10.0, tau_load=0.1)
    assert step(inst.slave.component, 0.0, H, 1) == 0
    before = inst.get("omega_out")
    inst.slave.terminate()
    assert inst.get("omega_out") == before
    assert step(inst.slave.component, H, H, 1) == 2          # fmi3Discard
    assert any("the instance is terminated (fmi3Terminate ended its run): fmi3Reset" in m for m in log), log


def test_fmi3_calls_with_a_wrong_type_or_an_unknown_value_reference_are_refused_without_a_crash(fmu3_dir,
                                                                                                  run_wrong_calls):
    """As the FMI 2.0 FMUs (tests/fmu/test_fmu_hosting.py): fmi3SetFloat64 on an Int32 or Boolean variable, fmi3GetInt64
    or fmi3GetUInt64 on what is not one, an unknown value reference: each refused naming the variable, its type and
    the call to use; pythonfmu3's own TypeError or KeyError had crashed the host (SIGSEGV) at exit; so had
    fmi3SetFloat64 on the independent time variable (a Float64 without a setter) twice, a review found."""
    calls = ("lambda: slave.setFloat64([vr['profile']], [2.0]), "
             "lambda: slave.setFloat64([vr['ideal_speed_source']], [1.0]), lambda: slave.getFloat64([9999]), "
             "lambda: slave.setFloat64([9999], [1.0]), lambda: slave.setInt32([vr['omega_set']], [2]), "
             "lambda: slave.getBoolean([vr['omega_set']]), lambda: slave.getInt64([vr['omega_set']]), "
             "lambda: slave.getUInt64([9999]), lambda: slave.setFloat64([0], [1.0]), "
             "lambda: slave.setFloat64([0], [1.0]),")
    run_wrong_calls("FmuInstance3", fmu3_dir / "Motor.fmu", calls, (
        "fmi3SetFloat64: profile (value reference 5) is of type Int32, not Float64: use fmi3SetInt32",
        "fmi3SetFloat64: ideal_speed_source (value reference 10) is of type Boolean, not Float64: use fmi3SetBoolean",
        "fmi3GetFloat64: no variable has value reference 9999", "fmi3SetFloat64: no variable has value reference 9999",
        "fmi3SetInt32: omega_set (value reference 6) is of type Float64, not Int32: use fmi3SetFloat64",
        "fmi3GetBoolean: omega_set", "fmi3GetInt64: omega_set", "fmi3GetUInt64: no variable has value reference 9999",
        "fmi3SetFloat64: time (value reference 0) cannot be set: its causality is independent"))


def test_a_solver_failure_at_a_switch_names_it_and_the_models_advice(fmu3_dir, opened):
    """Where our runner's CVode fails with an FMU's event indicator at its switch (a PI law sliding along its torque
    limit: a speed step into a loop damped below 0.5, which the solver grinds at until its step limit), its error
    names the indicator and the model's remedy; away from the switch it adds nothing."""
    from ujfmu.model_exchange import _switch_hint
    inst = _open(MeInstance, fmu3_dir, "MotorController", [])
    opened.append(inst)
    inst.initialize(dict(profile=0, omega_set=100.0, Kp=2.0, Ki=10.0, tau_max=5.0))
    inst.set(omega=98.0)   # v = Kp e + Ki I = 4 + 10 I
    for integral, said in ((0.1 + 1e-9, True), (0.2, False)):   # v 1e-8 N.m past the limit 5 N.m, then 1 N.m
        inst.buffer[0] = integral
        inst.slave.setContinuousStates(inst.buffer, 1)
        hint = _switch_hint({"motor": inst})
        assert bool(hint) == said, hint
    inst.buffer[0] = 0.1
    inst.slave.setContinuousStates(inst.buffer, 1)
    hint = _switch_hint({"motor": inst})
    assert "motor.z.upper_limit = " in hint and "slides along its torque limit" in hint and "Co-Simulation" in hint


def _sliding_controller(fmu3_dir, log):
    """fmpy's own Model Exchange loop (CVode) on the MotorController alone (Kp 0.2, Ki 10, limit 5 N.m, a ramp of
    30 rad/s^2 to 60 rad/s), its measured speed stalled to 0.3 s, then ramping at 66.7 rad/s^2: the PI law comes
    back to its limit at 0.4115 s with Ki e > Kp |de/dt| and slides along it until 0.5255 s."""
    from fmpy import simulate_fmu
    speed = np.array([(0.0, 0.0), (0.3, 0.0), (1.5, 80.0)], dtype=[("time", float), ("omega", float)])
    return simulate_fmu(str(fmu3_dir / "MotorController.fmu"), fmi_type="ModelExchange", stop_time=0.6,
                        output_interval=1e-3, input=speed, output=["tau_motor"], record_events=True,
                        start_values=dict(Kp=0.2, Ki=10.0, tau_max=5.0, profile=1, accel=30.0, omega_set=60.0),
                        logger=lambda *args: log.append(args[-1]))


def test_a_host_locating_every_crossing_of_a_sliding_pi_limit_is_stopped_with_the_reason(fmu3_dir):
    """A host that locates each crossing of the sliding PI limit as an event would take them for ever, time hardly
    advancing (100,000 in a minute of wall time: 1e-4 s). The FMU ends the run at the ZENO_EVENTS-th
    (terminateSimulation), its logged reason naming the indicator and the remedy."""
    from ujfmu.fmu3.base import ZENO_EVENTS
    log = []
    result = _sliding_controller(fmu3_dir, log)
    assert 0.41 < result["time"][-1] < 0.412
    events = np.count_nonzero(np.diff(result["time"]) == 0.0)
    assert ZENO_EVENTS - 1 <= events <= ZENO_EVENTS + 1, events
    said = [m.decode() if isinstance(m, bytes) else str(m) for m in log]
    assert any(f"{ZENO_EVENTS} events within" in m and "switch back and forth at z.upper_limit" in m
               and "slides along its torque limit" in m for m in said), said


def test_event_iteration_at_one_instant_and_ordinary_limit_events_do_not_stop_a_run(fmu3_dir, opened):
    """Calls of fmi3UpdateDiscreteStates at one instant (a host's event iteration, or a state restored and its
    event redone) are not events in a row; a run through ordinary torque-limit switches is not stopped either."""
    inst = _open(MeInstance, fmu3_dir, "MotorController", [])
    opened.append(inst)
    inst.initialize(dict(profile=0, omega_set=100.0, Kp=2.0, Ki=10.0, tau_max=5.0))
    inst.set(omega=98.0)
    inst.buffer[0] = 0.1   # v at the upper limit: the indicator at its switch
    inst.slave.setContinuousStates(inst.buffer, 1)
    inst.slave.enterEventMode()
    state = inst.slave.getFMUState()
    for k in range(3 * 50):   # event iteration at one instant
        assert not inst.slave.updateDiscreteStates()[1], k
    for k in range(3 * 50):   # the state restored and its event redone
        inst.slave.setFMUState(state)
        assert not inst.slave.updateDiscreteStates()[1], k
    components, connections = _saturating_drive(fmu3_dir)
    events = []
    simulate_me(components, connections, 2.5, 0.01, ["motor.tau_motor"], events=events)
    assert [name for _, name in events] == ["motor.z.upper_limit"]


def test_a_model_exchange_run_ends_where_an_fmu_asks_to_terminate(fmu3_dir, monkeypatch):
    """An FMU's terminateSimulation at an event (here forced at the torque limit's end, 1.95 s) ends our runner's
    run with an error naming the component and the time, not a run that steps on."""
    from fmpy.fmi3 import FMU3Model
    update = FMU3Model.updateDiscreteStates

    def terminating(self):   # the motor's first update (initialization) as it is, every later one terminating
        result = update(self)
        first, self._updated = not getattr(self, "_updated", False), True
        return result if first or self.instanceName != "motor" else (result[0], True, *result[2:])
    monkeypatch.setattr(FMU3Model, "updateDiscreteStates", terminating)
    components, connections = _saturating_drive(fmu3_dir)
    with pytest.raises(ModelExchangeError, match=r"motor ended the simulation \(fmi3UpdateDiscreteStates: "
                                                 r"terminateSimulation\) at t = 1\.95"):
        simulate_me(components, connections, 2.5, 0.01, ["motor.tau_motor"])
