"""ujfmu.models.motor.model: speed profiles, PI law, closed-loop tracking against closed forms."""

import math
import numpy as np

import pytest

from ujfmu.fmu import rk4
from ujfmu.models.motor import model as motor


def pi_step(p, t, h, y, tau_load):
    """One communication step of the PI motor as its FMU takes it: RK4 with the substeps of rate_bound."""
    u = motor.Inputs(tau_load)
    n = rk4.substeps(motor.rate_bound(p, y, 0.0), h)
    return tuple(rk4.integrate_time(lambda s, y: motor.derivatives(p, t + s, y, u), y, h, n))


def test_ramp_profile_and_its_integral():
    w, a, ang = motor.speed_reference(2.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0)
    assert (w, a, ang) == (60.0, 30.0, 60.0)
    w, a, ang = motor.speed_reference(7.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0)
    assert (w, a) == (150.0, 0.0) and ang == pytest.approx(0.5 * 30 * 25 + 150 * 2)


def test_ramp_is_at_rest_before_it_starts():
    """A run that starts before t = 0 finds the ramp at rest (it runs up from rest at t = 0), never backwards; the
    ramp's start is a corner as its end is: a time event for a Model Exchange host, and a step across it is split
    there, each piece exact (the exact PI step assumes one linear piece): the independent solve's numbers."""
    assert motor.speed_reference(-0.5, motor.RAMP, 150.0, 30.0, 0.0, 0.0) == (0.0, 0.0, 0.0)
    assert motor.speed_reference(0.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0) == (0.0, 30.0, 0.0)   # the ramp's piece
    p = motor.Parameters(0.2, 10.0, 5.0, motor.RAMP, 3.0, 30.0, 0.0, 0.0, J_rotor=1e-3)
    assert [motor.Controller.next_time_event(p, t) for t in (-1.0, 0.0, 0.05, 0.1)] == [0.0, 0.1, 0.1, None]
    y, u = (0.0, 0.0, 0.0), motor.Inputs(0.0)
    assert motor.integrate(p, -2e-3, 1e-3, y, u) == y                   # at rest before the ramp
    across = motor.integrate(p, -5e-4, 1e-3, y, u)
    assert across[1] > 0.0
    np.testing.assert_allclose(across, fine_solve(p, -5e-4, y, 5e-4, 0.0), rtol=1e-9, atol=1e-13)


def test_step_and_constant_profiles():
    assert motor.speed_reference(0.5, motor.STEP, 10.0, 1.0, 1.0, 2.0) == (2.0, 0.0, 1.0)
    assert motor.speed_reference(1.5, motor.STEP, 10.0, 1.0, 1.0, 2.0) == (10.0, 0.0, 2.0 + 5.0)
    assert motor.speed_reference(3.0, motor.CONSTANT, 10.0, 1.0, 1.0, 2.0) == (10.0, 0.0, 30.0)


def test_pi_saturation_and_anti_windup():
    assert motor.pi_torque(1.0, 0.0, 2.0, 1.0, 5.0) == (2.0, 1.0)
    assert motor.pi_torque(10.0, 0.0, 2.0, 1.0, 5.0) == (5.0, 0.0)     # saturated: integration stops
    assert motor.pi_torque(-1.0, 10.0, 2.0, 1.0, 5.0) == (5.0, -1.0)   # saturated, error unwinds: integrate
    assert motor.pi_torque(-10.0, 0.0, 2.0, 1.0, 5.0) == (-5.0, 0.0)


def test_closed_loop_tracks_ramp_with_load_exactly_in_steady_state():
    """PI + inertia is type 2 for the speed loop: a ramp and a constant load leave no steady speed error."""
    p = motor.Parameters(0.2, 10.0, 50.0, motor.RAMP, 1e9, 30.0, 0.0, 0.0, J_rotor=1e-3)
    state, t, h = (0.0, 0.0, 0.0), 0.0, 1e-3
    lags = []
    for k in range(1000):
        state = pi_step(p, t, h, state, 0.25)
        t += h
        if k in (499, 999):
            lags.append(0.5 * 30.0 * t * t - state[0])
    assert state[1] == pytest.approx(30.0 * t, abs=1e-6)
    assert lags[1] == pytest.approx(lags[0], abs=1e-6)   # the start-up transient's angle lag stays constant


