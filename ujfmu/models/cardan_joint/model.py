"""Single Cardan (Hooke) joint: kinematics and transmitted moment.

Source [Feng2012]: Changlin Feng, Deshi Wang, Yongyong Zhu, "Analysis of Moment Transmitted by Universal Joint in
Varying Operating Condition", Advanced Engineering Forum, vols. 2-3, p. 999, Trans Tech Publications, 2012,
https://www.scientific.net/AEF.2-3.999; Eqs. (1)-(10). Standard library only: this module runs inside FMUs.

Frames. ``xyz`` is fixed to the driven shaft's bearings, ``z`` along the driven shaft (Eq. 2). The driving shaft's
frame is reached by ``C = C_gamma C_beta C_delta C_phi``. Expanding candidate elementary rotations and comparing term
by term with the printed Eqs. (1) and (9) fixes them uniquely (see README.md):

    C_phi   = R_x(+phi)     structural misalignment, ``bend_angle``
    C_delta = R_y(+delta)   structural misalignment, second Euler angle, ``bend_plane_angle``
    C_beta  = R_x(-beta)    error misalignment, ``error_angle_beta``
    C_gamma = R_y(-gamma)   error misalignment, ``error_angle_gamma``

so the driving-shaft axis is K = C (0,0,1) (Eq. 9) and the driving yoke's pin is e1 = C (-sin t1, cos t1, 0)
(Eq. 1). Interpretation: with the printed matrices delta is a tilt about y, not an azimuth of the bend plane; the
angle between the shafts is acos(K_z).

Derived identities used below (proofs in README.md; the tests check each against the literal Eq. 10):
    xi^2 = e1x^2 + e1y^2,      e_n . K = K_z / xi,     e_n,z = xi
    d(theta2)/d(theta1) = K_z / xi^2                  (velocity ratio)
"""

import math
from dataclasses import dataclass, field
from typing import NamedTuple

from ..protocol import (NEGLIGIBLE_SWING, Drive, NoState, Torques, joint_angle_advice, kinematic_always,
                        no_derivatives, no_rate, no_state, shaft_inertia_problems)

#: Largest admissible magnitude of each misalignment angle and of the total shaft angle acos(K_z) [rad].
MAX_ANGLE = math.radians(89.0)
#: the error misalignments beta, gamma of Feng et al.'s laboratory joint, the FMU's defaults [rad]
LAB_ERROR_ANGLE = math.radians(0.3)
#: a 2x speed swing changed by more than this fraction by the default error angles draws a warning (``advice``)
ERROR_ANGLE_EFFECT = 0.05
#: an error angle past this [rad] is far beyond a manufactured joint's (the laboratory joint's 0.3 deg): degrees
#: meant? (``advice``)
LARGE_ERROR_ANGLE = math.radians(2.0)
#: the order of the input speed the outputs carry at full size: the joint's speed ratio turns twice a revolution (its
#: 4x, 6x, ... are smaller by q, q^2, ..., q = tan^2(psi/2), psi the shaft angle); a record must sample it
#: (``ujfmu.scenario_run``)
EXCITATION_ORDER = 2


def excitation_order(p: "Parameters") -> int:
    """``EXCITATION_ORDER`` where the joint is misaligned (bend and error angles); an aligned one carries none, nor
    one whose angles are all so small that half the sum of their squares (the order of the peak-to-peak speed-ratio
    swing, about psi^2 for the shaft angle psi) is below ``protocol.NEGLIGIBLE_SWING``."""
    swing = 0.5 * (p.bend_angle ** 2 + p.bend_plane_angle ** 2 + p.error_angle_beta ** 2 + p.error_angle_gamma ** 2)
    return EXCITATION_ORDER if swing > NEGLIGIBLE_SWING else 0


def excited_orders(p: "Parameters") -> tuple:
    """The orders of the input speed the outputs carry at full size at p: the joint's 2x alone (its kinematics
    repeat every half turn, error angles included: no odd order), or none (:func:`excitation_order`)."""
    return (EXCITATION_ORDER,) if excitation_order(p) else ()


