"""Elastic centrifugal ring coupling between radially misaligned shafts.

Source [Turla2002]: Vytautas Turla, Igor Iljin, "The investigation of dynamics of misaligned units in vehicle
transmission", Transport (Vilnius Gediminas Technical University), 2002; Eqs. (5)-(22).

Derivation and every interpretation of the paper: README.md. Standard library only: this module runs
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
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from ...fmu import rk4
from ..protocol import Drive, Torques, shaft_inertia_problems

#: Eq. (5)/(7): M_p = MP_COEFFICIENT (EI/R^3) e^2 cos(phi1 + phi2)
MP_COEFFICIENT = 157.0
#: Eq. (21)-(22) with [6]: c_s = CS_COEFFICIENT EI/R
CS_COEFFICIENT = 87.0
#: Eq. (20): amplitude of the 2x part of x_e = SMALL_PARAMETER_COEFFICIENT e^2 EI / (omega^2 I2 R^3) = A_e/(4 w^2)
SMALL_PARAMETER_COEFFICIENT = MP_COEFFICIENT / 4.0   # 39.25
#: the order of the input speed the outputs carry at full size: M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2) turns at
#: twice the running speed (Eq. 7, 20); a record must sample it (``ujfmu.scenario_run``)
EXCITATION_ORDER = 2


def bending_stiffness(E: float, d: float) -> float:
    """EI of a round wire of diameter d [N.m^2]."""
    return E * math.pi * d ** 4 / 64.0


def rotational_stiffness(E: float, d: float, R: float) -> float:
    """c_s = 87 EI / R [N.m/rad] (Eq. 21-22, units corrected)."""
    return CS_COEFFICIENT * bending_stiffness(E, d) / R


def pendulum_constant(E: float, d: float, R: float, e: float, I2: float) -> float:
    """A_e = 157 e^2 EI / (I2 R^3) [1/s^2] (Eq. 12)."""
    return MP_COEFFICIENT * e * e * bending_stiffness(E, d) / (I2 * R ** 3)


def small_parameter_amplitude(E: float, d: float, R: float, e: float, I2: float, omega: float) -> float:
    """Amplitude of the double-frequency part of x_e, Eq. (20): 39.25 e^2 EI / (omega^2 I2 R^3) [rad]."""
    return SMALL_PARAMETER_COEFFICIENT * e * e * bending_stiffness(E, d) / (omega * omega * I2 * R ** 3)


def validity_speed(E: float, d: float, R: float, I2: float) -> float:
    """Lowest speed [rad/s] at which Eq. (20) holds: its amplitude must not exceed the largest static shift
    x_e_max = M_p,max / c_s = (157/87) (e/R)^2 (Eq. 21-22). e cancels: omega_min^2 = (87/4) EI / (I2 R) =
    c_s / (4 I2), i.e. where twice the running speed meets the coupling's own natural frequency sqrt(c_s/I2)."""
    return math.sqrt(CS_COEFFICIENT / 4.0 * bending_stiffness(E, d) / (I2 * R))


@dataclass(slots=True)
class Parameters:
    """The RingCoupling FMU's parameters (names as declared there) and the constants the equations use: the
    amplitude 157 (EI/R^3) e^2 of M_p (Eq. 7), the offset alpha2 - alpha1 of Eq. (8) and the natural-rate bound."""

    R: float
    d: float
    E: float
    e: float
    I1: float
    I2: float
    c_s: float
    c_d: float
    phi_in_start: float = 0.0
    phi_out_start: float = 0.0
    start_at_input_speed: bool = True
    omega_out_start: float = 0.0
    mp_amplitude: float = field(init=False, repr=False)
    offset: float = field(init=False, repr=False)
    natural_rate: float = field(init=False, repr=False)

    def __post_init__(self):
        self.mp_amplitude = MP_COEFFICIENT * bending_stiffness(self.E, self.d) * self.e * self.e / self.R ** 3
        self.offset = self.phi_out_start - self.phi_in_start        # alpha2 - alpha1
        self.natural_rate = natural_rate(self)


