"""The flexible driveline's integrators (model.flexible_step, model.torque_driven_step, model.multistep_step):
Dormand and Prince's fifth-order formula is fifth order on a closed-form solution, replaces the RK4 substeps only
where it needs fewer evaluations, is then at least as accurate, its stability covers the step the rule gives it, the
rule's bound of |lambda| (model.mode_rate_bound) bounds the linearised equations' eigenvalues, and the unrolled
integrators the FMUs run are the readable formula's numbers and what the generator writes; the speed-driven FMU's
exponential Adams method is of order 7, exact on the linear part, restarts where its history cannot serve, and is
at least about as accurate as the Dormand-Prince step it replaced."""

import cmath
import math
from pathlib import Path

import numpy as np
import pytest

from ujfmu.fmu import rk4, series
from ujfmu.models.double_cardan_driveline import model as dc

#: Omar's driveline (Table 1) with both joints straight: r = 1, dy/db = 0, J_out = J_load, and the lateral mode left
#: at rest (phi = 0 would otherwise bend the joints)
STRAIGHT = dict(beta1=0.0, beta2=0.0, yoke_phase=0.0, joint_plane_angle=0.0, I_input=0.0, I_cross_pin=0.0,
                I_cross_normal=0.0, I_intermediate=0.0, J_load=0.0045, k_theta=92.2, xi_theta=0.002, m_s=4.09,
                k_phi=26331.0, xi_phi=0.002, L_c=0.325)
SPEED, LOAD = 70.0, 3.0
TWIST0, TWIST_RATE0 = 0.01, -0.5


def closed_form(p, t):
    """(phi4, w4, phi, dphi) at t, the input at constant SPEED from phi1 = 0: the twist x = phi1 - phi4 obeys
    J x'' + c x' + k x = tau_load, x = tau_load / k + Re(A exp(lambda t)), lambda = -c / 2J + i sqrt(k/J - (c/2J)^2),
    A fitted to x(0) = TWIST0, x'(0) = TWIST_RATE0."""
    lam = complex(-p.c_theta / (2 * p.J_load), math.sqrt(p.k_theta / p.J_load - (p.c_theta / (2 * p.J_load)) ** 2))
    a0 = TWIST0 - LOAD / p.k_theta
    amplitude = complex(a0, (lam.real * a0 - TWIST_RATE0) / lam.imag)
    mode = amplitude * cmath.exp(lam * t)
    return (SPEED * t - (LOAD / p.k_theta + mode.real), SPEED - (lam * mode).real, 0.0, 0.0)


def error(p, interval, n, step):
    """Largest state error against the closed form at the ends of n intervals, each advanced by
    ``step(rates, y, interval)`` (a phase-independent figure: a single end time can fall where an error vanishes)."""
    y, worst = closed_form(p, 0.0), 0.0
    for i in range(n):
        def rates(t, y, start=i * interval):
            return dc.derivatives(p, start + t, y, dc.Drive(SPEED * (start + t), SPEED, 0.0, LOAD))
        y = step(rates, y, interval)
        worst = max(worst, *(abs(a - b) for a, b in zip(y, closed_form(p, (i + 1) * interval))))
    return worst


def test_dormand_prince_is_fifth_order_on_a_closed_form_solution():
    """Halving the step divides the error by 2^5: observed order 5 (a wrong coefficient shows order 1-4)."""
    p = dc.Parameters(**STRAIGHT)
    errors = [error(p, 0.1 / n, n, lambda f, y, t: dc.dormand_prince(f, y, t, 1))   # 143 rad/s x h = 0.72,
              for n in (20, 40, 80)]                                                 # 0.36, 0.18
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert errors[-1] < 1e-6
    assert orders == pytest.approx([5.0, 5.0], abs=0.3)


@pytest.mark.parametrize("substeps, omega, steps", [(1, 0.0, 0), (2, 0.0, 1), (4, 0.0, 1), (4, 300.0, 2),
                                                     (3, 300.0, 0), (8, 300.0, 2), (29, 3000.0, 13)])
def test_fifth_order_steps_only_where_they_take_fewer_evaluations(substeps, omega, steps):
    """ceil(h (mode_rate + 4 |omega|)) fifth-order steps of h = 1 ms, where RK4's rule asks for two substeps or
    more and the steps take fewer evaluations (6 each against 4); 0: RK4."""
    p = dc.Parameters(**STRAIGHT)
    assert 1e-3 * (p.mode_rate + 4.0 * omega) <= steps or not steps
    assert dc.fifth_order_steps(p, 1e-3, omega, substeps) == steps
    if steps:
        assert 6 * steps < 4 * substeps


