"""TwinJeffcottRotor physics: joint kinematics, secondary couple, disc equations, energy, natural frequencies."""

import math

import numpy as np
import pytest

from ujfmu.analysis import order_amplitudes
from ujfmu.fmu import rk4
from ujfmu.models.twin_jeffcott_rotor import model as tj

DEG = math.pi / 180.0


def rotor(**changes):
    values = {**tj.rig_parameters(), "phase_u1": 0.0, "phase_u2": 0.0}
    values.update(changes)
    return tj.Parameters(**values)


@pytest.mark.parametrize("beta_deg", [0.0, 5.0, 30.0, -60.0, 85.0])
def test_joint_without_tilt_is_the_exact_hooke_relation_and_continuous(beta_deg):
    """tan(psi) = cos(beta) tan(theta1) (paper Eq. 1) over ten revolutions, psi continuous and increasing."""
    p = rotor(beta=beta_deg * DEG)
    theta = np.linspace(-3.0, 60.0, 4001)
    psi = np.array([tj.joint(p, th, 0.0, 0.0, 0.0, 0.0)[0] for th in theta])
    far = np.abs(np.cos(theta)) > 1e-3
    np.testing.assert_allclose(np.tan(psi[far]), math.cos(beta_deg * DEG) * np.tan(theta[far]), rtol=1e-9, atol=1e-9)
    assert np.all(np.diff(psi) > 0) and np.max(np.abs(psi - theta)) < math.pi / 2


@pytest.mark.parametrize("tilt", [1e-4, 0.05, 0.4])
@pytest.mark.parametrize("beta_deg", [0.0, 10.0, 45.0])
def test_joint_derivatives_match_finite_differences(beta_deg, tilt):
    """Analytic dpsi/d(theta1, u1, v1, u2, v2) against central differences, for tilts in the series branch of the
    Rodrigues coefficients (angle^2 < 1e-2) and in the closed-form branch."""
    p = rotor(beta=beta_deg * DEG)
    rng = np.random.default_rng(int(beta_deg))
    for _ in range(20):
        args = np.concatenate([[rng.uniform(-10, 10)], rng.normal(scale=tilt, size=4)])
        grad = tj.joint(p, *args)[1:]
        for i in range(5):
            hi, lo = args.copy(), args.copy()
            hi[i] += 1e-6
            lo[i] -= 1e-6
            fd = (tj.joint(p, *hi)[0] - tj.joint(p, *lo)[0]) / 2e-6
            assert grad[i] == pytest.approx(fd, abs=1e-8)


@pytest.mark.parametrize("beta_deg", [0.0, 7.0, 40.0])
def test_bent_ends_turn_by_the_exact_rotation_about_the_bending_plane_normal(beta_deg):
    """Oracle: scipy's rotation from a rotation vector. The primary end section is turned by its slope angle
    sqrt(u1^2 + v1^2) about the normal to its bending plane (rotation vector (v1, -u1, 0), axis tilted towards
    (-u1, -v1)), the secondary likewise in its frame R_y(beta) (rotation vector (-v2, u2, 0)); psi is the angle of
    the driven pin z x p, p the driving pin in the secondary end frame."""
    from scipy.spatial.transform import Rotation
    b = beta_deg * DEG
    p = rotor(beta=b)
    rng = np.random.default_rng(7)
    for tilt in (1e-5, 1e-3, 0.08, 0.5):
        for _ in range(10):
            th = rng.uniform(-7.0, 7.0)
            u1, v1, u2, v2 = rng.normal(scale=tilt, size=4)
            r1 = Rotation.from_rotvec([v1, -u1, 0.0]).as_matrix()
            r2 = Rotation.from_rotvec([0.0, b, 0.0]).as_matrix() @ Rotation.from_rotvec([-v2, u2, 0.0]).as_matrix()
            e1 = r1 @ np.array([-math.sin(th), math.cos(th), 0.0])
            axis1 = r1 @ np.array([0.0, 0.0, 1.0])
            slope = math.atan2(math.hypot(axis1[0], axis1[1]), axis1[2])
            assert slope == pytest.approx(math.hypot(u1, v1), rel=1e-9, abs=1e-15)
            px, py, _ = r2.T @ e1
            psi = tj.joint(p, th, u1, v1, u2, v2)[0]
            assert math.remainder(psi - math.atan2(-px, py), 2 * math.pi) == pytest.approx(0.0, abs=1e-13)


