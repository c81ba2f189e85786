"""Drive motor: rotor inertia with a PI speed controller and a torque limit, or an ideal speed source.

    J * domega/dt = tau_motor - tau_load,   dphi/dt = omega
    e = omega_ref(t) - omega,  u = Kp*e + Ki*I,  tau_motor = clamp(u, -tau_max, tau_max)
    dI/dt = e, except while the output is saturated and e drives it further into saturation
            (conditional integration, the usual anti-windup)

Speed profiles omega_ref(t) (Feng et al. accelerate the driving shaft at alpha = 30 rad/s^2 from rest):
    CONSTANT: omega_ref = omega_set
    RAMP:     omega_ref = min(accel * t, omega_set)  (from rest)
    STEP:     omega_ref = omega_initial before t_step, omega_set from t_step on
Standard library only: runs inside the Motor FMU.
"""

import math

from ...fmu import rk4

CONSTANT, RAMP, STEP = 0, 1, 2


def speed_reference(t, profile, omega_set, accel, t_step, omega_initial):
    """(omega_ref, alpha_ref, phi_ref): reference speed, its derivative and its integral from t = 0."""
    if profile == RAMP:
        t_end = omega_set / accel
        if t < t_end:
            return accel * t, accel, 0.5 * accel * t * t
        return omega_set, 0.0, 0.5 * accel * t_end * t_end + omega_set * (t - t_end)
    if profile == STEP:
        if t < t_step:
            return omega_initial, 0.0, omega_initial * t
        return omega_set, 0.0, omega_initial * t_step + omega_set * (t - t_step)
    return omega_set, 0.0, omega_set * t


def pi_torque(error, integral, kp, ki, tau_max):
    """(tau_motor, dI/dt) of the PI law with clamp and conditional-integration anti-windup."""
    u = kp * error + ki * integral
    if u > tau_max:
        return tau_max, (0.0 if error > 0.0 else error)
    if u < -tau_max:
        return -tau_max, (0.0 if error < 0.0 else error)
    return u, error


def controller_substeps(step, inertia, kp, ki):
    """RK4 substeps per communication step: keep |lambda| h_sub <= 0.2 for the closed PI loop's fastest pole."""
    # closed loop: J s^2 + Kp s + Ki = 0; |lambda| <= Kp/J + sqrt(Ki/J) bounds both roots
    lam = kp / inertia + math.sqrt(ki / inertia)
    n = step * lam / 0.2
    if not n <= 100_000:
        raise ValueError(f"a step of {step!r} s needs {n:.3g} RK4 substeps for the PI loop's fastest pole "
                         f"{lam:.6g} 1/s (allowed at most 100000): reduce the step, Kp or Ki, or raise J_rotor")
    return max(1, math.ceil(n))


def pi_motor_step(t, h, state, tau_load, p):
    """Advance (phi, omega, integral) over [t, t+h] with tau_load held; classical RK4 with substeps.

    p: (inertia, kp, ki, tau_max, profile, omega_set, accel, t_step, omega_initial, substeps).
    """
    inertia, kp, ki, tau_max, profile, omega_set, accel, t_step, omega_initial, n = p

    def rhs(time, omega, integral):
        omega_ref = speed_reference(time, profile, omega_set, accel, t_step, omega_initial)[0]
        tau, d_integral = pi_torque(omega_ref - omega, integral, kp, ki, tau_max)
        return omega, (tau - tau_load) / inertia, d_integral

    phi, omega, integral = state
    hs = h / n
    for i in range(n):
        ts = t + i * hs
        k1 = rhs(ts, omega, integral)
        k2 = rhs(ts + 0.5 * hs, omega + 0.5 * hs * k1[1], integral + 0.5 * hs * k1[2])
        k3 = rhs(ts + 0.5 * hs, omega + 0.5 * hs * k2[1], integral + 0.5 * hs * k2[2])
        k4 = rhs(ts + hs, omega + hs * k3[1], integral + hs * k3[2])
        phi += hs / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        omega += hs / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        integral += hs / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
    return phi, omega, integral


def controller_step(t: float, h: float, integral: float, omega: float, p: tuple) -> float:
    """Advance the PI controller's integral over [t, t+h] with the measured speed omega held (a sampled speed
    controller without a rotor of its own): dI/dt of :func:`pi_torque` with e = omega_ref(t) - omega, one RK4
    step (exact while unsaturated: e is linear in t between the profile's corners).

    p: (kp, ki, tau_max, profile, omega_set, accel, t_step, omega_initial).
    """
    kp, ki, tau_max, profile, omega_set, accel, t_step, omega_initial = p

    def rates(s, y):
        omega_ref = speed_reference(t + s, profile, omega_set, accel, t_step, omega_initial)[0]
        return (pi_torque(omega_ref - omega, y[0], kp, ki, tau_max)[1],)
    return rk4.integrate_time(rates, (integral,), h, 1)[0]