def test_closed_loop_step_response_matches_linear_closed_form():
    """Critically damped loop (omega_n = 100 rad/s): omega(t) = w_set (1 - (1 + wn t - 2 zeta wn t ...))."""
    J, wn = 1e-3, 100.0
    kp, ki = 2 * wn * J, wn * wn * J     # zeta = 1
    p = motor.Parameters(kp, ki, 1e9, motor.CONSTANT, 1.0, 1.0, 0.0, 0.0, J_rotor=J)
    state, t = (0.0, 0.0, 0.0), 0.0
    for _ in range(30):
        state = pi_step(p, t, 1e-3, state, 0.0)
        t += 1e-3
    # closed loop W/Wref = (kp s + ki)/(J s^2 + kp s + ki) = (2 wn s + wn^2)/(s + wn)^2; unit step response:
    exact = 1 - math.exp(-wn * t) * (1 - wn * t)
    assert state[1] == pytest.approx(exact, abs=1e-7)  # RK4 at |lambda| h_sub <= 0.2


# --- the PI motor's own step (model.integrate): exact while linear, RK4 where the limit or a corner acts ----------

def rk4_step(p, t, h, y, tau_load):
    """The classical RK4 substeps of rate_bound (the FMU's default step, and integrate's fallback)."""
    u = motor.Inputs(tau_load)
    return rk4.unrolled("held", 3)(motor.derivatives, p, t, u, y, h, rk4.substeps(motor.rate_bound(p, y, 0.0), h))


def fine_solve(p, t0, y0, t1, tau_load):
    """An independent solve of the loop (scipy DOP853 at rtol 1e-13) of model.derivatives."""
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp
    sol = solve_ivp(lambda t, y: motor.derivatives(p, t, y, motor.Inputs(tau_load)), (t0, t1), list(y0),
                    method="DOP853", rtol=1e-13, atol=1e-15)
    return sol.y[:, -1]


@pytest.mark.parametrize("h", [1e-3, 1e-2])
def test_exact_step_matches_the_closed_form_step_response(h):
    """Critically damped loop (omega_n = 100 rad/s), unit speed step: omega(t) = 1 - exp(-wn t) (1 - wn t) to
    round-off at any step (RK4 at this step is 1e-7 off, see above), and the angle is its integral."""
    J, wn = 1e-3, 100.0
    p = motor.Parameters(2 * wn * J, wn * wn * J, 1e9, motor.CONSTANT, 1.0, 1.0, 0.0, 0.0, J_rotor=J)
    y, t = (0.0, 0.0, 0.0), 0.0
    for _ in range(round(0.03 / h)):
        y = motor.integrate(p, t, h, y, motor.Inputs(0.0))
        t += h
    assert y[1] == pytest.approx(1 - math.exp(-wn * t) * (1 - wn * t), abs=1e-14)
    phi = t * (1 - math.exp(-wn * t))      # the integral of omega from 0
    assert y[0] == pytest.approx(phi, abs=1e-15)


def test_exact_step_follows_a_ramp_with_load_to_round_off():
    """Ramp reference (alpha = 30 rad/s^2) and a held load, from 2 rad/s off the reference, unsaturated: 20
    exact steps agree with a fine independent solve to round-off, while RK4 at the same steps is off by far more."""
    p = motor.Parameters(0.2, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0, J_rotor=1e-3)
    y = z = y0 = (0.0, 2.0, 0.01)
    for k in range(20):
        y = motor.integrate(p, k * 1e-3, 1e-3, y, motor.Inputs(0.25))
        z = rk4_step(p, k * 1e-3, 1e-3, z, 0.25)
    ref = fine_solve(p, 0.0, y0, 0.02, 0.25)
    assert max(abs(a - b) for a, b in zip(y, ref)) < 1e-13
    assert max(abs(a - b) for a, b in zip(z, ref)) > 1e3 * max(abs(a - b) for a, b in zip(y, ref))