@pytest.mark.parametrize("beta_deg", [5.0, 30.0, -12.0])
def test_a_disc_displaced_along_plus_x_steepens_the_bend_by_its_end_slope(beta_deg):
    """The outputs' sign convention (README, "The system"): +X of either disc points to the side the
    secondary shaft leans to at beta > 0, the inside of the bend. A disc at +X turns its shaft's joint end by the
    end slope 3 X / L away from the other shaft (primary: its end's axis towards -X1; secondary: towards +X2), so
    the joint works at beta + 3 X / L exactly; at -X at beta - 3 X / L."""
    b = beta_deg * DEG
    for th in np.linspace(-3.0, 3.0, 11):
        for slope in (1e-3, -2e-3, 0.05):
            steeper = tj.joint(rotor(beta=b + slope), th, 0.0, 0.0, 0.0, 0.0)[0]
            assert tj.joint(rotor(beta=b), th, slope, 0.0, 0.0, 0.0)[0] == pytest.approx(steeper, abs=1e-13)
            assert tj.joint(rotor(beta=b), th, 0.0, 0.0, slope, 0.0)[0] == pytest.approx(steeper, abs=1e-13)


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


def test_aligned_rotor_under_load_keeps_circular_orbits_and_no_2x():
    """beta = 0, 100 rad/s, 2 N.m: an aligned isotropic rotor is axisymmetric, so in steady state each disc's orbit
    is a circle (X and Y 1x equal) and neither tau_in nor omega_out has a 2x. The RK4 map is axisymmetric too, so
    this holds to round-off. Round-off measured here: X and Y 1x agree to 1e-15..3e-15 relative; the 2x of tau_in is
    ~1e-12 N.m (K1T = 329 N.m/rad times the ulp of an input angle of some 100 rad, averaged by the fit), that of
    omega_out ~1e-13 rad/s. The bounds leave about two decades; the Euler-sequence tilt R_x(v) R_y(-u) misses the
    first by eight (disc 1: 5.7e-4 relative). Damping raised (20% lateral, 30% torsional) so that the start
    transient is below round-off after 1.8 s."""
    r = tj.rig_parameters()
    changes = dict(beta=0.0, phase_u1=0.4, phase_u2=-1.1)
    for i in (1, 2):
        c = 2.0 * 0.2 * math.sqrt(r[f"K{i}X"] * (r[f"M{i}"] + r[f"m_u{i}"]))
        changes.update({f"C{i}X": c, f"C{i}Y": c, f"C{i}T": 2.0 * 0.3 * math.sqrt(r[f"K{i}T"] * r[f"J_M{i}"])})
    p = rotor(**changes)
    w, h, tau, n = 100.0, 1e-3, 2.0, 2500
    y, rate, rows = tj.rest_state(p, 0.0, w), tj.natural_rate_bound(p), []
    for k in range(n):
        if k >= n - 629:   # the last 10 revolutions (628.3 steps)
            torque = tj.torque_outputs(p, w * k * h, w, 0.0, y)["tau_in"]
            rows.append((w * k * h, y[2], y[4], y[8], y[10], torque, y[7]))
        y = tj.step(p, h, w * k * h, w, 0.0, y, tau, rate)
    angle, x1, y1, x2, y2, tau_in, omega_out = np.array(rows).T
    damping_power = 0.0
    for i, x, yy in ((1, x1, y1), (2, x2, y2)):
        amp_x, amp_y = order_amplitudes(angle, x, [1, 2])[0], order_amplitudes(angle, yy, [1, 2])[0]
        assert abs(amp_x[0] - amp_y[0]) < 1e-13 * amp_x[0] and max(amp_x[1], amp_y[1]) < 1e-13 * amp_x[0]
        damping_power += changes[f"C{i}X"] * (w * amp_x[0]) ** 2
    # power balance: the driver supplies the load and the lateral damping of the whirling discs
    assert tau_in.mean() * w == pytest.approx(tau * w + damping_power, rel=1e-9)
    assert order_amplitudes(angle, tau_in, [2])[0][0] < 1e-10
    assert order_amplitudes(angle, omega_out, [2])[0][0] < 1e-11


