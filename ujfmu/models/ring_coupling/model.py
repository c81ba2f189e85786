"""Elastic centrifugal ring coupling between radially misaligned shafts (Turla, Iljin, Transport 2002 [Turla2002]).

Derivation and every interpretation of the paper: ujfmu/models/ring_coupling/README.md. Standard library only: this module runs
inside the RingCoupling FMU.

Shaft 1 (angle phi1, prescribed) drives shaft 2 (angle phi2, inertia I2) through a steel-wire ring (radius R, wire
diameter d, Young's modulus E, EI = E pi d^4 / 64) with radial misalignment e:

    M_p = 157 (EI / R^3) e^2 cos(phi1 + phi2)                      (Eq. 7; acts on both shafts, see below)
    x_e = phi2 - phi1 - (alpha2 - alpha1)                           (Eq. 8: unevenness of the second shaft)
    I2 phi2'' = M_p - c_s x_e - c_d x_e' - tau_load                 (Eq. 9 plus the coupling's elastic torque)
    c_s = 87 EI / R  [N.m/rad]                                      (Eq. 21-22; the paper prints EI / R^3)

M_p derives from the ring's potential Pi = -157 (EI/R^3) e^2 sin(phi1 + phi2): -dPi/dphi2 = M_p (Eq. 9), and the
same -dPi/dphi1 = M_p acts on shaft 1, so the driver supplies tau_in = I1 alpha1 - M_p - (c_s x_e + c_d x_e').
With c_s = c_d = tau_load = 0 this is Eq. (9), the pendulum y'' + A_e sin y = 0 in y = pi/2 - (phi1 + phi2)
(Eq. 11-12), A_e = 157 e^2 EI / (I2 R^3).
"""

import math

from ...fmu import rk4

#: Eq. (5)/(7): M_p = MP_COEFFICIENT (EI/R^3) e^2 cos(phi1 + phi2)
MP_COEFFICIENT = 157.0
#: Eq. (21)-(22) with [6]: c_s = CS_COEFFICIENT EI/R
CS_COEFFICIENT = 87.0
#: Eq. (20): amplitude of the 2x part of x_e = SMALL_PARAMETER_COEFFICIENT e^2 EI / (omega^2 I2 R^3) = A_e/(4 w^2)
SMALL_PARAMETER_COEFFICIENT = MP_COEFFICIENT / 4.0   # 39.25


def bending_stiffness(E, d):
    """EI of a round wire of diameter d [N.m^2]."""
    return E * math.pi * d ** 4 / 64.0


def rotational_stiffness(E, d, R):
    """c_s = 87 EI / R [N.m/rad] (Eq. 21-22, units corrected)."""
    return CS_COEFFICIENT * bending_stiffness(E, d) / R


def pendulum_constant(E, d, R, e, I2):
    """A_e = 157 e^2 EI / (I2 R^3) [1/s^2] (Eq. 12)."""
    return MP_COEFFICIENT * e * e * bending_stiffness(E, d) / (I2 * R ** 3)


def small_parameter_amplitude(E, d, R, e, I2, omega):
    """Amplitude of the double-frequency part of x_e, Eq. (20): 39.25 e^2 EI / (omega^2 I2 R^3) [rad]."""
    return SMALL_PARAMETER_COEFFICIENT * e * e * bending_stiffness(E, d) / (omega * omega * I2 * R ** 3)


def validity_speed(E, d, R, I2):
    """Lowest speed [rad/s] at which Eq. (20) holds: its amplitude must not exceed the largest static shift
    x_e_max = M_p,max / c_s = (157/87) (e/R)^2 (Eq. 21-22). e cancels: omega_min^2 = (87/4) EI / (I2 R) =
    c_s / (4 I2), i.e. where twice the running speed meets the coupling's own natural frequency sqrt(c_s/I2)."""
    return math.sqrt(CS_COEFFICIENT / 4.0 * bending_stiffness(E, d) / (I2 * R))


class Coupling:
    """Parameters and derived constants (names as the FMU's parameters)."""

    PARAMETERS = ("R", "d", "E", "e", "I1", "I2", "c_s", "c_d", "phi_in_start", "phi_out_start")

    def __init__(self, R, d, E, e, I1, I2, c_s, c_d, phi_in_start, phi_out_start):
        self.I1, self.I2, self.c_s, self.c_d = I1, I2, c_s, c_d
        self.mp_amplitude = MP_COEFFICIENT * bending_stiffness(E, d) * e * e / R ** 3   # [N.m]
        self.offset = phi_out_start - phi_in_start        # alpha2 - alpha1


def torques(p, phi1, w1, phi2, w2):
    """(M_p, x_e, elastic torque on shaft 2 = -(c_s x_e + c_d x_e'))."""
    x_e = phi2 - phi1 - p.offset
    return p.mp_amplitude * math.cos(phi1 + phi2), x_e, -(p.c_s * x_e + p.c_d * (w2 - w1))


def derivatives(p, phi1, w1, y, tau_load):
    """d/dt (phi2, w2) from Eq. (9) with the elastic torque and the load."""
    m_p, _, elastic = torques(p, phi1, w1, y[0], y[1])
    return (y[1], (m_p + elastic - tau_load) / p.I2)


def outputs(p, phi1, w1, alpha1, y):
    """dict of the FMU's outputs for a state y = (phi2, w2)."""
    m_p, x_e, elastic = torques(p, phi1, w1, y[0], y[1])
    potential = -p.mp_amplitude * math.sin(phi1 + y[0]) + 0.5 * p.c_s * x_e * x_e
    return dict(M_p=m_p, x_e=x_e, transmitted_torque=m_p + elastic, tau_in=p.I1 * alpha1 - m_p + elastic,
                stored_energy=0.5 * (p.I1 * w1 * w1 + p.I2 * y[1] * y[1]) + potential)


def natural_rate(p):
    """Bound [1/s] of the free motion: sqrt((c_s + M_p amplitude) / I2) + c_d / I2."""
    return math.sqrt((p.c_s + p.mp_amplitude) / p.I2) + p.c_d / p.I2


def step(p, t_span, phi1, w1, alpha1, y, tau_load, rate):
    """Advance (phi2, w2) over t_span with RK4 substeps resolving the natural rate and the 2x forcing."""
    w_max = max(abs(w1), abs(w1 + alpha1 * t_span), abs(y[1]))

    def f(phi, w, state):
        return derivatives(p, phi, w, state, tau_load)
    return rk4.integrate(f, y, t_span, rk4.substeps(rate + 4.0 * w_max, t_span), phi1, w1, alpha1)
