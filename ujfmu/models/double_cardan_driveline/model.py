"""Double Cardan driveline: input shaft -> joint 1 -> intermediate shaft -> joint 2 -> output shaft.

Sources: [Brutti1999] Carlo Brutti, Ettore Pennestri, Marco Evangelos Biancolini, "On the Dynamics of the
Transmission with a Double Cardan Joint", Proceedings of the Tenth World Congress on the Theory of Machines and
Mechanisms (IFToMM), Oulu, Finland, 1999: rigid-body torque analysis, section 4. [Omar2023] M. H. Omar,
M. A. Rahim, M. N. A. M. Rejab, "Numerical Study on the Torsional and Lateral Vibrations of Double Universal Joint
Driveline System", International Journal of Automotive and Mechanical Engineering (IJAME), 2023: torsional-lateral
model, Eqs. (1)-(19).
Derivation and every interpretation: README.md. Standard library only: this module runs inside FMUs.

Angles (rad): phi1 input shaft, phi2 / phi3 the intermediate shaft at its joint-1 / joint-2 end, phi4 output shaft.
One joint with bend b, driving-yoke angle x and driven-yoke angle y (Omar Eq. 4):

    tan y = tan x / cos b,   y = x + joint_error(x, b)                       (continuous, |error| < pi/2)
    dy/dx = cos b / (1 - sin^2 b cos^2 x)               (Omar eta_1, eta_2)
    dy/db = sin(2x) sin b / (2 (1 - sin^2 b cos^2 x))   (Omar eta_1A, eta_2A; the paper prints cos^2(2 phi1))

Joint 1: phi2 = phi1 + joint_error(phi1, b1). Joint 2 is the same relation seen from the output shaft (Omar
Eq. 6): phi3 = phi4 + joint_error(phi4 + delta, b2), delta = yoke_phase - joint_plane_angle the phase of joint 2
relative to joint 1. delta = 0 with b1 = +-b2 is the constant-velocity Z (b1 = b2) or W (b1 = -b2) layout.
Dynamic misalignment phi (Omar Eq. 3): b1 = beta1 + phi, b2 = beta2 + phi*cos(joint_plane_angle).

Lagrangian (Omar Eqs. 9-15 generalised; twist = phi2 - phi3 = -theta_s of Omar Eq. 1):
    T = J_in(phi1) w1^2/2 + J_out(phi4) w4^2/2 + M_lat dphi^2/2,    M_lat = m_s (L_c cos beta1)^2   (Eq. 11)
    P = k_theta twist^2/2 + k_phi (L_c cos beta1)^2 phi^2/2                                        (Eq. 14)
    D = c_theta dtwist^2/2 + c_phi (L_c cos beta1)^2 dphi^2/2,    c = xi k                          (Eq. 12)
J_in, J_out: the inertias kinematically tied to phi1 / phi4, evaluated at the static joint angles.
"""

import functools
import math
from math import atan2, cos, sin
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from ...fmu import rk4, series
from ..protocol import (MIN_SHAFT_INERTIA, NEGLIGIBLE_SWING, Drive, Torques, joint_angle_advice,
                        phase_angle_advice, shaft_inertia_problems, torque_driven_outputs)

#: Largest admissible magnitude of a joint angle (static plus dynamic) [rad].
MAX_ANGLE = math.radians(89.0)
HALF_PI = 0.5 * math.pi
#: the order of the input speed the outputs carry at full size: each joint's 2x (their 4x, ... are smaller by q, ...,
#: q = tan^2(beta/2)); a record must sample it (``ujfmu.scenario_run``)
EXCITATION_ORDER = 2


def excitation_order(p: "Parameters") -> int:
    """``EXCITATION_ORDER`` where a joint is bent; straight joints carry none (the speed ratios are 1, the inertias
    constant, the shaft's lateral coupling g zero), nor joints whose speed-ratio swing, about beta^2 / 2, is below
    ``protocol.NEGLIGIBLE_SWING``."""
    return EXCITATION_ORDER if 0.5 * max(p.beta1 * p.beta1, p.beta2 * p.beta2) > NEGLIGIBLE_SWING else 0


def excited_orders(p: "Parameters") -> tuple:
    """The orders of the input speed the outputs carry at full size at p: the joints' 2x alone (their kinematics
    repeat every half turn: no odd order), or none (:func:`excitation_order`)."""
    return (EXCITATION_ORDER,) if excitation_order(p) else ()


def joint_error(x: float, b: float) -> float:
    """y - x for tan y = tan x / cos b: atan2((1 - c) sin 2x, (1 + c) - (1 - c) cos 2x), c = cos b (Omar Eq. 4)."""
    return _error(math.sin(x), math.cos(x), math.cos(b))


def _error(sx: float, cx: float, c: float) -> float:
    """:func:`joint_error` from sin x, cos x and cos b (sin 2x = 2 sx cx, cos 2x = (cx - sx)(cx + sx))."""
    return math.atan2((1.0 - c) * 2.0 * sx * cx, (1.0 + c) - (1.0 - c) * (cx - sx) * (cx + sx))


def joint_inverse(y: Sequence[float], b: float) -> float:
    """x with y = x + joint_error(x, b): x = y + joint_error(y + pi/2, b) (tan x = cos b tan y)."""
    return y + joint_error(y + HALF_PI, b)


def joint_ratio(x: float, b: float) -> tuple:
    """(dy/dx, d2y/dx2, dy/db) of one joint (Omar eta_1 and eta_1A, corrected)."""
    return _ratio(math.sin(x), math.cos(x), math.sin(b), math.cos(b))


def _ratio(sx: float, cx: float, s: float, c: float) -> tuple:
    """:func:`joint_ratio` from sin x, cos x, sin b, cos b."""
    d = 1.0 - s * s * cx * cx
    r = c / d
    return r, -r * s * s * 2.0 * sx * cx / d, s * sx * cx / d


def cross_inertia(x: float, b: float, i_pin: float, i_normal: float) -> tuple:
    """(J, dJ/dx): kinetic energy of a joint's cross is J(x) w_x^2 / 2, w_x the driving yoke's speed.

    The cross turns about e_A, e_B (pins, i_pin each) and e_n (normal, i_normal) at rates
    (r w sin b cos x, w sin b sin x / sqrt(d), w cos b / sqrt(d)),  d = 1 - sin^2 b cos^2 x,  r = cos b / d.
    """
    return _cross_inertia(math.sin(x), math.cos(x), math.sin(b), math.cos(b), i_pin, i_normal)


def _cross_inertia(sx: float, cx: float, s: float, c: float, i_pin: float, i_normal: float) -> tuple:
    """:func:`cross_inertia` from sin x, cos x, sin b, cos b."""
    s2x = 2.0 * sx * cx
    d = 1.0 - s * s * cx * cx
    dd = s * s * s2x
    r = c / d
    dr = -r * dd / d
    pin = r * r * cx * cx + sx * sx / d
    dpin = 2.0 * r * dr * cx * cx - r * r * s2x + s2x / d - sx * sx * dd / (d * d)
    return (i_pin * s * s * pin + i_normal * c * c / d,
            i_pin * s * s * dpin - i_normal * c * c * dd / (d * d))


@dataclass(slots=True)
class Parameters:
    """The DoubleCardanDriveline FMU's parameters (names as declared there) and the constants the equations use:
    delta = yoke_phase - joint_plane_angle (joint 2's phase relative to joint 1), c = xi k (Omar Eq. 12),
    lever2 = (L_c cos beta1)^2 and m_lat = m_s lever2 (Omar Eqs. 11, 14), sin and cos of the static joint angles
    (the inertias J_in, J_out are evaluated at them), whether the crosses and the intermediate shaft have no
    inertia (constant_inertias: J_in = I_input and J_out = J_load at every angle), and the natural-rate bound of
    the flexible equations (0 for a rigid shaft, or where :func:`check` refuses the parameters), and the exponential
    Adams method's linear part and rate (:func:`linear_part`: J_mean, linear, its speed rows linear_rows,
    remainder_rate), and the joints' largest kinematic errors at dynamic misalignments up to 0.2 rad (twist_slack:
    :func:`state_advice`).
    outputs_memo: the outputs' last evaluation of the equations, which the step after them and a second read reuse
    (:func:`_output_rates`); adams_memo: the method's operators for the last substep length
    (:func:`adams_operators`); per parameters object, so per FMU instance; neither a parameter nor compared."""

    beta1: float
    beta2: float
    yoke_phase: float
    joint_plane_angle: float
    I_input: float
    I_cross_pin: float
    I_cross_normal: float
    I_intermediate: float
    J_load: float
    k_theta: float
    xi_theta: float
    m_s: float
    k_phi: float
    xi_phi: float
    L_c: float
    rigid_intermediate_shaft: bool = False
    phi_in_start: float = 0.0
    delta: float = field(init=False, repr=False)
    cos_plane: float = field(init=False, repr=False)
    c_theta: float = field(init=False, repr=False)
    c_phi: float = field(init=False, repr=False)
    lever2: float = field(init=False, repr=False)
    m_lat: float = field(init=False, repr=False)
    sc_beta1: tuple = field(init=False, repr=False)
    sc_beta2: tuple = field(init=False, repr=False)
    natural_rate: float = field(init=False, repr=False)
    mode_rate: float = field(init=False, repr=False)
    constant_inertias: bool = field(init=False, repr=False)
    J_mean: float = field(init=False, repr=False)
    linear: tuple = field(init=False, repr=False)
    linear_rows: tuple = field(init=False, repr=False)
    remainder_rate: float = field(init=False, repr=False)
    ringing_rate: float = field(init=False, repr=False)
    twist_slack: float = field(init=False, repr=False)
    outputs_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)
    adams_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        self.delta = self.yoke_phase - self.joint_plane_angle
        self.cos_plane = math.cos(self.joint_plane_angle)
        self.c_theta = self.xi_theta * self.k_theta
        self.c_phi = self.xi_phi * self.k_phi
        self.lever2 = (self.L_c * math.cos(self.beta1)) ** 2   # (L_c cos beta0)^2 of Omar Eqs. (11), (12), (14)
        self.m_lat = self.m_s * self.lever2
        self.sc_beta1 = (math.sin(self.beta1), math.cos(self.beta1))
        self.sc_beta2 = (math.sin(self.beta2), math.cos(self.beta2))
        self.constant_inertias = self.I_cross_pin == 0.0 and self.I_cross_normal == 0.0 and self.I_intermediate == 0.0
        flexible = not self.rigid_intermediate_shaft and self.J_load > 0.0
        self.natural_rate = natural_rate_bound(self) if flexible else 0.0
        self.mode_rate = mode_rate_bound(self) if flexible else 0.0
        self.J_mean = mean_output_inertia(self) if flexible else 0.0
        self.linear = linear_part(self) if flexible else ()
        self.linear_rows = (*self.linear[0][1], *self.linear[1][1]) if flexible else ()
        self.remainder_rate = remainder_rate_bound(self) if flexible else 0.0
        self.ringing_rate = ringing_rate(self) if flexible else 0.0
        self.twist_slack = (_joint_error_bound(abs(self.beta1) + _TWIST_GATE_PHI)
                            + _joint_error_bound(abs(self.beta2) + _TWIST_GATE_PHI))