@pytest.mark.parametrize("j, kp, ki", [(1e-3, 0.2, 10.0), (1e-3, 0.02, 10.0), (0.05, 8.0, 160.0), (0.22, 8.8, 88.0)])
def test_exact_step_propagator_at_any_step_length(j, kp, ki):
    """pi_propagator's rows against scipy's expm of the augmented matrix M h (Van Loan) at the step lengths of a host
    that varies its step (each h new; powers of 2 apart and within one), each row to 1e-13 of its size: the kept
    powers, the balancing and the squarings reproduce exp(M h) at every h."""
    np = pytest.importorskip("numpy")
    expm = pytest.importorskip("scipy.linalg").expm
    p = motor.Parameters(kp, ki, 1e9, motor.CONSTANT, 1.0, 1.0, 0.0, 0.0, J_rotor=j)
    rng = np.random.default_rng(1)
    for h in [*(1e-3 * (0.9 + 0.2 * rng.random(6))), 1e-3, 2.5e-4, 1e-5, 3.7e-2, 0.37]:
        m = np.zeros((7, 7))
        m[0, 1], m[1, 1], m[1, 2], m[1, 3], m[2, 1], m[2, 4], m[3, 5], m[4, 6] = 1, -kp / j, ki / j, 1, -1, 1, 1, 1
        exact = expm(m * h)[:3]
        size = np.max(np.abs(exact), axis=1, keepdims=True)
        assert np.all(np.abs(np.array(motor.pi_propagator(p, float(h))) - exact) <= 1e-13 * size), h


BOUND_CASES = [  # (Kp, Ki, J, profile, omega_set, accel, tau_load, state, h): |torque| peaks inside the step
    (0.02, 10.0, 1e-3, motor.CONSTANT, 100.0, 1.0, 0.0, (0.0, 99.0, 0.0), 0.03),     # zeta = 0.1, half a period
    (0.02, 10.0, 1e-3, motor.CONSTANT, 100.0, 1.0, 0.0, (0.0, 101.0, 0.0), 0.03),    # the same, downwards
    (0.2, 10.0, 1e-3, motor.CONSTANT, 100.0, 1.0, 0.0, (0.0, 99.0, -0.02), 0.03),    # critically damped
    (5.0, 125.0, 0.05, motor.RAMP, 1e4, 15.0, 3.0, (0.0, -0.5, 0.01), 0.06),         # ramp and load, zeta = 1
    # a 1 N.m load at equilibrium (v = u - u* = 0), the error 2 (Kp/J) T / Ki: the load's share of u'
    (0.02, 10.0, 1e-3, motor.CONSTANT, 100.0, 1.0, 1.0, (0.0, 96.0, 0.092), 0.03),
    # the ramp's own share: following accel 15 at equilibrium, e = Kp a / Ki, I = (J a - Kp e) / Ki
    (0.02, 10.0, 1e-3, motor.RAMP, 1e4, 15.0, 0.0, (0.0, -0.03, 0.00144), 0.03),
]
@pytest.mark.parametrize("kp, ki, j, profile, omega_set, accel, tau_load, y0, h", BOUND_CASES)
def test_torque_bound_holds_the_torque_inside_the_step(kp, ki, j, profile, omega_set, accel, tau_load, y0, h):
    """pi_torque_bound is an upper bound of |Kp e + Ki I| all along a step of the linear loop (sampled at 400
    points by exact sub-steps); the cases are chosen so that the sampled maximum lies inside the step, above both
    ends (a bound from the ends alone would fail)."""
    p = motor.Parameters(kp, ki, 1e9, profile, omega_set, accel, 0.0, 0.0, J_rotor=j)
    r0, a, _ = motor.reference(p, 0.0)
    y1 = motor.integrate(p, 0.0, h, y0, motor.Inputs(tau_load))
    bound = motor.pi_torque_bound(p, h, y0, y1, r0, a, tau_load)
    y, torques = y0, []
    for k in range(400):
        y = motor.integrate(p, k * h / 400, h / 400, y, motor.Inputs(tau_load))
        torques.append(abs(kp * (motor.reference(p, (k + 1) * h / 400)[0] - y[1]) + ki * y[2]))
    ends = max(abs(kp * (r0 - y0[1]) + ki * y0[2]), torques[-1])
    assert y == pytest.approx(y1, rel=1e-11, abs=1e-13)
    assert max(torques) > ends * (1 + 1e-9)
    assert max(torques) <= bound