def joint_frame(bend_angle: float, bend_plane_angle: float, error_angle_beta: float, error_angle_gamma: float) -> tuple:
    """Columns (a, b, K) of C = R_y(-gamma) R_x(-beta) R_y(delta) R_x(phi); K is the driving axis (Eq. 9).

    e1(theta1) = -sin(theta1) a + cos(theta1) b (Eq. 1).
    """
    c = _matmul(_rot_y(-error_angle_gamma),
                _matmul(_rot_x(-error_angle_beta), _matmul(_rot_y(bend_plane_angle), _rot_x(bend_angle))))
    a = (c[0][0], c[1][0], c[2][0])
    b = (c[0][1], c[1][1], c[2][1])
    k = (c[0][2], c[1][2], c[2][2])
    return a, b, k


def shaft_angle(frame: tuple) -> float:
    """Angle between driving and driven shafts, acos(K_z) [rad]."""
    return math.acos(max(-1.0, min(1.0, frame[2][2])))


def driving_pin(frame: tuple, theta1: float) -> tuple:
    """e1 in xyz, Eq. (1)."""
    a, b, _ = frame
    s, c = math.sin(theta1), math.cos(theta1)
    return (-s * a[0] + c * b[0], -s * a[1] + c * b[1], -s * a[2] + c * b[2])


def cross_normal(e1: tuple) -> tuple:
    """Unit normal of the cross piece e_n = e1 x e2, Eqs. (3)-(4); returns (e_n, xi)."""
    xi = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1])
    return (-e1[0] * e1[2] / xi, -e1[1] * e1[2] / xi, xi), xi


def driven_angle(frame: tuple, theta1: float) -> float:
    """Driven shaft angle theta2 [rad], continuous in theta1.

    Phase convention: the driven yoke's pin is e2 = e3 x (-sin theta2, cos theta2, 0), i.e. theta2 is to the
    driven shaft what theta1 is to the driving one, so theta2 = theta1 when the shafts are aligned and, with only
    a bend phi, tan(theta2) = tan(theta1)/cos(phi). Computed as theta1 plus the bounded angle error, so there is
    no atan branch jump (the error stays below pi/2 for shaft angles below 90 deg).
    """
    e1x, e1y, _ = driving_pin(frame, theta1)
    s, c = math.sin(theta1), math.cos(theta1)
    return theta1 + math.atan2(-e1x * c - e1y * s, e1y * c - e1x * s)


def velocity_ratio(frame: tuple, theta1: float) -> float:
    """omega2/omega1 = d(theta2)/d(theta1) = K_z/xi^2; with a bend phi only, cos(phi)/(1 - sin^2 phi cos^2 theta1)."""
    e1x, e1y, _ = driving_pin(frame, theta1)
    return frame[2][2] / (e1x * e1x + e1y * e1y)


def velocity_ratio_and_slope(frame: tuple, theta1: float) -> tuple:
    """(r, dr/dtheta1) with r = K_z/xi^2 and dr/dtheta1 = -2 K_z (e1 . f1)_xy / xi^4, f1 = de1/dtheta1."""
    a, b, k = frame
    s, c = math.sin(theta1), math.cos(theta1)
    e1x, e1y = -s * a[0] + c * b[0], -s * a[1] + c * b[1]
    f1x, f1y = -c * a[0] - s * b[0], -c * a[1] - s * b[1]
    xi2 = e1x * e1x + e1y * e1y
    r = k[2] / xi2
    return r, -2.0 * r * (e1x * f1x + e1y * f1y) / xi2


def transmitted_moment(frame: tuple, theta1: float, net_input_torque: float) -> tuple:
    """Moment on the driven shaft (M_x, M_y, M_z), Eq. (10).

    net_input_torque is T0 - J1*alpha of Eq. (8): the driving torque less the driving shaft's inertia torque.
    """
    k = frame[2]
    en, _ = cross_normal(driving_pin(frame, theta1))
    m = net_input_torque / (en[0] * k[0] + en[1] * k[1] + en[2] * k[2])
    return m * en[0], m * en[1], m * en[2]


