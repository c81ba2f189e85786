"""Torque-driven equations (the TorqueDriven protocols of cardan_joint, double_cardan_driveline, twin_jeffcott_rotor,
ring_coupling): power balance of the whole system, driver's rotor included, and the speed-driven models' tau_in
recovered from the accelerations."""

import math

import pytest

from ujfmu.models.cardan_joint import model as cardan
from ujfmu.models.double_cardan_driveline import model as dc
from ujfmu.models.protocol import Torques


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


def _twin(**kw):
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    args = dict(tj.rig_parameters(), phase_u1=0.4, phase_u2=-1.1, J_drive=0.02, omega_in_start=30.0)
    args.update(kw)
    return tj, tj.TorqueDrivenParameters(**args)


def test_twin_rotor_torque_driven_power_balance():
    """d/dt (E + J_d w_in^2/2) = tau_drive w_in - tau_load w2 - dissipation (E the rotor's stored energy with the
    gearbox flange), and the audit states integrate the dissipation and the power through the input shaft end,
    (tau_drive - J_d alpha_in) w_in; a bent, unbalanced rotor at a general state."""
    tj, p = _twin()
    tau, load = 3.0, 1.2
    state = [0.3, 31.0, 0.28, 30.5, 2e-5, 1e-3, -1e-5, 2e-3, 0.25, 30.2, 3e-5, -1e-3, 1e-5, 5e-4, 0.0, 0.0]

    def energy(y):
        return tj.stored_energy(p, y[0], y[1], y[2:]) + 0.5 * p.J_drive * y[1] ** 2

    def rates(y):
        return tj.TorqueDriven.derivatives(p, 0.0, y, Torques(tau, load))

    def power(y, d):
        return tau * y[1] - load * y[9] - d[14]

    assert abs(_power_residual(energy, rates, state, power)) < 1e-6 * (abs(tau) + abs(load)) * 31.0
    d = rates(state)
    assert d[15] == pytest.approx((tau - p.J_drive * d[1]) * state[1], rel=1e-12)
    assert d[14] > 0.0


def test_twin_rotor_torque_driven_reproduces_the_speed_driven_torque():
    """The speed-driven rotor driven at the acceleration the torque-driven one computes demands tau_drive less the
    rotor's J_d alpha_in, and its rates are the torque-driven ones."""
    tj, p = _twin()
    y = (0.3, 31.0, 0.28, 30.5, 2e-5, 1e-3, -1e-5, 2e-3, 0.25, 30.2, 3e-5, -1e-3, 1e-5, 5e-4, 0.0, 0.0)
    d = tj.TorqueDriven.derivatives(p, 0.0, y, Torques(3.0, 1.2))
    tau_in = tj.torque_outputs(p, y[0], y[1], d[1], y[2:])["tau_in"]
    assert tau_in + p.J_drive * d[1] == pytest.approx(3.0, rel=1e-12)
    assert d[2:] == tuple(tj.rates(p, y[0], y[1], d[1], y[2:], 1.2))


def _ring(**kw):
    from ujfmu.models.ring_coupling import model as rc
    args = dict(R=0.1, d=0.003, E=2.1e11, e=0.003, I1=0.01, I2=0.05, c_s=726.0, c_d=1.2, J_drive=0.04,
                omega_in_start=0.0, phi_in_start=0.2, phi_out_start=0.5)
    args.update(kw)
    return rc, rc.TorqueDrivenParameters(**args)


def test_ring_coupling_torque_driven_power_balance():
    """E = (J_d + I1) w1^2/2 + I2 w2^2/2 - 157 (EI/R^3) e^2 sin(phi1 + phi2) + c_s x_e^2/2 (written out here):
    dE/dt = tau_drive w1 - tau_load w2 - c_d (w2 - w1)^2."""
    rc, p = _ring()
    tau, load = 4.0, 1.5
    ei = 2.1e11 * math.pi * 0.003 ** 4 / 64

    def energy(y):
        x_e = y[2] - y[0] - (0.5 - 0.2)
        return (0.5 * ((0.04 + 0.01) * y[1] ** 2 + 0.05 * y[3] ** 2) - 157 * ei / 0.1 ** 3 * 0.003 ** 2
                * math.sin(y[0] + y[2]) + 0.5 * 726.0 * x_e ** 2)

    def rates(y):
        return rc.TorqueDriven.derivatives(p, 0.0, y, Torques(tau, load))

    def power(y, d):
        return tau * y[1] - load * y[3] - 1.2 * (y[3] - y[1]) ** 2

    assert abs(_power_residual(energy, rates, [0.7, 40.0, 1.02, 41.0], power)) < 1e-6 * (tau + load) * 41.0


def test_ring_coupling_torque_driven_natural_rate_covers_the_two_mass_mode():
    """With the input shaft free, the aligned coupling (e = 0) is a two-mass oscillator, sqrt(c_s (1/I2 + 1/J_in))."""
    _, p = _ring(e=0.0, c_d=0.0)
    assert p.natural_rate >= math.sqrt(726.0 * (1 / 0.05 + 1 / 0.05)) * (1 - 1e-12)