def test_disc_accelerations_solve_the_mass_matrix():
    """One disc's block of the paper's Eq. (10) solved by numpy against the closed-form Schur complement."""
    d = tj._disc_constants(3.1, 0.02, 0.05, 0.07)
    angle, w, q = 0.9, 40.0, (1.3, -2.0, 0.7)
    s, c = math.sin(angle), math.cos(angle)
    mass = np.array([[d["jt"], -d["a"] * s, d["a"] * c], [-d["a"] * s, d["m"], 0.0], [d["a"] * c, 0.0, d["m"]]])
    rhs = np.array([q[0], q[1] + d["a"] * c * w * w, q[2] + d["a"] * s * w * w])
    np.testing.assert_allclose(tj._disc_accelerations(d, angle, w, *q), np.linalg.solve(mass, rhs), rtol=1e-12)



def test_light_outputs_are_the_state_and_the_shaft_torques_of_torque_outputs():
    """light_outputs (which outputs builds on) against an independent path: the discs' motion and energy rows are
    the state's fields, tau_in and the primary shaft's torque those of torque_outputs (shaft_torques); the two left
    out are torque_outputs' secondary torque and stored energy."""
    p = rotor(beta=20 * DEG)
    y = (0.31, 101.0, 2e-5, -1e-4, -3e-5, 2e-4, 0.27, 99.0, 4e-5, 3e-4, 1e-5, -2e-4, 0.7, 3.1)
    u = tj.Drive(0.35, 100.0, 12.0, 2.0)
    light = tj.light_outputs(p, 0.0, y, u)
    torques = tj.torque_outputs(p, u.phi, u.omega, u.alpha, y)
    assert light == {"phi_disc1": y[0], "omega_disc1": y[1], "X1": y[2], "Y1": y[4], "phi_out": y[6],
                     "omega_out": y[7], "X2": y[8], "Y2": y[10], "dissipated_energy": y[12], "input_work": y[13],
                     "tau_in": torques["tau_in"], "primary_shaft_torque": torques["primary_shaft_torque"]}
    full = tj.outputs(p, 0.0, y, u)
    assert (full["secondary_shaft_torque"], full["stored_energy"]) == (torques["secondary_shaft_torque"],
                                                                       torques["stored_energy"])


def test_straight_line_rates_are_the_composed_equations():
    """joint_gradient (straight-line) is joint, and rates (straight-line code, the integrator's inner loop) is
    Lagrange's equations assembled from joint (its derivatives tested against finite differences, its tilts against
    scipy's rotations above) and _disc_accelerations (against numpy's solve), at random joint angles, unbalance
    phases, rigs, states and inputs, end slopes in both branches of the Rodrigues coefficients."""
    rng = np.random.default_rng(16)
    for i in range(300):
        p = rotor(beta=rng.uniform(-1.2, 1.2), phase_u1=rng.uniform(-6.0, 6.0), phase_u2=rng.uniform(-6.0, 6.0),
                  m_u1=rng.uniform(0.0, 0.05), m_u2=rng.uniform(0.0, 0.05), L1=rng.uniform(0.2, 1.0),
                  L2=rng.uniform(0.2, 1.0), C1X=rng.uniform(0.0, 50.0), K2Y=rng.uniform(1e4, 1e6))
        lateral = 10.0 ** rng.uniform(-7.0, -1.5)   # end slopes 3 X / L from 1e-7 to 0.15 rad
        y = [rng.uniform(-50.0, 50.0), rng.uniform(-300.0, 300.0), *rng.normal(scale=lateral, size=2) * (1, 100),
             *rng.normal(scale=lateral, size=2) * (1, 100), rng.uniform(-50.0, 50.0), rng.uniform(-300.0, 300.0),
             *rng.normal(scale=lateral, size=2) * (1, 100), *rng.normal(scale=lateral, size=2) * (1, 100), 0.3, 0.7]
        phi_in, w_in, alpha_in, tau = rng.uniform(-50.0, 50.0), rng.uniform(-300.0, 300.0), *rng.uniform(-500, 500, 2)
        th1, w1, x1, vx1, y1, vy1, th2, w2, x2, vx2, y2, vy2 = y[:12]
        s1, s2 = p.slope1, p.slope2
        psi, g_th, g_u1, g_v1, g_u2, g_v2 = tj.joint(p, th1, s1 * x1, s1 * y1, s2 * x2, s2 * y2)
        np.testing.assert_allclose(tj.joint_gradient(p, th1, s1 * x1, s1 * y1, s2 * x2, s2 * y2, math.sin(th1),
                                                     math.cos(th1)), (psi, g_th, g_u1, g_v1, g_u2, g_v2),
                                   rtol=1e-12, atol=1e-300)
        dpsi = g_th * w1 + s1 * (g_u1 * vx1 + g_v1 * vy1) + s2 * (g_u2 * vx2 + g_v2 * vy2)
        t1 = p.K1T * (phi_in - th1) + p.C1T * (w_in - w1)
        t2 = p.K2T * (psi - th2) + p.C2T * (dpsi - w2)
        disc1 = tj._disc_accelerations(p.disc1, th1 + p.phase_u1, w1, t1 - t2 * g_th,
                                       -p.K1X * x1 - p.C1X * vx1 - t2 * s1 * g_u1,
                                       -p.K1Y * y1 - p.C1Y * vy1 - t2 * s1 * g_v1)
        disc2 = tj._disc_accelerations(p.disc2, th2 + p.phase_u2, w2, t2 - tau,
                                       -p.K2X * x2 - p.C2X * vx2 - t2 * s2 * g_u2,
                                       -p.K2Y * y2 - p.C2Y * vy2 - t2 * s2 * g_v2)
        dissipation = (p.C1T * (w_in - w1) ** 2 + p.C2T * (dpsi - w2) ** 2 + p.C1X * vx1 ** 2 + p.C1Y * vy1 ** 2
                       + p.C2X * vx2 ** 2 + p.C2Y * vy2 ** 2)
        composed = np.array([w1, disc1[0], vx1, disc1[1], vy1, disc1[2], w2, disc2[0], vx2, disc2[1], vy2, disc2[2],
                             dissipation, (p.J_gb * alpha_in + t1) * w_in])
        ours = np.array(tj.rates(p, phi_in, w_in, alpha_in, y, tau))
        # each component against its own scale: the lateral ones are tiny beside the torsional ones
        np.testing.assert_allclose(ours, composed, rtol=1e-12, atol=1e-300)

