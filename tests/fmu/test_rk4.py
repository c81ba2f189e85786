"""The FMUs' integrator (ujfmu.fmu.rk4): classical RK4 is fourth order on a model with a closed-form solution, driven
through the model protocol as the FMU base drives it, and its stability limits are those the substep rule
(``rk4.fastest_rate``, ``rk4.RATE_STEP``) relies on."""

import math
from pathlib import Path

import pytest

from ujfmu.fmu import rk4, rk4_unrolled
from ujfmu.models.double_cardan_driveline import model as dc
from ujfmu.models.protocol import Drive

#: Omar's driveline with both joints straight (r = 1, dy/db = 0, J_out = J_load): the twist x = phi1 - phi4 obeys
#: J x'' + c_theta x' + k_theta x = J alpha1 + tau_load under an input angle phi1 = w0 t + alpha1 t^2 / 2, and the
#: lateral misalignment m_s phi'' + c_phi phi' + k_phi phi = 0 stays at rest: a damped oscillator at 143 rad/s
STRAIGHT = dict(beta1=0.0, beta2=0.0, yoke_phase=0.0, joint_plane_angle=0.0, I_input=0.0, I_cross_pin=0.0,
                I_cross_normal=0.0, I_intermediate=0.0, J_load=0.0045, k_theta=92.2, xi_theta=0.002, m_s=4.09,
                k_phi=26331.0, xi_phi=0.002, L_c=0.325)
W0, ALPHA, TAU = 70.0, 40.0, 3.0
X0, V0 = 0.01, -0.5   # the lateral phi starts and stays 0 (it would enter the joint angles)


def oscillator(m, c, k, force, x0, v0, t):
    """(x, x') of m x'' + c x' + k x = force (constant), x(0) = x0, x'(0) = v0, underdamped: closed form."""
    sigma = c / (2.0 * m)
    wd = math.sqrt(k / m - sigma * sigma)
    a = x0 - force / k
    b = (v0 + sigma * a) / wd
    decay, cos, sin = math.exp(-sigma * t), math.cos(wd * t), math.sin(wd * t)
    return (force / k + decay * (a * cos + b * sin),
            decay * ((b * wd - sigma * a) * cos - (a * wd + sigma * b) * sin))


def exact_state(p, t):
    """(phi4, w4, phi, dphi) at t from the closed forms (phi1(0) = 0)."""
    x, dx = oscillator(p.J_load, p.c_theta, p.k_theta, p.J_load * ALPHA + TAU, X0, V0, t)
    return (W0 * t + 0.5 * ALPHA * t * t - x, W0 + ALPHA * t - dx, 0.0, 0.0)


def _readable(p, y, duration, n):
    """rk4.integrate_time of the protocol's derivatives, the input extrapolated over the step as the FMU base
    does (angle quadratic, speed linear in time, tau_load held)."""
    def rates(s, y):
        return dc.derivatives(p, s, y, Drive(s * (W0 + 0.5 * ALPHA * s), W0 + ALPHA * s, ALPHA, TAU))
    return rk4.integrate_time(rates, y, duration, n)


def _unrolled(p, y, duration, n):
    """What the FMU runs: rk4.integrate_drive of the protocol's drive_derivatives."""
    return rk4.integrate_drive(dc.drive_derivatives, p, 0.0, y, duration, n, 0.0, W0, ALPHA, TAU)


def rk4_error(p, duration, n, integrate=_readable):
    """Largest state error at the end of n RK4 substeps."""
    y = integrate(p, exact_state(p, 0.0), duration, n)
    return max(abs(a - b) for a, b in zip(y, exact_state(p, duration)))


@pytest.mark.parametrize("integrate", [_readable, _unrolled])
def test_classical_rk4_is_fourth_order_on_a_closed_form_solution(integrate):
    """Halving the substep divides the error by 2^4: observed order 4 (a wrong stage weight or stage time
    would show order 1-3), in the readable statement of the scheme and in the unrolled one the FMUs run."""
    p = dc.Parameters(**STRAIGHT)
    errors = [rk4_error(p, 0.1, n, integrate) for n in (80, 160, 320)]   # 143 rad/s x h = 0.18, 0.09, 0.045
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert errors[-1] < 1e-6
    assert orders == pytest.approx([4.0, 4.0], abs=0.2)


def _amplification(z):
    """|y(h) / y(0)| of one RK4 step of y' = lambda y with h lambda = z, through rk4.integrate_time (as a real
    2-vector)."""
    def rates(t, y):
        return (z.real * y[0] - z.imag * y[1], z.imag * y[0] + z.real * y[1])
    y = rk4.integrate_time(rates, (1.0, 0.0), 1.0, 1)
    return math.hypot(*y)


def test_stability_interval_is_2_83_on_the_imaginary_axis_and_2_78_on_the_real_one():
    """|R(z)| <= 1 up to h |lambda| = 2 sqrt(2) for oscillation and 2.785 for decay: RATE_STEP keeps 5.6x from both."""
    assert _amplification(2.82j) < 1.0 < _amplification(2.84j)
    assert _amplification(-2.78 + 0j) < 1.0 < _amplification(-2.80 + 0j)
    assert 2.78 / rk4.RATE_STEP > 5.5