@pytest.mark.parametrize("steps", [1, 2])
def test_the_fifth_order_steps_at_their_limit_are_more_accurate_than_rk4_substeps_at_theirs(steps):
    """With the torsional mode's |lambda| x step at the limits of the two rules (1 a fifth-order step, RATE_STEP =
    0.5 an RK4 substep), the fifth-order steps err less than twice as many RK4 substeps over 15 such intervals."""
    p = dc.Parameters(**STRAIGHT)
    interval = steps * 2 * rk4.RATE_STEP / math.sqrt(p.k_theta / p.J_load)
    ours = error(p, interval, 15, lambda f, y, t: dc.dormand_prince(f, y, t, steps))
    classical = error(p, interval, 15, lambda f, y, t: rk4.integrate_time(f, y, t, 2 * steps))
    assert ours < 0.8 * classical


def _driveline(**changes):
    return dc.TorqueDrivenParameters(**{**STRAIGHT, "J_drive": 0.05, "omega_in_start": 0.0, **changes})


@pytest.mark.parametrize("changes", [
    dict(beta1=0.349, beta2=0.349, yoke_phase=0.524, k_theta=2e4, J_load=0.5),             # the stiff scenario's
    dict(beta1=0.26, beta2=0.26),                                                              # Omar's, input free
    dict(beta1=0.3, beta2=-0.2, joint_plane_angle=0.4, xi_theta=0.05, I_cross_pin=1e-4,     # overdamped torsion
         I_cross_normal=1e-4, I_intermediate=1e-3),
    dict(beta1=0.2, beta2=0.2, xi_phi=0.2, k_theta=500.0),                                  # overdamped support
    dict(beta1=0.14, beta2=0.14, k_theta=8000.0, xi_theta=6e-4, J_load=7.0, J_drive=0.3,    # undamped stiff support
         k_phi=1e8, xi_phi=0.0),                                                            # beside a damped shaft
])
def test_mode_rate_bounds_the_linearised_equations_eigenvalues(changes):
    """max |lambda| of the torque-driven equations' Jacobian (central differences, at rest, untwisted, at 12 input
    angles) stays below mode_rate, which is at most natural_rate; a bound that dropped the damping's branch or the
    free input shaft's side of the torsional mode would fail one of these, and so would one that kept only the
    overdamped branch where xi^2 Lambda > 4 while an undamped mode rings (a motorsport trial's stiff support,
    xi_phi = 0 at k_phi = 1e8 N/m: 4945 rad/s bounded by 17, one fifth-order step per 1 ms, and the run diverged)."""
    np = pytest.importorskip("numpy")
    p = _driveline(**changes)
    u = dc.Torques(0.0, 0.0)
    largest = 0.0
    for phi1 in np.linspace(0.0, math.pi, 12, endpoint=False):
        y0 = np.array(dc.TorqueDriven.initial_state(p, 0.0, u))
        y0[0] = phi1
        y0[2] = dc.rigid_output_angle(p, phi1)
        steps = 1e-7 * np.maximum(1.0, np.abs(y0))
        jacobian = np.column_stack([
            (np.array(dc.TorqueDriven.derivatives(p, 0.0, tuple(y0 + e), u))
             - np.array(dc.TorqueDriven.derivatives(p, 0.0, tuple(y0 - e), u))) / (2 * e[i])
            for i, e in enumerate(np.diag(steps))])
        largest = max(largest, np.max(np.abs(np.linalg.eigvals(jacobian))))
    assert largest > 0.5 * p.mode_rate                  # a bound, not a loose one
    assert largest <= p.mode_rate <= p.natural_rate


def test_the_stiff_driveline_takes_one_fifth_order_step_where_the_sum_bound_asked_for_two():
    """The stiff torque-driven scenario's driveline at 60 rad/s: the torsional mode's damping ratio is about 0.66,
    natural_rate (frequency plus decay) 2.4x mode_rate; one fifth-order step per 1 ms instead of two."""
    p = _driveline(beta1=0.349, beta2=0.349, yoke_phase=0.524, k_theta=2e4, J_load=0.5)
    assert p.natural_rate > 2.3 * p.mode_rate
    substeps = rk4.substeps(p.natural_rate + 4.0 * 60.0, 1e-3)
    assert (substeps, dc.fifth_order_steps(p, 1e-3, 60.0, substeps)) == (4, 1)