def input_inertia(p: Parameters, phi1: float) -> tuple:
    """(J_in, dJ_in/dphi1): input shaft, cross 1 and the joint-1 half of the intermediate shaft."""
    if p.constant_inertias:
        return p.I_input, 0.0
    return _shaft_end_inertia(p, p.I_input, math.sin(phi1), math.cos(phi1), p.sc_beta1)


def output_inertia(p: Parameters, phi4: float) -> tuple:
    """(J_out, dJ_out/dphi4): driven load, cross 2 and the joint-2 half of the intermediate shaft."""
    if p.constant_inertias:
        return p.J_load, 0.0
    u4 = phi4 + p.delta
    return _shaft_end_inertia(p, p.J_load, math.sin(u4), math.cos(u4), p.sc_beta2)


def _shaft_end_inertia(p: Parameters, shaft: float, sx: float, cx: float, sc_beta: tuple) -> tuple:
    """(J, dJ/dx) of a shaft of inertia ``shaft``, its joint's cross and the half of the intermediate shaft at that
    joint, from sin x, cos x of the joint's driving-yoke angle x and (sin b, cos b) of its static angle."""
    jc, djc = _cross_inertia(sx, cx, sc_beta[0], sc_beta[1], p.I_cross_pin, p.I_cross_normal)
    r, dr, _ = _ratio(sx, cx, sc_beta[0], sc_beta[1])
    half = 0.5 * p.I_intermediate
    return shaft + jc + half * r * r, djc + 2.0 * half * r * dr


# --- rigid intermediate shaft (Brutti, section 4): one degree of freedom, phi1 imposed -------------------------

def rigid_output_angle(p: Parameters, phi1: float) -> float:
    """phi4(phi1) through both joints with an untwisted shaft (phi3 = phi2)."""
    phi2 = phi1 + joint_error(phi1, p.beta1)
    return joint_inverse(phi2 + p.delta, p.beta2) - p.delta


def rigid_state(p: Parameters, phi1: float, omega1: float, alpha1: float, tau_load: float) -> dict:
    """Rigid driveline at the imposed input motion. T = J_eq(phi1) w1^2 / 2 with

        J_eq = J_in + J_out rho^2,   rho = dphi4/dphi1 = r1 / r2,
    and Lagrange with the load's virtual work (-tau_load dphi4):
        tau_in = J_eq alpha1 + J_eq' w1^2 / 2 + rho tau_load.
    The output shaft's acceleration is alpha4 = rho alpha1 + rho' w1^2, and the torque at its flange (joint 2's
    output yoke) tau_out = J_load alpha4 + tau_load.
    Returns dict: phi2, phi4, omega2, omega4, tau_in, shaft_torque (at the middle of the intermediate shaft), energy,
    inertia (J_eq), tau_out.
    """
    phi2 = phi1 + joint_error(phi1, p.beta1)
    phi4 = joint_inverse(phi2 + p.delta, p.beta2) - p.delta
    r1, dr1, _ = joint_ratio(phi1, p.beta1)
    r2, dr2, _ = joint_ratio(phi4 + p.delta, p.beta2)
    rho = r1 / r2
    drho = dr1 / r2 - r1 * dr2 * rho / (r2 * r2)
    j_in, dj_in = input_inertia(p, phi1)
    j_out, dj_out = output_inertia(p, phi4)
    j_eq = j_in + j_out * rho * rho
    dj_eq = dj_in + dj_out * rho * rho * rho + 2.0 * j_out * rho * drho
    w2 = omega1 * omega1
    tau_in = j_eq * alpha1 + 0.5 * dj_eq * w2 + rho * tau_load
    shaft = (tau_in - j_in * alpha1 - 0.5 * dj_in * w2) / r1
    return {"phi2": phi2, "phi4": phi4, "omega2": r1 * omega1, "omega4": rho * omega1, "tau_in": tau_in,
            "shaft_torque": shaft, "energy": 0.5 * j_eq * w2, "inertia": j_eq,
            "tau_out": p.J_load * (rho * alpha1 + drho * w2) + tau_load}


# --- flexible intermediate shaft (Omar, Eqs. 16-19 re-derived): states phi4, w4, phi, dphi ----------------------

def flexible_kinematics(p: Parameters, phi1: float, omega1: float,
        phi4: float, omega4: float, phi: float, dphi: float) -> tuple:
    """Twist, twist rate and the partials the equations need.

    Returns (twist, dtwist, r1, r2, g, e1): twist = phi2 - phi3, r1 = dphi2/dphi1, r2 = dphi3/dphi4,
    e1 = dphi2/db1, g = d(twist)/d(phi) = e1 - cos(plane) dphi3/db2 (Omar eta_1A - eta_2A), and
    dtwist = r1 w1 - r2 w4 + g dphi (Omar Eq. 18 with theta_s = -twist).
    """
    u4 = phi4 + p.delta
    return _kinematics(p, phi1, math.sin(phi1), math.cos(phi1), omega1,
                       phi4, math.sin(u4), math.cos(u4), omega4, phi, dphi)


def _kinematics(p, phi1, s1, c1, omega1, phi4, s4, c4, omega4, phi, dphi):
    """:func:`flexible_kinematics` from the sines and cosines s1, c1 of phi1 and s4, c4 of phi4 + delta."""
    b1 = p.beta1 + phi
    b2 = p.beta2 + phi * p.cos_plane
    sb1, cb1, sb2, cb2 = math.sin(b1), math.cos(b1), math.sin(b2), math.cos(b2)
    r1, _, e1 = _ratio(s1, c1, sb1, cb1)
    r2, _, e2 = _ratio(s4, c4, sb2, cb2)
    g = e1 - p.cos_plane * e2
    twist = (phi1 + _error(s1, c1, cb1)) - (phi4 + _error(s4, c4, cb2))
    return twist, r1 * omega1 - r2 * omega4 + g * dphi, r1, r2, g, e1


def flexible_derivatives(p: Parameters, phi1: float, omega1: float, state: Sequence[float], tau_load: float) -> tuple:
    """d/dt of (phi4, w4, phi, dphi): Lagrange's equations of the T, P, D above (cf. Omar Eqs. 16, 17, 19):

        J_out dw4/dt = r2 (k_theta twist + c_theta dtwist) - J_out' w4^2 / 2 - tau_load
        M_lat d2phi/dt2 = -(L_c cos beta1)^2 (c_phi dphi + k_phi phi) - g (k_theta twist + c_theta dtwist)
    """
    return _flexible_rates(p, phi1, omega1, state, tau_load)[0]


def _flexible_rates(p, phi1, omega1, state, tau_load):
    """(flexible_derivatives, r1, shaft torque k_theta twist + c_theta dtwist, twist, e1 = dphi2/db1, the output
    shaft's torque before the load r2 S - J_out' w4^2 / 2, J_out), straight-line: the integrator's inner loop and the outputs' kinematics. The same equations as
    :func:`flexible_kinematics` and :func:`output_inertia` (tests compare them), each sine and cosine once, no
    calls: joint i at yoke angle x and angle b (sx, cx, sb, cb its sines and cosines) has d = 1 - sb^2 cx^2,
    dy/dx = cb / d, dy/db = sb sx cx / d and y - x = atan2((1 - cb) sin 2x, (1 + cb) - (1 - cb) cos 2x) (Omar
    Eq. 4) = atan2(q sx cx, 1 - q cx^2), q = 1 - cb (both arguments halved, cos 2x = 2 cx^2 - 1); J_out is :func:`cross_inertia` at the static beta2 plus half the intermediate shaft's inertia times
    (dy/dx)^2, or J_load (dJ_out = 0) without crosses and intermediate-shaft inertia (``constant_inertias``: the
    terms it skips are all zero then)."""
    phi4, omega4, phi, dphi = state
    u4 = phi4 + p.delta
    s1, c1, s4, c4 = sin(phi1), cos(phi1), sin(u4), cos(u4)
    b1 = p.beta1 + phi
    b2 = p.beta2 + phi * p.cos_plane
    sb1, cb1, sb2, cb2 = sin(b1), cos(b1), sin(b2), cos(b2)
    sc1, cc1, sc4, cc4 = s1 * c1, c1 * c1, s4 * c4, c4 * c4
    # the joints at the dynamic angles b1, b2: ratios r, dtwist/dphi = g, twist = phi2 - phi3
    d1 = 1.0 - sb1 * sb1 * cc1
    d2 = 1.0 - sb2 * sb2 * cc4
    r1, r2 = cb1 / d1, cb2 / d2
    e1 = sb1 * sc1 / d1
    g = e1 - p.cos_plane * sb2 * sc4 / d2
    q1, q2 = 1.0 - cb1, 1.0 - cb2
    twist = phi1 + atan2(q1 * sc1, 1.0 - q1 * cc1) - phi4 - atan2(q2 * sc4, 1.0 - q2 * cc4)
    shaft = p.k_theta * twist + p.c_theta * (r1 * omega1 - r2 * omega4 + g * dphi)
    lateral = -(p.c_phi * dphi + p.k_phi * phi) / p.m_s - g * shaft / p.m_lat
    if p.constant_inertias:
        net = r2 * shaft
        return (omega4, (net - tau_load) / p.J_load, dphi, lateral), r1, shaft, twist, e1, net, p.J_load
    # J_out and dJ_out/dphi4: joint 2 at its static angle beta2 (s, c)
    s, c = p.sc_beta2
    ss, s2x = s * s, 2.0 * sc4
    d = 1.0 - ss * cc4
    dd = ss * s2x
    r = c / d
    dr = -r * dd / d
    half = 0.5 * p.I_intermediate
    j_out = p.J_load + p.I_cross_pin * ss * (r * r * cc4 + s4 * s4 / d) + p.I_cross_normal * c * c / d + half * r * r
    dj_out = (p.I_cross_pin * ss * (2.0 * r * dr * cc4 - r * r * s2x + s2x / d - s4 * s4 * dd / (d * d))
              - p.I_cross_normal * c * c * dd / (d * d) + 2.0 * half * r * dr)
    net = r2 * shaft - 0.5 * dj_out * omega4 * omega4
    return (omega4, (net - tau_load) / j_out, dphi, lateral), r1, shaft, twist, e1, net, j_out


