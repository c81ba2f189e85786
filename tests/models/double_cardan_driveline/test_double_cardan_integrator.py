"""The flexible driveline's integrator (model.flexible_step, model.torque_driven_step): Dormand and Prince's
fifth-order formula is fifth order on a closed-form solution, replaces the RK4 substeps only where it needs fewer
evaluations, is then at least as accurate, its stability covers the step the rule gives it, the rule's bound of
|lambda| (model.mode_rate_bound) bounds the linearised equations' eigenvalues, and the unrolled integrators the FMUs
run are the readable formula's numbers and what the generator writes."""

import cmath
import math
from pathlib import Path

import pytest

from ujfmu.fmu import rk4
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
])
def test_mode_rate_bounds_the_linearised_equations_eigenvalues(changes):
    """max |lambda| of the torque-driven equations' Jacobian (central differences, at rest, untwisted, at 12 input
    angles) stays below mode_rate, which is at most natural_rate; a bound that dropped the damping's branch or the
    free input shaft's side of the torsional mode would fail one of these."""
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