def rk4_step(p, h, phi, w, alpha, y, tau):
    """The RK4 path (``tj.step``, substeps from the natural rate + 4 |omega|)."""
    return tj.step(p, h, phi, w, alpha, y, tau, tj.natural_rate_bound(p))


class Multistep:
    """``tj.multistep_step`` (the FMU's stepper) called as the one-step integrators are: it keeps its history and
    time between calls and starts afresh when called with a state it did not return last."""

    def __init__(self):
        self.last, self.t, self.history = None, 0.0, tj.NO_HISTORY

    def __call__(self, p, h, phi, w, alpha, y, tau):
        if y is not self.last:
            self.t, self.history = 0.0, tj.NO_HISTORY
        self.last, self.history = tj.multistep_step(p, self.t, h, phi, w, alpha, y, tau, self.history)
        self.t += h
        return self.last


#: the model's integrators: RK4, the exponential Runge-Kutta one and the exponential Adams one the FMU runs
STEPPERS = {"rk4": rk4_step, "exponential": tj.exponential_step, "multistep": Multistep()}


def _energy_audit_error(p, h, stepper, alpha=60.0, tau=2.0, duration=3.0):
    """(|input work - load work - dissipation - change of stored energy|, input work) of a run-up."""
    y, phi, w = tj.rest_state(p, 0.0, 0.0), 0.0, 0.0
    e0, load_work = tj.stored_energy(p, phi, w, y), 0.0
    for _ in range(int(round(duration / h))):
        y_next = stepper(p, h, phi, w, alpha, y, tau)
        load_work += tau * (y_next[6] - y[6])
        y, phi, w = y_next, phi + h * (w + 0.5 * alpha * h), w + alpha * h
    change = tj.stored_energy(p, phi, w, y) - e0
    assert y[12] > 1e-3 * y[13] and change > 0.1 * y[13]
    return abs(y[13] - load_work - y[12] - change), y[13]


