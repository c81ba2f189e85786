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

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from ...fmu import rk4, series
from ..protocol import MIN_SHAFT_INERTIA, NEGLIGIBLE_SWING, Drive, Torques, shaft_inertia_problems

#: Eq. (5)/(7): M_p = MP_COEFFICIENT (EI/R^3) e^2 cos(phi1 + phi2)
MP_COEFFICIENT = 157.0
#: Eq. (21)-(22) with [6]: c_s = CS_COEFFICIENT EI/R
CS_COEFFICIENT = 87.0
#: Eq. (20): amplitude of the 2x part of x_e = SMALL_PARAMETER_COEFFICIENT e^2 EI / (omega^2 I2 R^3) = A_e/(4 w^2)
SMALL_PARAMETER_COEFFICIENT = MP_COEFFICIENT / 4.0   # 39.25
#: the order of the input speed the outputs carry at full size: M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2) turns at
#: twice the running speed (Eq. 7, 20); a record must sample it (``ujfmu.scenario_run``)
EXCITATION_ORDER = 2


def excitation_order(p: "Parameters") -> int:
    """``EXCITATION_ORDER`` where the shafts are misaligned; aligned (or (e / R)^2 below
    ``protocol.NEGLIGIBLE_SWING``: M_p goes with e^2), nothing turns at 2x."""
    return EXCITATION_ORDER if (p.e / p.R) ** 2 > NEGLIGIBLE_SWING else 0


def excited_orders(p: "Parameters") -> tuple:
    """The orders of the input speed the outputs carry at full size at p: M_p's 2x alone (cos(phi1 + phi2): no odd
    order), or none (:func:`excitation_order`)."""
    return (EXCITATION_ORDER,) if excitation_order(p) else ()


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
    #: the linear part L of the FMU's exponential integrator (:func:`linear_blocks`), the bound of its rates and of
    #: the remainder N's own (:func:`exponential_steps`)
    linear: tuple = field(init=False, repr=False)
    linear_rate: float = field(init=False, repr=False)
    remainder_rate: float = field(init=False, repr=False)
    #: (h, :func:`krogstad_operators` at h) of the last substep length, a pure cache (one float compared a step)
    operators_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        self.mp_amplitude = MP_COEFFICIENT * bending_stiffness(self.E, self.d) * self.e * self.e / self.R ** 3
        self.offset = self.phi_out_start - self.phi_in_start        # alpha2 - alpha1
        self.natural_rate = natural_rate(self)
        self.linear = linear_blocks(self.c_s, self.c_d, self.I2)
        self.linear_rate = math.sqrt(self.c_s / self.I2) + self.c_d / self.I2
        self.remainder_rate = math.sqrt(self.mp_amplitude / self.I2)


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
    """The FMU's step (the protocol's optional ``integrate``): :func:`exponential_steps` from the input motion u at
    the step's start (phi(s) = phi + s (omega + alpha s / 2), w(s) = omega + alpha s, tau_load held), in
    :func:`exponential_substeps` at the input speed's bound over the step, max(|omega|, |omega + alpha h|)."""
    phi, omega, alpha, tau_load = u
    n = exponential_substeps(p, h, max(abs(omega), abs(omega + alpha * h)), y[1])
    return exponential_steps(p, y, h, n, phi, omega, alpha, tau_load)


# --- the FMU's step: an exponential Runge-Kutta method, the ring's linear oscillator exact -------------------------

def linear_blocks(c_s: float, c_d: float, inertia: float) -> tuple:
    """L of the exponential integrator: the ring's oscillator in the twist x_e = phi2 - phi1 - offset and its rate,
    ((0, 1), (-c_s / J, -c_d / J)) with J the inertia it moves (I2 behind a prescribed shaft 1; the two shafts'
    reduced inertia in the torque-driven coupling)."""
    return ((0.0, 1.0), (-c_s / inertia, -c_d / inertia)),