def torques(p: Parameters, phi1: float, w1: float, phi2: float, w2: float) -> tuple:
    """(M_p, x_e, elastic torque on shaft 2 = -(c_s x_e + c_d x_e'))."""
    x_e = phi2 - phi1 - p.offset
    return p.mp_amplitude * math.cos(phi1 + phi2), x_e, -(p.c_s * x_e + p.c_d * (w2 - w1))


def outputs_at(p: Parameters, phi1: float, w1: float, alpha1: float, y: Sequence[float],
               tau_drive: float | None = None) -> dict:
    """dict of the FMU's outputs at shaft 1's motion (phi1, w1, alpha1) and shaft 2's state y = (phi2, w2): shaft 2's
    motion, M_p, x_e, the transmitted torque M_p - (c_s x_e + c_d x_e'), tau_in = I1 alpha1 - M_p + (the elastic
    torque) and the stored energy (:func:`torques` written out: the same numbers). With tau_drive (the torque-driven
    coupling), alpha1 is shaft 1's acceleration under it (:func:`input_acceleration`), returned as alpha_in, and
    tau_in is named tau_input_shaft (``protocol.torque_driven_outputs``)."""
    phi2, w2 = y
    x_e = phi2 - phi1 - p.offset
    m_p = p.mp_amplitude * math.cos(phi1 + phi2)
    elastic = -(p.c_s * x_e + p.c_d * (w2 - w1))
    values = {"phi_out": phi2, "omega_out": w2, "M_p": m_p, "x_e": x_e, "transmitted_torque": m_p + elastic,
              "stored_energy": 0.5 * (p.I1 * w1 * w1 + p.I2 * w2 * w2)
              + (-p.mp_amplitude * math.sin(phi1 + phi2) + 0.5 * p.c_s * x_e * x_e)}
    if tau_drive is None:
        values["tau_in"] = p.I1 * alpha1 - m_p + elastic
    else:
        alpha1 = input_acceleration(p, tau_drive, m_p, elastic)
        values["alpha_in"], values["tau_input_shaft"] = alpha1, p.I1 * alpha1 - m_p + elastic
    return values


def natural_rate(p: "Parameters") -> float:
    """Bound [1/s] of the free motion: sqrt((c_s + M_p amplitude) / I2) + c_d / I2."""
    return math.sqrt((p.c_s + p.mp_amplitude) / p.I2) + p.c_d / p.I2


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

class State(NamedTuple):
    """Shaft 2's angle phi2 [rad] and speed [rad/s]."""

    phi_out: float
    omega_out: float


Inputs = Drive


def initial_state(p: Parameters, t: float, u: Drive) -> State:
    """Shaft 2 at phi_out_start, turning with the input (start_at_input_speed) or at omega_out_start."""
    return State(p.phi_out_start, u.omega if p.start_at_input_speed else p.omega_out_start)


def derivatives(p: Parameters, t: float, y: State, u: Drive) -> tuple:
    """:func:`drive_derivatives` at the input motion u."""
    return drive_derivatives(p, t, y, u.phi, u.omega, u.alpha, u.tau_load)


def drive_derivatives(p: Parameters, t: float, y: State, phi: float, omega: float, alpha: float,
        tau_load: float) -> tuple:
    """d/dt (phi2, w2), Eq. (9) with the elastic torque and the load, at the input shaft's angle phi and speed
    omega: I2 w2' = M_p - (c_s x_e + c_d x_e') - tau_load (:func:`torques` written out: the same numbers)."""
    phi2, w2 = y
    return (w2, (p.mp_amplitude * math.cos(phi + phi2) - (p.c_s * (phi2 - phi - p.offset) + p.c_d * (w2 - omega))
                 - tau_load) / p.I2)