def flexible_outputs(p: Parameters, phi1: float, omega1: float, alpha1: float, state: Sequence[float]) -> dict:
    """Torques and energy at one instant: dict of twist, dtwist, shaft_torque, tau_in, omega2, energy.

    tau_in = J_in alpha1 + J_in' w1^2 / 2 + r1 (k_theta twist + c_theta dtwist) (Lagrange for the imposed phi1);
    power balance: tau_in w1 - tau_load w4 = dE/dt + c_theta dtwist^2 + c_phi (L_c cos beta1)^2 dphi^2.
    """
    phi4, omega4, phi, dphi = state
    u4 = phi4 + p.delta
    s1, c1, s4, c4 = math.sin(phi1), math.cos(phi1), math.sin(u4), math.cos(u4)
    twist, dtwist, r1, _, _, e1 = _kinematics(p, phi1, s1, c1, omega1, phi4, s4, c4, omega4, phi, dphi)
    shaft = p.k_theta * twist + p.c_theta * dtwist
    j_in, dj_in = _shaft_end_inertia(p, p.I_input, s1, c1, p.sc_beta1)
    j_out, _ = _shaft_end_inertia(p, p.J_load, s4, c4, p.sc_beta2)
    energy = 0.5 * (j_in * omega1 * omega1 + j_out * omega4 * omega4 + p.m_lat * dphi * dphi
                    + p.k_theta * twist * twist + p.k_phi * p.lever2 * phi * phi)
    # joint-1 end of the intermediate shaft: phi2 depends on phi1 and, through b1, on phi
    return {"twist": twist, "dtwist": dtwist, "shaft_torque": shaft,
            "tau_in": j_in * alpha1 + 0.5 * dj_in * omega1 * omega1 + r1 * shaft,
            "omega2": r1 * omega1 + e1 * dphi, "energy": energy}


def _rate_terms(p: Parameters, input_inertia: float) -> tuple:
    """(Lambda, D): upper bounds of the largest eigenvalue of M^-1 K and of M^-1 C, the stiffness and damping of the
    flexible equations linearised in (phi1 if free, phi4, phi) over their mass matrix M: K = k_theta a a^T +
    k_phi (L_c cos beta1)^2 e e^T, C = c_theta a a^T + c_phi (L_c cos beta1)^2 e e^T with a = d(twist)/dq =
    (r1, -r2, g), e the lateral coordinate, both bounded by their traces, with r <= 1/cos b and |g| <= the sum of
    |dy/db| <= tan b / (2 cos b) of both joints."""
    (k_twist, c_twist), (k_support, c_support) = _rate_parts(p, input_inertia)
    return k_twist + k_support, c_twist + c_support


def _rate_parts(p: Parameters, input_inertia: float) -> tuple:
    """((stiffness, damping) terms of :func:`_rate_terms`) of the intermediate shaft's torsion and of the lateral
    support, the parts it sums."""
    mobility = _twist_mobility(p, input_inertia)
    return (p.k_theta * mobility, p.c_theta * mobility), (p.k_phi / p.m_s, p.c_phi / p.m_s)


def _twist_mobility(p: Parameters, input_inertia: float) -> float:
    """a^T M^-1 a of :func:`_rate_terms`: the twist's mobility, with r <= 1/cos b and |g| <= tan b / (2 cos b)."""
    r_max = 1.0 / min(math.cos(p.beta1), math.cos(p.beta2))  # dy/dx <= 1/cos b
    g_max = 0.5 * (  # |dy/db| <= tan b / (2 cos b)
                   abs(math.tan(p.beta1)) / math.cos(p.beta1) + abs(math.tan(p.beta2)) / math.cos(p.beta2))
    return r_max * r_max * (1.0 / p.J_load + 1.0 / input_inertia) + g_max ** 2 / p.m_lat


def rate_sources(p: Parameters, input_inertia: float = math.inf) -> list:
    """(what, rate [1/s]) of each part of the flexible equations' rate bound (:func:`_rate_parts`; input_inertia as
    there), sqrt(stiffness) + damping of each with the parameters that set it: the intermediate shaft's torsion and
    the lateral support's motion; [] for a rigid shaft. A step refused for its substeps names them."""
    if p.rigid_intermediate_shaft or not p.J_load > 0.0:
        return []
    (k_twist, c_twist), (k_support, c_support) = _rate_parts(p, input_inertia)
    return [(f"the intermediate shaft's torsion (k_theta = {p.k_theta:g} N.m/rad, xi_theta = {p.xi_theta:g} s, "
             f"J_load = {p.J_load:g} kg.m2)", math.sqrt(k_twist) + c_twist),
            (f"the lateral support (k_phi = {p.k_phi:g} N/m, xi_phi = {p.xi_phi:g} s, m_s = {p.m_s:g} kg)",
             math.sqrt(k_support) + c_support)]


def natural_rate_bound(p: Parameters, input_inertia: float = math.inf) -> float:
    """An upper bound [1/s] of the fastest free motion of the flexible equations: sqrt(Lambda) + D of
    :func:`_rate_terms` (the largest oscillation plus the largest decay rate; RK4's substep rule, :func:`rate_bound`).

    input_inertia: a lower bound of the inertia on the input shaft when that shaft is free (torque-driven), which
    adds its side of the torsional mode, k_theta r^2 (1/J_out + 1/J_in); inf for a prescribed input shaft.
    """
    stiffness, damping = _rate_terms(p, input_inertia)
    return math.sqrt(stiffness) + damping


def mode_rate_bound(p: Parameters, input_inertia: float = math.inf) -> float:
    """An upper bound [1/s] of |lambda| over the eigenvalues of the flexible equations' free motion (the fifth-order
    steps' rule, :func:`fifth_order_steps`), tighter than :func:`natural_rate_bound`'s sum.

    An eigenvalue s with mode v of M s^2 + C s + K (M, C, K symmetric, M > 0, C >= 0) solves m s^2 + c s + k = 0 with
    m = v*Mv, c = v*Cv, k = v*Kv; k/m <= Lambda and, as C = xi_theta (k_theta a a^T) + xi_phi (k_phi ... e e^T)
    <= xi K with xi = max(xi_theta, xi_phi), c <= xi k. Underdamped (c^2 < 4 m k): |s| = sqrt(k/m) <= sqrt(Lambda);
    overdamped: |s| <= (c + sqrt(c^2 - 4 m k)) / 2m, which grows with k/m, so |s| <= (xi Lambda + sqrt(xi^2 Lambda^2
    - 4 Lambda)) / 2, and <= c/m <= D. No mode can be overdamped while xi^2 Lambda <= 4; then |lambda| <=
    sqrt(Lambda). Beyond, the other modes may still be underdamped (an undamped stiff support beside a damped shaft:
    xi_phi = 0, k_phi = 1e8 N/m rings at 4945 rad/s), so the bound is the larger of the two. (The sum sqrt(Lambda) + D
    of :func:`natural_rate_bound` adds the decay rate to the frequency instead: 2.4x |lambda| on the stiff
    torque-driven driveline, whose torsional mode has damping ratio 0.66.)
    """
    stiffness, damping = _rate_terms(p, input_inertia)
    xi = max(p.xi_theta, p.xi_phi)
    if xi * xi * stiffness <= 4.0:
        return math.sqrt(stiffness)
    return max(math.sqrt(stiffness),
               min(damping, 0.5 * (xi * stiffness + math.sqrt(xi * xi * stiffness * stiffness - 4.0 * stiffness))))


def flexible_substeps(natural_rate: float, h: float, omega1_max: float) -> int:
    """RK4 substeps for a step h: each at most RATE_STEP / (natural_rate + 4 |omega1|) long (the kinematics carry
    harmonics 2x, 4x, ... of the input angle with amplitudes q, q^2, ...; :func:`rate_bound`)."""
    return rk4.substeps(natural_rate + 4.0 * omega1_max, h)


def flexible_step(p: Parameters, t_span: float, phi1: float, omega1: float, alpha1: float, state: Sequence[float],
        tau_load: float, substeps: int, k1: Sequence[float] | None = None) -> tuple:
    """Advance the flexible states over t_span, phi1(t) = phi1 + w1 t + alpha1 t^2/2 and tau_load held, where RK4's
    rule asks for ``substeps`` substeps: :func:`fifth_order_steps` steps of :func:`dormand_prince` where it gives
    any, else the RK4 substeps (``rk4.unrolled``); k1: the rates at the start, if the caller has them (not
    evaluated again). Returns the new state."""
    steps = fifth_order_steps(p, t_span, max(abs(omega1), abs(omega1 + alpha1 * t_span)), substeps)
    if steps:
        return _dp5_drive_4(_flexible_rates, p, state, t_span, steps, phi1, omega1, alpha1, tau_load, k1)
    return rk4.unrolled("drive", 4)(drive_derivatives, p, 0.0, state, t_span, substeps, phi1, omega1, alpha1,
                                    tau_load, k1)


def torque_driven_step(p: "TorqueDrivenParameters", t: float, t_span: float, y: Sequence[float], u: Torques,
        omega_max: float, substeps: int, k1: Sequence[float] | None = None) -> tuple:
    """:func:`flexible_step` of the torque-driven driveline: y (:class:`TorqueDriven.State`) at t advanced over
    t_span, the input shaft's speed within omega_max and the torques u held; k1: the rates at the start, if the
    caller has them (not evaluated again)."""
    steps = fifth_order_steps(p, t_span, omega_max, substeps)
    if steps:
        rates = _rigid_driven_rates if p.rigid_intermediate_shaft else _driven_rates
        return _dp5_held_6(rates, p, p.J_drive, y, t_span, steps, u.tau_in, u.tau_load, k1)
    return rk4.integrate_held(TorqueDriven.derivatives, p, t, u, y, t_span, substeps, k1)


# --- the integrator: classical RK4, or Dormand-Prince's fifth-order formula where it is cheaper ----------------

def fifth_order_steps(p: Parameters, h: float, omega_max: float, substeps: int) -> int:
    """Dormand-Prince steps for a step h where RK4's rule (:func:`rate_bound`) asks for ``substeps`` substeps: none
    (0: RK4) where it asks for one, else ceil(h (mode_rate + 4 |omega1|) / (2 RATE_STEP)), each step at most
    2 RATE_STEP = 1 over the bound of every |lambda| (:func:`mode_rate_bound`) plus the kinematics' fastest
    harmonic, where that takes fewer derivative evaluations than the RK4 substeps (6 a step against 4), else 0.

    Accuracy. One step multiplies a mode exp(z), z = h lambda, by R(z) = 1 + z + ... + z^5 / 120 + z^6 / 600 (RK4:
    to z^4 / 24); for an undamped oscillation at the limits, |exp(z) - R(z)| / |z| is 3.6e-4 at w h = 1 against
    RK4's 5.2e-4 at w h = 0.5: 0.69x the error per radian, and 0.51x at w h = 0.8 against RK4 at 0.4 (fifth order
    against fourth). Stability: |R| <= 1 for |z| <= 1 wherever the mode has any damping (Re z <= -0.001); an
    undamped mode exactly at the bound would grow by at most 1.4e-6 a step (|R(i)|); decay is stable to
    h |lambda| = 3.3. RK4's rule keeps natural_rate (frequency plus decay rate) as its substeps were set with it
    (:func:`rate_bound`); a fifth-order step needs only |lambda| <= mode_rate, at most natural_rate.
    """
    if substeps < 2:
        return 0
    steps = start_steps(p, h, omega_max)
    return steps if 6 * steps < 4 * substeps else 0