#: the rigid rotation's block of the torque-driven coupling's L: d/dt (theta, Omega) = (Omega, 0)
RIGID_BLOCK = ((0.0, 1.0), (0.0, 0.0))


def exponential_substeps(p: Parameters, t_span: float, w_in: float, w_out: float) -> int:
    """Substeps of :func:`exponential_steps`: each resolves the remainder N's own rate (sqrt(M_p amplitude / J),
    ``remainder_rate``) plus the ring's forcing at 2 max(|w1|, |w2|) (:func:`forcing_rate`), and keeps h |lambda| <=
    1 over L's eigenvalues (``rk4.substeps``: h rate <= RATE_STEP = 0.5), where the phi-functions' series converge
    fast; the oscillator itself needs no resolving (its part is exact)."""
    return rk4.substeps(max(p.remainder_rate + forcing_rate(w_in, w_out), 0.5 * p.linear_rate), t_span)


@functools.lru_cache(maxsize=64)
def krogstad_operators(blocks: tuple, h: float) -> tuple:
    """Per 2x2 block of L (:func:`linear_blocks`), the operators of one substep of h of Krogstad's method
    (:func:`exponential_steps`), memoized (varying steps evict the oldest): E(h/2) and E(h) = exp(h L) row by row
    (4 numbers each), then the rate columns (L acts on N's second row alone: N = (0, g)) of Q1 = (h/2) phi_1(h L/2),
    Q2 = h phi_2(h L/2), R1 = h phi_1(h L), R2 = 2 h phi_2(h L), S1 = h (2 phi_2 - 4 phi_3)(h L),
    S2 = h (4 phi_3 - phi_2)(h L) (2 numbers each)."""
    half = 0.5 * h

    def full(block, step):
        if block == RIGID_BLOCK:   # L^2 = 0: exp(step L) = I + step L
            return 1.0, step, 0.0, 1.0
        return tuple(v for row in series.phi_sum(block, step, (1.0,)) for v in row)

    def rate_column(block, step, coefficients):
        if block == RIGID_BLOCK:   # phi_k(step L) = I / k! + step L / (k + 1)!
            return (step * sum(c / math.factorial(k + 1) for k, c in enumerate(coefficients)),
                    sum(c / math.factorial(k) for k, c in enumerate(coefficients)))
        return tuple(row[0] for row in series.phi_sum(block, step, coefficients, (1,)))

    return tuple((full(b, half), full(b, h), rate_column(b, half, (0.0, half)), rate_column(b, half, (0.0, 0.0, h)),
                  rate_column(b, h, (0.0, h)), rate_column(b, h, (0.0, 0.0, 2.0 * h)),
                  rate_column(b, h, (0.0, 0.0, 2.0 * h, -4.0 * h)), rate_column(b, h, (0.0, 0.0, -h, 4.0 * h)))
                 for b in blocks)


def operators(p: Parameters, h: float) -> tuple:
    """:func:`krogstad_operators` (p.linear, h), kept on p for the last h: its memo hashes L every call, this
    compares one float."""
    memo = p.operators_memo
    if memo is None or memo[0] != h:
        memo = p.operators_memo = h, krogstad_operators(p.linear, h)
    return memo[1]