def test_the_committed_unrolled_integrators_are_what_the_generator_writes():
    text = Path(dc.__file__).read_text()
    assert text[text.index(dc._GENERATED):] == dc.unrolled_source()


@pytest.mark.parametrize("steps", [1, 3])
@pytest.mark.parametrize("inertias", [dict(I_cross_pin=1e-4, I_cross_normal=1e-4, I_intermediate=1e-3), {}])
def test_the_unrolled_integrators_compute_the_readable_formula_s_numbers_bit_for_bit(steps, inertias):
    """model._dp5_drive_4 and _dp5_held_6 (what the FMUs run) against dormand_prince with the protocol's rates,
    with and without the crosses' and intermediate shaft's inertia."""
    p = _driveline(beta1=0.3, beta2=-0.2, joint_plane_angle=0.4, **inertias)
    phi0, w0, alpha, tau_load, t0 = 0.3, 70.0, 150.0, 4.0, 0.25
    y4 = (0.21, 69.0, 1e-4, -2e-3)

    def drive(s, y):
        return dc._flexible_rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, y, tau_load)[0]
    assert dc._dp5_drive_4(dc._flexible_rates, p, y4, 2e-3, steps, phi0, w0, alpha, tau_load) == \
        tuple(dc.dormand_prince(drive, y4, 2e-3, steps))
    u, y6 = dc.Torques(30.0, tau_load), (phi0, w0) + y4
    readable = dc.dormand_prince(lambda s, y: dc.TorqueDriven.derivatives(p, t0 + s, y, u), y6, 2e-3, steps)
    held = (dc._driven_rates, p, p.J_drive, y6, 2e-3, steps, u.tau_in, u.tau_load)
    assert dc._dp5_held_6(*held) == tuple(readable)
    assert dc._dp5_held_6(*held, dc.TorqueDriven.derivatives(p, t0, y6, u)) == tuple(readable)


def _amplification(z):
    """|y(h) / y(0)| of one fifth-order step of y' = lambda y with h lambda = z (as a real 2-vector)."""
    def rates(t, y):
        return (z.real * y[0] - z.imag * y[1], z.imag * y[0] + z.real * y[1])
    return math.hypot(*dc.dormand_prince(rates, (1.0, 0.0), 1.0, 1))


def test_stability_covers_the_rule_s_steps():
    """The rule gives the formula |h lambda| <= 1 (two RK4 substeps of RATE_STEP = 0.5): there |R| <= 1 wherever the
    mode has any damping, and an undamped mode at the bound itself grows at most 1.4e-6 a step (R(z) = exp(z) to
    z^5 / 120, then z^6 / 600); decay is stable to h |lambda| = 3.3."""
    assert 2 * rk4.RATE_STEP == 1.0
    for radius in (0.25, 0.5, 0.75, 1.0):
        for k in range(61):
            z = -0.001 + radius * cmath.exp(1j * math.pi * (0.5 + k / 60))
            assert _amplification(z) <= 1.0
    assert _amplification(0.99j) < 1.0 < _amplification(1.0j) < 1.0 + 1.4e-6
    assert _amplification(-3.30 + 0j) < 1.0 < _amplification(-3.32 + 0j)


# --- the step's first stage from the outputs' evaluation (model._output_rates, Parameters.outputs_memo) ---------

def _counted(monkeypatch):
    """Wrap model._flexible_rates (the integrators, rates and outputs call it through the module) to count its calls;
    returns the list holding the count."""
    calls, rates = [0], dc._flexible_rates

    def counting(*args):
        calls[0] += 1
        return rates(*args)
    monkeypatch.setattr(dc, "_flexible_rates", counting)
    return calls


def _evaluations(calls, f, *args):
    """(f(*args), the _flexible_rates calls it made)."""
    calls[0] = 0
    result = f(*args)
    return result, calls[0]


RIGS = [dict(beta1=0.26, beta2=0.26),                                           # Omar's Z layout, no inertia
        dict(beta1=0.3, beta2=-0.2, joint_plane_angle=0.4, yoke_phase=0.2,      # the inertia terms' branch
             I_input=1e-3, I_cross_pin=1e-4, I_cross_normal=1e-4, I_intermediate=1e-3)]


