"""The torque-driven TwinJeffcottRotor's integrators: the exponential Runge-Kutta one (``torque_exponential_step``:
order, the linear part and the rigid-body mode exact) and the exponential Adams one the FMU steps with
(``torque_multistep_step``: N free of the reference rotation, order, restarts, input-free history, its operators at
extreme parameters), the energy audit of both, and the FMU's step through it."""

import math

import numpy as np
import pytest

from ujfmu.fmu import series
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


class Multistep:
    """``TorqueDriven.integrate_with_history`` (the FMU's stepper) called as ``TorqueDriven.integrate`` is: it keeps
    its history and time between calls and starts afresh when called with a state it did not return last."""

    def __init__(self):
        self.last, self.t, self.history = None, 0.0, tj.TORQUE_NO_HISTORY

    def __call__(self, p, t, h, y, u):
        if y is not self.last:
            self.t, self.history = 0.0, tj.TORQUE_NO_HISTORY
        self.last, self.history = tj.TorqueDriven.integrate_with_history(p, self.t, h, y, u, self.history)
        self.t += h
        return self.last


#: the FMU's integrators: ETDRK4-B alone, and the exponential Adams method it starts
STEPPERS = {"exponential": tj.TorqueDriven.integrate, "multistep": Multistep}


def _assert_within(actual, expected, tolerance, message=""):
    """|actual - expected| <= tolerance elementwise (tolerance an array: each element against its own size)."""
    difference = np.abs(np.asarray(actual, dtype=float) - np.asarray(expected, dtype=float))
    assert np.all(difference <= tolerance), (message, difference, tolerance)


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


def _audit(p, h, u, duration, stepper):
    """(|input work - load work - dissipation - change of stored energy|, input work) of a run under u."""
    y = tj.TorqueDriven.initial_state(p, 0.0, u)
    step = stepper() if stepper is Multistep else stepper

    def energy(s):
        return tj.stored_energy(p, s[0], s[1], s[2:])
    e0, load_work = energy(y), 0.0
    for _ in range(int(round(duration / h))):
        y_next = step(p, 0.0, h, y, u)
        load_work += u.tau_load * (y_next[8] - y[8])
        y = y_next
    change = energy(y) - e0
    assert y[14] > 1e-3 * y[15] and change > 0.1 * y[15]
    return abs(y[15] - load_work - y[14] - change), y[15]


@pytest.mark.parametrize("stepper", STEPPERS)
@pytest.mark.parametrize("beta_deg", [0.0, 10.0])
def test_torque_driven_energy_balance_over_a_run_up(beta_deg, stepper):
    """Input work through the flange's shaft end - load work - dissipation = change of the rotor's stored energy
    (flange J_gb, discs, shafts, supports) along a torque-driven run-up through the lateral criticals (5 N.m against
    1 N.m, 0 -> 195 rad/s in 2 s): exact but for the integrator's truncation error, tiny, and falling at least as a
    fourth-order method's should (a bookkeeping error would not fall with the step). Both the ETDRK4-B steps and the
    exponential Adams ones (the input work's tau_in column added to the history's input-free points)."""
    p = rotor(beta=beta_deg * DEG, m_u1=0.01, m_u2=0.01)
    u = Torques(5.0, 1.0)
    error, work = _audit(p, 1e-3, u, 2.0, STEPPERS[stepper])
    assert error < 1e-7 * work
    if error > 1e-12 * work:
        finer, _ = _audit(p, 2.5e-4, u, 2.0, STEPPERS[stepper])
        assert finer < error / 16


def _twisted_state(p, rng, phi, w):
    """A torque-driven state about the rigid rotation (phi, w): twisted shafts, moving discs, displaced centres."""
    z = rng.normal(size=14) * np.array([0.0, 0.0, 5e-3, 1.0, 1e-5, 1e-3, 1e-5, 1e-3, 8e-3, 1.0, 1e-5, 1e-3, 1e-5, 1e-3])
    z[0], z[1] = rng.normal() * 1e-3, rng.normal() * 0.5
    return [phi + z[0], w + z[1], phi + z[2], w + z[3], *z[4:8], phi + z[8], w + z[9], *z[10:14], 0.0, 0.0]