def dormand_prince(rates, y: Sequence[float], t_span: float, n: int) -> list:
    """n steps of the fifth-order formula of Dormand and Prince's embedded pair (J. R. Dormand, P. J. Prince, "A
    family of embedded Runge-Kutta formulae", Journal of Computational and Applied Mathematics 6 (1), 19-26, 1980,
    doi:10.1016/0771-050X(80)90013-3, Table 2: RK5(4)7M): six stages at c = 0, 1/5, 3/10, 4/5, 8/9, 1, the weights
    b = (35/384, 0, 500/1113, 125/192, -2187/6784, 11/84) of the fifth-order solution (its seventh stage only serves
    the error estimate, which a fixed step does not use). Fifth order (tests/fmu/test_rk4.py's closed form)."""
    h = t_span / n
    t = 0.0
    for _ in range(n):
        k1 = rates(t, y)
        k2 = rates(t + h / 5, [a + h * (b / 5) for a, b in zip(y, k1)])
        k3 = rates(t + 0.3 * h, [a + h * (3 / 40 * b + 9 / 40 * c) for a, b, c in zip(y, k1, k2)])
        k4 = rates(t + 0.8 * h, [a + h * (44 / 45 * b - 56 / 15 * c + 32 / 9 * d) for a, b, c, d in zip(y, k1, k2, k3)])
        k5 = rates(t + 8 / 9 * h, [a + h * (19372 / 6561 * b - 25360 / 2187 * c + 64448 / 6561 * d - 212 / 729 * e)
                                   for a, b, c, d, e in zip(y, k1, k2, k3, k4)])
        k6 = rates(t + h, [a + h * (9017 / 3168 * b - 355 / 33 * c + 46732 / 5247 * d + 49 / 176 * e
                                    - 5103 / 18656 * f) for a, b, c, d, e, f in zip(y, k1, k2, k3, k4, k5)])
        y = [a + h * (35 / 384 * b + 500 / 1113 * d + 125 / 192 * e - 2187 / 6784 * f + 11 / 84 * g)
             for a, b, d, e, f, g in zip(y, k1, k3, k4, k5, k6)]
        t += h
    return y


#: :func:`dormand_prince`'s stages after the first: the stage's time from the step's start t and its state's increment
#: over h from the earlier stages' rates b, c, d, e, f (k1 ... k5); then the fifth-order solution's (k1, k3 ... k6)
_DP5_STAGES = (("t + h / 5", "{b} / 5"),
               ("t + 0.3 * h", "3 / 40 * {b} + 9 / 40 * {c}"),
               ("t + 0.8 * h", "44 / 45 * {b} - 56 / 15 * {c} + 32 / 9 * {d}"),
               ("t + 8 / 9 * h", "19372 / 6561 * {b} - 25360 / 2187 * {c} + 64448 / 6561 * {d} - 212 / 729 * {e}"),
               ("t + h", "9017 / 3168 * {b} - 355 / 33 * {c} + 46732 / 5247 * {d} + 49 / 176 * {e} - 5103 / 18656 * {f}"))
_DP5_SOLUTION = "35 / 384 * {b} + 500 / 1113 * {d} + 125 / 192 * {e} - 2187 / 6784 * {f} + 11 / 84 * {g}"
#: the unrolled integrators (name, parameters, state size, the rates at stage time s and state {y}): the speed-driven
#: driveline's straight-line ``_flexible_rates`` under the extrapolated input motion, and the torque-driven one's
#: :func:`torque_driven_rates` (or ``_driven_rates``) with the torques held
_DP5_KINDS = (("_dp5_drive_4", "rates, p, y, t_span, n, phi0, w0, alpha, tau_load, k1=None", 4,
               "rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, {y}, tau_load)[0]"),
              ("_dp5_held_6", "rates, p, j_drive, y, t_span, n, tau_drive, tau_load, k1=None", 6,
               "rates(p, j_drive, {y}, tau_drive, tau_load)"))
_GENERATED = "# --- generated by unrolled_source() (python -m ujfmu.models.double_cardan_driveline.model): do not edit ---\n"


def unrolled_source() -> str:
    """The text of this module's generated part: :func:`dormand_prince` with its stage arithmetic written out per
    state component for each of _DP5_KINDS (no per-component loop, list or zip; the same operations in the same
    order, so the same numbers bit for bit: tests), rates called at stage time s as the kind says."""
    text = [_GENERATED]
    for name, params, size, call in _DP5_KINDS:
        def names(letter):
            return ", ".join(f"{letter}{i}" for i in range(size)) + ","

        def vector(combination, letters, indent):
            return "(\n" + "".join(f"{indent}    y{i} + h * ({combination.format(**{k: k + str(i) for k in letters})}),\n"
                                   for i in range(size)) + f"{indent})"
        lines = [f"\n\ndef {name}({params}):", "    h = t_span / n", "    t = 0.0", "    for _ in range(n):",
                 f"        {names('y')} = y", "        if k1 is None:", "            s = t",
                 f"            k1 = {call.format(y='y')}", f"        {names('b')} = k1", "        k1 = None"]
        for (time, increment), letter in zip(_DP5_STAGES, "cdefg"):
            lines += [f"        s = {time}", f"        {names(letter)} = {call.format(y=vector(increment, 'bcdef', ' ' * 8))}"]
        lines += [f"        y = {vector(_DP5_SOLUTION, 'bdefg', ' ' * 8)}", "        t += h", "    return y"]
        text.append("\n".join(lines) + "\n")
    return "".join(text)


def _write_unrolled():
    """Replace this module's generated part with :func:`unrolled_source`."""
    path = Path(__file__)
    text = path.read_text()
    path.write_text(text[:text.index(_GENERATED)] + unrolled_source())


# --- torque-driven input shaft: phi1 is a state, the driver's rotor inertia J_d lumped on it -------------------

def torque_driven_rates(p: Parameters, j_drive: float, state, tau_drive: float, tau_load: float) -> tuple:
    """d/dt of the state under a driving torque tau_drive on the input shaft (which carries J_d).

    Rigid shaft, state (phi1, w1): (J_d + J_eq) alpha1 = tau_drive - J_eq' w1^2 / 2 - rho tau_load, i.e.
    tau_drive = J_d alpha1 + tau_in(alpha1) with tau_in of :func:`rigid_state`, affine in alpha1.
    Flexible shaft, state (phi1, w1, phi4, w4, phi, dphi): Lagrange's phi1 equation of the T, P, D above,
        (J_d + J_in) alpha1 = tau_drive - J_in' w1^2 / 2 - r1 (k_theta twist + c_theta dtwist),
    and :func:`flexible_derivatives` for the rest.
    """
    phi1, omega1 = state[0], state[1]
    if len(state) == 2:
        rest = rigid_state(p, phi1, omega1, 0.0, tau_load)
        return omega1, (tau_drive - rest["tau_in"]) / (j_drive + rest["inertia"])
    return _driven_rates(p, j_drive, state, tau_drive, tau_load)


def _driven_rates(p, j_drive, state, tau_drive, tau_load):
    """:func:`torque_driven_rates` of a flexible shaft (the integrator's inner loop; without crosses and
    intermediate-shaft inertia J_in' = 0 and the term is skipped: the same numbers)."""
    omega1 = state[1]
    rates, r1, shaft = _flexible_rates(p, state[0], omega1, state[2:], tau_load)[:3]
    if p.constant_inertias:
        return (omega1, (tau_drive - r1 * shaft) / (j_drive + p.I_input)) + rates
    j_in, dj_in = input_inertia(p, state[0])
    return (omega1, (tau_drive - 0.5 * dj_in * omega1 * omega1 - r1 * shaft) / (j_drive + j_in)) + rates


def _rigid_driven_rates(p, j_drive, state, tau_drive, tau_load):
    """:func:`torque_driven_rates` of a rigid shaft on the torque-driven state, the flexible entries at rest."""
    return torque_driven_rates(p, j_drive, state[:2], tau_drive, tau_load) + _AT_REST


# --- the exponential Adams method (the FMU's stepper of a flexible shaft under a prescribed input) --------------
#
# Twist coordinates z = y - r(t), r(t) = (phi1(t), omega1(t), 0, 0) the rigid rotation with the input at the double
# joint's mean speed ratio 1: z' = L z + N(t, z), L the constant-coefficient part (:func:`linear_part`) and
# N(t, z) = f(t, r + z) - r'(t) - L z the rest (the joints' kinematic modulation and excitation, the inertias'
# variation, the load, the input's acceleration). The angle rows of f are the speeds, which r' and L z reproduce:
# only N's rows w4 and dphi are non-zero. tau_load and alpha1, held over a step, enter N linearly:
# N_w4 = N0_w4 - tau_load / J_out(phi4) - alpha1.

#: the points of N the method keeps: N at t, t - h, ..., t - 5h
HISTORY_POINTS = 6
#: the history (FMU state): substep h, the time the next step starts at, points held, the tau_load, alpha1 and the
#: input speed at the end of the step that ended there, then per point (newest first) N0's row w4 (without tau_load
#: and alpha1), then per point N's row dphi, then per point 1 / J_out there
HISTORY_SIZE = 6 + 3 * HISTORY_POINTS
#: no history: the next steps start the method with :func:`dormand_prince` steps
NO_HISTORY = (0.0,) * HISTORY_SIZE
#: a change of the held inputs between steps [rad/s^2] (tau_load / J_out, alpha1, omega1's jump from the speed the
#: last step extrapolated to / h) above which the history is discarded: the driven side's acceleration then jumps,
#: which no polynomial through the history follows (the twin rotor's measured threshold, TwinJeffcottRotor)
INPUT_JUMP = 20.0
_NODES = tuple(-float(j) for j in range(HISTORY_POINTS))


def mean_output_inertia(p: Parameters) -> float:
    """J_out averaged over 16 output angles in a half turn (J_out has period pi): the inertia L holds."""
    if p.constant_inertias:
        return p.J_load
    return sum(output_inertia(p, math.pi * k / 16.0)[0] for k in range(16)) / 16.0


def linear_part(p: Parameters) -> tuple:
    """L in twist coordinates (z_phi4, z_w4, phi, dphi), block-diagonal: the torsional oscillator of the aligned
    joints [[0, 1], [-k_theta / J, -c_theta / J]], J the mean output inertia (:func:`mean_output_inertia`), and the
    lateral one [[0, 1], [-k_phi / m_s, -c_phi / m_s]] (M_lat dphi'' = -(L_c cos beta1)^2 (k_phi phi + c_phi dphi))."""
    j = p.J_mean
    return (((0.0, 1.0), (-p.k_theta / j, -p.c_theta / j)), ((0.0, 1.0), (-p.k_phi / p.m_s, -p.c_phi / p.m_s)))


def remainder_rate_bound(p: Parameters) -> float:
    """Bound [1/s] of the fastest rate of N's own stiffness and damping: what the bounds of
    :func:`natural_rate_bound` (Lambda, D of :func:`_rate_terms`) exceed L's stiffness and damping traces by (the
    joints' modulation of the torsional stiffness, their lateral coupling, J_out's variation)."""
    stiffness, damping = _rate_terms(p, math.inf)
    torsion, lateral = p.linear
    return (math.sqrt(max(0.0, stiffness + torsion[1][0] + lateral[1][0]))
            + max(0.0, damping + torsion[1][1] + lateral[1][1]))