def integrate(p: Parameters, t: float, h: float, y: State, u: Drive) -> tuple:
    """The FMU's step (the protocol's optional ``integrate``): classical RK4, fourth order, of
    :func:`drive_derivatives` from the input motion u at the step's start (phi(s) = phi + s (omega + alpha s / 2),
    w(s) = omega + alpha s, tau_load held, as ``rk4.integrate_drive``) in ``rk4.substeps`` of :func:`rate_bound` at
    the input speed's bound over the step, max(|omega|, |omega + alpha h|): :func:`rk4_steps`."""
    phi, omega, alpha, tau_load = u
    n = rk4.substeps(rate_bound(p, y, max(abs(omega), abs(omega + alpha * h))), h)
    return rk4_steps(p, y, h, n, phi, omega, alpha, tau_load)


def rk4_steps(p: Parameters, y: Sequence[float], t_span: float, n: int, phi0: float, w0: float, alpha: float,
              tau_load: float) -> tuple:
    """``rk4.integrate_drive(drive_derivatives, p, t, y, t_span, n, phi0, w0, alpha, tau_load)`` with the equation
    of motion (:func:`drive_derivatives`) written into the four stages: the same operations in the same order, so
    the same numbers bit for bit (test), without a call per stage. Classical RK4: fourth order (test: observed
    order against a fine independent solve)."""
    amplitude, c_s, c_d, offset, i2 = p.mp_amplitude, p.c_s, p.c_d, p.offset, p.I2
    cos = math.cos
    h = t_span / n
    hh, h6 = 0.5 * h, h / 6.0
    s = 0.0
    phi_s, w_s = phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s
    y0, y1 = y
    for _ in range(n):
        sm, se = s + 0.5 * h, s + h
        phi_m, w_m = phi0 + sm * (w0 + 0.5 * alpha * sm), w0 + alpha * sm
        phi_e, w_e = phi0 + se * (w0 + 0.5 * alpha * se), w0 + alpha * se
        a1 = (amplitude * cos(phi_s + y0) - (c_s * (y0 - phi_s - offset) + c_d * (y1 - w_s)) - tau_load) / i2
        z0, b0 = y0 + hh * y1, y1 + hh * a1
        b1 = (amplitude * cos(phi_m + z0) - (c_s * (z0 - phi_m - offset) + c_d * (b0 - w_m)) - tau_load) / i2
        z0, c0 = y0 + hh * b0, y1 + hh * b1
        c1 = (amplitude * cos(phi_m + z0) - (c_s * (z0 - phi_m - offset) + c_d * (c0 - w_m)) - tau_load) / i2
        z0, d0 = y0 + h * c0, y1 + h * c1
        d1 = (amplitude * cos(phi_e + z0) - (c_s * (z0 - phi_e - offset) + c_d * (d0 - w_e)) - tau_load) / i2
        y0, y1 = y0 + h6 * (y1 + 2.0 * (b0 + c0) + d0), y1 + h6 * (a1 + 2.0 * (b1 + c1) + d1)
        s = se
        phi_s, w_s = phi_e, w_e
    return y0, y1


def forcing_rate(omega_max: float, omega_out: float) -> float:
    """Bound [1/s] of the frequency with which the ring forces the shafts: M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2)
    (Eq. 7) is the only torque that depends on the angles, and it turns at |w1 + w2| <= 2 max(|w1|, |w2|), shaft 1
    within omega_max over the step, shaft 2 at omega_out. Its other orders come from the unevenness x_e inside
    the cosine, cos(2 phi1 + x_e + const), and have the relative size of x_e's own oscillation (Eq. 20: 5.9e-4 rad
    at 100 rad/s for the Fig. 3 ring; conclusion 3 of the paper: the speed's other orders are < 1e-3 of the 2x)."""
    return 2.0 * max(omega_max, abs(omega_out))