@pytest.mark.parametrize("changes", RIGS)
@pytest.mark.parametrize("omega", [40.0, 71.6, -71.6])   # one RK4 substep; one fifth-order step
def test_a_step_after_the_outputs_starts_from_their_evaluation_bit_for_bit(monkeypatch, changes, omega):
    """The speed-driven FMU reads the outputs at (phi, omega, y), then steps from the same state object under a
    tau_load set in between: the step takes its first stage from the outputs' evaluation (one evaluation fewer)
    and is the step evaluated from scratch, bit for bit (tau_load, 0 in the outputs, corrected in dw4/dt)."""
    calls = _counted(monkeypatch)
    p, fresh = _driveline(**changes), _driveline(**changes)
    for tau_load in (3.0, -1.5, 0.0):
        y = dc.State(0.21, 0.98 * omega, 2e-4, -3e-3)   # a new state object each time: the outputs evaluate
        u = dc.Drive(0.37, omega, 150.0, tau_load)
        outputs, n_outputs = _evaluations(calls, dc.outputs, p, 0.0, y, u)
        assert n_outputs == 1 and outputs == dc.outputs(fresh, 0.0, y, u)
        served, n_served = _evaluations(calls, dc.integrate, p, 0.0, 1e-3, y, u)
        fresh.outputs_memo = None
        evaluated, n_evaluated = _evaluations(calls, dc.integrate, fresh, 0.0, 1e-3, y, u)
        assert served == evaluated
        assert n_served == n_evaluated - 1 and n_evaluated in (4, 6)
        assert dc._first_stage(p, y, u) == dc.flexible_derivatives(p, u.phi, u.omega, y, tau_load)


@pytest.mark.parametrize("changes", RIGS)
@pytest.mark.parametrize("omega", [40.0, -71.6])
def test_an_adams_step_after_the_outputs_starts_from_their_evaluation_bit_for_bit(monkeypatch, changes, omega):
    """The FMU's step (integrate_with_history) with a full history, after the outputs' read at its state and input
    motion, takes N_n from their evaluation (1 evaluation of the equations, the predicted state's, where a step
    evaluated afresh takes 2) and is that step bit for bit, under a tau_load set in between; with omega_in set again
    after the read, nothing is served."""
    p, fresh = _driveline(**changes), _driveline(**changes)
    u, h = dc.Drive(0.37, omega, 150.0, 3.0), 1e-3
    y, history = (dc.rigid_output_angle(p, u.phi), omega, 0.0, 0.0), dc.NO_HISTORY
    for k in range(dc.HISTORY_POINTS):   # the input moving on as the steps extrapolate it
        y, history = dc.integrate_with_history(p, k * h, h, y, u, history)
        u = u._replace(phi=u.phi + h * (u.omega + 0.5 * u.alpha * h), omega=u.omega + u.alpha * h)
    t, calls = dc.HISTORY_POINTS * h, _counted(monkeypatch)
    for tau_load in (3.0, 3.05):   # a load FMU's drift, below INPUT_JUMP
        step = u._replace(tau_load=tau_load)
        dc.outputs(p, t, y, u)
        served, n_served = _evaluations(calls, dc.integrate_with_history, p, t, 1e-3, y, step, history)
        fresh.outputs_memo = None
        evaluated, n_evaluated = _evaluations(calls, dc.integrate_with_history, fresh, t, 1e-3, y, step, history)
        assert served == evaluated and (n_served, n_evaluated) == (1, 2)
    dc.outputs(p, t, y, u)
    other = u._replace(omega=u.omega + 0.01)
    (served, _), n_served = _evaluations(calls, dc.integrate_with_history, p, t, 1e-3, y, other, history)
    fresh.outputs_memo = None
    assert n_served == 2 and served == dc.integrate_with_history(fresh, t, 1e-3, y, other, history)[0]