def ringing_rate(p: Parameters) -> float:
    """The natural frequency [rad/s] of the fastest underdamped block of L (damping ratio below 1), 0 without one.
    L's part is exact at any step, but N reads the states L moves (the support's tilt enters the joint angles, the
    twist the shaft torque): an underdamped fast mode makes N ring at its frequency, which the Adams polynomial
    through N's history must resolve (an undamped support at k_phi = 1e9 N/m rang at 15600 rad/s, and 1 ms steps
    grew it to 18 rad); an overdamped one dies within a step and leaves N smooth."""
    fastest = 0.0
    for block in p.linear:
        stiffness, damping = -block[1][0], -block[1][1]   # k / m, c / m
        if stiffness > 0.0 and damping * damping < 4.0 * stiffness:
            fastest = max(fastest, math.sqrt(stiffness))
    return fastest


def adams_substeps(p: Parameters, t_span: float, w_max: float) -> int:
    """Substeps of :func:`multistep_step`: each resolves N's own rates (:func:`remainder_rate_bound`), an
    underdamped mode of L that N rings with (:func:`ringing_rate`) and the 2x and 4x excitation of the joints'
    kinematics, 4 |omega1| (``rk4.substeps``: h rate <= RATE_STEP = 0.5). L's part is exact at any h
    (:func:`_phi_block`): a stiff shaft's overdamped modes set no substep."""
    return rk4.substeps(max(p.remainder_rate + 4.0 * w_max, p.ringing_rate), t_span)


def start_steps(p: Parameters, h: float, w_max: float) -> int:
    """Dormand-Prince steps over h, each with h (mode_rate + 4 |omega1|) <= 2 RATE_STEP (:func:`fifth_order_steps`'
    rule), as a substep that starts or restarts :func:`multistep_step` takes them: one on Omar's driveline, more on
    a stiff shaft (``rk4.substeps``' cap refuses a step past what any substeps resolve)."""
    return rk4.substeps(0.5 * (p.mode_rate + 4.0 * w_max), h)


@functools.lru_cache(maxsize=16)
def _adams_operators(linear: tuple, h: float) -> tuple:
    """E(h), Psi and W of :func:`multistep_step` for L's blocks and h as one tuple, memoized: E's blocks row by row
    (8 numbers); Psi on N's speed columns, the torsional block's column w4 (2 rows) then the lateral block's column
    dphi (2 rows); then W on the same four rows, each row over the points j = 0, -1, ..., -5 (24 numbers).
    W_j = h sum_m c_jm m! phi_(m+1)(h L), c_jm the coefficients of theta^m of the Lagrange basis polynomial of node
    j; Psi the same of the corrector's Newton polynomial (``series.integral_coefficients``)."""
    def speed_column(coefficients):
        return tuple(row[0] for block in linear for row in _phi_block(block, h, coefficients, (1,)))
    state = tuple(v for block in linear for row in _phi_block(block, h, (1.0,)) for v in row)
    weights = zip(*(speed_column(series.integral_coefficients(h, c)) for c in series.lagrange_coefficients(_NODES)))
    return (*state, *speed_column(series.integral_coefficients(h, series.newton_coefficients(_NODES))),
            *(v for row in weights for v in row))


def _phi_block(block: tuple, h: float, coefficients: tuple, columns: tuple | None = None) -> list:
    """sum_k coefficients[k] phi_k(h block) of one oscillator block [[0, 1], [-k, -c]]: its Taylor series
    (``series.phi_sum``) where h (sqrt(k) + c) <= 1 bounds h |lambda| (every bundled scenario), else scaling and
    squaring (``series.phi_sum_stiff``: a stiff shaft)."""
    (_, _), (minus_k, minus_c) = block
    if h * (math.sqrt(-minus_k) - minus_c) <= 1.0:
        return series.phi_sum(block, h, coefficients, columns)
    return series.phi_sum_stiff(block, h, coefficients, columns)


def adams_operators(p: Parameters, h: float) -> tuple:
    """:func:`_adams_operators` (p.linear, h), kept on p for the last h (one float compared per call)."""
    memo = p.adams_memo
    if memo is None or memo[0] != h:
        memo = p.adams_memo = h, _adams_operators(p.linear, h)
    return memo[1]


def multistep_step(p: Parameters, t: float, t_span: float, phi1: float, w1: float, alpha1: float,
                   y: Sequence[float], tau_load: float, history: Sequence[float]) -> tuple:
    """(state, history) after t_span from t, phi1(t) quadratic and tau_load held, by an exponential Adams method in
    twist coordinates in PECE mode (Hochbruck, Ostermann, "Exponential multistep methods of Adams-type", BIT Numer.
    Math. 51, 2011): per substep of h from z_n, with N_n = N(t_n, z_n) (the outputs' evaluation where they were
    read) and the history N_j (j = 0, -1, ..., -5), p the quintic through them,
        predict   z* = E(h) z_n + sum_j W_j N_j
        evaluate  N* = N(t_n + h, z*)
        correct   z_n+1 = z* + Psi (N* - p(1))
    the variation-of-constants integral of the interpolated N taken exactly (:func:`_adams_operators`); L's part
    exact at any h. Two evaluations of the equations per substep, the first shared with the outputs: one per step where one
    substep suffices (:func:`adams_substeps`). Order 7 (tests): the corrector is the Adams-Moulton one through N* and
    the six points, its predictor of order 6. The points are kept without tau_load and alpha1
    and recombined with each step's held inputs. Without a history (the first steps, a new substep length, a jump of
    time or of the inputs: ``INPUT_JUMP``) a substep is taken by :func:`dormand_prince` steps (fifth order,
    :func:`start_steps`: one on Omar's driveline), its N_n added to the history until it holds six points."""
    w_max = max(abs(w1), abs(w1 + alpha1 * t_span))
    n = (1 if max(p.remainder_rate + 4.0 * w_max, p.ringing_rate) * t_span <= rk4.RATE_STEP
         else adams_substeps(p, t_span, w_max))
    h = rk4.kept_substep(t_span / n, history[0], t, n)
    count = history[2]
    if count and (history[0] != h or abs(history[1] - t) > 1e-6 * h
                  or abs(tau_load - history[3]) * history[18] + abs(alpha1 - history[4])
                  + abs(w1 - history[5]) / h > INPUT_JUMP):
        count = 0.0
    xs, ds, invs = history[6:12], history[12:18], history[18:24]
    a0, a1, b0, b1 = p.linear_rows
    state, phi, w = y, phi1, w1
    for k in range(1, n + 1):
        z0, z1, z2, z3 = state[0] - phi, state[1] - w, state[2], state[3]
        rates, _, _, _, _, net, j_out = (k == 1 and _served_rates(p, phi, w, y)) or _flexible_rates(p, phi, w, state,
                                                                                                    0.0)
        inverse = 1.0 / j_out
        xs, ds, invs = ((net * inverse - a0 * z0 - a1 * z1,) + xs[:5], (rates[3] - b0 * z2 - b1 * z3,) + ds[:5],
                        (inverse,) + invs[:5])
        te = k * h
        phi_e, w_e = phi1 + te * (w1 + 0.5 * alpha1 * te), w1 + alpha1 * te
        if count < 5.0:
            count += 1.0
            state = _dp5_drive_4(_flexible_rates, p, state, h, start_steps(p, h, w_max), phi, w, alpha1, tau_load,
                                 (rates[0], (net - tau_load) * inverse, rates[2], rates[3]))
            phi, w = phi_e, w_e
            continue
        count = 6.0
        (e0, e1, e2, e3, l0, l1, l2, l3, s0, s1, s2, s3, t0, t1, t2, t3, t4, t5, u0, u1, u2, u3, u4, u5,
         q0, q1, q2, q3, q4, q5, c0, c1, c2, c3, c4, c5) = adams_operators(p, h)
        # each point's N_w4 with this step's inputs, N0_w4 - tau_load / J_out - alpha1
        x0, x1, x2, x3, x4, x5 = xs
        i0, i1, i2, i3, i4, i5 = invs
        x0, x1, x2 = x0 - tau_load * i0 - alpha1, x1 - tau_load * i1 - alpha1, x2 - tau_load * i2 - alpha1
        x3, x4, x5 = x3 - tau_load * i3 - alpha1, x4 - tau_load * i4 - alpha1, x5 - tau_load * i5 - alpha1
        v0, v1, v2, v3, v4, v5 = ds
        # predictor E z + sum_j W_j N_j
        r0 = e0 * z0 + e1 * z1 + t0 * x0 + t1 * x1 + t2 * x2 + t3 * x3 + t4 * x4 + t5 * x5
        r1 = e2 * z0 + e3 * z1 + u0 * x0 + u1 * x1 + u2 * x2 + u3 * x3 + u4 * x4 + u5 * x5
        r2 = l0 * z2 + l1 * z3 + q0 * v0 + q1 * v1 + q2 * v2 + q3 * v3 + q4 * v4 + q5 * v5
        r3 = l2 * z2 + l3 * z3 + c0 * v0 + c1 * v1 + c2 * v2 + c3 * v3 + c4 * v4 + c5 * v5
        f = _flexible_rates(p, phi_e, w_e, (phi_e + r0, w_e + r1, r2, r3), tau_load)[0]
        # corrector + Psi (N* - p(1)), p(1) = 6 N_0 - 15 N_-1 + 20 N_-2 - 15 N_-3 + 6 N_-4 - N_-5 (the quintic)
        d0 = f[1] - alpha1 - a0 * r0 - a1 * r1 - (6.0 * (x0 + x4) - 15.0 * (x1 + x3) + 20.0 * x2 - x5)
        d1 = f[3] - b0 * r2 - b1 * r3 - (6.0 * (v0 + v4) - 15.0 * (v1 + v3) + 20.0 * v2 - v5)
        state = (phi_e + r0 + s0 * d0, w_e + r1 + s1 * d0, r2 + s2 * d1, r3 + s3 * d1)
        phi, w = phi_e, w_e
    return state, (h, t + t_span, count, tau_load, alpha1, w, *xs, *ds, *invs)


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

class State(NamedTuple):
    """Flexible intermediate shaft: output shaft angle and speed, dynamic misalignment and its rate (unused, zero,
    with a rigid shaft)."""

    phi4: float
    omega4: float
    phi: float
    dphi: float


Inputs = Drive

#: the lateral degree of freedom (the dynamic misalignment, Omar Eq. 3): the rest is twist
LATERAL_STATES = ("phi", "dphi")


def kinematic(p: Parameters) -> bool:
    """A rigid intermediate shaft: the output follows the joints' kinematics, nothing to integrate."""
    return p.rigid_intermediate_shaft


def initial_state(p: Parameters, t: float, u: Drive) -> State:
    """Untwisted, phi = 0, the output at the rigid kinematics' angle and speed of the input motion u."""
    if p.rigid_intermediate_shaft:
        return State(0.0, 0.0, 0.0, 0.0)
    return State(rigid_output_angle(p, u.phi), rigid_state(p, u.phi, u.omega, 0.0, 0.0)["omega4"], 0.0, 0.0)


def derivatives(p: Parameters, t: float, y: State, u: Drive) -> tuple:
    """:func:`flexible_derivatives` at the input motion u."""
    return _flexible_rates(p, u.phi, u.omega, y, u.tau_load)[0]


