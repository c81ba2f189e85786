"""Driven load: resisting torque tau = T0*s(omega) + c1*omega + c2*omega*|omega|_s.

s(omega) = omega/sqrt(omega^2 + omega_s^2) is a smooth sign and |omega|_s = sqrt(omega^2 + omega_s^2) a smooth
absolute value, so the law is infinitely differentiable through omega = 0 and odd in omega (the torque always
opposes the motion). For |omega| >> omega_s it is Coulomb T0*sign(omega), viscous c1*omega and fan/propeller
c2*omega^2 (Brutti et al.'s M_u = c*omega_5^2). Standard library only: runs inside the Load FMU.
"""

import math


def load_torque(omega, t0, c1, c2, omega_smooth):
    """Resisting torque [N.m] at speed omega [rad/s]; positive opposes positive rotation."""
    mag = math.sqrt(omega * omega + omega_smooth * omega_smooth)
    return t0 * omega / mag + c1 * omega + c2 * omega * mag