def joint_torques(frame: tuple, theta1: float, omega1: float,
        alpha1: float, tau_load: float, j1: float, j2: float) -> tuple:
    """Torques of the kinematically driven joint with driven-side inertia J2.

    Driven shaft: M_z - tau_load = J2 * alpha2 with alpha2 = r*alpha1 + r'*omega1^2.
    Driving shaft, Eq. (8): T0 = J1*alpha1 + M (e_n . K), M = M_z / e_n,z.
    Returns (tau_in, M_x, M_y, M_z, omega2, alpha2); lossless: tau_in*omega1 = J1*alpha1*omega1 + M_z*omega2.
    """
    k = frame[2]
    r, dr = velocity_ratio_and_slope(frame, theta1)
    alpha2 = r * alpha1 + dr * omega1 * omega1
    m_z = j2 * alpha2 + tau_load
    en, _ = cross_normal(driving_pin(frame, theta1))
    m = m_z / en[2]
    tau_in = j1 * alpha1 + m * (en[0] * k[0] + en[1] * k[1] + en[2] * k[2])
    return tau_in, m * en[0], m * en[1], m_z, r * omega1, alpha2


def torque_driven_rates(frame: tuple, state, tau_drive: float, tau_load: float, j_drive: float, j1: float,
                        j2: float) -> tuple:
    """d/dt of (theta1, omega1) for the joint driven by a torque tau_drive on the driving shaft, which carries
    the driver's rotor inertia j_drive lumped with J1. Lagrange with T = (J_d + J1 + J2 r^2) omega1^2 / 2:

        (J_d + J1 + J2 r^2) alpha1 = tau_drive - J2 r r' omega1^2 - r tau_load

    i.e. tau_drive = J_d alpha1 + tau_in(alpha1) with tau_in of :func:`joint_torques`, which is affine in alpha1.
    """
    theta1, omega1 = state
    r = velocity_ratio(frame, theta1)
    tau_at_rest = joint_torques(frame, theta1, omega1, 0.0, tau_load, j1, j2)[0]
    return omega1, (tau_drive - tau_at_rest) / (j_drive + j1 + j2 * r * r)


def joint_motion(p: "Parameters", theta1: float, omega1: float, alpha1: float, tau_load: float,
                 tau_drive: float | None = None) -> tuple:
    """(alpha1, tau_in, M_x, M_y, M_z, omega2, theta2) of :func:`joint_torques` and :func:`driven_angle` as
    straight-line code (what the FMUs evaluate: one sine and cosine, no calls; a test checks it against the composed
    functions). With tau_drive (the torque-driven joint), alpha1 is :func:`torque_driven_rates`' with the driver's
    J_drive lumped on the driving shaft (p.J_drive), not the given one.

    With e1 = -s a + c b, f1 = de1/dtheta1 = -c a - s b (s, c = sin, cos theta1; a, b, K the columns of C):
    r = K_z/xi^2, r' = -2 r (e1 . f1)_xy / xi^2, alpha2 = r alpha1 + r' omega1^2, M_z = J2 alpha2 + tau_load,
    (M_x, M_y) = -M_z e1z (e1x, e1y) / xi^2 (Eq. 10 with e_n = (-e1x e1z, -e1y e1z, xi^2)/xi, M = M_z/e_n,z) and
    tau_in = J1 alpha1 + r M_z (Eq. 8 with e_n . K = K_z/xi).
    """
    ax, ay, az, bx, by, bz, kz = p.coefficients
    s, c = math.sin(theta1), math.cos(theta1)
    e1x, e1y, e1z = c * bx - s * ax, c * by - s * ay, c * bz - s * az
    xi2 = e1x * e1x + e1y * e1y
    r = kz / xi2
    dr = 2.0 * r * (e1x * (c * ax + s * bx) + e1y * (c * ay + s * by)) / xi2
    w2 = dr * omega1 * omega1
    j2 = p.J2
    if tau_drive is not None:
        alpha1 = (tau_drive - r * (j2 * w2 + tau_load)) / (p.J_drive + p.J1 + j2 * r * r)
    m_z = j2 * (r * alpha1 + w2) + tau_load
    q = -m_z * e1z / xi2
    return (alpha1, p.J1 * alpha1 + r * m_z, q * e1x, q * e1y, m_z, r * omega1,
            theta1 + math.atan2(-e1x * c - e1y * s, e1y * c - e1x * s))


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