def drive_derivatives(p: Parameters, t: float, y: State, phi: float, omega: float, alpha: float,
        tau_load: float) -> tuple:
    """:func:`derivatives` at the input motion (phi, omega, alpha) and tau_load as plain floats."""
    return _flexible_rates(p, phi, omega, y, tau_load)[0]


def load_output_names(p: Parameters) -> tuple:
    """The outputs that depend on tau_load (:func:`load_outputs`; no input is output-free, as tau_out depends on
    tau_load): a flexible shaft's tau_out alone (tau_load enters only the output shaft's equation of motion), a rigid
    one's tau_in (rho tau_load) and shaft torque too."""
    return ("tau_out",) if not p.rigid_intermediate_shaft else ("tau_in", "shaft_torque", "tau_out")


def load_outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """The outputs of :func:`outputs` that depend on tau_load (:func:`load_output_names`), the same numbers: rigid,
    from :func:`rigid_state`; flexible, tau_out from the outputs' evaluation at this state (:func:`_output_rates`)."""
    if p.rigid_intermediate_shaft:
        out = rigid_state(p, u.phi, u.omega, u.alpha, u.tau_load)
        return {"tau_in": out["tau_in"], "shaft_torque": out["shaft_torque"], "tau_out": out["tau_out"]}
    (_, _, _, _, _, net, j_out), _ = _output_rates(p, u.phi, u.omega, y, y)
    return {"tau_out": output_flange_torque(p, net, j_out, u.tau_load)}


def output_flange_torque(p: Parameters, net: float, j_out: float, tau_load: float) -> float:
    """tau_out = J_load dw4/dt + tau_load, dw4/dt = (net - tau_load) / J_out (:func:`_flexible_rates`): the torque
    joint 2's output yoke passes to the output shaft and load (J_out adds the crosses' and intermediate shaft's
    share to J_load; without them tau_out = net)."""
    return tau_load + p.J_load * (net - tau_load) / j_out


def rate_bound(p: Parameters, y: State, omega_max: float) -> float:
    """The natural-rate bound plus 4 |omega1| (the kinematics carry harmonics 2x, 4x, ... of the input angle).

    The sum, not ``rk4.fastest_rate``'s max: with the max (one substep instead of two at Omar's 684 rpm) the
    error against the monolithic reference grows 16x, as RK4's fourth order says (2^4), to 3.7-4.9x the tolerance
    of double_cardan_omar_torsional, which is set at a few times the error of these substeps."""
    return p.natural_rate + 4.0 * omega_max


def integrate(p: Parameters, t: float, h: float, y: State, u: Drive) -> tuple:
    """The FMU's step of a flexible shaft (a rigid one has nothing to integrate): :func:`flexible_step` from the input
    motion u at the step's start (angle quadratic, speed linear in time, tau_load held), RK4's substep count from
    :func:`rate_bound` at the input speed's bound over the step; its first stage from the outputs' evaluation at
    the same state and input motion where that was the last (:func:`_first_stage`)."""
    omega_max = max(abs(u.omega), abs(u.omega + u.alpha * h))
    return flexible_step(p, h, u.phi, u.omega, u.alpha, y, u.tau_load, rk4.substeps(rate_bound(p, y, omega_max), h),
                         _first_stage(p, y, u))


def integrate_with_history(p: Parameters, t: float, h: float, y: State, u: Drive, history: tuple) -> tuple:
    """The FMU's step of a flexible shaft: (state, history) of :func:`multistep_step` from the input motion u at the
    step's start (angle quadratic, speed linear in time, tau_load held); :func:`integrate` without a history."""
    return multistep_step(p, t, h, u.phi, u.omega, u.alpha, y, u.tau_load, history)


def _output_rates(p: Parameters, phi1: float, omega1: float, y: Sequence[float], key: tuple) -> tuple:
    """(``_flexible_rates(p, phi1, omega1, y, 0.0)``, ``input_inertia(p, phi1)``): the outputs' evaluation, kept in
    p.outputs_memo = (key, phi1, omega1, both) and given from there while key, the state tuple they are at (y, or
    the torque-driven state y is part of; immutable), is the same object and phi1, omega1 the same nonzero floats
    (equal nonzero floats are the same bits; a zero, which may be -0.0, evaluates). A pure cache: anything else
    (another state, a restored FMU state's copy, another input motion) evaluates again."""
    if _served_rates(p, phi1, omega1, key) is not None:
        return p.outputs_memo[3:]
    rates, inertia = _flexible_rates(p, phi1, omega1, y, 0.0), input_inertia(p, phi1)
    p.outputs_memo = key, phi1, omega1, rates, inertia
    return rates, inertia


def _served_rates(p: Parameters, phi1: float, omega1: float, y: tuple) -> tuple | None:
    """``_flexible_rates(p, phi1, omega1, y, 0.0)`` from the outputs' evaluation (:func:`_output_rates`) where it is
    at this state object (or the torque-driven state it is part of: the memo's key) and at phi1, omega1, both
    nonzero (a step's first stage is at phi0 + s (w0 + alpha s / 2) and w0 + alpha s with s = 0.0, which is phi0
    and w0 bit for bit unless one is a zero), else None (evaluate)."""
    memo = p.outputs_memo
    if memo is None or memo[0] is not y or not (memo[1] == phi1 and memo[2] == omega1 and phi1 and omega1):
        return None
    return memo[3]


def _first_stage(p: Parameters, y: State, u: Drive) -> tuple | None:
    """The step's first-stage rates, :func:`flexible_derivatives` at (u.phi, u.omega, y, u.tau_load), from the outputs'
    evaluation where it serves (:func:`_served_rates`), else None. tau_load enters only dw4/dt = (net - tau_load) /
    J_out, computed here from ``_flexible_rates``' net and J_out as it does: the same expression on the same floats,
    bit for bit."""
    flexible = _served_rates(p, u.phi, u.omega, y)
    if flexible is None:
        return None
    rates, _, _, _, _, net, j_out = flexible
    return rates[0], (net - u.tau_load) / j_out, rates[2], rates[3]


def outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """Rigid: :func:`rigid_state`; flexible: :func:`flexible_outputs` at state y (computed straight-line)."""
    if p.rigid_intermediate_shaft:
        out = rigid_state(p, u.phi, u.omega, u.alpha, u.tau_load)
        return {"phi_out": out["phi4"], "omega_out": out["omega4"], "twist": 0.0, "dynamic_misalignment": 0.0,
                "tau_in": out["tau_in"], "shaft_torque": out["shaft_torque"], "omega_intermediate": out["omega2"],
                "stored_energy": out["energy"], "tau_out": out["tau_out"]}
    return flexible_output_values(p, u.phi, u.omega, u.alpha, y, tau_load=u.tau_load)


def flexible_output_values(p: Parameters, phi1: float, omega1: float, alpha1: float | None, y: Sequence[float],
        tau_drive: float = 0.0, j_drive: float | None = None, key: tuple | None = None,
        tau_load: float = 0.0) -> dict:
    """The FMU's outputs: :func:`flexible_outputs` with its kinematics from :func:`_flexible_rates` (tau_load 0),
    one call instead of eight (tests compare them), kept for the step and a second read (:func:`_output_rates`; key:
    the state object y is, or is part of, default y), and tau_out at tau_load (:func:`output_flange_torque`). With
    j_drive (the torque-driven driveline), alpha1 is the input shaft's acceleration under tau_drive
    (:func:`torque_driven_rates`), returned as alpha_in."""
    phi4, omega4, phi, dphi = y
    (rates, r1, shaft, twist, e1, net, j_out), (j_in, dj_in) = _output_rates(p, phi1, omega1, y,
                                                                             y if key is None else key)
    spin, driven = 0.5 * dj_in * omega1 * omega1, r1 * shaft
    if j_drive is not None:
        j_drive += j_in
        alpha1 = (tau_drive - spin - driven) / j_drive
    values = {"phi_out": phi4, "omega_out": omega4, "dynamic_misalignment": phi, "twist": twist,
              "tau_in": j_in * alpha1 + spin + driven, "shaft_torque": shaft,
              "tau_out": output_flange_torque(p, net, j_out, tau_load),
              "omega_intermediate": r1 * omega1 + e1 * dphi,
              "stored_energy": 0.5 * (j_in * omega1 * omega1 + j_out * omega4 * omega4 + p.m_lat * dphi * dphi
                                      + p.k_theta * twist * twist + p.k_phi * p.lever2 * phi * phi)}
    if j_drive is not None:
        values["alpha_in"] = alpha1
    return values


def free_output_inertia(p: Parameters) -> float | None:
    """The output side's mean inertia (:func:`mean_output_inertia`: J_load and what the joint passes on) behind the
    intermediate shaft's compliance; None with a rigid shaft (the output then follows the joints' kinematics)."""
    return None if p.rigid_intermediate_shaft else p.J_mean


def advice(p: Parameters) -> list:
    """Warnings on valid parameters likely not meant: a joint angle past ``protocol.LARGE_JOINT_ANGLE``, a phase
    that is a whole number of radians (``protocol.phase_angle_advice``): degrees given as radians? Joints of one
    angle (a Z or W layout) are named in one warning."""
    if p.beta1 == p.beta2 or p.beta1 == -p.beta2:
        joints = joint_angle_advice("beta1 = beta2" if p.beta1 == p.beta2 else "beta1 = -beta2", p.beta1)
    else:
        joints = joint_angle_advice("beta1", p.beta1) + joint_angle_advice("beta2", p.beta2)
    return (joints
            + phase_angle_advice("yoke_phase", p.yoke_phase)
            + phase_angle_advice("joint_plane_angle", p.joint_plane_angle))


def check(p: Parameters) -> list:
    """A rigid cross has I_normal <= 2 I_pin; a flexible shaft needs an output inertia."""
    problems = []
    if p.I_cross_normal > 2.0 * p.I_cross_pin:
        problems.append(f"I_cross_normal = {p.I_cross_normal!r} kg.m2 exceeds 2*I_cross_pin = "
                        f"{2.0 * p.I_cross_pin!r} kg.m2 (allowed range [0, 2*I_cross_pin] kg.m2: a rigid "
                        "cross has I_normal <= I_pin + I_pin)")
    if not p.rigid_intermediate_shaft and not p.J_load > 0.0:
        problems.append(f"J_load = {p.J_load!r} kg.m2 must be > 0 with a flexible intermediate shaft "
                        "(allowed range (0, 1000000] kg.m2; 0 only with rigid_intermediate_shaft = true)")
    return problems


#: twist [rad] of the intermediate shaft past which :func:`state_advice` warns: a steel propshaft yields at about
#: tau_yield L / (G r), 0.19 rad for L = 1.5 m, r = 40 mm (400 MPa, 80 GPa), and Omar's laboratory shaft twists
#: less than 0.09 rad through both its critical speeds (the bundled references)
LARGE_TWIST = 0.5
#: the intermediate shaft's torsional stiffness of Omar's laboratory rig [N.m/rad] (Table 1), the FMU's default
OMAR_K_THETA = 92.2
#: dynamic misalignment [rad] up to which :func:`state_advice` bounds the joints' kinematic errors without
#: evaluating them
_TWIST_GATE_PHI = 0.2