def test_the_outputs_evaluation_serves_only_its_own_state_object_and_input_motion():
    """A pure cache: another state (an equal copy too: a restored FMU state), input angle or speed, or a zero angle
    or speed (-0.0 and 0.0 are equal, not the same bits) evaluates again (None; the outputs too); a changed tau_load
    or alpha is served, corrected."""
    p = _driveline(**RIGS[1])
    y, u = dc.State(0.21, 69.0, 2e-4, -3e-3), dc.Drive(0.37, 70.0, 150.0, 2.0)
    dc.outputs(p, 0.0, y, u)
    assert dc._first_stage(p, y, u) is not None
    for other_y, other_u in ((dc.State(*y), u), (y, u._replace(phi=0.38)), (y, u._replace(omega=70.5))):
        assert other_y == y and other_y is not y or other_u != u
        assert dc._first_stage(p, other_y, other_u) is None
    for other_u in (u._replace(tau_load=-4.0), u._replace(alpha=-30.0)):
        assert dc._first_stage(p, y, other_u) == dc.flexible_derivatives(p, u.phi, u.omega, y, other_u.tau_load)
    dc.outputs(p, 0.0, y, u._replace(phi=-0.0))    # a zero: evaluated again, never served
    assert dc._first_stage(p, y, u._replace(phi=-0.0)) is None
    assert dc._first_stage(p, y, u._replace(phi=0.0)) is None
    fresh = _driveline(**RIGS[1])
    for other_u in (u._replace(phi=0.38), u._replace(omega=70.5), u._replace(omega=-0.0)):
        dc.outputs(p, 0.0, y, u)
        fresh.outputs_memo = None                      # the outputs at another input motion: evaluated again
        assert dc.outputs(p, 0.0, y, other_u) == dc.outputs(fresh, 0.0, y, other_u)
        assert p.outputs_memo[1:3] == (other_u.phi, other_u.omega)
    zero = u._replace(omega=0.0)
    dc.outputs(p, 0.0, y, zero)
    assert p.outputs_memo[2] is zero.omega            # 0.0 after -0.0: evaluated again (equal, not the same)
    other = _driveline(**RIGS[1])                      # per parameters object (per FMU instance)
    assert other.outputs_memo is None and dc._first_stage(other, y, u) is None and other == p


@pytest.mark.parametrize("changes", RIGS)
def test_the_torque_driven_reads_and_step_share_one_evaluation(monkeypatch, changes):
    """The torque-driven FMU's host reads omega_in, sets tau_in, reads alpha_in, sets tau_load and steps, all at
    one state object: the second read and the step's first stage (``derivatives``) come from the first read's
    evaluation, bit for bit what they are evaluated from scratch (both torques enter linearly), 6 evaluations where
    there were 8; another state object evaluates again."""
    calls = _counted(monkeypatch)
    p, fresh = _driveline(**changes), _driveline(**changes)
    y = (0.37, 70.0, 0.21, 69.0, 2e-4, -3e-3)
    _, n_first = _evaluations(calls, dc.TorqueDriven.outputs, p, 0.0, y, dc.Torques(1.0, 0.0))
    u = dc.Torques(30.0, 4.0)
    second, n_second = _evaluations(calls, dc.TorqueDriven.outputs, p, 0.0, y, u)
    assert (n_first, n_second) == (1, 0)
    assert second == dc.TorqueDriven.outputs(fresh, 0.0, y, u)
    k1, n_k1 = _evaluations(calls, dc.TorqueDriven.derivatives, p, 0.0, y, u)
    assert n_k1 == 0 and k1 == dc.torque_driven_rates(fresh, fresh.J_drive, y, u.tau_in, u.tau_load)
    served, n_served = _evaluations(calls, dc.TorqueDriven.integrate, p, 0.0, 1e-3, y, u)
    fresh.outputs_memo = None
    evaluated, n_evaluated = _evaluations(calls, dc.TorqueDriven.integrate, fresh, 0.0, 1e-3, y, u)
    assert served == evaluated and n_served == n_evaluated - 1 == 5
    copy = tuple(list(y))
    assert copy is not y
    assert _evaluations(calls, dc.TorqueDriven.derivatives, p, 0.0, copy, u) == (k1, 1)


# --- the FMU's integrator: the exponential Adams method --------------------------------------------------------

INERTIAS = dict(I_input=1e-3, I_cross_pin=2e-4, I_cross_normal=3e-4, I_intermediate=1e-3)
#: a W layout with the yokes 0.4 rad apart and the joints' planes 0.2 rad apart: every kinematic term at work
W_LAYOUT = dict(beta1=math.radians(15.0), beta2=math.radians(-20.0), yoke_phase=0.4, joint_plane_angle=0.2)


def _speed_driven(**changes):
    return dc.Parameters(**{**STRAIGHT, **changes})
#: scale of each state's error: phi4 [rad], omega4 [rad/s], phi [rad], dphi [rad/s]
SCALE = (1e-3, 1.0, 1e-4, 1e-2)


def _fine(p, h, phi, w, alpha, y, tau):
    """Oracle: 16 Dormand-Prince steps per step (dc.dormand_prince's formula, tested fifth order on its own)."""
    return dc._dp5_drive_4(dc._flexible_rates, p, y, h, 16, phi, w, alpha, tau)


def _one_dormand_prince_step(p, h, phi, w, alpha, y, tau):
    """What the FMU took before the exponential Adams method at these speeds: one Dormand-Prince step."""
    return dc._dp5_drive_4(dc._flexible_rates, p, y, h, 1, phi, w, alpha, tau)


