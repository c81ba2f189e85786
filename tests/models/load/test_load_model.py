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