def _joint_error_bound(b: float) -> float:
    """max over x of |y - x| for tan y = tan x / cos b: atan((1 - cos b) / (2 sqrt(cos b))) (at tan x = sqrt(cos b))."""
    c = math.cos(min(abs(b), MAX_ANGLE))
    return math.atan((1.0 - c) / (2.0 * math.sqrt(c)))


def state_advice(p: Parameters, h: float, y: State, u: Drive) -> list:
    """A warning where the flexible intermediate shaft's twist phi2 - phi3 passes ``LARGE_TWIST``: valid for the
    model, whose torsion is linear at any twist, but not for a real shaft, so the shaft's parameters are likely not
    the user's (the defaults are Omar's laboratory rig: a truck's torque twists its 92.2 N.m/rad by over 10 rad).
    The input angle at the step's end, phi + h (omega + alpha h / 2), is the FMU's; the kinematics are evaluated only
    where |phi1 - phi4| is within the joints' largest kinematic errors of the bound."""
    if p.rigid_intermediate_shaft:
        return []
    return _twist_advice(p, u.phi + h * (u.omega + 0.5 * u.alpha * h), y)


def _twist_advice(p: Parameters, phi1: float, y: Sequence[float]) -> list:
    """:func:`state_advice` at the input angle phi1 and the speed-driven state y (phi4, omega4, phi, dphi)."""
    phi4, _, phi, _ = y
    if abs(phi) <= _TWIST_GATE_PHI and abs(phi1 - phi4) <= LARGE_TWIST - p.twist_slack:
        return []
    twist = flexible_kinematics(p, phi1, 0.0, phi4, 0.0, phi, 0.0)[0]
    if abs(twist) <= LARGE_TWIST:
        return []
    whose = ("but the shaft is likely not yours: the defaults are Omar's laboratory rig (k_theta = "
             f"{OMAR_K_THETA:g} N.m/rad, J_load = 0.0045 kg.m2, m_s, k_phi); set k_theta, xi_theta, m_s, k_phi and "
             "J_load for your driveline" if p.k_theta == OMAR_K_THETA else
             "but check k_theta and the torques on the shaft (a run whose coupling diverges twists it without bound)")
    return [f"the intermediate shaft is twisted {twist:.3g} rad ({math.degrees(twist):.3g} deg), its spring torque "
            f"k_theta x twist {p.k_theta * twist:.4g} N.m on k_theta = {p.k_theta:.6g} N.m/rad (in a start-up or "
            f"another transient more than the load's: it also accelerates the inertias): past {LARGE_TWIST:g} rad, "
            f"more than a real driveshaft takes (a steel propshaft yields near 0.2 rad). The model's linear torsion "
            f"still holds, {whose}"]


def check_state(p: Parameters, y: State) -> list:
    """Both joint angles plus the dynamic misalignment phi must stay within [-MAX_ANGLE, MAX_ANGLE]."""
    if abs(p.beta1 + y[2]) <= MAX_ANGLE and abs(p.beta2 + p.cos_plane * y[2]) <= MAX_ANGLE:
        return []
    problems = []
    for name, angle in (("beta1", p.beta1 + y[2]), ("beta2", p.beta2 + p.cos_plane * y[2])):
        if abs(angle) > MAX_ANGLE:
            problems.append(f"joint angle {name} + dynamic misalignment = {angle!r} rad left its allowed "
                            f"range [{-MAX_ANGLE:.10g}, {MAX_ANGLE:.10g}] rad")
    return problems[:1]


# --- the torque-driven driveline (DoubleCardanDrivelineTorqueDriven): the input shaft free, in the state --------

@dataclass(slots=True, kw_only=True)
class TorqueDrivenParameters(Parameters):
    """DoubleCardanDrivelineTorqueDriven's parameters: DoubleCardanDriveline's, the driver's rotor inertia J_drive
    lumped on the input shaft [kg.m2] and the input shaft's speed at the start time [rad/s]; natural_rate and
    mode_rate are the bounds with the input shaft free, :func:`natural_rate_bound` and :func:`mode_rate_bound`
    (p, J_drive + I_input) (0 for a rigid shaft or
    where :meth:`TorqueDriven.check` refuses the parameters)."""

    J_drive: float
    omega_in_start: float

    def __post_init__(self):
        Parameters.__post_init__(self)
        j_in = self.J_drive + self.I_input
        flexible = not self.rigid_intermediate_shaft and self.J_load > 0.0 and j_in >= MIN_SHAFT_INERTIA
        self.natural_rate = natural_rate_bound(self, j_in) if flexible else 0.0
        self.mode_rate = mode_rate_bound(self, j_in) if flexible else 0.0


#: rates of the flexible entries of the torque-driven state, which a rigid shaft does not use
_AT_REST = (0.0, 0.0, 0.0, 0.0)


class TorqueDriven:
    """The protocol of the torque-driven driveline: state (phi1, omega1, phi4, omega4, phi, dphi), the input shaft
    driven by tau_in with the driver's rotor inertia J_drive lumped on it (:func:`torque_driven_rates`; the last
    four stay 0 with a rigid shaft); every other output is the speed-driven driveline's at that motion."""

    Parameters = TorqueDrivenParameters
    Inputs = Torques
    LATERAL_STATES = LATERAL_STATES

    @staticmethod
    def rate_sources(p: TorqueDrivenParameters) -> list:
        """:func:`rate_sources` with the input shaft free (J_drive + I_input)."""
        return rate_sources(p, p.J_drive + p.I_input)

    class State(NamedTuple):
        """Input shaft angle and speed, then the speed-driven driveline's :class:`State`."""

        phi1: float
        omega1: float
        phi4: float
        omega4: float
        phi: float
        dphi: float

    @staticmethod
    def initial_state(p: TorqueDrivenParameters, t: float, u: Torques) -> tuple:
        """The input shaft at phi_in_start and omega_in_start; untwisted, phi = 0, the output at the rigid
        kinematics' angle and speed."""
        if p.rigid_intermediate_shaft:
            return TorqueDriven.State(p.phi_in_start, p.omega_in_start, 0.0, 0.0, 0.0, 0.0)
        phi4 = rigid_output_angle(p, p.phi_in_start)
        omega4 = rigid_state(p, p.phi_in_start, p.omega_in_start, 0.0, 0.0)["omega4"]
        return TorqueDriven.State(p.phi_in_start, p.omega_in_start, phi4, omega4, 0.0, 0.0)

    @staticmethod
    def derivatives(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> tuple:
        """:func:`torque_driven_rates` (rigid: of (phi1, omega1), the rest at rest; flexible: from the outputs'
        evaluation at this state object where that was the last, :meth:`first_stage`)."""
        if p.rigid_intermediate_shaft:
            return torque_driven_rates(p, p.J_drive, y[:2], u.tau_in, u.tau_load) + _AT_REST
        memo = p.outputs_memo
        if memo is not None and memo[0] is y:
            return TorqueDriven.first_stage(p, y, u, memo[3], memo[4])
        return torque_driven_rates(p, p.J_drive, y, u.tau_in, u.tau_load)

    @staticmethod
    def first_stage(p: TorqueDrivenParameters, y: tuple, u: Torques, flexible: tuple, inertia: tuple) -> tuple:
        """:func:`torque_driven_rates` of a flexible shaft at state y from ``_flexible_rates(p, y[0], y[1], y[2:],
        0.0)`` (flexible) and ``input_inertia(p, y[0])`` (inertia), the outputs' evaluation: both torques enter
        linearly, tau_in (J_d + J_in) alpha1 and tau_load dw4/dt = (net - tau_load) / J_out, each by the same
        expression on the same floats as ``_driven_rates`` and ``_flexible_rates``, bit for bit."""
        rates, r1, shaft, _, _, net, j_out = flexible
        omega1 = y[1]
        rest = (rates[0], (net - u.tau_load) / j_out, rates[2], rates[3])
        if p.constant_inertias:
            return (omega1, (u.tau_in - r1 * shaft) / (p.J_drive + p.I_input)) + rest
        j_in, dj_in = inertia
        return (omega1, (u.tau_in - 0.5 * dj_in * omega1 * omega1 - r1 * shaft) / (p.J_drive + j_in)) + rest

    @staticmethod
    def input_acceleration(p: TorqueDrivenParameters, y: tuple, u: Torques) -> float:
        """alpha_in, the input shaft's acceleration at state y under the torques u (:meth:`derivatives`)."""
        return TorqueDriven.derivatives(p, 0.0, y, u)[1]

    @staticmethod
    def integrate(p: TorqueDrivenParameters, t: float, h: float, y: tuple, u: Torques) -> tuple:
        """One step: :meth:`integrate_from` the rates at its start."""
        return TorqueDriven.integrate_from(p, t, h, y, u, TorqueDriven.derivatives(p, t, y, u))

    @staticmethod
    def integrate_from(p: TorqueDrivenParameters, t: float, h: float, y: tuple, u: Torques, k1: tuple) -> tuple:
        """The FMU's step from the rates k1 = :meth:`derivatives` at its start (which the FMU asks for once, for its
        speed check; served from the outputs' evaluation at the same state where that was the last):
        :func:`torque_driven_step` with the input speed over the step bounded by |omega1| + |alpha1| h
        (k1's), and RK4's substep count from :meth:`rate_bound` there."""
        omega_max = abs(k1[0]) + abs(k1[1]) * h
        return torque_driven_step(p, t, h, y, u, omega_max, rk4.substeps(TorqueDriven.rate_bound(p, y, omega_max), h),
                                  k1)

    @staticmethod
    def rate_bound(p: TorqueDrivenParameters, y: tuple, omega_max: float) -> float:
        """The natural-rate bound with the input shaft free plus 4 |omega1| (the kinematics' harmonics; the sum as
        in :func:`rate_bound`)."""
        return p.natural_rate + 4.0 * omega_max

    @staticmethod
    def outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """The input shaft's motion from the state and :func:`torque_driven_rates`, the rest from :func:`outputs`
        at that motion (flexible: both from one evaluation of the kinematics)."""
        if not p.rigid_intermediate_shaft:
            return TorqueDriven.flexible_outputs(p, y, u)
        alpha = TorqueDriven.derivatives(p, t, y, u)[1]
        return torque_driven_outputs(outputs(p, t, State(*y[2:]), Drive(y[0], y[1], alpha, u.tau_load)), y, alpha)

    #: the outputs that are functions of the state alone (the FMU computes only these on a read of only these)
    STATE_OUTPUTS = ("phi_in", "omega_in", "omega_out", "phi_out")

    @staticmethod
    def state_outputs(p: TorqueDrivenParameters, t: float, y: tuple) -> dict:
        """The shafts' motion: the input shaft's from the state, the output shaft's from the state (flexible) or the
        rigid kinematics at the input shaft's motion (:func:`rigid_state`, as :meth:`outputs` computes them)."""
        if p.rigid_intermediate_shaft:
            rigid = rigid_state(p, y[0], y[1], 0.0, 0.0)
            return {"phi_in": y[0], "omega_in": y[1], "omega_out": rigid["omega4"], "phi_out": rigid["phi4"]}
        return {"phi_in": y[0], "omega_in": y[1], "omega_out": y[3], "phi_out": y[2]}

    @staticmethod
    def flexible_outputs(p: TorqueDrivenParameters, y: tuple, u: Torques) -> dict:
        """:meth:`outputs` of a flexible shaft: :func:`flexible_output_values` at the state's input motion under
        u.tau_in (its evaluation kept with the whole state y as key: a read after the torques change and the step's
        :meth:`derivatives` reuse it)."""
        values = flexible_output_values(p, y[0], y[1], None, y[2:], u.tau_in, p.J_drive, y, u.tau_load)
        return torque_driven_outputs(values, y, values.pop("alpha_in"))

    @staticmethod
    def check(p: TorqueDrivenParameters) -> list:
        """:func:`check`, and the input shaft needs an inertia to integrate."""
        return check(p) + shaft_inertia_problems("J_drive + I_input", p.J_drive + p.I_input, "input shaft")

    advice = staticmethod(advice)
    free_output_inertia = staticmethod(free_output_inertia)

    @staticmethod
    def check_state(p: TorqueDrivenParameters, y: tuple) -> list:
        """:func:`check_state` of the speed-driven driveline's part of the state."""
        return check_state(p, y[2:])

    @staticmethod
    def state_advice(p: TorqueDrivenParameters, h: float, y: tuple, u: Torques) -> list:
        """:func:`state_advice` at the input shaft's angle y[0]."""
        if p.rigid_intermediate_shaft:
            return []
        return _twist_advice(p, y[0], y[2:])


if __name__ == "__main__":
    _write_unrolled()


# --- generated by unrolled_source() (python -m ujfmu.models.double_cardan_driveline.model): do not edit ---


def _dp5_drive_4(rates, p, y, t_span, n, phi0, w0, alpha, tau_load, k1=None):
    h = t_span / n
    t = 0.0
    for _ in range(n):
        y0, y1, y2, y3, = y
        if k1 is None:
            s = t
            k1 = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, y, tau_load)[0]
        b0, b1, b2, b3, = k1
        k1 = None
        s = t + h / 5
        c0, c1, c2, c3, = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, (
            y0 + h * (b0 / 5),
            y1 + h * (b1 / 5),
            y2 + h * (b2 / 5),
            y3 + h * (b3 / 5),
        ), tau_load)[0]
        s = t + 0.3 * h
        d0, d1, d2, d3, = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, (
            y0 + h * (3 / 40 * b0 + 9 / 40 * c0),
            y1 + h * (3 / 40 * b1 + 9 / 40 * c1),
            y2 + h * (3 / 40 * b2 + 9 / 40 * c2),
            y3 + h * (3 / 40 * b3 + 9 / 40 * c3),
        ), tau_load)[0]
        s = t + 0.8 * h
        e0, e1, e2, e3, = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, (
            y0 + h * (44 / 45 * b0 - 56 / 15 * c0 + 32 / 9 * d0),
            y1 + h * (44 / 45 * b1 - 56 / 15 * c1 + 32 / 9 * d1),
            y2 + h * (44 / 45 * b2 - 56 / 15 * c2 + 32 / 9 * d2),
            y3 + h * (44 / 45 * b3 - 56 / 15 * c3 + 32 / 9 * d3),
        ), tau_load)[0]
        s = t + 8 / 9 * h
        f0, f1, f2, f3, = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, (
            y0 + h * (19372 / 6561 * b0 - 25360 / 2187 * c0 + 64448 / 6561 * d0 - 212 / 729 * e0),
            y1 + h * (19372 / 6561 * b1 - 25360 / 2187 * c1 + 64448 / 6561 * d1 - 212 / 729 * e1),
            y2 + h * (19372 / 6561 * b2 - 25360 / 2187 * c2 + 64448 / 6561 * d2 - 212 / 729 * e2),
            y3 + h * (19372 / 6561 * b3 - 25360 / 2187 * c3 + 64448 / 6561 * d3 - 212 / 729 * e3),
        ), tau_load)[0]
        s = t + h
        g0, g1, g2, g3, = rates(p, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, (
            y0 + h * (9017 / 3168 * b0 - 355 / 33 * c0 + 46732 / 5247 * d0 + 49 / 176 * e0 - 5103 / 18656 * f0),
            y1 + h * (9017 / 3168 * b1 - 355 / 33 * c1 + 46732 / 5247 * d1 + 49 / 176 * e1 - 5103 / 18656 * f1),
            y2 + h * (9017 / 3168 * b2 - 355 / 33 * c2 + 46732 / 5247 * d2 + 49 / 176 * e2 - 5103 / 18656 * f2),
            y3 + h * (9017 / 3168 * b3 - 355 / 33 * c3 + 46732 / 5247 * d3 + 49 / 176 * e3 - 5103 / 18656 * f3),
        ), tau_load)[0]
        y = (
            y0 + h * (35 / 384 * b0 + 500 / 1113 * d0 + 125 / 192 * e0 - 2187 / 6784 * f0 + 11 / 84 * g0),
            y1 + h * (35 / 384 * b1 + 500 / 1113 * d1 + 125 / 192 * e1 - 2187 / 6784 * f1 + 11 / 84 * g1),
            y2 + h * (35 / 384 * b2 + 500 / 1113 * d2 + 125 / 192 * e2 - 2187 / 6784 * f2 + 11 / 84 * g2),
            y3 + h * (35 / 384 * b3 + 500 / 1113 * d3 + 125 / 192 * e3 - 2187 / 6784 * f3 + 11 / 84 * g3),
        )
        t += h
    return y


