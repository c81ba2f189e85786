"""The torque-driven TwinJeffcottRotor's exponential integrator (``torque_exponential_step``, the FMU's step):
order, the linear part and the rigid-body mode exact, the energy audit, and the FMU's step through it."""

import math

import numpy as np
import pytest

from ujfmu.models.protocol import Torques
from ujfmu.models.twin_jeffcott_rotor import model as tj

DEG = math.pi / 180.0
#: per state, the size of an error that matters (angles rad, speeds rad/s, displacements m, velocities m/s, J)
SCALE = np.array([1.0, 100.0, 1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 1.0])


def rotor(**changes):
    values = {**tj.rig_parameters(), "phase_u1": 0.0, "phase_u2": 0.0, "J_drive": 0.02, "omega_in_start": 0.0}
    values.update(changes)
    return tj.TorqueDrivenParameters(**values)


def _steps(p, y, h, n, u):
    for _ in range(n):
        y = tj.TorqueDriven.integrate(p, 0.0, h, y, u)
    return np.array(y)


def test_torque_exponential_integrator_is_fourth_order():
    """Observed order of ``torque_exponential_step`` on a misaligned (10 deg), unbalanced rotor speeding up from
    80 rad/s under 5 N.m against 2 N.m: the error after 0.1 s against an independent fine solve (scipy's DOP853 at
    rtol 1e-12 of ``TorqueDriven.derivatives``) falls 16x per halving of the step (order observed between 3.6 and
    4.4; measured 3.97-3.99), one substep per step. A wrong weight or operator (e.g. S1 = h (2 phi_2 - 3 phi_3), or
    the flange's column of an operator dropped) leaves order 3 or less."""
    from scipy.integrate import solve_ivp
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8, omega_in_start=80.0)
    u, duration = Torques(5.0, 2.0), 0.1
    start = tj.TorqueDriven.initial_state(p, 0.0, u)
    fine = solve_ivp(lambda t, y: tj.TorqueDriven.derivatives(p, t, y, u), (0.0, duration), start, method="DOP853",
                     rtol=1e-12, atol=1e-14 * SCALE).y[:, -1]
    errors = []
    for h in (2e-3, 1e-3, 5e-4):
        assert tj.torque_exponential_substeps(p, h, 90.0) == 1
        errors.append(np.max(np.abs(_steps(p, start, h, int(round(duration / h)), u) - fine) / SCALE))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.6) & (orders < 4.4)), (errors, orders)


def _chain(p):
    """The aligned, balanced rotor's torsional equations, built here from the parameters: A on (phi_in, omega_in,
    theta1, omega1, theta2, omega2) of the chain flange (J_drive + J_gb) -- K1T, C1T -- J_M1 -- K2T, C2T -- J_M2."""
    j = (p.J_drive + p.J_gb, p.J_M1, p.J_M2)
    k, c = (p.K1T, p.K2T), (p.C1T, p.C2T)
    a = np.zeros((6, 6))
    for i in range(3):
        a[2 * i, 2 * i + 1] = 1.0
        for s in (i - 1, i):                 # shafts on either side of inertia i
            if 0 <= s < 2:
                other = s if s == i - 1 else s + 1
                a[2 * i + 1, [2 * i, 2 * i + 1]] -= np.array([k[s], c[s]]) / j[i]
                a[2 * i + 1, [2 * other, 2 * other + 1]] += np.array([k[s], c[s]]) / j[i]
    return a


@pytest.mark.parametrize("mode", ["torsional", "lateral"])
def test_torque_exponential_integrator_is_exact_on_the_linear_part(mode):
    """beta = 0, no unbalance, no torques: the flange, both discs and the Jeffcott oscillators move linearly,
    y(t) = expm(t A) y(0) (scipy's expm of the chain's and oscillators' matrices built here): a free torsional
    vibration about a rigid rotation at 20 rad/s (the rigid-body mode of A, eigenvalue 0, carried along), or a free
    lateral one. One step of 50 ms (several substeps) reproduces it to 1e-10 of the amplitude, far beyond a
    fourth-order method's own error at these substeps (h |lambda| about 1)."""
    from scipy.linalg import expm
    p = rotor(beta=0.0, m_u1=0.0, m_u2=0.0)
    y0 = np.zeros(16)
    if mode == "torsional":
        y0[[0, 1, 2, 3, 8, 9]] = [0.3, 20.0 + 0.4, 0.3 + 2e-3, 20.0 - 0.3, 0.3 - 1e-3, 20.0 + 0.5]
        rows, a = [0, 1, 2, 3, 8, 9], _chain(p)
    else:
        y0[[4, 5, 6, 7, 10, 11, 12, 13]] = [1e-9, 2e-7, -2e-9, 1e-7, 1.5e-9, -3e-7, 1e-9, -1e-7]
        rows, a = [4, 5, 6, 7, 10, 11, 12, 13], np.zeros((8, 8))
        for b, d in enumerate((1, 1, 2, 2)):
            m = getattr(p, f"M{d}")
            a[2 * b, 2 * b + 1] = 1.0
            a[2 * b + 1, 2 * b:2 * b + 2] = [-getattr(p, f"K{d}X") / m, -getattr(p, f"C{d}X") / m]
    h = 0.05
    assert tj.torque_exponential_substeps(p, h, 21.0) > 10
    y = np.array(tj.torque_exponential_step(p, h, list(y0), 0.0, 0.0))
    exact = expm(h * a) @ y0[rows]
    amplitude = 2e-3 if mode == "torsional" else 3e-7
    np.testing.assert_allclose(y[rows], exact, rtol=0.0, atol=1e-10 * amplitude * 300.0)
    assert np.max(np.abs(np.delete(y[:14], rows))) < 1e-12   # the other motion stays at rest