def test_fastest_rate_resolves_the_larger_of_the_natural_and_forcing_rates():
    assert rk4.fastest_rate(225.0, 286.5) == 286.5 and rk4.fastest_rate(1741.0, 240.0) == 1741.0
    assert rk4.substeps(rk4.fastest_rate(225.0, 286.5), 1e-3) == 1


def _nonlinear(p, t, y, u):
    """A right-hand side of every state entry, the time and every input, nonlinear and coupling the entries (each
    of the integrator's stage terms enters the result)."""
    c, tau = p
    total = sum(y)
    return tuple(math.sin(c * (i + 1) * t + x) * u[0] - 0.3 * total * x + tau * u[i % len(u)] for i, x in enumerate(y))


def test_the_committed_unrolled_integrators_are_what_the_generator_writes():
    """ujfmu/fmu/rk4_unrolled.py is generated (``python -m ujfmu.fmu.rk4``): edited by hand or stale, it fails."""
    assert Path(rk4_unrolled.__file__).read_text() == rk4.unrolled_source()


@pytest.mark.parametrize("size", [0, 1, 2, 3, 4, 5, 6, 14, 16])
def test_the_unrolled_integrators_compute_the_readable_schemes_numbers_bit_for_bit(size):
    """integrate_held and integrate_drive (what the FMUs run) give exactly integrate_time's numbers: the same
    operations in the same order, for held inputs and for the extrapolated input shaft, at every state size the
    models have (rk4.SIZES, unrolled) and at others (looped; a swapped stage, weight or stage time would differ in
    the last bits at least)."""
    y0 = tuple(0.1 * (i + 1) - 0.4 for i in range(size))
    p, t0, u, span = (3.0, 0.7), 2.5, (1.3, -0.4, 0.9), 0.01
    for n in (1, 3):
        expected = rk4.integrate_time(lambda s, y: _nonlinear(p, t0 + s, y, u), y0, span, n)
        assert rk4.integrate_held(_nonlinear, p, t0, u, y0, span, n) == tuple(expected)

        def drive(p, t, y, phi, omega, alpha, tau_load):
            return _nonlinear(p, t, y, (phi, omega, alpha, tau_load))
        phi0, w0, alpha, tau = 0.2, 31.0, -12.0, 4.0
        expected = rk4.integrate_time(lambda s, y: drive(p, t0 + s, y, phi0 + s * (w0 + 0.5 * alpha * s),
                                                         w0 + alpha * s, alpha, tau), y0, span, n)
        assert rk4.integrate_drive(drive, p, t0, y0, span, n, phi0, w0, alpha, tau) == tuple(expected)


def test_every_model_state_size_has_its_unrolled_integrators():
    from ujfmu.build import FMUS, fmu_class
    from ujfmu.fmu.base import ModelSlave
    sizes = {len(fmu_class(name).MODEL.State._fields) for name in FMUS if issubclass(fmu_class(name), ModelSlave)}
    assert sizes - {0} <= set(rk4.SIZES)
    assert rk4.unrolled("drive", 14) is rk4_unrolled.drive_14


def test_given_first_stage_rates_are_used_as_they_are():
    """integrate_held with k1 (the rates at the start, which the torque-driven FMUs have from their speed bound)
    gives the same numbers as evaluating them, and the given ones enter the result (a k1 off by a tenth moves it)."""
    p, t0, u, y0 = (3.0, 0.7), 2.5, (1.3, -0.4, 0.9), (0.2, -0.1, 0.4, 0.3)
    k1 = _nonlinear(p, t0, y0, u)
    assert rk4.integrate_held(_nonlinear, p, t0, u, y0, 0.01, 3, k1) == rk4.integrate_held(_nonlinear, p, t0, u, y0,
                                                                                          0.01, 3)
    assert rk4.integrate_held(_nonlinear, p, t0, u, y0, 0.01, 3, tuple(1.1 * k for k in k1)) != \
        rk4.integrate_held(_nonlinear, p, t0, u, y0, 0.01, 3)


def test_a_step_differing_by_the_rounding_of_the_hosts_times_keeps_the_substep():
    """``rk4.kept_substep``: the differences t_(k+1) - t_k of times t_k = k dt (up to t = 1000 s at dt = 1 ms) are
    all taken as the substep kept; a step 1e-8 longer, or half as long, is not (it is a new step length)."""
    dt = 1e-3
    for k in (1, 7, 12345, 999_998):
        a, b = k * dt, (k + 1) * dt
        assert rk4.kept_substep((b - a) / 4, dt / 4, a, 4) == dt / 4
    assert any((k + 1) * dt - k * dt != dt for k in range(1000))   # the differences do vary
    for t in (0.0, 1000.0):
        assert rk4.kept_substep(dt * (1 + 1e-8), dt, t, 1) == dt * (1 + 1e-8)
        assert rk4.kept_substep(dt / 2, dt, t, 1) == dt / 2