@pytest.mark.parametrize("stepper", STEPPERS)
@pytest.mark.parametrize("beta_deg", [0.0, 10.0])
def test_energy_balance_over_a_run_up(beta_deg, stepper):
    """Input work - load work - dissipation = change of stored energy along a run through the criticals:
    exact but for the integrator's truncation error, which is tiny and falls as a fourth-order method's should
    (a bookkeeping error would not fall with the step)."""
    p = rotor(beta=beta_deg * DEG, m_u1=0.01, m_u2=0.01)
    error, work = _energy_audit_error(p, 1e-3, STEPPERS[stepper])
    assert error < 1e-7 * work
    if error > 1e-12 * work:
        finer, _ = _energy_audit_error(p, 2.5e-4, STEPPERS[stepper])
        assert finer < error / 16


def _fine(p, h, phi, w, alpha, y, tau, substeps=64):
    """Oracle for the exponential integrator: classical RK4 (rk4.integrate, tested fourth order on its own) with
    many substeps."""
    return rk4.integrate(lambda a, b, s: tj.rates(p, a, b, alpha, s, tau), y, h, substeps, phi, w, alpha)


def test_exponential_integrator_is_fourth_order():
    """Observed order of ``exponential_step`` (Krogstad's ETDRK4-B in twist coordinates) on a misaligned,
    unbalanced rotor speeding up under load: the error after 0.1 s against a fine RK4 solution falls 16x per
    halving of the step (order 4 observed between 3.6 and 4.4; one substep per step at every h here). A wrong
    weight or operator (e.g. S1 = h (2 phi_2 - 3 phi_3)) leaves order 3 or less."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8)
    alpha, tau, duration = 200.0, 2.0, 0.1
    start = tj.rest_state(p, 0.0, 80.0)
    errors = []
    for h in (2e-3, 1e-3, 5e-4):
        assert tj.exponential_substeps(p, h, 80.0 + alpha * duration, 0.0) == 1
        y, ref, phi, w = start, start, 0.0, 80.0
        for _ in range(int(round(duration / h))):
            y = tj.exponential_step(p, h, phi, w, alpha, y, tau)
            ref = _fine(p, h, phi, w, alpha, ref, tau)
            phi, w = phi + h * (w + 0.5 * alpha * h), w + alpha * h
        scale = np.array([1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 1.0])
        errors.append(np.max(np.abs(np.array(y) - np.array(ref)) / scale))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.6) & (orders < 4.4)), (errors, orders)


def _run_against_fine(against_fine, p, h, duration, inputs, stepper):
    """Max scaled error after duration of ``stepper`` against the fine RK4 oracle, both from rest at 80 rad/s under
    inputs(t) = (alpha, tau) held over each step (the ``against_fine`` fixture)."""
    scale = (1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 100.0, 1e-5, 1e-3, 1e-5, 1e-3, 1.0, 1.0)
    return against_fine(stepper, _fine, p, tj.rest_state(p, 0.0, 80.0), 0.0, 80.0, h, duration, inputs, scale)


def test_multistep_integrator_order_and_accuracy(against_fine):
    """Observed order of ``multistep_step`` (exponential Adams PEC, six points of N, in twist coordinates) on the
    run of :func:`test_exponential_integrator_is_fourth_order`, from its start (five ETDRK4-B steps, then the
    multistep method): the error falls 2^5 per halving of the step (observed 5.1-5.2 between 1 ms and 0.25 ms: the
    start steps' O(h^5) local errors dominate; the Adams steps alone are of higher order), and at 1 ms it is below
    ETDRK4-B's (measured 7.0e-6 against 4.4e-5). A wrong operator or weight (a predictor weight off, the corrector
    left out) leaves order 4 or less or a larger error at 1 ms."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8)
    inputs = lambda t: (200.0, 2.0)   # noqa: E731
    errors = [_run_against_fine(against_fine, p, h, 0.1, inputs, Multistep()) for h in (1e-3, 5e-4, 2.5e-4)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 4.6) & (orders < 6.0)), (errors, orders)
    assert errors[0] < _run_against_fine(against_fine, p, 1e-3, 0.1, inputs, tj.exponential_step)