@dataclass(slots=True)
class Parameters:
    """The CardanJoint FMU's parameters (names as declared there) and the joint frame C they give (Eq. 1)."""

    bend_angle: float
    bend_plane_angle: float
    error_angle_beta: float
    error_angle_gamma: float
    J1: float
    J2: float
    phi_in_start: float = 0.0
    frame: tuple = field(init=False, repr=False)
    #: the components (a_x, a_y, a_z, b_x, b_y, b_z, K_z) of the frame :func:`joint_motion` uses
    coefficients: tuple = field(init=False, repr=False)

    def __post_init__(self):
        self.frame = joint_frame(self.bend_angle, self.bend_plane_angle, self.error_angle_beta,
                                 self.error_angle_gamma)
        a, b, k = self.frame
        self.coefficients = (*a, *b, k[2])


State = NoState   # the driven shaft follows the joint's kinematics exactly


Inputs = Drive


# theta2 = theta2(theta1): nothing to integrate
kinematic, initial_state, derivatives, rate_bound = kinematic_always, no_state, no_derivatives, no_rate


def outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """tau_in, the moment (M_x, M_y, M_z) of Eqs. (8), (10) and the driven shaft's motion (:func:`joint_motion`:
    :func:`joint_torques` and :func:`driven_angle` as straight-line code)."""
    _, tau_in, m_x, m_y, m_z, omega_out, phi_out = joint_motion(p, u.phi, u.omega, u.alpha, u.tau_load)
    return {"tau_in": tau_in, "M_x": m_x, "M_y": m_y, "M_z": m_z, "omega_out": omega_out, "phi_out": phi_out}


def load_outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """The outputs of :func:`outputs` that depend on tau_load: tau_in and the moment (:func:`joint_motion`, the same
    numbers as :func:`outputs`); the driven shaft's motion does not."""
    _, tau_in, m_x, m_y, m_z, _, _ = joint_motion(p, u.phi, u.omega, u.alpha, u.tau_load)
    return {"tau_in": tau_in, "M_x": m_x, "M_y": m_y, "M_z": m_z}


def ratio_swing(frame: tuple, samples: int = 360) -> float:
    """Peak-to-peak of the velocity ratio omega2/omega1 over a revolution (:func:`velocity_ratio` at ``samples``
    input angles)."""
    values = [velocity_ratio(frame, 2.0 * math.pi * k / samples) for k in range(samples)]
    return max(values) - min(values)


