"""Motor.fmu and Load.fmu through fmpy."""

import math

import pytest
from fmpy.fmi1 import FMICallException


def test_ideal_speed_source_follows_ramp_and_reports_its_torque(open_fmu):
    m = open_fmu("Motor")
    m.initialize(dict(ideal_speed_source=True, profile=1, accel=30.0, omega_set=150.0, J_rotor=2e-3))
    h = 1e-3
    for k in range(1000):
        m.set(tau_load=0.4)
        m.slave.doStep(k * h, h)
    omega, phi, tau = m.get("omega", "phi", "tau_motor")
    assert omega == pytest.approx(30.0, rel=1e-12) and phi == pytest.approx(15.0, rel=1e-12)
    assert tau == pytest.approx(2e-3 * 30.0 + 0.4, rel=1e-12)


def test_pi_motor_torque_output_is_the_pi_law(open_fmu):
    """Proportional only (Ki = 0), speed step of 10 rad/s at t = 0.5 s onto a motor at rest, no load: at every
    communication point tau_motor = Kp (omega_ref - omega), and the speed rises as the first-order response
    10 (1 - exp(-Kp (t - 0.5) / J))."""
    m = open_fmu("Motor")
    kp, j = 0.2, 1.0
    m.initialize(dict(profile=2, t_step=0.5, omega_initial=0.0, omega_set=10.0, Kp=kp, Ki=0.0, tau_max=1e3,
                      J_rotor=j))
    h = 1e-3
    for k in range(1500):
        m.set(tau_load=0.0)
        m.slave.doStep(k * h, h)
        t = (k + 1) * h
        omega, omega_ref, tau = m.get("omega", "omega_ref", "tau_motor")
        assert tau == pytest.approx(kp * (omega_ref - omega), rel=1e-12, abs=1e-15)
    assert omega == pytest.approx(10.0 * (1.0 - math.exp(-kp * (t - 0.5) / j)), rel=1e-3)


def test_pi_motor_holds_speed_against_load_and_respects_torque_limit(open_fmu):
    m = open_fmu("Motor")
    m.initialize(dict(profile=0, omega_set=100.0, tau_max=0.5, J_rotor=1e-3, Kp=0.2, Ki=10.0))
    h = 1e-3
    for k in range(2000):
        m.set(tau_load=0.3 if k < 1000 else 0.8)   # 0.8 N.m exceeds the 0.5 N.m limit
        m.slave.doStep(k * h, h)
        if k == 999:
            assert m.get("omega")[0] == pytest.approx(100.0, abs=1e-3)
    omega, tau = m.get("omega", "tau_motor")
    assert tau == pytest.approx(0.5) and omega < 100.0 - 0.3 / 1e-3 * 0.5 * 0.9  # decelerating at the limit


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("started", [False, True])
def test_a_pi_motor_started_at_its_load_torque_holds_its_speed_from_the_first_step(open_fmu, started, sign):
    """A PI motor at its set speed against a constant load (0.3 N.m, or -0.3 N.m turning at -100 rad/s): with
    tau_initial = the load it starts in equilibrium (tau_motor = tau_load, no speed error: the closed loop's state
    at rest) and holds its speed to round-off; from zero torque (the default) the load first slows it, in the first
    step by tau_load h / J_rotor less the PI's own response, Kp h^2 / J of that (the loop's first-order term)."""
    m = open_fmu("Motor")
    j, h, kp, load, speed = 1e-3, 1e-3, 0.2, sign * 0.3, sign * 100.0
    tau_initial = load if started else 0.0
    m.initialize(dict(profile=2, t_step=-1.0, omega_set=speed, tau_max=0.5, J_rotor=j, Kp=kp, Ki=10.0,
                      tau_initial=tau_initial))
    assert m.get("tau_motor")[0] == pytest.approx(tau_initial, abs=1e-15)
    m.set(tau_load=load)
    m.slave.doStep(0.0, h)
    omega, tau = m.get("omega", "tau_motor")
    if started:
        assert omega == pytest.approx(speed, abs=1e-12) and tau == pytest.approx(load, rel=1e-12)
    else:
        drop = load * h / j * (1.0 - 0.5 * kp * h / j)
        assert omega - speed == pytest.approx(-drop, rel=0.05)


def test_a_motor_controller_starts_at_its_starting_torque_and_integrates_from_there(open_fmu):
    """The MotorController's integral starts at tau_initial / Ki: at the reference speed it delivers tau_initial,
    and a speed 1 rad/s short for a step of h adds Kp e + Ki e h to it."""
    c = open_fmu("MotorController")
    kp, ki, h = 0.2, 10.0, 1e-3
    c.initialize(dict(profile=0, omega_set=100.0, tau_max=5.0, Kp=kp, Ki=ki, tau_initial=1.5))
    c.set(omega=100.0)
    assert c.get("tau_motor")[0] == pytest.approx(1.5, rel=1e-15)
    c.set(omega=99.0)
    c.slave.doStep(0.0, h)
    assert c.get("tau_motor")[0] == pytest.approx(1.5 + kp * 1.0 + ki * 1.0 * h, rel=1e-12)


@pytest.mark.parametrize("params, words", [(dict(Ki=0.0, tau_initial=0.3), "needs an integral to start from (Ki > 0)"),
                                           (dict(tau_max=0.5, tau_initial=-0.6), "beyond the drive's torque limit")])
def test_a_starting_torque_a_drive_cannot_hold_is_refused(open_fmu, params, words):
    """A P controller (Ki = 0) has no integral to start from, and no drive starts past its torque limit: both are
    refused at initialisation, naming tau_initial, for the Motor and the MotorController alike."""
    for fmu in ("Motor", "MotorController"):
        inst = open_fmu(fmu)
        with pytest.raises(FMICallException):
            inst.initialize(params)
        assert any("tau_initial" in msg and words in msg for msg in inst._log), (fmu, inst._log)