def test_torque_bound_holds_for_any_loop_load_and_ramp():
    """pi_torque_bound against |Kp e + Ki I| sampled at 100 points by exact sub-steps, on 300 loops drawn at random
    (seeded): gains, rotor inertia, constant or ramped reference, a load of either sign, a state off equilibrium, a
    step of 0.3-2 undamped half-periods. A bound that drops the load's or the ramp's share of u' (or turns a sign) is
    below the peak on some of them, and the exact step would then skip the torque limit."""
    import random
    rng = random.Random(20261128)
    for _ in range(300):
        kp, ki, j = 10 ** rng.uniform(-2, 1), 10 ** rng.uniform(0, 3), 10 ** rng.uniform(-3, -1)
        profile, accel, tau_load = rng.choice([motor.CONSTANT, motor.RAMP]), 10 ** rng.uniform(0, 2), rng.uniform(-20, 20)
        h = rng.uniform(0.3, 2.0) * math.pi / math.sqrt(ki / j)
        p = motor.Parameters(kp, ki, 1e9, profile, 1e4 if profile == motor.RAMP else 100.0, accel, 0.0, 0.0,
                             J_rotor=j)
        r0, a, _ = motor.reference(p, 0.0)
        y = y0 = (0.0, r0 + rng.uniform(-5.0, 5.0), rng.uniform(-0.5, 0.5))
        bound = motor.pi_torque_bound(p, h, y0, motor.integrate(p, 0.0, h, y0, motor.Inputs(tau_load)), r0, a,
                                      tau_load)
        peak = 0.0
        for k in range(100):
            y = motor.integrate(p, k * h / 100, h / 100, y, motor.Inputs(tau_load))
            peak = max(peak, abs(kp * (motor.reference(p, (k + 1) * h / 100)[0] - y[1]) + ki * y[2]))
        assert peak <= bound * (1 + 1e-9) + 1e-12, (kp, ki, j, profile, accel, tau_load, h, y0, peak, bound)


def test_step_reaching_the_torque_limit_falls_back_to_rk4():
    """A load step beyond tau_max: the step in which the torque reaches the limit, and the saturated steps after,
    are the RK4 substeps bit for bit (the clamp and anti-windup as before); the unsaturated steps before are not."""
    p = motor.Parameters(0.2, 10.0, 0.5, motor.CONSTANT, 100.0, 1.0, 0.0, 0.0, J_rotor=1e-3)
    y, h, fell_back = (0.0, 100.0, 0.0), 1e-3, []
    for k in range(60):
        load = 0.3 if k < 20 else 0.8
        fell_back.append(motor.integrate(p, k * h, h, y, motor.Inputs(load)) == rk4_step(p, k * h, h, y, load))
        y = motor.integrate(p, k * h, h, y, motor.Inputs(load))
    first = fell_back.index(True)
    assert 20 <= first < 40 and all(fell_back[first:]) and not any(fell_back[1:20])
    assert motor.pi_torque(p.omega_set - y[1], y[2], p.Kp, p.Ki, p.tau_max)[0] == p.tau_max


@pytest.mark.parametrize("profile, t0", [(motor.RAMP, 0.1), (motor.STEP, 0.1)])
def test_a_step_across_a_profile_corner_is_split_there(profile, t0):
    """A corner inside a step (the ramp's end at omega_set / accel = 0.1005 s; a step profile's jump at t_step =
    0.1005 s): the step is taken in two pieces, each exact, so it is the independent solve's number. One RK4 step
    across a step profile's jump had left 0.9% of the step in the speed (a control engineer's trial)."""
    p = (motor.Parameters(0.2, 10.0, 5.0, motor.RAMP, 3.015, 30.0, 0.0, 0.0, J_rotor=1e-3) if profile == motor.RAMP
         else motor.Parameters(2.8, 40.0, 1e3, motor.STEP, 60.0, 1.0, 0.1005, 50.0, J_rotor=0.1))
    y = (0.0, 3.0, 0.0) if profile == motor.RAMP else (0.0, 50.0, 0.0)
    stepped = motor.integrate(p, t0, 1e-3, y, motor.Inputs(0.1))
    # across a jump, each piece on its own, the first up to the corner's left side (a host's rounding of it, 1e-9,
    # counts as there); across a kink the solve follows it
    solved = (fine_solve(p, t0, y, t0 + 1e-3, 0.1) if profile == motor.RAMP else
              fine_solve(p, 0.1005, fine_solve(p, t0, y, 0.1005 - 2e-9, 0.1), t0 + 1e-3, 0.1))
    np.testing.assert_allclose(stepped[1:], solved[1:], rtol=1e-9, atol=1e-12)
    assert stepped[0] == pytest.approx(solved[0], abs=2e-7)   # the angle less the 2 ns the solve leaves out
    if profile == motor.STEP:   # and it is not RK4's across the jump
        assert abs(rk4_step(p, t0, 1e-3, y, 0.1)[1] - stepped[1]) > 1e-3