def advice(p: Parameters) -> list:
    """Warnings: a bend past ``protocol.LARGE_JOINT_ANGLE`` (degrees meant?); the error angles left at the
    laboratory joint's (``LAB_ERROR_ANGLE``) where they change the joint's 2x velocity-ratio swing by more than
    ``ERROR_ANGLE_EFFECT`` from the ideal joint's at the same bend (at a bend of a few degrees, a vehicle's, by a
    quarter or a third, with the bend's sign); an error angle past ``LARGE_ERROR_ANGLE`` (degrees meant?); a
    bend_plane_angle other than 0, a second bend about y (Eq. 1), which its name may be read as the bend plane's
    azimuth: the shaft angle then is acos(cos(bend_angle) cos(bend_plane_angle)) (:func:`shaft_angle`)."""
    angles = joint_angle_advice("bend_angle", p.bend_angle)
    if p.bend_plane_angle != 0.0:
        ideal = shaft_angle(joint_frame(p.bend_angle, p.bend_plane_angle, 0.0, 0.0))
        angles.append(f"bend_plane_angle = {p.bend_plane_angle:.6g} rad ({math.degrees(p.bend_plane_angle):.4g} deg) "
                      "is a second bend, about y (Feng et al.'s Eq. 1, C_delta = R_y(delta)), not the azimuth of the "
                      f"plane the shafts bend in: with bend_angle = {p.bend_angle:.6g} rad the shafts meet at "
                      f"acos(cos(bend_angle) cos(bend_plane_angle)) = {math.degrees(ideal):.4g} deg (error angles "
                      "aside), and the velocity ratio swings as at that angle; for a joint bent by bend_angle alone, "
                      "set bend_plane_angle = 0")
    for name in ("error_angle_beta", "error_angle_gamma"):
        value = getattr(p, name)
        if abs(value) > LARGE_ERROR_ANGLE:
            angles.append(f"{name} = {value:.6g} rad is {math.degrees(value):.4g} deg, past the "
                          f"{math.degrees(LARGE_ERROR_ANGLE):g} deg of a manufactured joint's errors (Feng et al.'s "
                          f"laboratory joint's: {math.degrees(LAB_ERROR_ANGLE):g} deg); if the value was meant in "
                          f"degrees, {name} = {math.radians(value):.6g} rad (the FMUs take SI units)")
    if p.error_angle_beta != LAB_ERROR_ANGLE or p.error_angle_gamma != LAB_ERROR_ANGLE:
        return angles
    ideal = ratio_swing(joint_frame(p.bend_angle, p.bend_plane_angle, 0.0, 0.0))
    actual = ratio_swing(p.frame)
    mirror = ratio_swing(joint_frame(-p.bend_angle, p.bend_plane_angle, LAB_ERROR_ANGLE, LAB_ERROR_ANGLE))
    if ideal > 1e-12 and abs(actual / ideal - 1.0) <= ERROR_ANGLE_EFFECT:
        return angles
    if ideal > 1e-12:
        change = (f"by {100.0 * (actual / ideal - 1.0):+.3g}% (to {actual:.4g} peak-to-peak; "
                  f"{100.0 * (mirror / ideal - 1.0):+.3g}% at the mirror-image bend_angle = "
                  f"{-p.bend_angle:.4g} rad)")
    else:
        change = f"from none, the ideal joint's at this bend, to {actual:.4g} peak-to-peak"
    return angles + [f"error_angle_beta = error_angle_gamma = {math.degrees(LAB_ERROR_ANGLE):g} deg are the "
                     f"defaults, Feng et al.'s laboratory joint's manufacturing errors: they change the joint's 2x "
                     f"velocity-ratio swing {change}; set both to 0 for an ideal joint"]


def check(p: Parameters) -> list:
    """The total shaft angle acos(K_z) must stay within MAX_ANGLE."""
    angle = shaft_angle(p.frame)
    if angle > MAX_ANGLE:
        return [f"total shaft angle acos(K_z) = {angle!r} rad from bend_angle, bend_plane_angle, "
                f"error_angle_beta, error_angle_gamma is outside its allowed range [0, {MAX_ANGLE:.10g}] rad"]
    return []



# --- the torque-driven joint (CardanJointTorqueDriven): the driving shaft free, its motion the state -------------

@dataclass(slots=True, kw_only=True)
class TorqueDrivenParameters(Parameters):
    """CardanJointTorqueDriven's parameters: CardanJoint's, the driver's rotor inertia J_drive lumped on the
    driving shaft [kg.m2] and the driving shaft's speed at the start time [rad/s]."""

    J_drive: float
    omega_in_start: float