class Multistep:
    """dc.multistep_step as a one-step stepper: its history and time carried from call to call."""

    def __init__(self):
        self.history, self.t = dc.NO_HISTORY, 0.0

    def __call__(self, p, h, phi, w, alpha, y, tau):
        y, self.history = dc.multistep_step(p, self.t, h, phi, w, alpha, y, tau, self.history)
        self.t += h
        return y


def _run_against_fine(against_fine, p, h, duration, inputs, stepper):
    """Max scaled error after duration of ``stepper`` against the fine oracle, both untwisted at 60 rad/s, under
    inputs(t) = (alpha, tau_load) held over each step (the ``against_fine`` fixture)."""
    y0 = (dc.rigid_output_angle(p, 0.1), 60.0, 0.0, 0.0)
    return against_fine(stepper, _fine, p, y0, 0.1, 60.0, h, duration, inputs, SCALE)


@pytest.mark.parametrize("inertias", [{}, INERTIAS], ids=["omar", "inertias"])
def test_multistep_integrator_order_and_accuracy(inertias, against_fine):
    """Observed order of ``multistep_step`` (exponential Adams PECE, six points of N, in twist coordinates) on a
    misaligned W-layout driveline (yokes 0.4 rad apart, planes 0.2 rad) speeding up at 300 rad/s^2 under 5 N.m, from
    its start (five Dormand-Prince steps, then the Adams method): the error falls 2^7 per halving of the step
    (measured 6.9-7.0 between 1 ms and 0.25 ms, one substep per step at each), and at 1 ms it is within 4x of one
    Dormand-Prince step a step, the fifth-order method it replaced in the FMU (measured 0.4x on Omar's massless
    crosses, 2.9x with cross and shaft inertias, whose J_out varies twice a turn). A wrong weight or operator (the
    corrector left out, an extrapolation weight off) leaves order 6 or less."""
    p = _speed_driven(**W_LAYOUT, **inertias)
    assert all(dc.adams_substeps(p, h, 90.0) == 1 for h in (1e-3, 5e-4, 2.5e-4))
    inputs = lambda t: (300.0, 5.0)   # noqa: E731
    errors = [_run_against_fine(against_fine, p, h, 0.1, inputs, Multistep()) for h in (1e-3, 5e-4, 2.5e-4)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 6.4) & (orders < 7.6)), (errors, orders)
    assert errors[0] < 4.0 * _run_against_fine(against_fine, p, 1e-3, 0.1, inputs, _one_dormand_prince_step)


@pytest.mark.parametrize("jump", ["load", "acceleration"])
def test_multistep_integrator_restarts_at_an_input_step(jump, monkeypatch, against_fine):
    """A load step (5 -> 15 N.m, 2200 rad/s^2 on Omar's driven inertia) or a jump of the input acceleration
    (300 -> -300 rad/s^2) at 30 ms: the driven side's acceleration jumps, which no polynomial through the history
    follows, so the method restarts there (``INPUT_JUMP``) and stays as accurate as one Dormand-Prince step a step
    (within 1.5x; measured 0.8x and 0.36x). Extrapolating across the jump instead (the restart disabled) is over 10x
    worse. A slow drift of the load, as a load FMU's, is recombined exactly."""
    p = _speed_driven(**W_LAYOUT)
    after = (300.0, 15.0) if jump == "load" else (-300.0, 5.0)
    inputs = lambda t: (300.0, 5.0 + 0.01 * t) if t < 0.03 - 1e-9 else after   # noqa: E731
    restarted = _run_against_fine(against_fine, p, 1e-3, 0.06, inputs, Multistep())
    assert restarted < 1.5 * _run_against_fine(against_fine, p, 1e-3, 0.06, inputs, _one_dormand_prince_step)
    monkeypatch.setattr(dc, "INPUT_JUMP", math.inf)
    assert _run_against_fine(against_fine, p, 1e-3, 0.06, inputs, Multistep()) > 10.0 * restarted