@pytest.mark.parametrize("jump", ["load", "acceleration"])
def test_multistep_integrator_restarts_at_an_input_step(jump, against_fine):
    """A load step (2 -> 20 N.m) or a jump of the input acceleration (200 -> -300 rad/s^2) at 30 ms: N's time
    derivative jumps with the discs' accelerations, which no polynomial through the history follows, so the
    multistep method restarts there (``INPUT_JUMP``) and stays as accurate as ETDRK4-B, which starts afresh every
    step (within 1.5x of its error against the fine solution; measured 1.2x and 0.75x). Extrapolating across the
    jump instead leaves 55x and 40x. A slow drift of the load, as a load FMU's, is recombined exactly."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8)
    after = (200.0, 20.0) if jump == "load" else (-300.0, 2.0)
    inputs = lambda t: (200.0, 2.0 + 0.01 * t) if t < 0.03 - 1e-9 else after   # noqa: E731
    one_step = _run_against_fine(against_fine, p, 1e-3, 0.06, inputs, tj.exponential_step)
    assert _run_against_fine(against_fine, p, 1e-3, 0.06, inputs, Multistep()) < 1.5 * one_step


def test_multistep_restarts_without_a_usable_history():
    """Without a history, with one of another step length or one that does not end at the step's start time, a
    step is exactly ETDRK4-B's (bitwise) and leaves a history of its start point; after five such steps the next
    one is the multistep method's and differs."""
    p = rotor(beta=5 * DEG)
    y0 = tj.rest_state(p, 0.0, 100.0)
    y1, history = tj.multistep_step(p, 0.0, 1e-3, 0.0, 100.0, 0.0, y0, 2.0, tj.NO_HISTORY)
    assert y1 == tj.exponential_step(p, 1e-3, 0.0, 100.0, 0.0, y0, 2.0) and history[2] == 1.0
    for t, h in ((1e-3, 2e-3), (0.5, 1e-3)):   # another step length; a history not ending at t
        y, fresh = tj.multistep_step(p, t, h, 0.1, 100.0, 0.0, y1, 2.0, history)
        assert y == tj.exponential_step(p, h, 0.1, 100.0, 0.0, y1, 2.0) and fresh[2] == 1.0
    y, history, t = y0, tj.NO_HISTORY, 0.0
    for k in range(tj.HISTORY_POINTS):
        previous = y
        y, history = tj.multistep_step(p, k * 1e-3, 1e-3, 0.1 * k, 100.0, 0.0, y, 2.0, history)
    assert history[2] == tj.HISTORY_POINTS
    assert y != tj.exponential_step(p, 1e-3, 0.1 * (tj.HISTORY_POINTS - 1), 100.0, 0.0, previous, 2.0)


@pytest.mark.parametrize("mode", ["torsional", "lateral"])
def test_exponential_integrator_is_exact_on_the_linear_part(mode):
    """beta = 0, no unbalance, no load, the input at rest: a free torsional vibration (lateral motion zero: the
    joint is exactly psi = theta1) or a free lateral one (torsion at rest; the tilts' second-order effects are
    below 1e-15 at these nm displacements) is a linear constant-coefficient motion, z(t) = expm(t A) z(0), A the
    chain input -- K1T -- J1 -- K2T -- J2 with dampers, and the Jeffcott oscillators (scipy's expm of matrices built
    here). One step of 50 ms (many substeps, h |lambda| up to 1) reproduces it to 1e-10, far beyond a fourth-order
    method's own error at these steps (RK4's is 1e-4 of the amplitude). The dissipated energy is a quadrature
    (RK4's weights on the stages), not exact: within 1e-4 of the closed form's damping power integrated by scipy's
    quad at these long substeps (2.3 ms, h |lambda| up to 1)."""
    from scipy.integrate import quad
    from scipy.linalg import expm
    r = tj.rig_parameters()
    p = rotor(beta=0.0, m_u1=0.0, m_u2=0.0)
    j1, j2 = r["J_M1"], r["J_M2"]
    k1, k2, c1, c2 = r["K1T"], r["K2T"], r["C1T"], r["C2T"]
    a = np.zeros((12, 12))
    a[0, 1] = a[6, 7] = 1.0
    a[1, [0, 1, 6, 7]] = [-(k1 + k2) / j1, -(c1 + c2) / j1, k2 / j1, c2 / j1]
    a[7, [0, 1, 6, 7]] = [k2 / j2, c2 / j2, -k2 / j2, -c2 / j2]
    for i, d in ((2, 1), (4, 1), (8, 2), (10, 2)):
        a[i, i + 1] = 1.0
        a[i + 1, [i, i + 1]] = [-r[f"K{d}X"] / r[f"M{d}"], -r[f"C{d}X"] / r[f"M{d}"]]
    z0 = np.zeros(12)
    if mode == "torsional":
        z0[[0, 1, 6, 7]] = [2e-3, -0.3, -1e-3, 0.5]
    else:
        z0[[2, 3, 4, 5, 8, 9, 10, 11]] = [1e-9, 2e-7, -2e-9, 1e-7, 1.5e-9, -3e-7, 1e-9, -1e-7]
    h = 0.05
    y = tj.exponential_step(p, h, 0.0, 0.0, 0.0, list(z0) + [0.0, 0.0], 0.0)
    exact = expm(h * a) @ z0
    excited = np.flatnonzero(z0)
    scale = np.max(np.abs(z0[excited])) * np.where(excited % 2, 300.0, 1.0)   # displacement, speed ~ 300/s x it
    assert tj.exponential_substeps(p, h, 0.0, 0.0) > 10
    np.testing.assert_array_less(np.abs(np.array(y)[excited] - exact[excited]), 1e-10 * scale)
    assert np.max(np.abs(np.delete(np.array(y[:12]), excited))) < 1e-12   # the other motion stays at rest

    def damping_power(t):
        v = expm(t * a) @ z0
        return (c1 * v[1] ** 2 + c2 * (v[1] - v[7]) ** 2 + r["C1X"] * (v[3] ** 2 + v[5] ** 2)
                + r["C2X"] * (v[9] ** 2 + v[11] ** 2))
    dissipated = quad(damping_power, 0.0, h, limit=200, epsabs=0.0, epsrel=1e-12)[0]
    assert y[12] == pytest.approx(dissipated, rel=1e-4)


