"""Torque-driven equations (torque_driven_rates of cardan_joint and double_cardan_driveline): power balance of the whole
system, driver's rotor included, and the speed-driven models' tau_in recovered from the accelerations."""

import math

import pytest

from ujfmu.models.cardan_joint import model as cardan
from ujfmu.models.double_cardan_driveline import model as dc


def _power_residual(energy, rates, state, power_in):
    """dE/dt along the state's own derivative (central difference) minus the net power in."""
    d = rates(state)
    eps = 1e-7
    plus = [x + eps * v for x, v in zip(state, d)]
    minus = [x - eps * v for x, v in zip(state, d)]
    return (energy(plus) - energy(minus)) / (2 * eps) - power_in(state, d)


@pytest.mark.parametrize("theta1", [0.1, 0.9, 2.3])
def test_cardan_torque_driven_conserves_power(theta1):
    """d/dt (J_d + J1 + J2 r^2) w1^2 / 2 = tau_drive w1 - tau_load w2 (Lagrange, lossless joint)."""
    frame = cardan.joint_frame(math.radians(25), 0.1, 0.01, 0.02)
    jd, j1, j2, tau, load = 0.03, 0.002, 0.4, 7.0, 3.0

    def energy(y):
        r = cardan.velocity_ratio(frame, y[0])
        return 0.5 * (jd + j1 + j2 * r * r) * y[1] ** 2

    def rates(y):
        return cardan.torque_driven_rates(frame, y, tau, load, jd, j1, j2)

    def power(y, d):
        return tau * y[1] - load * cardan.velocity_ratio(frame, y[0]) * y[1]

    scale = abs(tau * 40.0) + abs(load * 40.0)
    assert abs(_power_residual(energy, rates, [theta1, 40.0], power)) < 1e-6 * scale


def test_cardan_torque_driven_reproduces_the_speed_driven_torque():
    """The speed-driven joint driven at the acceleration the torque-driven one computes demands tau_drive less
    the rotor's J_d alpha1."""
    frame = cardan.joint_frame(math.radians(30), 0.0, 0.0, 0.0)
    jd, tau = 0.05, 12.0
    _, alpha = cardan.torque_driven_rates(frame, (0.7, 30.0), tau, 2.0, jd, 1e-3, 0.3)
    tau_in = cardan.joint_torques(frame, 0.7, 30.0, alpha, 2.0, 1e-3, 0.3)[0]
    assert tau_in + jd * alpha == pytest.approx(tau, rel=1e-12)


def _driveline(**kw):
    args = dict(beta1=math.radians(20), beta2=math.radians(20), yoke_phase=math.radians(30), joint_plane_angle=0.0,
                I_input=0.01, I_cross_pin=1e-3, I_cross_normal=1.5e-3, I_intermediate=0.02, J_load=0.5, k_theta=2e4,
                xi_theta=0.002, m_s=4.09, k_phi=26331.0, xi_phi=0.002, L_c=0.325)
    args.update(kw)
    return dc.Parameters(**args)


@pytest.mark.parametrize("rigid", [True, False])
def test_double_cardan_torque_driven_power_balance(rigid):
    """d/dt (E + J_d w1^2/2) = tau_drive w1 - tau_load w4 - c_theta dtwist^2 - c_phi (L_c cos beta1)^2 dphi^2."""
    p = _driveline()
    jd, tau, load = 0.05, 30.0, 8.0
    state = [0.4, 50.0] if rigid else [0.4, 50.0, 0.35, 49.0, 1e-3, 0.02]

    def outputs(y):
        if rigid:
            return dc.rigid_state(p, y[0], y[1], 0.0, load)
        return dc.flexible_outputs(p, y[0], y[1], 0.0, y[2:])

    def energy(y):
        return outputs(y)["energy"] + 0.5 * jd * y[1] ** 2

    def rates(y):
        return dc.torque_driven_rates(p, jd, y, tau, load)

    def power(y, d):
        out = outputs(y)
        if rigid:
            return tau * y[1] - load * out["omega4"]
        return tau * y[1] - load * y[3] - p.c_theta * out["dtwist"] ** 2 - p.c_phi * p.lever2 * y[5] ** 2

    residual = _power_residual(energy, rates, state, power)
    assert abs(residual) < 1e-6 * (abs(tau) + abs(load)) * 50.0


def test_double_cardan_flexible_torque_driven_reproduces_the_speed_driven_torque():
    p = _driveline()
    y = (0.4, 50.0, 0.35, 49.0, 1e-3, 0.02)
    jd, tau = 0.05, 30.0
    d = dc.torque_driven_rates(p, jd, y, tau, 8.0)
    tau_in = dc.flexible_outputs(p, y[0], y[1], d[1], y[2:])["tau_in"]
    assert tau_in + jd * d[1] == pytest.approx(tau, rel=1e-12)
    assert d[2:] == dc.flexible_derivatives(p, y[0], y[1], y[2:], 8.0)


def test_natural_rate_bound_covers_the_free_input_shaft():
    """The two-mass torsional mode sqrt(k r^2 (1/J_out + 1/J_in)) exceeds the prescribed-input bound's."""
    p = _driveline(I_input=0.0, I_cross_pin=0.0, I_cross_normal=0.0, I_intermediate=0.0)
    two_mass = math.sqrt(p.k_theta * (1.0 / p.J_load + 1.0 / 0.05))
    assert dc.natural_rate_bound(p) < two_mass <= dc.natural_rate_bound(p, 0.05)