def rate_bound(p: Parameters, y: State, omega_max: float) -> float:
    """max(natural rate, forcing rate): the free motion and the 2x forcing (:func:`forcing_rate`), the larger
    resolved, not their sum (``rk4.fastest_rate``), written out (the FMU's step asks for it every step)."""
    return max(p.natural_rate, 2.0 * max(omega_max, abs(y[1])))


def outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """:func:`outputs_at` the input motion u."""
    return outputs_at(p, u.phi, u.omega, u.alpha, y)


#: the default ring (Turla and Iljin's Fig. 3): Young's modulus [Pa], wire diameter [m], ring radius [m]
DEFAULT_RING = (2.1e11, 0.003, 0.1)


#: a misalignment above this fraction of the ring radius draws a warning (``advice``)
LARGE_MISALIGNMENT = 0.1


def free_output_inertia(p: Parameters) -> float:
    """Shaft 2's I2 behind the ring's stiffness c_s."""
    return p.I2


def advice(p: Parameters) -> list:
    """Warnings on valid parameters that are likely not what was meant: c_s left at the default ring's 87 EI/R
    while R, d or E describe another ring (c_s is a parameter of its own, not derived from them); a misalignment
    e above ``LARGE_MISALIGNMENT`` of R, where the paper's e^2 law (Eq. 7, derived for e small against R) is not
    established."""
    messages = []
    default = rotational_stiffness(*DEFAULT_RING)
    own = rotational_stiffness(p.E, p.d, p.R)
    if p.c_s == default and abs(own - default) > 1e-3 * default:
        messages.append(f"c_s = {p.c_s:.6g} N.m/rad is the default ring's stiffness (87 EI/R for R = "
                        f"{DEFAULT_RING[2]:g} m, d = {DEFAULT_RING[1]:g} m, E = {DEFAULT_RING[0]:g} Pa), but this "
                        f"ring's 87 EI/R is {own:.6g} N.m/rad: set c_s = {own:.6g} for it (or 0 for the paper's "
                        "pendulum case, Eq. 9)")
    if p.e > LARGE_MISALIGNMENT * p.R:
        messages.append(f"e = {p.e:.6g} m is {p.e / p.R:.3g} of the ring radius R = {p.R:.6g} m: the misalignment "
                        "moment M_p = 157 (EI/R^3) e^2 is the paper's result for a misalignment small against the "
                        f"ring, and above e = {LARGE_MISALIGNMENT:g} R the model runs outside what the paper "
                        "establishes (its twist and moment may be far from a real ring's); if e was meant in mm, "
                        f"e = {p.e / 1000.0:.6g} m")
    return messages


def check(p: Parameters) -> list:
    """The misalignment e must be smaller than the ring radius R."""
    if not p.e < p.R:
        return [f"e = {p.e!r} m must be smaller than the ring radius R = {p.R!r} m (allowed range [0, R) m)"]
    return []


# --- the torque-driven coupling (RingCouplingTorqueDriven): shaft 1 free, its motion in the state ----------------

@dataclass(slots=True, kw_only=True)
class TorqueDrivenParameters(Parameters):
    """RingCouplingTorqueDriven's parameters: RingCoupling's, the driver's rotor inertia J_drive lumped on shaft 1
    [kg.m2] and shaft 1's speed at the start time [rad/s]; natural_rate is the bound with shaft 1 free,
    sqrt((c_s + M_p amplitude) (1/I2 + 1/J_in)) + c_d (1/I2 + 1/J_in), J_in = J_drive + I1 (the two-mass mode;
    0 where :meth:`TorqueDriven.check` refuses J_in)."""

    J_drive: float
    omega_in_start: float

    def __post_init__(self):
        Parameters.__post_init__(self)
        j_in = self.J_drive + self.I1
        if j_in > 0.0:
            mobility = 1.0 / self.I2 + 1.0 / j_in
            self.natural_rate = math.sqrt((self.c_s + self.mp_amplitude) * mobility) + self.c_d * mobility