@pytest.mark.parametrize("stepper", ["exponential", "multistep"])
def test_exponential_integrator_agrees_with_rk4_in_a_steady_run(stepper):
    """The exponential integrators against the RK4 path (different error constants) at 1 ms over a
    second of the steady scenario's operating point (100 rad/s, 2 N.m, beta = 5 deg), from the start transient
    on: the lateral motions agree to 2e-5 of their amplitude and the shaft torques to 1e-4 of the load (measured
    7e-6 and 2e-5 with either, mostly RK4's error: the exponential integrators' are about 10x smaller,
    docs/cosimulation.md)."""
    p = rotor()
    step = STEPPERS[stepper]
    y_exp = y_rk = tj.rest_state(p, 0.0, 100.0)
    worst_lateral = worst_twist = 0.0
    for k in range(1000):
        phi = 0.1 * k
        y_exp = step(p, 1e-3, phi, 100.0, 0.0, y_exp, 2.0)
        y_rk = rk4_step(p, 1e-3, phi, 100.0, 0.0, y_rk, 2.0)
        worst_lateral = max(worst_lateral, max(abs(y_exp[i] - y_rk[i]) for i in (2, 4, 8, 10)))
        worst_twist = max(worst_twist, abs(y_exp[0] - y_rk[0]) * p.K1T, abs(y_exp[6] - y_rk[6]) * p.K2T)
    amplitude = max(abs(y_rk[i]) for i in (2, 4, 8, 10))
    assert worst_lateral < 2e-5 * amplitude and worst_twist < 1e-4 * 2.0


def test_linearised_natural_frequencies_are_the_jeffcott_and_torsional_chain_ones():
    """Without unbalance and joint angle, at rest: lateral sqrt(K/M) per disc and direction, torsional the
    eigenvalues of the fixed-free chain input - K1T - J_M1 - K2T - J_M2."""
    p = rotor(beta=0.0, m_u1=0.0, m_u2=0.0, C1X=0.0, C1Y=0.0, C2X=0.0, C2Y=0.0, C1T=0.0, C2T=0.0)
    r = tj.rig_parameters()
    y0 = np.zeros(tj.STATE_SIZE)
    f0 = np.array(tj.rates(p, 0.0, 0.0, 0.0, list(y0), 0.0))
    jac = np.empty((12, 12))
    for i in range(12):
        y = y0.copy()
        y[i] = 1e-6
        jac[:, i] = (np.array(tj.rates(p, 0.0, 0.0, 0.0, list(y), 0.0)) - f0)[:12] / 1e-6
    ours = np.sort(np.abs(np.linalg.eigvals(jac).imag))[::2]
    stiffness = np.array([[r["K1T"] + r["K2T"], -r["K2T"]], [-r["K2T"], r["K2T"]]])
    torsion = np.sqrt(np.linalg.eigvals(np.linalg.solve(np.diag([r["J_M1"], r["J_M2"]]), stiffness)).real)
    lateral = [math.sqrt(r["K1X"] / r["M1"])] * 2 + [math.sqrt(r["K2X"] / r["M2"])] * 2
    np.testing.assert_allclose(ours, np.sort(np.concatenate([torsion, lateral])), rtol=1e-6)