def test_load_torque_law_feeds_through(open_fmu):
    ld = open_fmu("Load")
    ld.initialize(dict(T0=0.2, c1=0.01, c2=0.017, omega_smooth=0.1))
    for w in (-50.0, 0.0, 209.4):
        ld.set(omega=w)   # no step needed: the output follows the input directly
        mag = math.sqrt(w * w + 0.01)
        assert ld.get("tau")[0] == pytest.approx(0.2 * w / mag + 0.01 * w + 0.017 * w * mag, rel=1e-14)


@pytest.mark.parametrize("smooth", [0.1, 1e-9])
def test_load_at_rest_is_smooth_and_odd(open_fmu, smooth):
    """omega = 0: no torque and no division by zero, whatever the (allowed, > 0) regularisation speed; the
    slope there is T0/omega_smooth + c1 + c2 omega_smooth; at omega = omega_smooth the smooth sign is 1/sqrt(2)."""
    ld = open_fmu("Load")
    ld.initialize(dict(T0=0.2, c1=0.01, c2=0.017, omega_smooth=smooth))
    ld.set(omega=0.0)
    assert ld.get("tau")[0] == 0.0
    dw = 1e-6 * smooth
    ld.set(omega=dw)
    assert ld.get("tau")[0] / dw == pytest.approx(0.2 / smooth + 0.01 + 0.017 * smooth, rel=1e-6)
    ld.set(omega=-smooth)
    assert ld.get("tau")[0] == pytest.approx(-(0.2 / math.sqrt(2) + 0.01 * smooth + 0.017 * smooth ** 2 * math.sqrt(2)),
                                             rel=1e-12)


@pytest.mark.parametrize("fmu, param, value", [("Motor", "J_rotor", 0.0), ("Motor", "profile", 7),
                                               ("Motor", "Kp", float("nan")), ("Load", "omega_smooth", -1.0)])
def test_bad_parameters_name_the_parameter(open_fmu, fmu, param, value):
    inst = open_fmu(fmu)
    with pytest.raises(FMICallException):
        inst.initialize({param: value})
    assert any(param in msg and "allowed range" in msg for msg in inst._log), inst._log


@pytest.mark.parametrize("fmu, params", [("CardanJoint", {}), ("Motor", dict(ideal_speed_source=True)),
                                         ("Motor", dict(ideal_speed_source=False))])
def test_outputs_follow_every_input_set_between_reads(open_fmu, fmu, params):
    """After a step, the host reads the outputs, sets tau_load (the FMU recomputes only what depends on it, or
    nothing in PI mode), reads again, then sets another input and reads: every output equals a second instance's
    that took the same step and got the final inputs before its first read (never a stale value)."""
    insts = [open_fmu(fmu, f"i{k}") for k in range(2)]
    other = "omega_in" if fmu == "CardanJoint" else None
    for inst in insts:
        inst.initialize(params)
        if other:
            inst.set(omega_in=30.0)
        inst.set(tau_load=0.2)
        inst.slave.doStep(0.0, 1e-3)
        if other:
            inst.set(omega_in=31.0)
    from ujfmu.build import fmu_class
    names = [v.name for v in fmu_class(fmu).VARIABLES if v.causality == "output"]
    first, second = insts
    first.get(*names)
    first.set(tau_load=0.7)
    mid = first.get(*names)
    second.set(tau_load=0.7)
    assert mid == second.get(*names)
    if other:
        first.set(tau_load=0.9)
        first.set(omega_in=33.0)
        second.set(tau_load=0.9)
        second.set(omega_in=33.0)
        assert first.get(*names) == second.get(*names)
    first.set(tau_load=-0.4)
    second.set(tau_load=-0.4)
    assert first.get(*names) == second.get(*names)


def test_a_pi_motor_braking_down_a_slew_agrees_with_the_reference(fmu_dir):
    """Feng's joint turned at 150 rad/s, then braked to 50 rad/s at 100 rad/s^2 from 0.3 s (profile 3): the PI
    motor's speed follows the ramp down (its set point at 0.8 s is 100 rad/s, at 1.3 s 50 rad/s), and the motor's
    speed and torque and the joint's input torque agree with the monolithic reference, which writes the profile and
    the PI law again (``references.common``), after the start's first 0.1 s."""
    from pathlib import Path

    import numpy as np

    from ujfmu.master import cosimulate
    from ujfmu.references import generate
    from ujfmu.scenario import Scenario
    startup = Scenario(Path(__file__).parents[3] / "scenarios" / "cardan_startup.toml")
    braking = startup.with_parameters({"motor.profile": 3, "motor.omega_initial": 150.0, "motor.omega_set": 50.0,
                                       "motor.accel": 100.0, "motor.t_step": 0.3})
    braking.stop_time = 1.6
    names = ["motor.omega", "motor.tau_motor", "joint.tau_in"]
    run = cosimulate(braking.master_components(fmu_dir), braking.connections, braking.stop_time,
                     braking.step_size, names + ["motor.omega_ref"], coupling=braking.coupling)
    assert list(run["motor.omega_ref"][[0, 300, 800, 1300, 1600]]) == pytest.approx([150.0, 150.0, 100.0, 50.0, 50.0])
    reference, _ = generate(braking)
    late = run["time"] > 0.1
    for name, rel in zip(names, (1e-4, 5e-3, 1e-3)):
        expected = np.interp(run["time"], reference["time"], reference[name])
        assert np.max(np.abs(run[name] - expected)[late]) < rel * np.ptp(expected), name