def input_acceleration(p: TorqueDrivenParameters, tau_in: float, m_p: float, elastic: float) -> float:
    """alpha1 of the free shaft 1, (J_drive + I1) alpha1 = tau_in + M_p + c_s x_e + c_d x_e' (the ring's torque on
    shaft 1: -dPi/dphi1 = M_p and the elastic torque's reaction, see the module docstring), from M_p and the
    elastic torque on shaft 2 of :func:`torques` at the state."""
    return (tau_in + m_p - elastic) / (p.J_drive + p.I1)


class TorqueDriven:
    """The protocol of the torque-driven coupling: state (phi1, w1) of shaft 1, driven by tau_in with the driver's
    rotor inertia J_drive lumped on it (:func:`input_acceleration`), then shaft 2's (phi2, w2) (:func:`derivatives`
    at that motion); every other output is the speed-driven coupling's (stored_energy counts I1, not J_drive)."""

    Parameters = TorqueDrivenParameters
    Inputs = Torques

    class State(NamedTuple):
        """Shaft 1's angle phi1 [rad] and speed [rad/s], then shaft 2's."""

        phi_in: float
        omega_in: float
        phi_out: float
        omega_out: float

    @staticmethod
    def initial_state(p: TorqueDrivenParameters, t: float, u: Torques) -> tuple:
        """Shaft 1 at phi_in_start turning at omega_in_start; shaft 2 at phi_out_start, turning with shaft 1
        (start_at_input_speed) or at omega_out_start."""
        w2 = p.omega_in_start if p.start_at_input_speed else p.omega_out_start
        return TorqueDriven.State(p.phi_in_start, p.omega_in_start, p.phi_out_start, w2)

    @staticmethod
    def derivatives(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> tuple:
        """(w1, alpha1 of :func:`input_acceleration`) and :func:`derivatives` of shaft 2 at that motion, with the
        ring's torques (:func:`torques`) evaluated once and written out (the same numbers)."""
        phi1, w1, phi2, w2 = y
        m_p = p.mp_amplitude * math.cos(phi1 + phi2)
        elastic = p.c_s * (phi2 - phi1 - p.offset) + p.c_d * (w2 - w1)
        return w1, (u.tau_in + m_p + elastic) / (p.J_drive + p.I1), w2, (m_p - elastic - u.tau_load) / p.I2

    @staticmethod
    def rate_bound(p: TorqueDrivenParameters, y: tuple, omega_max: float) -> float:
        """max(natural-rate bound with shaft 1 free, forcing rate), as :func:`rate_bound`."""
        return rk4.fastest_rate(p.natural_rate, forcing_rate(omega_max, y[3]))

    @staticmethod
    def outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """Shaft 1's motion from the state and :func:`input_acceleration`, the rest from :func:`outputs` at that
        motion (named as ``protocol.torque_driven_outputs`` names them): :func:`outputs_at` under tau_in."""
        values = outputs_at(p, y[0], y[1], 0.0, y[2:], u.tau_in)
        values["phi_in"], values["omega_in"] = y[0], y[1]
        return values

    @staticmethod
    def load_outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """The outputs that move with the inputs (the FMU recomputes only these when only the torques changed since
        the outputs were computed): shaft 1's acceleration and tau_input_shaft = I1 alpha_in - M_p + the elastic
        torque, as :meth:`outputs` gives them (every other output is a function of the state)."""
        m_p, _, elastic = torques(p, y[0], y[1], y[2], y[3])
        alpha = input_acceleration(p, u.tau_in, m_p, elastic)
        return {"alpha_in": alpha, "tau_input_shaft": p.I1 * alpha - m_p + elastic}

    advice = staticmethod(advice)
    free_output_inertia = staticmethod(free_output_inertia)

    @staticmethod
    def check(p: TorqueDrivenParameters) -> list:
        """:func:`check`, and shaft 1 needs an inertia to integrate."""
        return check(p) + shaft_inertia_problems("J_drive + I1", p.J_drive + p.I1, "shaft 1")