def test_default_rig_critical_speeds_are_the_documented_ones():
    """ujfmu/models/twin_jeffcott_rotor/README.md quotes these (lateral with the unbalance mass, torsional chain)."""
    r = tj.rig_parameters()
    assert math.sqrt(r["K1X"] / (r["M1"] + r["m_u1"])) == pytest.approx(153.8, abs=0.05)
    assert math.sqrt(r["K2X"] / (r["M2"] + r["m_u2"])) == pytest.approx(117.0, abs=0.05)
    assert r["M1"] == pytest.approx(3.468, abs=5e-4) and r["K1T"] == pytest.approx(328.9, abs=0.05)


#: stiff shafts at large joint angles, unbalance off: N's own rate (the joint's modulation of the shafts' stiffness)
#: far above the aligned rotor's; the damping scales with sqrt(K) (the default rig's damping ratio)
STIFF_LARGE_ANGLES = [dict(beta=30.0 * DEG, K1T=1e6, K2T=1e6, C1T=38.0, C2T=38.0),
                      dict(beta=40.0 * DEG, K1T=1e5, K2T=1e5, C1T=12.0, C2T=12.0),
                      dict(beta=45.0 * DEG, K1T=1e7, K2T=1e7, C1T=120.0, C2T=120.0)]


def _adams_run(p, steps=50, h=1e-3, w=100.0):
    """The FMU's stepper (multistep_step) at a constant input speed w from rest in the joint: the states."""
    y, history, states = tj.initial_state(p, 0.0, tj.Drive(0.0, w, 0.0, 0.0)), tj.NO_HISTORY, []
    for k in range(steps):
        y, history = tj.multistep_step(p, k * h, h, w * k * h, w, 0.0, y, 0.0, history)
        states.append(y)
    return np.array(states)


@pytest.mark.parametrize("changes", STIFF_LARGE_ANGLES)
def test_the_adams_method_is_stable_at_large_joint_angles_with_stiff_shafts(changes, monkeypatch):
    """At 30-45 deg and shafts of 1e5-1e7 N.m/rad (a fresh-eyes trial's rotors) the FMU's Adams method keeps the
    output speed near the joint's kinematic bounds omega cos(beta) .. omega / cos(beta) (within 3%: the shafts'
    compliance adds up to 1% here) and within 2e-6 of omega of ETDRK4-B's steps of an eighth of the step
    (``exponential_step``, stable at its own rule; measured 2.4e-7..9.5e-7): its substeps keep h times N's own
    rate bound within ``ADAMS_RATE_STEP``. With only the ETDRK4-B rule (h rate <= 0.5) it diverged (the output at
    2.5x the input speed and more within 50 ms, or a math domain error on the way)."""
    p = rotor(m_u1=0.0, m_u2=0.0, **changes)
    w, cos_beta, h = 100.0, math.cos(changes["beta"]), 1e-3
    states = _adams_run(p, w=w, h=h)
    assert np.all(np.isfinite(states))
    assert np.all((states[:, 7] > 0.97 * w * cos_beta) & (states[:, 7] < 1.03 * w / cos_beta))
    fine = tj.initial_state(p, 0.0, tj.Drive(0.0, w, 0.0, 0.0))
    for k in range(8 * len(states)):
        fine = tj.exponential_step(p, h / 8, w * k * h / 8, w, 0.0, fine, 0.0)
    assert abs(states[-1][7] - fine[7]) < 2e-6 * w
    monkeypatch.setattr(tj, "ADAMS_RATE_STEP", 0.5)   # the ETDRK4-B rule alone
    try:
        with np.errstate(all="ignore"):
            loose = _adams_run(p, w=w, h=h)
        assert not np.all(np.abs(loose[:, 7]) < 1.03 * w / cos_beta)
    except ValueError:   # a math domain error on the way out
        pass
