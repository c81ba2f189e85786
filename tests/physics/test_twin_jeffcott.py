"""TwinJeffcottRotor physics: joint kinematics, secondary couple, disc equations, energy, natural frequencies."""

import math

import numpy as np
import pytest

from ujfmu.physics import twin_jeffcott as tj

DEG = math.pi / 180.0


def rotor(**changes):
    values = {**tj.rig_parameters(), "phase_u1": 0.0, "phase_u2": 0.0}
    values.update(changes)
    return tj.TwinRotor(**values)


@pytest.mark.parametrize("beta_deg", [0.0, 5.0, 30.0, -60.0, 85.0])
def test_joint_without_tilt_is_the_exact_hooke_relation_and_continuous(beta_deg):
    """tan(psi) = cos(beta) tan(theta1) (paper Eq. 1) over ten revolutions, psi continuous and increasing."""
    p = rotor(beta=beta_deg * DEG)
    theta = np.linspace(-3.0, 60.0, 4001)
    psi = np.array([tj.joint(p, th, 0.0, 0.0, 0.0, 0.0)[0] for th in theta])
    far = np.abs(np.cos(theta)) > 1e-3
    np.testing.assert_allclose(np.tan(psi[far]), math.cos(beta_deg * DEG) * np.tan(theta[far]), rtol=1e-9, atol=1e-9)
    assert np.all(np.diff(psi) > 0) and np.max(np.abs(psi - theta)) < math.pi / 2


@pytest.mark.parametrize("beta_deg", [0.0, 10.0, 45.0])
def test_joint_derivatives_match_finite_differences(beta_deg):
    p = rotor(beta=beta_deg * DEG)
    rng = np.random.default_rng(int(beta_deg))
    for _ in range(20):
        args = np.concatenate([[rng.uniform(-10, 10)], rng.normal(scale=0.05, size=4)])
        grad = tj.joint(p, *args)[1:]
        for i in range(5):
            hi, lo = args.copy(), args.copy()
            hi[i] += 1e-6
            lo[i] -= 1e-6
            fd = (tj.joint(p, *hi)[0] - tj.joint(p, *lo)[0]) / 2e-6
            assert grad[i] == pytest.approx(fd, abs=1e-8)


def test_aligned_joint_does_not_couple_lateral_motion_at_first_order():
    p = rotor(beta=0.0)
    for th in np.linspace(0, 2 * math.pi, 13):
        assert tj.joint(p, th, 0.0, 0.0, 0.0, 0.0)[2:] == pytest.approx((0.0,) * 4, abs=1e-15)


@pytest.mark.parametrize("beta_deg", [5.0, 20.0, 40.0])
def test_lateral_load_of_the_joint_is_the_massless_cross_moment(beta_deg):
    """Independent oracle (statics of the massless cross): pins carry no moment about themselves, so the joint
    passes a moment along the cross normal n = e1 x e2; on the secondary shaft M = T2 n / (n . b). Its components
    normal to the shaft do virtual work on the end-section rotation (-dv2, du2, 0), so the generalised forces
    -T2 dpsi/du2, -T2 dpsi/dv2 must be M_y and -M_x in the secondary frame."""
    b = beta_deg * DEG
    p = rotor(beta=b)
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    torque = 3.7
    for th in np.linspace(0.1, 2 * math.pi, 11):
        e1 = np.array([-math.sin(th), math.cos(th), 0.0])
        axis = ry @ np.array([0.0, 0.0, 1.0])
        e2 = np.cross(axis, e1)
        e2 /= np.linalg.norm(e2)
        n = np.cross(e1, e2)
        moment = ry.T @ (torque * n / (n @ axis))          # in the secondary frame
        assert moment[2] == pytest.approx(torque)
        g = tj.joint(p, th, 0.0, 0.0, 0.0, 0.0)
        assert -torque * g[4] == pytest.approx(moment[1], abs=1e-12)
        assert -torque * g[5] == pytest.approx(-moment[0], abs=1e-12)


def test_secondary_couple_on_the_driven_shaft_has_a_mean_and_a_2x_part_only():
    """Bending moment on the secondary shaft ~ T tan(beta)-sized, period pi in theta1: mean + 2x, 4x, ..."""
    p = rotor(beta=10 * DEG)
    theta = np.linspace(0, 2 * math.pi, 256, endpoint=False)
    gy = np.array([tj.joint(p, th, 0.0, 0.0, 0.0, 0.0)[5] for th in theta])
    spectrum = np.abs(np.fft.rfft(gy)) / len(theta)
    assert spectrum[0] > 0.01 and spectrum[2] > 0.01
    assert np.max(spectrum[1::2]) < 1e-15


