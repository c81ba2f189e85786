"""ujfmu.models.load.model: limits of the smooth torque law."""

import numpy as np
import pytest

from ujfmu.models.load.model import load_torque


def test_limits_far_from_rest():
    w = 200.0
    assert load_torque(w, 0.3, 0.0, 0.0, 0.1) == pytest.approx(0.3, rel=1e-6)
    assert load_torque(w, 0.0, 0.01, 0.0, 0.1) == pytest.approx(2.0)
    assert load_torque(w, 0.0, 0.0, 0.017, 0.1) == pytest.approx(0.017 * w * w, rel=1e-6)  # Brutti's M_u


def test_odd_and_smooth_through_rest():
    w = np.linspace(-2, 2, 4001)
    tau = np.array([load_torque(x, 0.3, 0.01, 0.02, 0.5) for x in w])
    np.testing.assert_allclose(tau, -tau[::-1], atol=1e-15)
    assert load_torque(0.0, 0.3, 0.01, 0.02, 0.5) == 0.0
    d2 = np.diff(tau, 2)
    assert np.max(np.abs(np.diff(d2))) < 1e-6  # no kink: third differences stay small


def test_a_load_step_or_ramp_changes_T0_at_its_corners():
    """T(t): T0 before t_change, T0 + T_change after t_change (a step) or after t_change + ramp_time (linear
    between); the corners are where it jumps or bends, announced as time events after t; no change, none."""
    from ujfmu.models.load import model as load
    step = load.Parameters(20.0, 0.0, 0.0, 0.1, T_change=30.0, t_change=5.0)
    assert [load.level(step, t) for t in (0.0, 4.999, 5.0, 60.0)] == [20.0, 20.0, 50.0, 50.0]
    ramp = load.Parameters(20.0, 0.0, 0.0, 0.1, T_change=-10.0, t_change=1.0, ramp_time=2.0)
    assert [load.level(ramp, t) for t in (0.5, 1.0, 1.5, 2.0, 3.0, 9.0)] == [20.0, 20.0, 17.5, 15.0, 10.0, 10.0]
    assert load.corners(step) == (5.0,) and load.corners(ramp) == (1.0, 3.0)
    assert [load.next_time_event(ramp, t) for t in (0.0, 1.0, 2.0, 3.0)] == [1.0, 3.0, 3.0, None]
    constant = load.Parameters(20.0, 0.0, 0.0, 0.1, T_change=0.0, t_change=5.0, ramp_time=1.0)
    assert load.corners(constant) == () and load.level(constant, 9.0) == 20.0
    out = load.outputs(step, 6.0, (), load.Inputs(200.0))["tau"]
    assert out == pytest.approx(load_torque(200.0, 50.0, 0.0, 0.0, 0.1), rel=1e-15)


def test_a_negative_coefficient_is_said_to_drive_the_shaft():
    """T0, c1 or c2 below 0 (valid: the declared ranges allow an assisting load) turn the law into a driving
    torque, c1 and c2 into negative damping: advice names each; a resisting load, none; a change to below 0 is
    named as T0 + T_change."""
    from ujfmu.models.load import model as load
    assert load.advice(load.Parameters(0.3, 0.01, 0.002, 0.1)) == []
    messages = load.advice(load.Parameters(-0.3, -0.01, 0.002, 0.1))
    assert [m.split(" =")[0] for m in messages] == ["T0", "c1"] and "negative damping" in messages[1]
    (change,) = load.advice(load.Parameters(0.3, 0.0, 0.0, 0.1, T_change=-0.5, t_change=1.0))
    assert change.startswith("T0 + T_change = -0.2")
    assert load.advice(load.Parameters(0.3, 0.0, 0.0, 0.1, T_change=-0.2, t_change=1.0)) == []


def test_an_active_torque_keeps_its_sign_whatever_the_direction():
    """T_active (a gradient, a hoisted weight) is the same torque at any speed and either direction, where T0
    reverses with the speed (a negative T0 pushes whichever way the shaft turns: said, naming T_active); it adds to
    the rest of the law, and the references' law (``references.common.load_torque``) is the FMU's."""
    from ujfmu.models.load import model as load
    from ujfmu.references.common import load_torque as reference_law
    gradient = load.Parameters(0.0, 0.0, 0.0, 0.1, T_active=-40.0)
    assert [load.outputs(gradient, 0.0, (), load.Inputs(w))["tau"] for w in (-20.0, 0.0, 20.0)] == [-40.0] * 3
    friction = load.Parameters(-40.0, 0.0, 0.0, 0.1)
    torques = [load.outputs(friction, 0.0, (), load.Inputs(w))["tau"] for w in (-20.0, 20.0)]
    assert torques == pytest.approx([40.0, -40.0], rel=1e-4) and "T_active" in load.advice(friction)[0]
    mixed = dict(T0=3.0, c1=0.2, c2=0.01, omega_smooth=0.1, T_active=-40.0)
    for w in (-20.0, 0.5, 20.0):
        fmu = load.outputs(load.Parameters(**mixed), 0.0, (), load.Inputs(w))["tau"]
        assert fmu == pytest.approx(load_torque(w, 3.0, 0.2, 0.01, 0.1) - 40.0, rel=1e-14)
        assert float(reference_law(mixed, w, 0.0)) == pytest.approx(fmu, rel=1e-14)


def test_an_active_torque_is_what_the_drive_holds_at_constant_speed(fmu_dir):
    """Feng's start-up against T_active = 0.4 N.m alone: once the PI motor holds its set speed, its mean torque over
    whole revolutions is the load's (power balance through a joint whose mean speed ratio is 1); the reference,
    solving the same law independently, agrees with the co-simulation."""
    from pathlib import Path

    from ujfmu.master import cosimulate
    from ujfmu.references import generate
    from ujfmu.scenario import Scenario
    startup = Scenario(Path(__file__).parents[3] / "scenarios" / "cardan_startup.toml")
    gradient = startup.with_parameters({"load.T0": 0.0, "load.c1": 0.0, "load.c2": 0.0, "load.T_active": 0.4,
                                        "motor.accel": 300.0})
    gradient.stop_time = 1.5
    run = cosimulate(gradient.master_components(fmu_dir), gradient.connections, gradient.stop_time,
                     gradient.step_size, ["motor.tau_motor", "motor.phi", "load.tau"], coupling=gradient.coupling)
    steady = run["time"] >= 1.0
    phi = run["motor.phi"][steady]
    whole = phi - phi[0] <= 2.0 * np.pi * np.floor((phi[-1] - phi[0]) / (2.0 * np.pi))
    assert np.all(run["load.tau"] == 0.4)
    assert np.trapezoid(run["motor.tau_motor"][steady][whole], phi[whole]) / (phi[whole][-1] - phi[0]) == \
        pytest.approx(0.4, rel=2e-3)
    reference, _ = generate(gradient)
    assert np.max(np.abs(run["motor.tau_motor"] - np.interp(run["time"], reference["time"],
                                                             reference["motor.tau_motor"]))) < 0.02