def test_multistep_restarts_without_a_usable_history():
    """Without a history, with one of another step length or one that does not end at the step's start time, a
    step is exactly one Dormand-Prince step (bitwise) and leaves a history of its start point; after five such steps
    the next one is the Adams method's and differs."""
    p = _speed_driven(beta1=math.radians(15.0), beta2=math.radians(15.0))
    y0 = (0.0, 70.0, 0.0, 0.0)
    y1, history = dc.multistep_step(p, 0.0, 1e-3, 0.0, 70.0, 0.0, y0, 5.0, dc.NO_HISTORY)
    assert y1 == _one_dormand_prince_step(p, 1e-3, 0.0, 70.0, 0.0, y0, 5.0) and history[2] == 1.0
    for t, h in ((1e-3, 5e-4), (0.5, 1e-3)):   # another step length; a history not ending at t
        y, fresh = dc.multistep_step(p, t, h, 0.07, 70.0, 0.0, y1, 5.0, history)
        assert y == _one_dormand_prince_step(p, h, 0.07, 70.0, 0.0, y1, 5.0) and fresh[2] == 1.0
    y, history = y0, dc.NO_HISTORY
    for k in range(dc.HISTORY_POINTS):
        previous = y
        y, history = dc.multistep_step(p, k * 1e-3, 1e-3, 0.07 * k, 70.0, 0.0, y, 5.0, history)
    assert history[2] == dc.HISTORY_POINTS
    assert y != _one_dormand_prince_step(p, 1e-3, 0.07 * (dc.HISTORY_POINTS - 1), 70.0, 0.0, previous, 5.0)


def test_multistep_integrator_is_exact_on_the_linear_part():
    """Straight joints, massless crosses, the input at a constant speed under a constant load: the twist is
    exactly phi1 - phi4 and N is the load's constant -tau_load / J_load, so from a history of that N the method
    is exact: it follows the closed form to rounding over 100 steps (a wrong E or Psi, or a history point misplaced,
    would not)."""
    p = dc.Parameters(**STRAIGHT)
    h = 1e-3
    history = ((h, 0.0, float(dc.HISTORY_POINTS), LOAD, 0.0, SPEED) + (0.0,) * (2 * dc.HISTORY_POINTS)
               + (1.0 / p.J_load,) * dc.HISTORY_POINTS)
    y, worst = closed_form(p, 0.0), 0.0
    for k in range(100):
        y, history = dc.multistep_step(p, k * h, h, SPEED * k * h, SPEED, 0.0, y, LOAD, history)
        exact = closed_form(p, (k + 1) * h)
        worst = max(worst, abs(y[0] - exact[0]), 1e-3 * abs(y[1] - exact[1]))
    assert history[2] == dc.HISTORY_POINTS   # no restart along the way
    assert worst < 1e-12 and y[2:] == (0.0, 0.0)
    assert abs(closed_form(p, 0.1)[0] - SPEED * 0.1 + LOAD / p.k_theta) > 1e-4   # the twist still oscillates


@pytest.mark.parametrize("k_theta", [1e4, 1e5])
def test_a_stiff_shaft_is_taken_exactly_with_few_substeps(k_theta, against_fine):
    """A stiff intermediate shaft (Omar's Z layout, k_theta 100x and 1000x his): the method takes the shaft's
    oscillator exactly at any h (scaling and squaring where its series would not converge), so only the joints'
    modulation sets its substeps (3 and 10 a 1 ms step, 2 evaluations each, where the Dormand-Prince rule takes 5
    and 48 steps of 6), and over 50 ms of a run-up under load it is more accurate than that rule's steps (measured
    0.35x and 0.30x; the oracle: Dormand-Prince steps at 8x the RK4 rule's count)."""
    p = _speed_driven(beta1=math.radians(15.0), beta2=math.radians(15.0), k_theta=k_theta)
    y0, w_max = (dc.rigid_output_angle(p, 0.1), 60.0, 0.0, 0.0), 70.0
    dense = rk4.substeps(0.5 * (p.mode_rate + 4.0 * w_max), 1e-3) * 8

    def fine(p, h, phi, w, alpha, y, tau):
        return dc._dp5_drive_4(dc._flexible_rates, p, y, h, dense, phi, w, alpha, tau)

    def rule(p, h, phi, w, alpha, y, tau):
        return dc.flexible_step(p, h, phi, w, alpha, y, tau, rk4.substeps(dc.rate_bound(p, y, w_max), h))
    rk4_rule = rk4.substeps(dc.rate_bound(p, y0, w_max), 1e-3)
    assert 2 * 2 * dc.adams_substeps(p, 1e-3, w_max) <= 6 * dc.fifth_order_steps(p, 1e-3, w_max, rk4_rule)
    inputs = lambda t: (100.0, 5.0)   # noqa: E731
    scale = (1e-6, 1e-3, 1e-7, 1e-5)
    adams = against_fine(Multistep(), fine, p, y0, 0.1, 60.0, 1e-3, 0.05, inputs, scale)
    assert adams < 0.7 * against_fine(rule, fine, p, y0, 0.1, 60.0, 1e-3, 0.05, inputs, scale)