def test_remainder_does_not_depend_on_the_reference_rotation():
    """L r = r' for every rigid rotation r of the whole rotor (every angle phi, every speed w, discs centred): so
    N = f(r + z) - r' - L z = f(y) - L y is a function of the state y alone, and the history's points carry over from
    one step's reference rotation to the next's without re-referencing. At random states and torques, N of
    :func:`tj._flange_remainder` taken about rotations 40 rad and 150 rad/s apart agrees to round-off (of the angles'
    size); a remainder that kept part of the rigid motion (e.g. the flange's speed row of L dropped) would not."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8)
    torsion = np.array(p.torque_linear[0])
    for phi, w in ((0.3, 20.0), (-41.0, 170.0)):
        r = np.array([phi, w, phi, w, phi, w])
        _assert_within(torsion @ r, [w, 0.0, w, 0.0, w, 0.0], 1e-14 * (np.abs(torsion) @ np.abs(r)))
    rng = np.random.default_rng(7)
    scale = np.array([1.0, 1e4, 1e2, 1e2, 1e4, 1e2, 1e2, 1e2, 1e3])   # N's rows' sizes (rad/s^2, m/s^2, W)
    for _ in range(20):
        y = _twisted_state(p, rng, rng.uniform(-5.0, 5.0), rng.uniform(-100.0, 100.0))
        torques = rng.uniform(-5.0, 5.0, size=2)
        values = []
        for phi, w in ((y[0], y[1]), (y[0] - 40.0, y[1] + 150.0), (y[8] + 3.0, y[9] - 60.0)):
            z = [y[0] - phi, y[1] - w, y[2] - phi, y[3] - w, *y[4:8], y[8] - phi, y[9] - w, *y[10:14]]
            values.append(np.array(tj._flange_remainder(p, phi, w, z, *torques)))
        for other in values[1:]:
            _assert_within(other, values[0], 1e-11 * scale)


def test_torque_multistep_integrator_order_and_accuracy():
    """Observed order of ``torque_multistep_step`` (exponential Adams PEC, six points of N) on the run of
    :func:`test_torque_exponential_integrator_is_fourth_order`, from its start (five ETDRK4-B steps, then the Adams
    steps), against DOP853 at rtol 1e-13 at every step: the largest error of the run falls 2^5 or more per halving
    of the step (measured 6.2 between 1 ms and 0.5 ms, 5.2 to 0.25 ms, 4.9 on to 0.125 ms: the Adams steps'
    sixth-order error gives way to the start steps' fifth-order one), and it is below ETDRK4-B's at 1 ms (measured
    1.7e-5 against 2.9e-5 of the states' scales) and 0.5 ms (2.3e-7 against 1.9e-6). A wrong operator or weight (a
    predictor weight off, the corrector or the constant rows left out) leaves order 4 or less or a larger error."""
    from scipy.integrate import solve_ivp
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8, omega_in_start=80.0)
    u, duration, finest = Torques(5.0, 2.0), 0.1, 2.5e-4
    start = tj.TorqueDriven.initial_state(p, 0.0, u)
    fine = solve_ivp(lambda t, y: tj.TorqueDriven.derivatives(p, t, y, u), (0.0, duration), start, method="DOP853",
                     rtol=1e-13, atol=1e-15 * SCALE, t_eval=np.arange(int(round(duration / finest)) + 1) * finest).y

    def worst(h, stepper):
        y, error, stride = start, 0.0, int(round(h / finest))
        for k in range(int(round(duration / h))):
            y = stepper(p, k * h, h, y, u)
            error = max(error, np.max(np.abs(np.array(y) - fine[:, (k + 1) * stride]) / SCALE))
        return error

    errors = [worst(h, Multistep()) for h in (1e-3, 5e-4, 2.5e-4)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 4.6) & (orders < 7.0)), (errors, orders)
    assert errors[0] < worst(1e-3, tj.TorqueDriven.integrate) and errors[1] < worst(5e-4, tj.TorqueDriven.integrate)


def _run_against_fine(p, h, duration, inputs, stepper):
    """Max scaled error after duration of ``stepper`` against DOP853 (rtol 1e-13) from the same start, both under
    inputs(t) = (tau_in, tau_load) held over the step from t."""
    from scipy.integrate import solve_ivp
    y = ref = tj.TorqueDriven.initial_state(p, 0.0, Torques(*inputs(0.0)))
    for k in range(int(round(duration / h))):
        u = Torques(*inputs(k * h))
        y = stepper(p, k * h, h, y, u)
        ref = solve_ivp(lambda t, s: tj.TorqueDriven.derivatives(p, t, s, u), (0.0, h), ref, method="DOP853",
                        rtol=1e-13, atol=1e-15 * SCALE).y[:, -1]
    return np.max(np.abs(np.array(y) - ref) / SCALE)


@pytest.mark.parametrize("jump", ["drive", "load"])
def test_torque_multistep_integrator_restarts_at_a_torque_step(jump):
    """A step of the driving torque (3 -> 8 N.m: the flange's acceleration steps by 5 N.m / J_in = 238 rad/s^2) or of
    the load (2 -> 20 N.m: disc 2's by 18 N.m / J_eff2 = 1840 rad/s^2) at 30 ms, after a slow drift of both: the
    motion's accelerations jump, so N's time derivative does, which no polynomial through the history follows. The
    multistep method restarts there (``TORQUE_INPUT_JUMP``) and stays as accurate as ETDRK4-B, which starts afresh
    every step (within 1.5x of its error against DOP853; measured 0.29x and 1.1x); extrapolating across the step
    instead leaves 5.6x and 88x. The drift before it (0.01 N.m/s of each) is recombined with the held torques."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8, omega_in_start=80.0)
    after = (8.0, 2.0) if jump == "drive" else (3.0, 20.0)
    inputs = lambda t: (3.0 + 0.01 * t, 2.0 + 0.01 * t) if t < 0.03 - 1e-9 else after   # noqa: E731
    one_step = _run_against_fine(p, 1e-3, 0.06, inputs, tj.TorqueDriven.integrate)
    assert _run_against_fine(p, 1e-3, 0.06, inputs, Multistep()) < 1.5 * one_step


def test_torque_multistep_restarts_without_a_usable_history():
    """Without a history, with one of another step length or one that does not end at the step's start time, a
    step is exactly ETDRK4-B's (bitwise) and leaves a history of its start point; after five such steps the next
    one is the Adams method's and differs. A change of the torques keeps the history below the bound
    |d tau_in| / J_in + |d tau_load| / J_eff2 <= ``TORQUE_INPUT_JUMP`` (the steps of the flange's and disc 2's
    accelerations) and discards it above, for either torque."""
    p = rotor(beta=5 * DEG, omega_in_start=100.0)
    u = Torques(3.0, 2.0)
    y0 = tj.TorqueDriven.initial_state(p, 0.0, u)
    y1, history = tj.TorqueDriven.integrate_with_history(p, 0.0, 1e-3, y0, u, tj.TorqueDriven.NO_HISTORY)
    assert y1 == tj.TorqueDriven.integrate(p, 0.0, 1e-3, y0, u) and history[2] == 1.0
    for t, h in ((1e-3, 2e-3), (0.5, 1e-3)):   # another step length; a history not ending at t
        y, fresh = tj.TorqueDriven.integrate_with_history(p, t, h, y1, u, history)
        assert y == tj.TorqueDriven.integrate(p, t, h, y1, u) and fresh[2] == 1.0
    y, history = y0, tj.TorqueDriven.NO_HISTORY
    for k in range(tj.HISTORY_POINTS):
        previous = y
        y, history = tj.TorqueDriven.integrate_with_history(p, k * 1e-3, 1e-3, y, u, history)
    assert history[2] == tj.HISTORY_POINTS
    assert y != tj.TorqueDriven.integrate(p, 0.0, 1e-3, previous, u)
    t = tj.HISTORY_POINTS * 1e-3
    bound = tj.TORQUE_INPUT_JUMP
    for d_in, d_load in ((0.99 * bound / p.inverse_j_in, 0.0), (0.0, 0.99 * bound * p.j_eff2),
                         (0.49 * bound / p.inverse_j_in, -0.49 * bound * p.j_eff2)):
        kept = tj.TorqueDriven.integrate_with_history(p, t, 1e-3, y, Torques(3.0 + d_in, 2.0 + d_load), history)[1]
        assert kept[2] == tj.HISTORY_POINTS, (d_in, d_load)
        changed = Torques(3.0 + 1.03 * d_in, 2.0 + 1.03 * d_load)
        y_new, fresh = tj.TorqueDriven.integrate_with_history(p, t, 1e-3, y, changed, history)
        assert fresh[2] == 1.0 and y_new == tj.TorqueDriven.integrate(p, t, 1e-3, y, changed), (d_in, d_load)


def test_torque_history_points_are_input_free():
    """The history keeps N at zero torques (N_0) with disc 2's lateral load columns and the flange's speed, so that a
    change of the torques rewrites no point: the point a start step stores (N at the held torques less their
    columns: tau_in / J_in on the flange, -tau_load / J_eff2 on disc 2, tau_load G_2 on its lateral rows,
    tau_in J_gb / J_in omega_in on the input work) is N_0 at its state (:func:`tj._flange_remainder` at
    tau_in = tau_load = 0) to round-off; a column with the wrong sign or inertia would leave it off by its size."""
    p = rotor(beta=10 * DEG, m_u1=0.01, m_u2=0.01, phase_u1=0.3, phase_u2=-0.8)
    rng = np.random.default_rng(3)
    y = _twisted_state(p, rng, 0.7, 60.0)
    _, history = tj.torque_multistep_step(p, 0.0, 1e-3, y, 4.0, 3.0, tj.TORQUE_NO_HISTORY)
    z = [0.0, 0.0, y[2] - y[0], y[3] - y[1], *y[4:8], y[8] - y[0], y[9] - y[1], *y[10:14]]
    free = tj._flange_remainder(p, y[0], y[1], z, 0.0, 0.0)
    assert free[0] == 0.0
    expected = [*free[1:], *tj._input_columns(p, y[8]), y[1]]
    scale = np.array([1e4, 1e2, 1e2, 1e4, 1e2, 1e2, 1e2, 1e3, 1e-2, 1e-2, 1e2])
    _assert_within(history[5:16], expected, 1e-13 * scale)


def _phi_reference(a, h, count):
    """[phi_0(h a), ..., phi_(count-1)(h a)] to 30 digits (mpmath): the series sum_j (h a)^j / (j + k)! to 80 terms,
    whose truncation and round-off are far below double precision at h |lambda| <= 1."""
    import mpmath
    with mpmath.workdps(30):
        x = mpmath.matrix([[h * v for v in row] for row in a])
        power, phis = mpmath.eye(len(a)), [mpmath.zeros(len(a)) for _ in range(count)]
        for j in range(80):
            for k in range(count):
                phis[k] += power / mpmath.factorial(j + k)
            power = power * x
        return [np.array(phi.tolist(), dtype=float) for phi in phis]


#: the default rig and parameters at the ends of the FMU's ranges: a flange 1e6x lighter than the discs, the stiffest
#: shaft on a light flange, overdamped shafts, a disc 1e12x lighter than the other
EXTREME_TORSION = [dict(), dict(J_drive=0.0, J_gb=1e-8), dict(K1T=1e9, J_drive=0.0, J_gb=1e-4, K2T=1e-6),
                   dict(C1T=1e3, C2T=1e3, J_drive=0.0, J_gb=1e-3), dict(J_M1=1e3, J_M2=1e-9, K2T=1e6, C2T=0.0)]


def _extreme_torsion():
    """(changes, p, the substep h of a 1 ms step at 100 rad/s, the torsional block) of each EXTREME_TORSION case, the
    substep rule's h |lambda| <= 1 checked."""
    for changes in EXTREME_TORSION:
        p = rotor(**changes)
        h = 1e-3 / tj.torque_exponential_substeps(p, 1e-3, 100.0)
        torsion = p.torque_linear[0]
        assert np.max(np.abs(np.linalg.eigvals(h * np.array(torsion)))) <= 1.0, changes
        yield changes, p, h, torsion


def test_adams_operators_at_extreme_parameters():
    """The Adams operators' phi-functions (Taylor series in double precision, :func:`series.phi_sum`) of the 6x6
    torsional block with its rigid-body mode, at the substep h the FMU takes for a 1 ms step, against the same
    functions to 30 digits, at EXTREME_TORSION. The substep rule keeps h |lambda| <= 1 (checked), where the series
    converges fast and cancels little: each row of each phi_k agrees to 1e-14 of its size (measured 6e-16 at most;
    scipy's ``expm`` of the augmented matrix [[hL, I, 0, ...], [0, 0, I, ...], ...] reaches only 2e-13..8e-13
    there)."""
    count = tj.HISTORY_POINTS + 2
    for changes, p, h, torsion in _extreme_torsion():
        for k, exact in enumerate(_phi_reference(torsion, h, count)):
            ours = series.phi_sum(torsion, h, (0.0,) * k + (1.0,))
            size = np.max(np.abs(exact), axis=1, keepdims=True)   # each row against its own size
            _assert_within(ours, exact, 1e-14 * size, (changes, k))


def test_start_step_operators_at_extreme_parameters():
    """ETDRK4-B's operators (:func:`tj._torque_propagators_of`, the start and restart steps) on the torsional block,
    against its phi-functions to 30 digits at EXTREME_TORSION: E(h/2) and E(h) row by row, and R1 = h phi_1(hL) and
    R2 = 2 h phi_2(hL) on the columns omega_in, omega1, omega2, each row to 1e-14 of its size (scaling and squaring
    the augmented matrix in double precision instead misses by 1.5e-14 on the default rig, 1.4e-9 at K1T = 1e9)."""
    for changes, p, h, torsion in _extreme_torsion():
        ops = tj._torque_propagators_of(p.torque_linear, h)
        half, full = _phi_reference(torsion, 0.5 * h, 1), _phi_reference(torsion, h, 3)
        for name, ours, exact in (("E(h/2)", ops[0][:36], half[0]), ("E(h)", ops[3][:36], full[0]),
                                  ("R1", ops[4][:18], h * full[1][:, (1, 3, 5)]),
                                  ("R2", ops[5][:18], 2.0 * h * full[2][:, (1, 3, 5)])):
            exact = np.asarray(exact).reshape(6, -1)
            size = np.max(np.abs(exact), axis=1, keepdims=True)
            _assert_within(np.reshape(ours, exact.shape), exact, 1e-14 * size, (changes, name))


def test_operators_at_the_step_lengths_of_a_host_that_varies_its_step():
    """ETDRK4-B's operators of the torque-driven rotor (:func:`tj._torque_propagators_of`) and of the speed-driven
    one (:func:`tj._propagators_of`) at steps a host that varies its step takes, each h new, within one power of 2
    of the kept powers of the blocks (:func:`series.phi_sum`) and across them: E(h) and the two-term
    S2 = h (4 phi_3 - phi_2)(hL) of the torsional blocks against the phi-functions to 30 digits, E's rows each to
    1e-14 of its size, S2's columns each to 1e-14 of theirs (its angle rows cancel to O(h^3), far below the speed
    rows of the same column)."""
    p = rotor()
    rng = np.random.default_rng(2)
    for step in [*(1e-3 * (0.9 + 0.2 * rng.random(3))), 0.6e-3, 0.7e-3, 1.45e-3]:
        h = step / tj.torque_exponential_substeps(p, step, 100.0)
        ops, (e, _, p2, p3) = tj._torque_propagators_of(p.torque_linear, h), _phi_reference(p.torque_linear[0], h, 4)
        s2 = h * (4.0 * p3 - p2)[:, (1, 3, 5)]
        for name, ours, exact in (("E(h)", ops[3][:36], e), ("S2", ops[7][:18], s2)):
            exact = np.asarray(exact).reshape(6, -1)
            size = np.max(np.abs(exact), axis=1 if name == "E(h)" else 0, keepdims=True)
            _assert_within(np.reshape(ours, exact.shape), exact, 1e-14 * size, (step, name))
        h = step / tj.exponential_substeps(p, step, 100.0, 0.0)
        ops, (e, _, p2, p3) = tj._propagators_of(p.linear, h), _phi_reference(p.linear[0], h, 4)
        s2 = h * (4.0 * p3 - p2)[:, (1, 3)].T   # the layout: the column omega1, then omega2 (here as rows)
        for name, ours, exact in (("E(h)", ops[3][:16], np.asarray(e)), ("S2", ops[7][:8], s2)):
            size = np.max(np.abs(exact), axis=1, keepdims=True)
            _assert_within(np.reshape(ours, exact.shape), exact, 1e-14 * size, (step, name, "speed-driven"))


def test_fmu_steps_with_the_multistep_integrator(open_fmu):
    """TwinJeffcottRotorTorqueDriven's step is ``TorqueDriven.integrate_with_history`` (its history is FMU state):
    100 steps of the FMU equal the model's own to round-off; a torque that would take the flange past the speed range
    within a step is refused (fmi2Discard, the cause named), its history as it was (the step is tried, since the
    bound on the speed extrapolates the acceleration, and its end is out of range): the instance then steps on with
    a sane torque as the model does from the history it had."""
    params = dict(J_drive=0.02, omega_in_start=30.0)
    inst = open_fmu("TwinJeffcottRotorTorqueDriven")
    inst.initialize(params)
    p = rotor(omega_in_start=30.0)
    u = Torques(3.0, 1.0)
    y, history = tj.TorqueDriven.initial_state(p, 0.0, u), tj.TorqueDriven.NO_HISTORY
    for k in range(100):
        inst.set(tau_in=3.0, tau_load=1.0)
        inst.slave.doStep(k * 1e-3, 1e-3)
        y, history = tj.TorqueDriven.integrate_with_history(p, k * 1e-3, 1e-3, y, u, history)
    assert inst.get("omega_in", "phi_out", "X2")[:3] == pytest.approx([y[1], y[8], y[10]], rel=1e-12, abs=1e-18)
    assert history[2] == tj.HISTORY_POINTS
    inst.set(tau_in=1e6)
    assert inst.raw("fmi2DoStep")(inst.slave.component, 0.1, 1e-3, 1) == 2
    assert "tau_in = 1000000.0 N.m" in inst._log[-1] and "would reach" in inst._log[-1], inst._log[-1]
    inst.set(tau_in=3.0)
    inst.slave.doStep(0.1, 1e-3)
    y, _ = tj.TorqueDriven.integrate_with_history(p, 0.1, 1e-3, y, u, history)
    assert inst.get("omega_in", "phi_out", "X2")[:3] == pytest.approx([y[1], y[8], y[10]], rel=1e-12, abs=1e-18)


@pytest.mark.parametrize("beta_deg, k", [(30.0, 1e6), (45.0, 1e5)])
def test_the_adams_method_is_stable_at_large_joint_angles_with_stiff_shafts(beta_deg, k, monkeypatch):
    """The torque-driven FMU's Adams method at 30-45 deg with shafts of 1e5-1e6 N.m/rad, a heavy flange spinning
    freely at 100 rad/s: the output speed stays within 3% of the joint's kinematic bounds omega_in cos(beta) ..
    omega_in / cos(beta) (the substeps keep h times N's own rate bound within ``ADAMS_RATE_STEP``); with only the
    ETDRK4-B rule (h rate <= 0.5) it diverged."""
    damping = 12.0 * math.sqrt(k / 1e5)
    p = rotor(beta=beta_deg * DEG, K1T=k, K2T=k, C1T=damping, C2T=damping, m_u1=0.0, m_u2=0.0, J_drive=1.0,
              omega_in_start=100.0)
    cos_beta, u = math.cos(beta_deg * DEG), Torques(0.0, 0.0)

    def run():
        y, history, ratios = tj.TorqueDriven.initial_state(p, 0.0, u), tj.TorqueDriven.NO_HISTORY, []
        for step in range(50):
            y, history = tj.TorqueDriven.integrate_with_history(p, step * 1e-3, 1e-3, y, u, history)
            ratios.append(y[9] / y[1])
        return np.array(ratios)
    ratios = run()
    assert np.all((ratios > 0.97 * cos_beta) & (ratios < 1.03 / cos_beta))
    monkeypatch.setattr(tj, "ADAMS_RATE_STEP", 0.5)
    try:
        with np.errstate(all="ignore"):
            assert not np.all(np.abs(run()) < 1.03 / cos_beta)
    except ValueError:   # a math domain error on the way out
        pass
