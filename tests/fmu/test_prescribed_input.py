"""The input shaft's acceleration that the speed-driven FMUs estimate from omega_in's history
(``ujfmu.fmu.base.PrescribedInputSlave.input_acceleration``), through fmpy, against the speed's exact derivative."""

import math

import numpy as np
import pytest

#: a straight CardanJoint (no bend, no error angles) turns its driven side at the input speed: tau_in = (J1 + J2) alpha
STRAIGHT = dict(bend_angle=0.0, error_angle_beta=0.0, error_angle_gamma=0.0, J1=0.3, J2=0.7)


def cornered(t: float, t_corner: float = 0.02, w0: float = 40.0, a: float = -1000.0) -> float:
    """A speed held at w0, then decelerating at a from t_corner (a drive reaching its torque limit)."""
    return w0 + a * max(t - t_corner, 0.0)


@pytest.mark.parametrize("name, params, output", [
    ("CardanJoint", STRAIGHT, "tau_in"),
    ("DoubleCardanDriveline", dict(rigid_intermediate_shaft=True), "alpha_in"),
])
def test_an_acceleration_that_jumps_from_flat_is_not_overshot(open_fmu, drive, name, params, output):
    """A speed held, then decelerating at -1000 rad/s^2 from 20 ms (a drive braking at its limit from a steady
    speed) and held again from 30 ms: the second-order slope through the first corner had read -1500 rad/s^2 at the
    next point, half the jump beyond it (so J alpha +50% in tau_in, at any step); now the estimate is exact on both
    sides of it (and after the corner back to flat, where an unchanged speed gives 0). The straight joint's tau_in
    is (J1 + J2) alpha."""
    h = 1e-3
    speed = lambda t: cornered(t) - cornered(t, 0.03)   # noqa: E731 (decelerates from 20 to 30 ms only)
    r = drive(open_fmu(name), speed, 0.0, h, 45, (output,), params)
    true = np.where((r.time > 0.02 + 1e-9) & (r.time < 0.03 + 1e-9), -1000.0, 0.0)
    per_alpha = STRAIGHT["J1"] + STRAIGHT["J2"] if output == "tau_in" else 1.0
    np.testing.assert_allclose(r[output], per_alpha * true, atol=1e-9 * 1000.0 * per_alpha)


@pytest.mark.parametrize("ramp, phase, samples", [(-0.854, 3.882, 17.35), (0.9868, 2.4994, 24.44), (-1.0, 0.0, 15.0),
                                                   (0.3, 1.0, 17.35)])
def test_a_swing_on_a_ramp_is_no_corner(open_fmu, drive, ramp, phase, samples):
    """A speed whose acceleration is ramp * 200 + 200 cos(Omega t + phase) rad/s^2, sampled a given number of times
    a period (a second joint's 2x swing on a ramp): where its zeros lie near its extremes (ramp near -1 or 1), a
    rule on the last steps alone had taken it for a corner and made the error up to 2.5x the parabola's (20.7
    against 8.66 rad/s^2 in the first case); with the decayed peak of the accelerations before, the estimate is
    never worse than the parabola's (BDF2 from the same speeds)."""
    h, amplitude = 1e-3, 200.0
    omega = 2.0 * math.pi / (samples * h)
    w = lambda t: 50.0 + ramp * amplitude * t + amplitude / omega * math.sin(omega * t + phase)   # noqa: E731
    r = drive(open_fmu("DoubleCardanDriveline"), w, 0.0, h, 200, ("alpha_in",), dict(rigid_intermediate_shaft=True))
    exact = ramp * amplitude + amplitude * np.cos(omega * r.time + phase)
    bdf2 = (3.0 * r.omega_in[2:] - 4.0 * r.omega_in[1:-1] + r.omega_in[:-2]) / (2.0 * h)
    assert np.max(np.abs(r.alpha_in[2:] - exact[2:])) <= np.max(np.abs(bdf2 - exact[2:])) * (1 + 1e-9)


def test_a_smooth_speeds_acceleration_stays_second_order(open_fmu, drive):
    """A speed with a 2x-like swing, 50 + 5 sin(40 t) rad/s: its acceleration's error halves four-fold with the
    step (second order) wherever the estimate drops the parabola's term (near the acceleration's zeros or extremes,
    never both), and is within 0.3% of the 200 rad/s^2 amplitude at 1 ms."""
    errors = []
    for h in (1e-3, 5e-4):
        n = round(0.3 / h)
        r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 50.0 + 5.0 * math.sin(40.0 * t), 0.0, h, n,
                  ("alpha_in",), dict(rigid_intermediate_shaft=True))
        errors.append(np.max(np.abs(r.alpha_in[3:] - 200.0 * np.cos(40.0 * r.time[3:]))))
    assert errors[0] < 3e-3 * 200.0 and 3.5 < errors[0] / errors[1] < 4.5, errors
