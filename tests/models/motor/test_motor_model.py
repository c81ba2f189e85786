"""ujfmu.models.motor.model: speed profiles, PI law, closed-loop tracking against closed forms."""

import math

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