def _dp5_held_6(rates, p, j_drive, y, t_span, n, tau_drive, tau_load, k1=None):
    h = t_span / n
    t = 0.0
    for _ in range(n):
        y0, y1, y2, y3, y4, y5, = y
        if k1 is None:
            s = t
            k1 = rates(p, j_drive, y, tau_drive, tau_load)
        b0, b1, b2, b3, b4, b5, = k1
        k1 = None
        s = t + h / 5
        c0, c1, c2, c3, c4, c5, = rates(p, j_drive, (
            y0 + h * (b0 / 5),
            y1 + h * (b1 / 5),
            y2 + h * (b2 / 5),
            y3 + h * (b3 / 5),
            y4 + h * (b4 / 5),
            y5 + h * (b5 / 5),
        ), tau_drive, tau_load)
        s = t + 0.3 * h
        d0, d1, d2, d3, d4, d5, = rates(p, j_drive, (
            y0 + h * (3 / 40 * b0 + 9 / 40 * c0),
            y1 + h * (3 / 40 * b1 + 9 / 40 * c1),
            y2 + h * (3 / 40 * b2 + 9 / 40 * c2),
            y3 + h * (3 / 40 * b3 + 9 / 40 * c3),
            y4 + h * (3 / 40 * b4 + 9 / 40 * c4),
            y5 + h * (3 / 40 * b5 + 9 / 40 * c5),
        ), tau_drive, tau_load)
        s = t + 0.8 * h
        e0, e1, e2, e3, e4, e5, = rates(p, j_drive, (
            y0 + h * (44 / 45 * b0 - 56 / 15 * c0 + 32 / 9 * d0),
            y1 + h * (44 / 45 * b1 - 56 / 15 * c1 + 32 / 9 * d1),
            y2 + h * (44 / 45 * b2 - 56 / 15 * c2 + 32 / 9 * d2),
            y3 + h * (44 / 45 * b3 - 56 / 15 * c3 + 32 / 9 * d3),
            y4 + h * (44 / 45 * b4 - 56 / 15 * c4 + 32 / 9 * d4),
            y5 + h * (44 / 45 * b5 - 56 / 15 * c5 + 32 / 9 * d5),
        ), tau_drive, tau_load)
        s = t + 8 / 9 * h
        f0, f1, f2, f3, f4, f5, = rates(p, j_drive, (
            y0 + h * (19372 / 6561 * b0 - 25360 / 2187 * c0 + 64448 / 6561 * d0 - 212 / 729 * e0),
            y1 + h * (19372 / 6561 * b1 - 25360 / 2187 * c1 + 64448 / 6561 * d1 - 212 / 729 * e1),
            y2 + h * (19372 / 6561 * b2 - 25360 / 2187 * c2 + 64448 / 6561 * d2 - 212 / 729 * e2),
            y3 + h * (19372 / 6561 * b3 - 25360 / 2187 * c3 + 64448 / 6561 * d3 - 212 / 729 * e3),
            y4 + h * (19372 / 6561 * b4 - 25360 / 2187 * c4 + 64448 / 6561 * d4 - 212 / 729 * e4),
            y5 + h * (19372 / 6561 * b5 - 25360 / 2187 * c5 + 64448 / 6561 * d5 - 212 / 729 * e5),
        ), tau_drive, tau_load)
        s = t + h
        g0, g1, g2, g3, g4, g5, = rates(p, j_drive, (
            y0 + h * (9017 / 3168 * b0 - 355 / 33 * c0 + 46732 / 5247 * d0 + 49 / 176 * e0 - 5103 / 18656 * f0),
            y1 + h * (9017 / 3168 * b1 - 355 / 33 * c1 + 46732 / 5247 * d1 + 49 / 176 * e1 - 5103 / 18656 * f1),
            y2 + h * (9017 / 3168 * b2 - 355 / 33 * c2 + 46732 / 5247 * d2 + 49 / 176 * e2 - 5103 / 18656 * f2),
            y3 + h * (9017 / 3168 * b3 - 355 / 33 * c3 + 46732 / 5247 * d3 + 49 / 176 * e3 - 5103 / 18656 * f3),
            y4 + h * (9017 / 3168 * b4 - 355 / 33 * c4 + 46732 / 5247 * d4 + 49 / 176 * e4 - 5103 / 18656 * f4),
            y5 + h * (9017 / 3168 * b5 - 355 / 33 * c5 + 46732 / 5247 * d5 + 49 / 176 * e5 - 5103 / 18656 * f5),
        ), tau_drive, tau_load)
        y = (
            y0 + h * (35 / 384 * b0 + 500 / 1113 * d0 + 125 / 192 * e0 - 2187 / 6784 * f0 + 11 / 84 * g0),
            y1 + h * (35 / 384 * b1 + 500 / 1113 * d1 + 125 / 192 * e1 - 2187 / 6784 * f1 + 11 / 84 * g1),
            y2 + h * (35 / 384 * b2 + 500 / 1113 * d2 + 125 / 192 * e2 - 2187 / 6784 * f2 + 11 / 84 * g2),
            y3 + h * (35 / 384 * b3 + 500 / 1113 * d3 + 125 / 192 * e3 - 2187 / 6784 * f3 + 11 / 84 * g3),
            y4 + h * (35 / 384 * b4 + 500 / 1113 * d4 + 125 / 192 * e4 - 2187 / 6784 * f4 + 11 / 84 * g4),
            y5 + h * (35 / 384 * b5 + 500 / 1113 * d5 + 125 / 192 * e5 - 2187 / 6784 * f5 + 11 / 84 * g5),
        )
        t += h
    return y