def controller_rk4_step(p, t, h, y, omega):
    """One RK4 step of the controller's integral, omega held (the FMU's default for a rate bound of 0)."""
    u = motor.Controller.Inputs(omega)
    return tuple(rk4.integrate_time(lambda s, y: motor.Controller.derivatives(p, t + s, y, u), y, h, 1))


def test_controller_step_is_the_integral_of_the_speed_error():
    """Unsaturated, omega held: I(t + h) = I + integral of e = omega_ref - omega over the step, in closed form on a
    ramp (e linear in t), and RK4 gives the same number to round-off (it integrates a linear e exactly)."""
    p = motor.ControllerParameters(0.2, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0)
    t, h, y, omega = 0.4, 1e-3, (0.01,), 11.5
    expected = 0.01 + ((30.0 * t - omega) + (30.0 * (t + h) - omega)) / 2.0 * h
    y1 = motor.Controller.integrate(p, t, h, y, motor.Controller.Inputs(omega))
    assert y1[0] == pytest.approx(expected, rel=1e-15, abs=1e-18)
    assert y1[0] == pytest.approx(controller_rk4_step(p, t, h, y, omega)[0], rel=1e-14)


def test_controller_step_with_the_torque_peak_inside_falls_back_to_rk4():
    """A long step on a ramp where Kp e + Ki I is -0.3 N.m at both ends but -0.675 N.m at mid-step, beyond
    tau_max = 0.5 N.m: the clamp and the anti-windup act inside the step, so the step is the RK4 one (bit for bit),
    not the closed form of the linear law (which an end-point check alone would take)."""
    kp, ki, a, h = 0.2, 10.0, 30.0, 0.1
    e0 = -(kp * a + ki * a * h / 2.0) / ki            # the vertex of the torque at mid-step
    integral = (-0.3 - kp * e0) / ki                  # -0.3 N.m at the start (and, by symmetry, at the end)
    p = motor.ControllerParameters(kp, ki, 0.5, motor.RAMP, 1e4, a, 0.0, 0.0)
    t = 1.0
    omega = a * t - e0
    assert motor.controller_torque_peak(p, h, e0, a, integral) == pytest.approx(0.675)
    y1 = motor.Controller.integrate(p, t, h, (integral,), motor.Controller.Inputs(omega))
    assert y1 == controller_rk4_step(p, t, h, (integral,), omega)
    assert y1[0] != pytest.approx(integral + h * (e0 + 0.5 * a * h), rel=1e-6)


@pytest.mark.parametrize("sense", [1.0, -1.0])
@pytest.mark.parametrize("omega, frozen", [(20.0, True), (29.99, False), (30.0 - 1e-12, False)])
def test_controller_step_held_at_a_limit_keeps_its_integral(sense, omega, frozen):
    """A slew from 60 rad/s down at 30 rad/s^2 (t = 1: 30 rad/s, or its mirror from -60) with the speed held 10 rad/s
    below: Kp e + Ki I beyond tau_max all along with e of the same sign, so the conditional integration freezes I:
    the step leaves it exactly (bitwise RK4's, whose four stages each give dI/dt = 0). Where e reaches 0 within the
    step (0.01 rad/s below, the set point coming down to the speed; or within round-off of 0), the integration
    resumes inside the step: it is RK4's step as before, which moves I."""
    p = motor.ControllerParameters(0.2, 10.0, 1.0, motor.SLEW, 0.0, 30.0, 0.0, 60.0 * sense)
    t, h, y = 1.0, 1e-3, (0.2 * sense,)
    ref = motor.Controller.outputs(p, t, y, motor.Controller.Inputs(0.0))["omega_ref"]
    assert ref == pytest.approx(30.0 * sense, rel=1e-12)
    speed = omega * sense
    u = motor.Controller.Inputs(speed)
    assert motor.Controller.outputs(p, t, y, u)["tau_motor"] == sense * 1.0   # at the limit
    y1 = motor.Controller.integrate(p, t, h, y, u)
    assert y1 == controller_rk4_step(p, t, h, y, speed)
    assert (y1 == y) == frozen
    # the speed 10 rad/s past the set point, the integral still holding the limit: it unwinds (dI/dt = e)
    wound, past = (0.5 * sense,), motor.Controller.Inputs(40.0 * sense)
    assert motor.Controller.outputs(p, t, wound, past)["tau_motor"] == sense * 1.0
    y1 = motor.Controller.integrate(p, t, h, wound, past)
    assert y1 == controller_rk4_step(p, t, h, wound, 40.0 * sense) and y1 != wound