def exponential_steps(p: Parameters, y: Sequence[float], t_span: float, n: int, phi0: float, w0: float,
                      alpha: float, tau_load: float) -> tuple:
    """Shaft 2's state after t_span (shaft 1 at phi(s) = phi0 + s (w0 + alpha s / 2), tau_load held) by n substeps
    of Krogstad's fourth-order exponential Runge-Kutta method (ETDRK4-B: Krogstad, "Generalized integrating factor
    methods for stiff PDEs", J. Comput. Phys. 203, 2005) in the twist z = (x, x') of x = phi2 - phi(s) - offset:
        z' = L z + (0, g),   L = ((0, 1), (-c_s/I2, -c_d/I2)),   g = (M_p - tau_load) / I2 - alpha,
        M_p = 157 (EI/R^3) e^2 cos(2 phi(s) + offset + x)                                  (Eq. 9 in the twist)
    The ring's free oscillation is exact at any step (an undamped ring keeps its amplitude and phase, of which RK4
    at h omega_n = 0.5 would lose 1e-4 a substep); g, the misalignment moment turning at twice the running speed, by four
    evaluations a substep (N_u = g(t, z), D_i = g(stage i) - N_u):
        a = E(h/2) z + Q1 N_u,  b = a + Q2 D_a,  c = E(h) z + R1 N_u + R2 D_b,
        z+ = E(h) z + R1 N_u + S1 (D_a + D_b) + S2 D_c                       (:func:`krogstad_operators`)
    Order 4 (test against a fine independent solve); with L = 0 it is classical RK4."""
    h = t_span / n
    (e, f, q1, q2, r1, r2, s1, s2), = operators(p, h)
    amplitude, offset, load = p.mp_amplitude / p.I2, p.offset, tau_load / p.I2 + alpha
    cos = math.cos
    x, v = y[0] - phi0 - offset, y[1] - w0
    s = 0.0
    for _ in range(n):
        sm, se = s + 0.5 * h, s + h
        at_u = 2.0 * (phi0 + s * (w0 + 0.5 * alpha * s)) + offset
        at_m = 2.0 * (phi0 + sm * (w0 + 0.5 * alpha * sm)) + offset
        at_e = 2.0 * (phi0 + se * (w0 + 0.5 * alpha * se)) + offset
        nu = amplitude * cos(at_u + x) - load
        ax = e[0] * x + e[1] * v + q1[0] * nu   # g depends on the stages' x alone
        da = amplitude * cos(at_m + ax) - load - nu
        db = amplitude * cos(at_m + ax + q2[0] * da) - load - nu
        cx, cv = f[0] * x + f[1] * v + r1[0] * nu, f[2] * x + f[3] * v + r1[1] * nu
        dc = amplitude * cos(at_e + cx + r2[0] * db) - load - nu
        dab = da + db
        x, v = cx + s1[0] * dab + s2[0] * dc, cv + s1[1] * dab + s2[1] * dc
        s = se
    return (x + phi0 + t_span * (w0 + 0.5 * alpha * t_span) + offset, v + w0 + alpha * t_span)


def forcing_rate(omega_max: float, omega_out: float) -> float:
    """Bound [1/s] of the frequency with which the ring forces the shafts: M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2)
    (Eq. 7) is the only torque that depends on the angles, and it turns at |w1 + w2| <= 2 max(|w1|, |w2|), shaft 1
    within omega_max over the step, shaft 2 at omega_out. Its other orders come from the unevenness x_e inside
    the cosine, cos(2 phi1 + x_e + const), and have the relative size of x_e's own oscillation (Eq. 20: 5.9e-4 rad
    at 100 rad/s for the Fig. 3 ring; conclusion 3 of the paper: the speed's other orders are < 1e-3 of the 2x)."""
    return 2.0 * max(omega_max, abs(omega_out))


def rate_bound(p: Parameters, y: State, omega_max: float) -> float:
    """max(natural rate, forcing rate): the free motion and the 2x forcing (:func:`forcing_rate`), the larger
    resolved, not their sum (``rk4.fastest_rate``): the protocol's RK4 rule, not used by the FMU, which steps with
    :func:`integrate`."""
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


