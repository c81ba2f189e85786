"""The flexible driveline's integrator (model.integrate_substeps): Dormand and Prince's fifth-order formula is fifth order on
a closed-form solution, replaces the RK4 substeps only where it needs fewer evaluations, is then at least as
accurate, and its stability covers the step the rule gives it."""

import cmath
import math

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


@pytest.mark.parametrize("substeps, steps", [(1, 0), (2, 1), (3, 0), (4, 2), (5, 3), (8, 4), (29, 15)])
def test_fifth_order_steps_only_where_they_take_fewer_evaluations(substeps, steps):
    """Each fifth-order step spans two RK4 substeps (6 evaluations against 8); 0: RK4 is as cheap or cheaper."""
    assert dc.fifth_order_steps(substeps) == steps
    if steps:
        assert 6 * steps < 4 * substeps


@pytest.mark.parametrize("substeps", [2, 4])
def test_the_fifth_order_steps_are_at_least_as_accurate_as_the_rk4_substeps_they_replace(substeps):
    """At the substep rule's limit (the torsional mode's |lambda| x substep = RATE_STEP), model.integrate_substeps (the
    fifth-order formula, one step per two substeps) errs less than the RK4 substeps over 15 such intervals."""
    p = dc.Parameters(**STRAIGHT)
    interval = substeps * rk4.RATE_STEP / math.sqrt(p.k_theta / p.J_load)
    assert rk4.substeps(math.sqrt(p.k_theta / p.J_load), interval) == substeps
    ours = error(p, interval, 15, lambda f, y, t: dc.integrate_substeps(f, y, t, substeps))
    classical = error(p, interval, 15, lambda f, y, t: rk4.integrate_time(f, y, t, substeps))
    assert ours < 0.8 * classical


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