def test_constant_torque_on_the_free_rotor_is_the_exact_uniform_acceleration():
    """The rigid-body mode: beta = 0, balanced, the shafts twisted as a uniformly accelerating rotor's (every inertia
    at alpha = (tau_in - tau_load) / J_total: K1T tw1 = tau_in - J_in alpha, K2T tw2 = J_M2 alpha + tau_load) turning
    at 20 rad/s: every angle follows phi_0 + omega_0 t + alpha t^2 / 2 and every speed omega_0 + alpha t, exactly
    (to round-off: 1e-10 after the 112 substeps) over one step of 0.2 s, and the input work is its closed form (the power through the shaft end
    is linear in time, which the quadrature integrates exactly), nothing dissipated. RK4 of the same steps would
    be exact too on the rigid motion, but here the step is 0.2 s: the chain's phi-functions carry it."""
    p = rotor(beta=0.0, m_u1=0.0, m_u2=0.0)
    tau_in, tau_load, w0, phi0, h = 3.0, 1.0, 20.0, 0.4, 0.2
    j_in = p.J_drive + p.J_gb
    alpha = (tau_in - tau_load) / (j_in + p.J_M1 + p.J_M2)
    twist1, twist2 = (tau_in - j_in * alpha) / p.K1T, (p.J_M2 * alpha + tau_load) / p.K2T
    start = [phi0, w0, phi0 - twist1, w0, 0.0, 0.0, 0.0, 0.0, phi0 - twist1 - twist2, w0, 0.0, 0.0, 0.0, 0.0, 0.0,
             0.0]
    y = tj.torque_exponential_step(p, h, start, tau_in, tau_load)
    moved = phi0 + w0 * h + 0.5 * alpha * h * h
    expected = [moved, w0 + alpha * h, moved - twist1, w0 + alpha * h, 0.0, 0.0, 0.0, 0.0, moved - twist1 - twist2,
                w0 + alpha * h]
    np.testing.assert_allclose(y[:10], expected, rtol=0.0, atol=1e-10)
    assert y[10:14] == [0.0] * 4
    work = (tau_in - p.J_drive * alpha) * (w0 * h + 0.5 * alpha * h * h)
    assert y[15] == pytest.approx(work, rel=1e-12) and 0.0 <= y[14] < 1e-15 * work


def _audit(p, h, u, duration):
    """(|input work - load work - dissipation - change of stored energy|, input work) of a run under u."""
    y = np.array(tj.TorqueDriven.initial_state(p, 0.0, u))

    def energy(s):
        return tj.stored_energy(p, s[0], s[1], s[2:])
    e0, load_work = energy(y), 0.0
    for _ in range(int(round(duration / h))):
        y_next = tj.TorqueDriven.integrate(p, 0.0, h, y, u)
        load_work += u.tau_load * (y_next[8] - y[8])
        y = y_next
    change = energy(y) - e0
    assert y[14] > 1e-3 * y[15] and change > 0.1 * y[15]
    return abs(y[15] - load_work - y[14] - change), y[15]


@pytest.mark.parametrize("beta_deg", [0.0, 10.0])
def test_torque_driven_energy_balance_over_a_run_up(beta_deg):
    """Input work through the flange's shaft end - load work - dissipation = change of the rotor's stored energy
    (flange J_gb, discs, shafts, supports) along a torque-driven run-up through the lateral criticals (5 N.m against
    1 N.m, 0 -> 195 rad/s in 2 s): exact but for the integrator's truncation error, tiny, and falling as a
    fourth-order method's should (a bookkeeping error would not fall with the step)."""
    p = rotor(beta=beta_deg * DEG, m_u1=0.01, m_u2=0.01)
    u = Torques(5.0, 1.0)
    error, work = _audit(p, 1e-3, u, 2.0)
    assert error < 1e-7 * work
    if error > 1e-12 * work:
        finer, _ = _audit(p, 2.5e-4, u, 2.0)
        assert finer < error / 16


def test_fmu_steps_with_the_exponential_integrator(open_fmu):
    """TwinJeffcottRotorTorqueDriven's step is ``TorqueDriven.integrate``: 100 steps of the FMU equal the model's own
    to round-off; a torque that would take the flange past the speed range within a step is refused (fmi2Discard,
    the cause named) before any integration, and the instance steps on with a sane torque."""
    params = dict(J_drive=0.02, omega_in_start=30.0)
    inst = open_fmu("TwinJeffcottRotorTorqueDriven")
    inst.initialize(params)
    p = rotor(omega_in_start=30.0)
    u = Torques(3.0, 1.0)
    y = tj.TorqueDriven.initial_state(p, 0.0, u)
    for k in range(100):
        inst.set(tau_in=3.0, tau_load=1.0)
        inst.slave.doStep(k * 1e-3, 1e-3)
        y = tj.TorqueDriven.integrate(p, k * 1e-3, 1e-3, y, u)
    assert inst.get("omega_in", "phi_out", "X2")[:3] == pytest.approx([y[1], y[8], y[10]], rel=1e-12, abs=1e-18)
    inst.set(tau_in=1e6)
    assert inst.raw("fmi2DoStep")(inst.slave.component, 0.1, 1e-3, 1) == 2
    assert "tau_in = 1000000.0 N.m" in inst._log[-1] and "would reach" in inst._log[-1], inst._log[-1]
    inst.set(tau_in=3.0)
    inst.slave.doStep(0.1, 1e-3)
    assert inst.get("omega_in")[0] == pytest.approx(y[1], rel=1e-3)
