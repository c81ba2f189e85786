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
def test_an_acceleration_that_jumps_is_not_overshot(open_fmu, drive, name, params, output):
    """A speed that turns a corner, constant to -1000 rad/s^2 at 20 ms (and back, at 30 ms): the second-order
    slope through the corner had read -1500 rad/s^2 at the next point, half the jump beyond it (so J alpha +50% in
    tau_in, at any step); now the estimate is the acceleration of the last step wherever the acceleration jumped,
    exact on both sides of each corner. The straight joint's tau_in is (J1 + J2) alpha."""
    h = 1e-3
    speed = lambda t: cornered(t) - cornered(t, 0.03)   # noqa: E731 (decelerates from 20 to 30 ms only)
    r = drive(open_fmu(name), speed, 0.0, h, 45, (output,), params)
    true = np.where((r.time > 0.02 + 1e-9) & (r.time < 0.03 + 1e-9), -1000.0, 0.0)
    per_alpha = STRAIGHT["J1"] + STRAIGHT["J2"] if output == "tau_in" else 1.0
    np.testing.assert_allclose(r[output], per_alpha * true, atol=1e-9 * 1000.0 * per_alpha)


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