def test_disc_accelerations_solve_the_mass_matrix():
    """One disc's block of the paper's Eq. (10) solved by numpy against the closed-form Schur complement."""
    d = tj._disc_constants(3.1, 0.02, 0.05, 0.07)
    angle, w, q = 0.9, 40.0, (1.3, -2.0, 0.7)
    s, c = math.sin(angle), math.cos(angle)
    mass = np.array([[d["jt"], -d["a"] * s, d["a"] * c], [-d["a"] * s, d["m"], 0.0], [d["a"] * c, 0.0, d["m"]]])
    rhs = np.array([q[0], q[1] + d["a"] * c * w * w, q[2] + d["a"] * s * w * w])
    np.testing.assert_allclose(tj._disc_accelerations(d, angle, w, *q), np.linalg.solve(mass, rhs), rtol=1e-12)


def _energy_audit_error(p, h, alpha=60.0, tau=2.0, duration=3.0):
    """(|input work - load work - dissipation - change of stored energy|, input work) of an RK4 run-up."""
    y, phi, w = tj.initial_state(p, 0.0, 0.0), 0.0, 0.0
    e0, load_work = tj.stored_energy(p, phi, w, y), 0.0
    rate = tj.natural_rate_bound(p)
    for _ in range(int(round(duration / h))):
        y_next = tj.step(p, h, phi, w, alpha, y, tau, rate)
        load_work += tau * (y_next[6] - y[6])
        y, phi, w = y_next, phi + h * (w + 0.5 * alpha * h), w + alpha * h
    change = tj.stored_energy(p, phi, w, y) - e0
    assert y[12] > 1e-3 * y[13] and change > 0.1 * y[13]
    return abs(y[13] - load_work - y[12] - change), y[13]


@pytest.mark.parametrize("beta_deg", [0.0, 10.0])
def test_energy_balance_over_a_run_up(beta_deg):
    """Input work - load work - dissipation = change of stored energy along an RK4 run through the criticals:
    exact but for the integrator's truncation error, which is tiny and falls as a fourth-order method's should
    (a bookkeeping error would not fall with the step)."""
    p = rotor(beta=beta_deg * DEG, m_u1=0.01, m_u2=0.01)
    error, work = _energy_audit_error(p, 1e-3)
    assert error < 1e-7 * work
    if error > 1e-12 * work:
        finer, _ = _energy_audit_error(p, 2.5e-4)
        assert finer < error / 16


def test_linearised_natural_frequencies_are_the_jeffcott_and_torsional_chain_ones():
    """Without unbalance and joint angle, at rest: lateral sqrt(K/M) per disc and direction, torsional the
    eigenvalues of the fixed-free chain input - K1T - J_M1 - K2T - J_M2."""
    p = rotor(beta=0.0, m_u1=0.0, m_u2=0.0, C1X=0.0, C1Y=0.0, C2X=0.0, C2Y=0.0, C1T=0.0, C2T=0.0)
    r = tj.rig_parameters()
    y0 = np.zeros(tj.STATE_SIZE)
    f0 = np.array(tj.derivatives(p, 0.0, 0.0, 0.0, list(y0), 0.0))
    jac = np.empty((12, 12))
    for i in range(12):
        y = y0.copy()
        y[i] = 1e-6
        jac[:, i] = (np.array(tj.derivatives(p, 0.0, 0.0, 0.0, list(y), 0.0)) - f0)[:12] / 1e-6
    ours = np.sort(np.abs(np.linalg.eigvals(jac).imag))[::2]
    stiffness = np.array([[r["K1T"] + r["K2T"], -r["K2T"]], [-r["K2T"], r["K2T"]]])
    torsion = np.sqrt(np.linalg.eigvals(np.linalg.solve(np.diag([r["J_M1"], r["J_M2"]]), stiffness)).real)
    lateral = [math.sqrt(r["K1X"] / r["M1"])] * 2 + [math.sqrt(r["K2X"] / r["M2"])] * 2
    np.testing.assert_allclose(ours, np.sort(np.concatenate([torsion, lateral])), rtol=1e-6)


def test_default_rig_critical_speeds_are_the_documented_ones():
    """docs/twin_jeffcott.md quotes these (lateral with the unbalance mass, torsional chain)."""
    r = tj.rig_parameters()
    assert math.sqrt(r["K1X"] / (r["M1"] + r["m_u1"])) == pytest.approx(153.8, abs=0.05)
    assert math.sqrt(r["K2X"] / (r["M2"] + r["m_u2"])) == pytest.approx(117.0, abs=0.05)
    assert r["M1"] == pytest.approx(3.468, abs=5e-4) and r["K1T"] == pytest.approx(328.9, abs=0.05)