def advice(p: Parameters, inertia: float | None = None, held: str = "with the input held") -> list:
    """Warnings on valid parameters that are likely not what was meant: c_s left at the default ring's 87 EI/R
    while R, d or E describe another ring (c_s is a parameter of its own, not derived from them); a stiff ring
    without damping (c_s > 0, c_d = 0: a mode sqrt(c_s / inertia) undamped within the coupling, inertia I2 with the
    input held, whose 2x crossing grows without bound unless the load or the drive damps it); a misalignment
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
    if p.c_s > 0.0 and p.c_d == 0.0:
        inertia = p.I2 if inertia is None else inertia
        w_n = math.sqrt(p.c_s / inertia)
        messages.append(f"c_d = 0 with c_s = {p.c_s:.6g} N.m/rad: the coupling's torsional mode, {w_n:.4g} rad/s "
                        f"{held}, has no damping within the coupling, so unless the load or the drive damps it a "
                        "run's start-up oscillation never decays (its amplitudes depend on how long the run is) and "
                        f"near a running speed of {0.5 * w_n:.4g} rad/s, where the 2x excitation meets it, the "
                        "response grows without bound; give the ring its damping, e.g. 10% of critical, c_d = "
                        f"{0.2 * math.sqrt(p.c_s * inertia):.4g} N.m.s/rad (0.2 sqrt(c_s J), J the mode's inertia), or "
                        "c_s = 0 for the paper's undamped pendulum case (Eq. 9)")
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
        if j_in >= MIN_SHAFT_INERTIA:   # else refused by the check
            mobility = 1.0 / self.I2 + 1.0 / j_in
            self.natural_rate = math.sqrt((self.c_s + self.mp_amplitude) * mobility) + self.c_d * mobility
            # the exponential integrator's (torque_exponential_steps): the rigid rotation and the twist oscillator
            # of the reduced inertia; N's rates, sqrt(M_p amplitude (4 / (J_in + I2) + kappa (1/I2 - 1/J_in)))
            self.linear = (RIGID_BLOCK, linear_blocks(self.c_s, self.c_d, 1.0 / mobility)[0])
            self.linear_rate = math.sqrt(self.c_s * mobility) + self.c_d * mobility
            total = j_in + self.I2
            self.remainder_rate = math.sqrt(self.mp_amplitude * (4.0 / total + (j_in - self.I2) ** 2
                                                                 / (total * j_in * self.I2)))


def input_acceleration(p: TorqueDrivenParameters, tau_in: float, m_p: float, elastic: float) -> float:
    """alpha1 of the free shaft 1, (J_drive + I1) alpha1 = tau_in + M_p + c_s x_e + c_d x_e' (the ring's torque on
    shaft 1: -dPi/dphi1 = M_p and the elastic torque's reaction, see the module docstring), from M_p and the
    elastic torque on shaft 2 of :func:`torques` at the state."""
    return (tau_in + m_p - elastic) / (p.J_drive + p.I1)


def torque_exponential_steps(p: TorqueDrivenParameters, y: Sequence[float], t_span: float, n: int, tau_in: float,
                             tau_load: float) -> tuple:
    """The torque-driven coupling's state (phi1, w1, phi2, w2) after t_span (the torques held) by n substeps of
    Krogstad's method (:func:`exponential_steps`) in the coordinates of its two motions, J_in = J_drive + I1,
    J = J_in + I2: the rigid rotation theta = (J_in phi1 + I2 phi2) / J and the twist x = phi2 - phi1 - offset,
        J theta'' = tau_in - tau_load + 2 M_p
        x'' = -(c_s x + c_d x') (1/I2 + 1/J_in) + M_p (1/I2 - 1/J_in) - tau_load / I2 - tau_in / J_in
        M_p = 157 (EI/R^3) e^2 cos(2 theta + kappa (x + offset)),  kappa = (J_in - I2) / J
    (the shafts' equations of :meth:`TorqueDriven.derivatives` added and subtracted; M_p acts on both shafts). L
    holds the rotation's block (0, 1; 0, 0) and the twist's oscillator exactly; N = (0, g_theta, 0, g_x) its
    remainders."""
    h = t_span / n
    (er, fr, q1r, q2r, r1r, r2r, s1r, s2r), (e, f, q1, q2, r1, r2, s1, s2) = operators(p, h)
    j_in, i2 = p.J_drive + p.I1, p.I2
    c1, c2 = j_in / (j_in + i2), i2 / (j_in + i2)
    kappa, offset, amplitude, cos = c1 - c2, p.offset, p.mp_amplitude, math.cos
    rigid, rigid_mp = (tau_in - tau_load) / (j_in + i2), 2.0 / (j_in + i2)
    twist, twist_mp = -tau_load / i2 - tau_in / j_in, 1.0 / i2 - 1.0 / j_in
    phi1, w1, phi2, w2 = y
    th, om, x, v = c1 * phi1 + c2 * phi2, c1 * w1 + c2 * w2, phi2 - phi1 - offset, w2 - w1
    for _ in range(n):
        mp = amplitude * cos(2.0 * th + kappa * (x + offset))
        nr, nx = rigid + rigid_mp * mp, twist + twist_mp * mp
        ath, ax = er[0] * th + er[1] * om + q1r[0] * nr, e[0] * x + e[1] * v + q1[0] * nx
        mp_a = amplitude * cos(2.0 * ath + kappa * (ax + offset))
        dar, dax = rigid_mp * mp_a + rigid - nr, twist_mp * mp_a + twist - nx
        bth, bx = ath + q2r[0] * dar, ax + q2[0] * dax
        mp_b = amplitude * cos(2.0 * bth + kappa * (bx + offset))
        dbr, dbx = rigid_mp * mp_b + rigid - nr, twist_mp * mp_b + twist - nx
        cth, com = fr[0] * th + fr[1] * om + r1r[0] * nr, fr[2] * th + fr[3] * om + r1r[1] * nr
        cx, cv = f[0] * x + f[1] * v + r1[0] * nx, f[2] * x + f[3] * v + r1[1] * nx
        mp_c = amplitude * cos(2.0 * (cth + r2r[0] * dbr) + kappa * (cx + r2[0] * dbx + offset))
        dcr, dcx = rigid_mp * mp_c + rigid - nr, twist_mp * mp_c + twist - nx
        sr, sx = dar + dbr, dax + dbx
        th, om = cth + s1r[0] * sr + s2r[0] * dcr, com + s1r[1] * sr + s2r[1] * dcr
        x, v = cx + s1[0] * sx + s2[0] * dcx, cv + s1[1] * sx + s2[1] * dcx
    return th - c2 * (x + offset), om - c2 * v, th + c1 * (x + offset), om + c1 * v


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
    def input_acceleration(p: TorqueDrivenParameters, y: tuple, u: Torques) -> float:
        """Shaft 1's acceleration at the state y under the torques u (:func:`input_acceleration`)."""
        m_p, _, elastic = torques(p, y[0], y[1], y[2], y[3])
        return input_acceleration(p, u.tau_in, m_p, elastic)

    @staticmethod
    def integrate(p: TorqueDrivenParameters, t: float, h: float, y: tuple, u: Torques) -> tuple:
        """The FMU's step: :func:`torque_exponential_steps` in :func:`exponential_substeps` at shaft 1's speed bound
        over the step, |w1| + |alpha1| h, and shaft 2's speed."""
        reach = abs(y[1]) + abs(TorqueDriven.input_acceleration(p, y, u)) * h
        n = exponential_substeps(p, h, reach, y[3])
        return torque_exponential_steps(p, y, h, n, u.tau_in, u.tau_load)

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

    @staticmethod
    def advice(p: TorqueDrivenParameters) -> list:
        """:func:`advice` with the coupling's two-mass mode: the reduced inertia J_in I2 / (J_in + I2), J_in =
        J_drive + I1."""
        j_in = p.J_drive + p.I1
        return advice(p, j_in * p.I2 / (j_in + p.I2) if j_in > 0.0 else None,
                      "with the input shaft free (J_drive + I1 against I2)")
    free_output_inertia = staticmethod(free_output_inertia)

    @staticmethod
    def check(p: TorqueDrivenParameters) -> list:
        """:func:`check`, and shaft 1 needs an inertia to integrate."""
        return check(p) + shaft_inertia_problems("J_drive + I1", p.J_drive + p.I1, "shaft 1")