def test_controller_step_across_a_profile_corner_is_split_there():
    """The ramp's end (0.1005 s) inside the step, the speed held at 3.0: e = 30 s rises to 0.015 at the corner, then
    stays, so I gains 30 (5e-4)^2 / 2 + 0.015 (5e-4) = 1.125e-5 rad exactly (not the ramp's slope carried past
    the corner, 1.5e-5, nor one RK4 step across the kink); the step that starts at the corner is the closed form of
    the constant error."""
    p = motor.ControllerParameters(0.2, 10.0, 5.0, motor.RAMP, 3.015, 30.0, 0.0, 0.0)
    y, u = (0.0,), motor.Controller.Inputs(3.0)
    across = motor.Controller.integrate(p, 0.1, 1e-3, y, u)
    assert across[0] == pytest.approx(1.125e-5, rel=1e-9)
    assert across != controller_rk4_step(p, 0.1, 1e-3, y, 3.0)
    assert motor.Controller.integrate(p, 0.1005, 1e-3, y, u)[0] == pytest.approx(0.015 * 1e-3, rel=1e-12)


def test_a_set_speed_past_1000_rad_s_asks_whether_rpm_was_meant():
    """omega_set = 3000 meant as rpm had run at 28,648 rpm without a word: the Motor's and the MotorController's
    advice give the rpm it is and the rad/s it would be (3000 rpm = 314.159 rad/s); a step profile's omega_initial
    too; 600 rad/s (5730 rpm) draws none."""
    def drive(omega_set, profile=motor.CONSTANT, omega_initial=0.0):
        return motor.Parameters(5.0, 125.0, 30.0, profile, omega_set, 15.0, 1.0, omega_initial, J_rotor=0.05)
    (message,) = motor.advice(drive(3000.0))
    assert message == ("omega_set = 3000 rad/s is 28647.9 rpm; if the value was meant in rpm, omega_set = 314.159 "
                       "rad/s (the FMUs take SI units)")
    assert motor.Controller.advice(drive(3000.0)) == [message]
    assert len(motor.advice(drive(600.0, motor.STEP, -2000.0))) == 1 and motor.advice(drive(600.0)) == []


def test_a_starting_torque_on_an_ideal_source_is_said_to_be_unused():
    """An ideal speed source delivers whatever torque its profile takes: a tau_initial given to it is named as
    unused; on a PI motor it is the integral's start, and says nothing."""
    ideal = motor.Parameters(5.0, 125.0, 30.0, motor.CONSTANT, 100.0, 15.0, 1.0, 0.0, 2.0, J_rotor=0.05,
                             ideal_speed_source=True)
    (message,) = motor.advice(ideal)
    assert message.startswith("tau_initial = 2 N.m is not used: an ideal speed source")
    pi = motor.Parameters(5.0, 125.0, 30.0, motor.CONSTANT, 100.0, 15.0, 1.0, 0.0, 2.0, J_rotor=0.05)
    assert motor.advice(pi) == [] and motor.initial_state(pi, 0.0, motor.Inputs(0.0)).integral == 2.0 / 125.0