def test_the_phi_functions_by_scaling_and_squaring_are_expm_s():
    """``series.phi_functions`` (a stiff block's phi_0 ... phi_7 from the exponential of the augmented matrix, by
    scaling and squaring) against scipy's expm of the same augmented matrix, on the stiff shaft's torsional
    block at h |lambda| up to 1e3 (within 1e-9 of each function's largest entry), and against the Taylor series
    (``series.phi_sum``) where that converges (within 1e-14); the model's operators (``_phi_block``, which takes
    one or the other) within 1e-9 too."""
    from scipy.linalg import expm
    for k, c, h in ((20489.0, 41.0, 1e-3), (2.2e7, 4.4e4, 1e-3), (2.2e9, 4.4e6, 1e-4), (2.2e9, 4.4e6, 1.5e-6)):
        a = ((0.0, 1.0), (-k, -c))
        w = np.zeros((16, 16))
        w[:2, :2] = h * np.array(a)
        for j in range(7):
            w[2 * j:2 * j + 2, 2 * j + 2:2 * j + 4] = np.eye(2)
        exact = expm(w)[:2]
        for j, phi in enumerate(series.phi_functions(a, h, 7)):
            block = exact[:, 2 * j:2 * j + 2]
            assert np.max(np.abs(np.array(phi) - block)) < 1e-9 * np.max(np.abs(block)), (k, h, j)
            ours = dc._phi_block(a, h, (0.0,) * j + (1.0,))   # the model's choice of the two
            assert np.max(np.abs(np.array(ours) - block)) < 1e-9 * np.max(np.abs(block)), (k, h, j)
            if h * (math.sqrt(k) + c) <= 1.0:
                ours = series.phi_sum(a, h, (0.0,) * j + (1.0,))
                assert np.max(np.abs(np.array(ours) - block)) < 1e-14 * np.max(np.abs(block)), (k, h, j)


def test_extrapolation_weights_are_the_lagrange_ones():
    """The corrector's extrapolation written out in multistep_step, p(1) = 6 N_0 - 15 N_-1 + 20 N_-2 - 15 N_-3 +
    6 N_-4 - N_-5, is the quintic through the six points at theta = 1 (``series.lagrange_coefficients``, the twin
    rotor's weights: the sixth difference vanishing); a wrong weight in the code itself turns the order test red."""
    nodes = [-float(j) for j in range(dc.HISTORY_POINTS)]
    weights = [sum(c) for c in series.lagrange_coefficients(nodes)]
    assert weights == pytest.approx((6.0, -15.0, 20.0, -15.0, 6.0, -1.0), rel=1e-12)


@pytest.mark.parametrize("k_phi", [1e9, 1e10])
def test_an_undamped_stiff_support_is_resolved_not_grown(k_phi, against_fine):
    """An undamped support 1e9 N/m stiff (a trial's way to leave the lateral motion out): its mode, 15600 rad/s on
    Omar's 4.09 kg, is exact in L, but N reads the tilt, so N rang at that frequency and 1 ms steps of the Adams
    method grew it until the joint angle left its range (18 rad). The substeps now resolve an underdamped mode of L
    (``ringing_rate``), and the run follows 16 Dormand-Prince steps a step; an overdamped one (Omar's xi_phi at this
    stiffness) sets none."""
    p = _speed_driven(**W_LAYOUT, k_phi=k_phi, xi_phi=0.0)
    assert p.ringing_rate == pytest.approx(math.sqrt(k_phi / 4.09))
    assert dc.adams_substeps(p, 1e-3, 90.0) >= p.ringing_rate * 1e-3 / 0.5
    assert _speed_driven(**W_LAYOUT, k_phi=k_phi).ringing_rate < p.ringing_rate   # damped: its torsion only
    def finer(p, h, phi, w, alpha, y, tau):   # the oracle's substeps resolving the mode too: h w <= 0.4
        return dc._dp5_drive_4(dc._flexible_rates, p, y, h, math.ceil(p.ringing_rate * h / 0.4), phi, w, alpha, tau)
    y0 = (dc.rigid_output_angle(p, 0.1), 60.0, 0.0, 0.0)
    error = against_fine(Multistep(), finer, p, y0, 0.1, 60.0, 1e-3, 0.05, lambda t: (300.0, 5.0), SCALE)
    assert error < 1e-3, error