class TorqueDriven:
    """The protocol of the torque-driven joint: state (theta1, omega1) of the driving shaft, driven by tau_in with
    the driver's rotor inertia J_drive lumped with J1 (:func:`torque_driven_rates`); every other output is the
    speed-driven joint's at that motion."""

    Parameters = TorqueDrivenParameters
    Inputs = Torques

    class State(NamedTuple):
        """Driving shaft angle theta1 [rad] and speed omega1 [rad/s]."""

        theta1: float
        omega1: float

    @staticmethod
    def initial_state(p: TorqueDrivenParameters, t: float, u: Torques) -> tuple:
        """The driving shaft at phi_in_start turning at omega_in_start."""
        return TorqueDriven.State(p.phi_in_start, p.omega_in_start)

    @staticmethod
    def derivatives(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> tuple:
        """(J_d + J1 + J2 r^2) alpha1 = tau_in - J2 r r' omega1^2 - r tau_load (:func:`torque_driven_rates`) as
        straight-line code (:func:`joint_motion`'s first lines; a test checks it against the composed function)."""
        theta1, omega1 = y
        ax, ay, _, bx, by, _, kz = p.coefficients
        s, c = math.sin(theta1), math.cos(theta1)
        e1x, e1y = c * bx - s * ax, c * by - s * ay
        xi2 = e1x * e1x + e1y * e1y
        r = kz / xi2
        dr = 2.0 * r * (e1x * (c * ax + s * bx) + e1y * (c * ay + s * by)) / xi2
        j2 = p.J2
        return omega1, (u.tau_in - r * (j2 * dr * omega1 * omega1 + u.tau_load)) / (p.J_drive + p.J1 + j2 * r * r)

    @staticmethod
    def rate_bound(p: TorqueDrivenParameters, y: tuple, omega_max: float) -> float:
        """The kinematics' harmonics of the driving angle, 4 |omega1| (the joint has no natural frequency)."""
        return 4.0 * omega_max

    @staticmethod
    def outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """The driving shaft's motion from the state and Eq. of :func:`torque_driven_rates`, the rest as
        :func:`outputs` at that motion (:func:`joint_motion` with the driving torque; tau_in is tau_input_shaft,
        as ``protocol.torque_driven_outputs`` names it)."""
        theta1, omega1 = y
        alpha, tau_shaft, m_x, m_y, m_z, omega_out, phi_out = joint_motion(p, theta1, omega1, 0.0, u.tau_load,
                                                                           u.tau_in)
        return {"phi_in": theta1, "omega_in": omega1, "alpha_in": alpha, "tau_input_shaft": tau_shaft, "M_x": m_x,
                "M_y": m_y, "M_z": m_z, "omega_out": omega_out, "phi_out": phi_out}

    #: the outputs that follow from the state alone (:meth:`state_outputs`)
    STATE_OUTPUTS = ("phi_in", "omega_in", "omega_out", "phi_out")

    @staticmethod
    def state_outputs(p: TorqueDrivenParameters, t: float, y: tuple) -> dict:
        """The shafts' motion, the driven one's by the kinematics (omega2 = r omega1, :func:`driven_angle`):
        :meth:`outputs`' values for these names, written as :func:`joint_motion` computes them (the same numbers)."""
        theta1, omega1 = y
        ax, ay, _, bx, by, _, kz = p.coefficients
        s, c = math.sin(theta1), math.cos(theta1)
        e1x, e1y = c * bx - s * ax, c * by - s * ay
        return {"phi_in": theta1, "omega_in": omega1, "omega_out": kz / (e1x * e1x + e1y * e1y) * omega1,
                "phi_out": theta1 + math.atan2(-e1x * c - e1y * s, e1y * c - e1x * s)}

    @staticmethod
    def check(p: TorqueDrivenParameters) -> list:
        """:func:`check`, and the driving shaft needs an inertia to integrate."""
        return check(p) + shaft_inertia_problems("J_drive + J1", p.J_drive + p.J1, "driving shaft")

    advice = staticmethod(advice)


def _rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return ((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c))


def _rot_y(t):
    c, s = math.cos(t), math.sin(t)
    return ((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c))


def _matmul(p, q):
    return tuple(tuple(sum(p[i][m] * q[m][j] for m in range(3)) for j in range(3)) for i in range(3))