def test_a_pi_loop_too_fast_for_its_steps_is_said_at_initialisation():
    """Kp = 1.8e4 N.m.s/rad on a 1e-3 kg.m2 rotor (within the declared ranges) closes the loop at 1.8e7 1/s: where
    the torque limit acts, a 1 ms step takes 9e4 RK4 substeps (0.2 s each: a 6 s run took 20 minutes unsaid).
    advice names the gains, the rate and the substeps; the bundled start-up's gains (0.2, 10) and an ideal
    speed source say nothing."""
    fast = motor.Parameters(1.8e4, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0, J_rotor=1e-3)
    (message,) = motor.advice(fast)
    pole = 1.8e4 / 1e-3 + math.sqrt(10.0 / 1e-3)
    assert f"as fast as {pole:.3g} 1/s" in message and f"about {1e-3 * pole / motor.POLE_STEP:.3g} RK4" in message
    assert rk4.substeps(motor.rate_bound(fast, (0.0, 0.0, 0.0), 0.0), 1e-3) > motor.SLOW_SUBSTEPS
    assert motor.advice(motor.Parameters(0.2, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0, J_rotor=1e-3)) == []
    ideal = motor.Parameters(1.8e4, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0, J_rotor=1e-3,
                             ideal_speed_source=True)
    assert motor.advice(ideal) == []
    (refused,) = motor.advice(motor.Parameters(1e4, 10.0, 5.0, motor.RAMP, 150.0, 30.0, 0.0, 0.0, J_rotor=1e-4))
    assert "more than the 100000 a step may take, so such a step is refused" in refused
    assert "so a run may take minutes" in message


@pytest.mark.parametrize("at", [1.04, 1.05, 0.3])
def test_a_corner_a_step_misses_by_rounding_is_taken_at_the_step(at):
    """A ramp's end meant at a communication point (omega_set / accel = 1.05 s) arrives as 1.0499999999999998 at
    1 ms: the step that starts there must follow the profile's next piece (the speed held), not the ramp for a
    whole step (0.1 rad/s of reference speed too much, 100 rad/s^2 x 1 ms). The run ends where one whose ramp ends
    1e-10 s later does (the corner inside a step, RK4 substeps: a continuous change of the parameter)."""
    def run(omega_set):
        p = motor.Parameters(2.0, 50.0, 1e9, motor.RAMP, omega_set, 100.0, 0.0, 0.0, J_rotor=0.02)
        y = motor.initial_state(p, 0.0, motor.Inputs(0.5))
        for k in range(int(round((at + 0.2) / 1e-3))):
            y = motor.integrate(p, k * 1e-3, 1e-3, y, motor.Inputs(0.5))
        return y
    on_grid, just_after = run(100.0 * at), run(100.0 * (at + 1e-10))
    assert abs(on_grid[1] - just_after[1]) < 1e-6 and abs(on_grid[2] - just_after[2]) < 1e-8


@pytest.mark.parametrize("w0, w1", [(40.0, 10.0), (-5.0, 25.0), (12.0, 12.0)])
def test_a_slew_goes_from_one_speed_to_the_other_at_its_rate(w0, w1):
    """Profile 3 (SLEW): omega_initial before t_step, then a straight line at +-accel (towards omega_set, up or
    down) until it gets there, omega_set after; the angle is the speed's integral (trapezoidal sums of a fine grid),
    alpha its slope, and the references' own writing of the profile (``references.common.profile``) agrees."""
    import numpy as np

    from ujfmu.references.common import profile
    accel, t_step = 100.0, 0.5
    p = motor.Parameters(1.0, 10.0, 5.0, motor.SLEW, w1, accel, t_step, w0, J_rotor=1e-3)
    t = np.linspace(0.0, 1.2, 24001)
    w, a, phi = np.array([motor.reference(p, x) for x in t]).T
    end = t_step + abs(w1 - w0) / accel
    expected = np.where(t < t_step, w0, np.where(t < end, w0 + np.sign(w1 - w0) * accel * (t - t_step), w1))
    np.testing.assert_allclose(w, expected, atol=1e-12 * accel)
    np.testing.assert_allclose(phi, np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))]),
                               atol=1e-9)
    far = (np.abs(t - t_step) > 1e-6) & (np.abs(t - end) > 1e-6)   # from the corners, which rounding may move
    inside = far & (t > t_step) & (t < end)
    assert np.all(a[inside] == np.sign(w1 - w0) * accel) and np.all(a[far & ~inside] == 0.0)
    assert motor.profile_corners(p) == pytest.approx((t_step, end))
    theirs = profile(dict(profile=3, omega_set=w1, accel=accel, t_step=t_step, omega_initial=w0), t)
    for mine, ours in zip(theirs, (w, a, phi)):
        np.testing.assert_allclose(mine[far], ours[far], atol=1e-9)
