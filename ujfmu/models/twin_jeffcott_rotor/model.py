"""Two unbalanced Jeffcott rotors coupled through a Hooke joint.

Source [Tchomeni2019]: Tchomeni, Alugongo, Masu, "Modeling and vibration analysis of twin-rotor system
interconnected by a Hooke's joint", Vibroengineering Procedia, vol. 27, 2019; Eqs. (1)-(11).

Derivation, every interpretation of the paper and the default rig: README.md. Standard library only:
this module runs inside the TwinJeffcottRotor FMU.

Layout: input (gearbox output, prescribed angle phi_in, inertia J_gb) -- primary shaft (torsion K1T, C1T) -- disc 1
(M1, J_M1, unbalance m_u1 at e) -- Hooke joint (angle beta) -- secondary shaft (torsion K2T, C2T) -- disc 2 (M2,
J_M2, unbalance m_u2 at e) -- load torque. Each disc sits mid-span on a massless shaft between self-aligning
bearings, lateral stiffness K and damping C per direction; the joint is at the shafts' adjacent bearings.
Coordinates q = (theta1, X1, Y1, theta2, X2, Y2): disc angles and disc-centre displacements, disc 2's in the
secondary shaft's frame (X in the plane of the two shafts).

Kinetic energy of one disc (paper Eq. 5 with sin(theta), not sin(2 theta); phase phi_u of the unbalance):
    T = (J + m_u e^2) w^2/2 + (M + m_u)(X'^2 + Y'^2)/2 + m_u e w (-sin(theta + phi_u) X' + cos(theta + phi_u) Y')
Potential and dissipation (Eqs. 6-7 with the torsional terms written as the shafts' twists):
    V = K1T (phi_in - theta1)^2/2 + K2T (psi - theta2)^2/2 + sum K X^2/2
    D = C1T (w_in - theta1')^2/2 + C2T (psi' - theta2')^2/2 + sum C X'^2/2
psi = joint output angle, exact Hooke kinematics tan(psi) = cos(beta) tan(theta1) (paper Eq. 1, driving pin normal
to the plane of the shafts at theta1 = 0), between the shafts' end sections, each turned exactly by its bending
slope angle sqrt(u^2 + v^2) about the normal to its bending plane (u = 3 X / L, v = 3 Y / L: end slope of a
mid-span-loaded simply supported shaft; Rodrigues' formula, so an aligned rotor stays axisymmetric): the torque
the joint transmits then loads the shafts laterally (its secondary couple), which is what puts twice-running-speed
components into the lateral response when beta != 0.
"""

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from ...fmu import rk4, series
from ..protocol import (MIN_SHAFT_INERTIA, NEGLIGIBLE_SWING, Drive, Torques, joint_angle_advice,
                        shaft_inertia_problems, torque_driven_outputs)

#: Largest admissible joint angle magnitude [rad].
MAX_ANGLE = math.radians(89.0)
#: the highest order of the input speed the outputs carry at full size: the unbalance's 1x and the joint's 2x; a
#: record must sample it (``ujfmu.scenario_run``)
EXCITATION_ORDER = 2


def excitation_order(p: "Parameters") -> int:
    """``EXCITATION_ORDER`` where the joint is bent (its 2x; a speed-ratio swing beta^2 / 2 below
    ``protocol.NEGLIGIBLE_SWING`` is none); straight, the discs' unbalance alone (m_u e) forces the 1x; neither,
    none."""
    if 0.5 * p.beta * p.beta > NEGLIGIBLE_SWING:
        return EXCITATION_ORDER
    return 1 if p.e and (p.m_u1 or p.m_u2) else 0


def excited_orders(p: "Parameters") -> tuple:
    """The orders of the input speed the outputs carry at full size at p: the discs' unbalance's 1x where there is
    one (m_u e), the joint's 2x where it is bent (:func:`excitation_order`)."""
    return tuple(k for k, present in ((1, p.e and (p.m_u1 or p.m_u2)), (EXCITATION_ORDER, excitation_order(p) == 2))
                 if present)

#: The default rig (one place for every default; README.md). Steel: E, G = E / (2 (1 + 0.3)), density.
RIG = dict(
    E=210.0e9, G=210.0e9 / 2.6, density=7850.0,   # Pa, Pa, kg/m^3 (structural steel handbook values)
    shaft_diameter=0.012,                          # m, both shafts
    L1=0.5, L2=0.6,                                # m, bearing spans of the primary and secondary shafts
    disc_diameter=0.15, disc_thickness=0.025,      # m, both discs (solid steel)
    m_u=0.002, e=0.06,                             # kg and m: a 2 g balancing screw at 60 mm radius
    lateral_damping_ratio=0.02, torsional_damping_ratio=0.01,
    J_gb=1.0e-3,                                   # kg.m^2, gearbox output flange
    beta_deg=5.0,                                  # deg; the paper: "usually below 6 deg"
)


def rig_parameters(rig: dict = RIG) -> dict:
    """Model parameters of a steel rig: Jeffcott stiffness 48 E I / L^3, torsion G J_p / L, disc mass and
    polar inertia from geometry, viscous damping from damping ratios (lateral: of the disc on its shaft;
    torsional: of each disc on its own shaft with the far end held)."""
    d, rho = rig["shaft_diameter"], rig["density"]
    area_moment = math.pi * d ** 4 / 64.0
    polar_moment = 2.0 * area_moment
    mass = rho * math.pi * rig["disc_diameter"] ** 2 / 4.0 * rig["disc_thickness"]
    inertia = 0.5 * mass * (0.5 * rig["disc_diameter"]) ** 2
    p = dict(beta=math.radians(rig["beta_deg"]), M1=mass, M2=mass, J_M1=inertia, J_M2=inertia, J_gb=rig["J_gb"],
             m_u1=rig["m_u"], m_u2=rig["m_u"], e=rig["e"], L1=rig["L1"], L2=rig["L2"])
    for i, span in ((1, rig["L1"]), (2, rig["L2"])):
        k = 48.0 * rig["E"] * area_moment / span ** 3
        c = 2.0 * rig["lateral_damping_ratio"] * math.sqrt(k * (mass + rig["m_u"]))
        kt = rig["G"] * polar_moment / span
        ct = 2.0 * rig["torsional_damping_ratio"] * math.sqrt(kt * inertia)
        p.update({f"K{i}X": k, f"K{i}Y": k, f"C{i}X": c, f"C{i}Y": c, f"K{i}T": kt, f"C{i}T": ct})
    return p


@dataclass(slots=True)
class Parameters:
    """The TwinJeffcottRotor FMU's parameters (names as declared there) and the constants the equations use:
    sin and cos of beta, the end slopes 3 / L per unit mid-span displacement, per disc M, J, m_u e, M + m_u (paper
    M_X1X1), J + m_u e^2 (paper M_theta theta) and its Schur complement, and the natural-rate bound."""

    beta: float
    M1: float
    J_M1: float
    m_u1: float
    phase_u1: float
    K1X: float
    K1Y: float
    C1X: float
    C1Y: float
    K1T: float
    C1T: float
    L1: float
    M2: float
    J_M2: float
    m_u2: float
    phase_u2: float
    K2X: float
    K2Y: float
    C2X: float
    C2Y: float
    K2T: float
    C2T: float
    L2: float
    e: float
    J_gb: float
    phi_in_start: float = 0.0
    sin_beta: float = field(init=False, repr=False)
    cos_beta: float = field(init=False, repr=False)
    slope1: float = field(init=False, repr=False)
    slope2: float = field(init=False, repr=False)
    disc1: dict = field(init=False, repr=False)
    disc2: dict = field(init=False, repr=False)
    natural_rate: float = field(init=False, repr=False)
    a1: float = field(init=False, repr=False)
    a_m1: float = field(init=False, repr=False)
    m1: float = field(init=False, repr=False)
    j_eff1: float = field(init=False, repr=False)
    sin_phase1: float = field(init=False, repr=False)
    cos_phase1: float = field(init=False, repr=False)
    a2: float = field(init=False, repr=False)
    a_m2: float = field(init=False, repr=False)
    m2: float = field(init=False, repr=False)
    j_eff2: float = field(init=False, repr=False)
    sin_phase2: float = field(init=False, repr=False)
    cos_phase2: float = field(init=False, repr=False)
    linear: tuple = field(init=False, repr=False)
    linear_rows: tuple = field(init=False, repr=False)
    linear_rate: float = field(init=False, repr=False)
    remainder_rate: float = field(init=False, repr=False)
    #: (h, :func:`_adams_operators` of linear and h): the last substep length's, a pure cache (:func:`adams_operators`)
    adams_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        self.sin_beta, self.cos_beta = math.sin(self.beta), math.cos(self.beta)
        self.slope1, self.slope2 = 3.0 / self.L1, 3.0 / self.L2   # end slope per unit mid-span displacement
        self.disc1 = _disc_constants(self.M1, self.J_M1, self.m_u1, self.e)
        self.disc2 = _disc_constants(self.M2, self.J_M2, self.m_u2, self.e)
        # the same per disc as plain attributes for :func:`rates`
        self.a1, self.m1, self.j_eff1 = self.disc1["a"], self.disc1["m"], self.disc1["j_eff"]
        self.a2, self.m2, self.j_eff2 = self.disc2["a"], self.disc2["m"], self.disc2["j_eff"]
        self.a_m1, self.a_m2 = self.a1 / self.m1, self.a2 / self.m2
        self.sin_phase1, self.cos_phase1 = math.sin(self.phase_u1), math.cos(self.phase_u1)
        self.sin_phase2, self.cos_phase2 = math.sin(self.phase_u2), math.cos(self.phase_u2)
        self.natural_rate = natural_rate_bound(self)
        self.linear = linear_part(self)
        t, *lateral = self.linear   # L's speed rows, flat for _remainder
        self.linear_rows = t[1] + t[3] + tuple(v for b in lateral for v in b[1])
        self.linear_rate = _rate(self.linear)
        self.remainder_rate = remainder_rate_bound(self)


def _disc_constants(mass, inertia, m_u, e):
    a, m, jt = m_u * e, mass + m_u, inertia + m_u * e * e
    return dict(M=mass, J=inertia, a=a, m=m, jt=jt, j_eff=jt - a * a / m)


def _tilt_coefficients(x):
    """(S, F, S', F') of x = angle^2: S = sin(angle)/angle, F = (1 - cos(angle))/angle^2 and their derivatives
    with respect to x. Taylor series below x = 1e-2, where the closed forms lose digits (a bent shaft's end slope
    is far below that: the short series below x = 1e-4 is exact to rounding)."""
    if x < 1e-4:
        return (1.0 - x / 6.0 * (1.0 - x / 20.0), 0.5 - x / 24.0 * (1.0 - x / 30.0),
                -1.0 / 6.0 + x / 60.0 - x * x / 1680.0, -1.0 / 24.0 + x / 360.0 - x * x / 13440.0)
    if x < 1e-2:
        return (1.0 - x / 6.0 * (1.0 - x / 20.0 * (1.0 - x / 42.0 * (1.0 - x / 72.0))),
                0.5 - x / 24.0 * (1.0 - x / 30.0 * (1.0 - x / 56.0 * (1.0 - x / 90.0))),
                -1.0 / 6.0 + x / 60.0 - x * x / 1680.0 + x ** 3 / 90720.0 - x ** 4 / 7983360.0,
                -1.0 / 24.0 + x / 360.0 - x * x / 13440.0 + x ** 3 / 907200.0 - x ** 4 / 95800320.0)
    angle = math.sqrt(x)
    s, c = math.sin(angle) / angle, math.cos(angle)
    f = 2.0 * math.sin(0.5 * angle) ** 2 / x
    return s, f, (c - s) / (2.0 * x), (s - 2.0 * f) / (2.0 * x)


def _tilt(k, a, b, x, y, z):
    """R v and its derivatives d(R v)/da, d(R v)/db for v = (x, y, z) and the rotation R = exp([r]x) by the tilt
    vector r = (a, b, 0) (Rodrigues: R v = v + S r x v + F r x (r x v), k = _tilt_coefficients(a^2 + b^2))."""
    s, f, ds, df = k
    m = a * y - b * x                  # (r x v)_z
    n = s * z + f * m
    c = 1.0 - f * (a * a + b * b)      # cos(angle)
    rv = (x + b * n, y - a * n, c * z + s * m)
    g = 2.0 * (ds * z + df * m)
    n_a = a * g + f * y
    n_b = b * g - f * x
    h = 2.0 * ds * m - s * z
    d_a = (b * n_a, -n - a * n_a, a * h + s * y)
    d_b = (n + b * n_b, -a * n_b, b * h - s * x)
    return rv, d_a, d_b


def joint(p: Parameters, theta1: float, u1: float, v1: float, u2: float, v2: float) -> tuple:
    """(psi, dpsi/dtheta1, dpsi/du1, dpsi/dv1, dpsi/du2, dpsi/dv2): Hooke joint output angle.

    Each bent end section is turned by its slope angle about the normal to its bending plane, exactly: the
    primary end by R1 = exp([(v1, -u1, 0)]x) (axis tilted towards (-u1, -v1)), the secondary end, in the secondary
    shaft's frame R_y(beta), by R2 = exp([(-v2, u2, 0)]x) (axis towards (u2, v2)). Driving pin
    e1 = R1 R_z(theta1) (0, 1, 0); in the secondary end frame p = R2^T R_y(-beta) e1 and the driven pin is z x p, so
    psi = atan2(-p_x, p_y): tan(psi) = cos(beta) tan(theta1) without tilts (paper Eq. 1). psi - theta1 is
    evaluated as one atan2, so psi is continuous over revolutions. Derivatives are analytic (Rodrigues'
    formula differentiated, `_tilt`); a change d of e1 changes psi by w . d with
    w = R_y(beta) R2 (-p_y, p_x, 0) / (p_x^2 + p_y^2), the gradient carried back through the rotations.
    """
    s, c = math.sin(theta1), math.cos(theta1)
    sb, cb = p.sin_beta, p.cos_beta
    k1 = _tilt_coefficients(u1 * u1 + v1 * v1)
    k2 = _tilt_coefficients(u2 * u2 + v2 * v2)
    e1, e1_a, e1_b = _tilt(k1, v1, -u1, -s, c, 0.0)
    # p = R2^T r with r = R_y(-beta) e1; R2^T = exp([(v2, -u2, 0)]x)
    p_, p_a, p_b = _tilt(k2, v2, -u2, cb * e1[0] - sb * e1[2], e1[1], sb * e1[0] + cb * e1[2])
    px, py = p_[0], p_[1]
    den = px * px + py * py
    psi = theta1 + math.atan2(-px * c - py * s, py * c - px * s)
    # w = R_y(beta) R2 (-p_y, p_x, 0) / den; R2 = exp([(-v2, u2, 0)]x) on a vector without z component
    qx, qy = -py / den, px / den
    m = -v2 * qy - u2 * qx
    n = k2[1] * m
    qx, qy, qz = qx + u2 * n, qy + v2 * n, k2[0] * m
    wx, wy, wz = cb * qx + sb * qz, qy, cb * qz - sb * qx
    # dpsi/dtheta1 = w . R1 (-c, -s, 0)
    m = -v1 * s - u1 * c
    n = k1[1] * m
    return (psi, wx * (-c - u1 * n) + wy * (-s - v1 * n) + wz * k1[0] * m,
            -(wx * e1_b[0] + wy * e1_b[1] + wz * e1_b[2]), wx * e1_a[0] + wy * e1_a[1] + wz * e1_a[2],
            -(px * p_b[1] - py * p_b[0]) / den, (px * p_a[1] - py * p_a[0]) / den)


def _disc_accelerations(d, angle, w, q_theta, q_x, q_y):
    """Solve one disc's 3x3 block of M q'' = Q (paper Eq. 10): returns (theta'', X'', Y'')."""
    a, m = d["a"], d["m"]
    s, c = math.sin(angle), math.cos(angle)
    fx = q_x + a * c * w * w
    fy = q_y + a * s * w * w
    acc = (q_theta + a / m * (s * fx - c * fy)) / d["j_eff"]
    return acc, (fx + a * s * acc) / m, (fy - a * c * acc) / m


#: state: theta1, w1, X1, X1', Y1, Y1', theta2, w2, X2, X2', Y2, Y2', dissipated energy, input work
STATE_SIZE = 14


def shaft_torques(p: Parameters, phi_in: float, w_in: float, y: Sequence[float]) -> tuple:
    """(T1, T2, psi, joint derivatives, rates) along a state: primary and secondary shaft torques, T > 0 driving."""
    th1, w1, x1, vx1, y1, vy1, th2, w2, x2, vx2, y2, vy2 = y[:12]
    s1, s2 = p.slope1, p.slope2
    g = joint_gradient(p, th1, s1 * x1, s1 * y1, s2 * x2, s2 * y2, math.sin(th1), math.cos(th1))
    dpsi = g[1] * w1 + s1 * (g[2] * vx1 + g[3] * vy1) + s2 * (g[4] * vx2 + g[5] * vy2)
    t1 = p.K1T * (phi_in - th1) + p.C1T * (w_in - w1)
    t2 = p.K2T * (g[0] - th2) + p.C2T * (dpsi - w2)
    return t1, t2, g, dpsi


def joint_gradient(p: Parameters, th1: float, u1: float, v1: float, u2: float, v2: float, s: float,
                   c: float) -> tuple:
    """:func:`joint` written straight-line (s, c = sin, cos of theta1 given): (psi, dpsi/dtheta1, dpsi/du1,
    dpsi/dv1, dpsi/du2, dpsi/dv2), no calls while the end slopes are in the short series of
    `_tilt_coefficients` (always, but for parameters far outside a real rotor). The integrator's inner loop
    (:func:`rates`) and the outputs (:func:`shaft_torques`) use it; tests compare it with :func:`joint`."""
    sb, cb = p.sin_beta, p.cos_beta
    # Rodrigues' coefficients S, F, dS/dx, dF/dx of both end tilts, x = angle^2 (`_tilt_coefficients`)
    x = u1 * u1 + v1 * v1
    if x < 1e-4:
        s1, f1 = 1.0 - x / 6.0 * (1.0 - x / 20.0), 0.5 - x / 24.0 * (1.0 - x / 30.0)
        ds1, df1 = -1.0 / 6.0 + x / 60.0 - x * x / 1680.0, -1.0 / 24.0 + x / 360.0 - x * x / 13440.0
    else:
        s1, f1, ds1, df1 = _tilt_coefficients(x)
    x = u2 * u2 + v2 * v2
    if x < 1e-4:
        s2, f2 = 1.0 - x / 6.0 * (1.0 - x / 20.0), 0.5 - x / 24.0 * (1.0 - x / 30.0)
        ds2, df2 = -1.0 / 6.0 + x / 60.0 - x * x / 1680.0, -1.0 / 24.0 + x / 360.0 - x * x / 13440.0
    else:
        s2, f2, ds2, df2 = _tilt_coefficients(x)
    # driving pin e1 = R1 (-s, c, 0), R1 = exp([(v1, -u1, 0)]x), and its derivatives d/dv1 (ea), d/d(-u1) (eb)
    m = v1 * c - u1 * s
    n = f1 * m
    e1x, e1y, e1z = -s - u1 * n, c - v1 * n, s1 * m
    g = 2.0 * df1 * m
    na, nb = v1 * g + f1 * c, f1 * s - u1 * g
    h = 2.0 * ds1 * m
    eax, eay, eaz = -u1 * na, -n - v1 * na, v1 * h + s1 * c
    ebx, eby, ebz = n - u1 * nb, -v1 * nb, s1 * s - u1 * h
    # p = R2^T R_y(-beta) e1, R2^T = exp([(v2, -u2, 0)]x), and its derivatives (x, y components)
    rx, ry, rz = cb * e1x - sb * e1z, e1y, sb * e1x + cb * e1z
    m = v2 * ry + u2 * rx
    pn = s2 * rz + f2 * m
    px, py = rx - u2 * pn, ry - v2 * pn
    g = 2.0 * (ds2 * rz + df2 * m)
    pna, pnb = v2 * g + f2 * ry, -u2 * g - f2 * rx
    den = px * px + py * py
    psi = th1 + math.atan2(-px * c - py * s, py * c - px * s)
    # w = R_y(beta) R2 (-p_y, p_x, 0) / den: the gradient of psi with respect to e1
    qx, qy = -py / den, px / den
    m = -v2 * qy - u2 * qx
    n = f2 * m
    qx, qy, qz = qx + u2 * n, qy + v2 * n, s2 * m
    wx, wy, wz = cb * qx + sb * qz, qy, cb * qz - sb * qx
    # dpsi/dtheta1 = w . R1 (-c, -s, 0); dpsi/du, dpsi/dv of both ends
    m = -v1 * s - u1 * c
    n = f1 * m
    g_th = wx * (-c - u1 * n) + wy * (-s - v1 * n) + wz * s1 * m
    g_u1 = -(wx * ebx + wy * eby + wz * ebz)
    g_v1 = wx * eax + wy * eay + wz * eaz
    g_u2 = -(px * (-v2 * pnb) - py * (pn - u2 * pnb)) / den
    g_v2 = (px * (-pn - v2 * pna) - py * (-u2 * pna)) / den
    return psi, g_th, g_u1, g_v1, g_u2, g_v2


def rates(p: Parameters, phi_in: float, w_in: float, alpha_in: float, y: Sequence[float], tau_load: float) -> tuple:
    """dy/dt of the 14 states (Lagrange, Eq. 8, with the energies above); tau_load acts on disc 2.

    Straight-line, the integrator's inner loop: the same equations as :func:`shaft_torques` (the joint at
    u = 3 X / L, v = 3 Y / L by :func:`joint_gradient`) and `_disc_accelerations` (paper Eq. 10), which the tests
    compare it with; each sine and cosine once (those of theta + phase_u by the angle sum)."""
    th1, w1, x1, vx1, y1, vy1, th2, w2, x2, vx2, y2, vy2, _, _ = y
    sl1, sl2 = p.slope1, p.slope2
    u1, v1, u2, v2 = sl1 * x1, sl1 * y1, sl2 * x2, sl2 * y2
    sin, cos = math.sin, math.cos
    s, c = sin(th1), cos(th1)
    psi, g_th, g_u1, g_v1, g_u2, g_v2 = joint_gradient(p, th1, u1, v1, u2, v2, s, c)
    # shaft torques (`shaft_torques`)
    dpsi = g_th * w1 + sl1 * (g_u1 * vx1 + g_v1 * vy1) + sl2 * (g_u2 * vx2 + g_v2 * vy2)
    d1, d2 = w_in - w1, dpsi - w2
    t1 = p.K1T * (phi_in - th1) + p.C1T * d1
    t2 = p.K2T * (psi - th2) + p.C2T * d2
    # each disc's 3x3 block of M q'' = Q (`_disc_accelerations`), sin and cos of theta + phase_u by the angle sum
    a, mass = p.a1, p.m1
    sa, ca = s * p.cos_phase1 + c * p.sin_phase1, c * p.cos_phase1 - s * p.sin_phase1
    fx = -p.K1X * x1 - p.C1X * vx1 - t2 * sl1 * g_u1 + a * ca * w1 * w1
    fy = -p.K1Y * y1 - p.C1Y * vy1 - t2 * sl1 * g_v1 + a * sa * w1 * w1
    acc1 = (t1 - t2 * g_th + p.a_m1 * (sa * fx - ca * fy)) / p.j_eff1
    ax1, ay1 = (fx + a * sa * acc1) / mass, (fy - a * ca * acc1) / mass
    a, mass = p.a2, p.m2
    s, c = sin(th2), cos(th2)
    sa, ca = s * p.cos_phase2 + c * p.sin_phase2, c * p.cos_phase2 - s * p.sin_phase2
    fx = -p.K2X * x2 - p.C2X * vx2 - t2 * sl2 * g_u2 + a * ca * w2 * w2
    fy = -p.K2Y * y2 - p.C2Y * vy2 - t2 * sl2 * g_v2 + a * sa * w2 * w2
    acc2 = (t2 - tau_load + p.a_m2 * (sa * fx - ca * fy)) / p.j_eff2
    ax2, ay2 = (fx + a * sa * acc2) / mass, (fy - a * ca * acc2) / mass
    dissipation = (p.C1T * d1 * d1 + p.C2T * d2 * d2 + p.C1X * vx1 * vx1 + p.C1Y * vy1 * vy1
                   + p.C2X * vx2 * vx2 + p.C2Y * vy2 * vy2)
    return (w1, acc1, vx1, ax1, vy1, ay1, w2, acc2, vx2, ax2, vy2, ay2, dissipation,
            (p.J_gb * alpha_in + t1) * w_in)


def stored_energy(p: Parameters, phi_in: float, w_in: float, y: Sequence[float]) -> float:
    """Kinetic energy of the gearbox flange and both discs plus elastic energy of shafts and supports [J]."""
    psi = joint(p, y[0], p.slope1 * y[2], p.slope1 * y[4], p.slope2 * y[8], p.slope2 * y[10])[0]
    return _stored_energy(p, w_in, phi_in - y[0], psi - y[6], y)


def _stored_energy(p: Parameters, w_in: float, twist1: float, twist2: float, y: Sequence[float]) -> float:
    """:func:`stored_energy` with the shafts' twists phi_in - theta1 and psi - theta2 given (T of each disc, module
    docstring: sin and cos of theta + phase_u by the angle sum)."""
    th1, w1, x1, vx1, y1, vy1, th2, w2, x2, vx2, y2, vy2 = y[:12]
    s, c = math.sin(th1), math.cos(th1)
    sa1, ca1 = s * p.cos_phase1 + c * p.sin_phase1, c * p.cos_phase1 - s * p.sin_phase1
    s, c = math.sin(th2), math.cos(th2)
    sa2, ca2 = s * p.cos_phase2 + c * p.sin_phase2, c * p.cos_phase2 - s * p.sin_phase2
    kinetic = (p.J_gb * w_in * w_in + p.disc1["jt"] * w1 * w1 + p.m1 * (vx1 * vx1 + vy1 * vy1)
               + p.disc2["jt"] * w2 * w2 + p.m2 * (vx2 * vx2 + vy2 * vy2))
    return (0.5 * kinetic + p.a1 * w1 * (ca1 * vy1 - sa1 * vx1) + p.a2 * w2 * (ca2 * vy2 - sa2 * vx2)
            + 0.5 * (p.K1T * twist1 * twist1 + p.K2T * twist2 * twist2 + p.K1X * x1 * x1 + p.K1Y * y1 * y1
                     + p.K2X * x2 * x2 + p.K2Y * y2 * y2))


def rest_state(p: Parameters, phi_in: float, w_in: float) -> list:
    """Untwisted shafts, discs centred, discs turning with the input as the rigid joint kinematics dictate."""
    g = joint(p, phi_in, 0.0, 0.0, 0.0, 0.0)
    return [phi_in, w_in, 0.0, 0.0, 0.0, 0.0, g[0], g[1] * w_in, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]


def natural_rate_bound(p: Parameters) -> float:
    """An upper bound [1/s] of the fastest free motion: sqrt of the trace of M^-1 K plus the trace of M^-1 C, with
    |dpsi/dtheta1| <= 1 / cos(beta) and |dpsi/du|, |dpsi/dv| <= tan(beta) (plus margin for the tilts)."""
    stiffness, decay = _rate_traces(p, p.cos_beta, p.sin_beta)
    return math.sqrt(stiffness) + decay


def rate_sources(p: Parameters, flange_inertia: float = math.inf) -> list:
    """(what, rate [1/s]) of each part of :func:`natural_rate_bound`'s traces (:func:`_rate_parts`), sqrt(stiffness)
    + damping of each with the parameters that set it: the shafts' torsion (with a free gearbox flange of
    flange_inertia [kg.m2]: the torque-driven rotor's K1T / J_in, C1T / J_in) and each disc's lateral motion. A step
    refused for its substeps names them."""
    (kt, ct), (k1, c1), (k2, c2) = _rate_parts(p, p.cos_beta, p.sin_beta)
    kt, ct = kt + p.K1T / flange_inertia, ct + p.C1T / flange_inertia
    return [(f"the shafts' torsion (K1T = {p.K1T:g}, K2T = {p.K2T:g} N.m/rad, C1T = {p.C1T:g}, C2T = {p.C2T:g} "
             f"N.m.s/rad, on J_M1 = {p.J_M1:g}, J_M2 = {p.J_M2:g} kg.m2)", math.sqrt(kt) + ct),
            (f"disc 1's lateral motion (K1X = {p.K1X:g}, K1Y = {p.K1Y:g} N/m, C1X = {p.C1X:g}, C1Y = {p.C1Y:g} N.s/m, "
             f"M1 = {p.M1:g} kg)", math.sqrt(k1) + c1),
            (f"disc 2's lateral motion (K2X = {p.K2X:g}, K2Y = {p.K2Y:g} N/m, C2X = {p.C2X:g}, C2Y = {p.C2Y:g} N.s/m, "
             f"M2 = {p.M2:g} kg)", math.sqrt(k2) + c2)]


def _rate_parts(p: Parameters, cos_beta: float, sin_beta: float) -> tuple:
    """((stiffness, damping) trace terms of M^-1 K, M^-1 C) of the shafts' torsion, disc 1's and disc 2's lateral
    motion at the joint angle given by its cos, sin: the parts :func:`_rate_traces` sums."""
    r = 1.0 / cos_beta
    g = 1.1 * abs(sin_beta) / cos_beta + 0.01
    j1, j2 = p.disc1["j_eff"], p.disc2["j_eff"]
    m1, m2 = p.disc1["M"], p.disc2["M"]
    lat1, lat2 = p.slope1 ** 2 * g * g, p.slope2 ** 2 * g * g
    return (((p.K1T + p.K2T * r * r) / j1 + p.K2T / j2, (p.C1T + p.C2T * r * r) / j1 + p.C2T / j2),
            ((p.K1X + p.K1Y + 2.0 * p.K2T * lat1) / m1, (p.C1X + p.C1Y + 2.0 * p.C2T * lat1) / m1),
            ((p.K2X + p.K2Y + 2.0 * p.K2T * lat2) / m2, (p.C2X + p.C2Y + 2.0 * p.C2T * lat2) / m2))


def _rate_traces(p: Parameters, cos_beta: float, sin_beta: float) -> tuple:
    """(trace M^-1 K, trace M^-1 C) bounds of :func:`natural_rate_bound` at the joint angle given by its cos, sin:
    the sums of :func:`_rate_parts`."""
    (kt, ct), (k1, c1), (k2, c2) = _rate_parts(p, cos_beta, sin_beta)
    return kt + k1 + k2, ct + c1 + c2


def step(p: Parameters, t_span: float, phi_in: float, w_in: float,
        alpha_in: float, y: Sequence[float], tau_load: float, natural_rate: float) -> list:
    """Advance the state over t_span with RK4 substeps (input angle quadratic in time, tau_load held); the
    substeps resolve the natural rate and the 1x, 2x, 4x forcing by the unbalance and the joint. The RK4 path, kept
    for comparison (tests); the FMU steps with :func:`exponential_step`."""
    w_max = max(abs(w_in), abs(w_in + alpha_in * t_span))

    def f(phi, w, state):
        return rates(p, phi, w, alpha_in, state, tau_load)
    return rk4.integrate(f, y, t_span, rk4.substeps(natural_rate + 4.0 * w_max, t_span), phi_in, w_in, alpha_in)


# --- the exponential integrator (the FMU's stepper) -------------------------------------------------------------
#
# Twist coordinates z = y - r(t), r(t) the rigid rotation with the input (theta1 = theta2 = phi_in(t),
# theta1' = theta2' = omega_in(t), discs centred): z' = L z + N(t, z), L the constant-coefficient linear part
# (:func:`linear_part`), N(t, z) = f(t, r + z) - r'(t) - L z the remainder (the joint's kinematic modulation, the
# unbalance forcing, the discs' mass coupling, the input's acceleration). Only the speed rows of N are non-zero:
# the angle rows of f are the speeds, which r' and L z reproduce exactly.

def linear_part(p: Parameters) -> tuple:
    """L in twist coordinates, block-diagonal: the torsional chain on (z_theta1, z_omega1, z_theta2, z_omega2),
    input -- K1T, C1T -- J_eff1 -- K2T, C2T -- J_eff2 with the joint's mean speed ratio 1, and per disc and direction
    the Jeffcott oscillator [[0, 1], [-K/m, -C/m]], m = M + m_u (X1, Y1, X2, Y2). J_eff = J + m_u e^2 - (m_u e)^2 / m
    as in the disc equations (paper Eq. 10 solved by its Schur complement)."""
    j1, j2 = p.j_eff1, p.j_eff2
    torsion = ((0.0, 1.0, 0.0, 0.0),
               (-(p.K1T + p.K2T) / j1, -(p.C1T + p.C2T) / j1, p.K2T / j1, p.C2T / j1),
               (0.0, 0.0, 0.0, 1.0),
               (p.K2T / j2, p.C2T / j2, -p.K2T / j2, -p.C2T / j2))
    lateral = (((0.0, 1.0), (-k / m, -c / m)) for k, c, m in ((p.K1X, p.C1X, p.m1), (p.K1Y, p.C1Y, p.m1),
                                                              (p.K2X, p.C2X, p.m2), (p.K2Y, p.C2Y, p.m2)))
    return (torsion, *lateral)


def _rate(blocks) -> float:
    """An upper bound of the spectral radius of L: for each block sqrt of the sum of its stiffness terms plus the
    sum of its damping terms (the traces of M^-1 K and M^-1 C: rows of the speeds)."""
    torsion, *lateral = blocks
    stiffness = -torsion[1][0] - torsion[3][2] + sum(-b[1][0] for b in lateral)
    decay = -torsion[1][1] - torsion[3][3] + sum(-b[1][1] for b in lateral)
    return math.sqrt(stiffness) + decay


def remainder_rate_bound(p: Parameters) -> float:
    """Bound [1/s] of the fastest rate of N's own stiffness and damping: the terms of :func:`natural_rate_bound`
    that the joint angle adds to those of the aligned joint (which L holds, up to the tilt margin): the joint's
    kinematic modulation of the torsional stiffness and its lateral coupling, sqrt(d trace M^-1 K) + d trace M^-1 C."""
    stiffness, decay = _rate_traces(p, p.cos_beta, p.sin_beta)
    aligned_stiffness, aligned_decay = _rate_traces(p, 1.0, 0.0)
    return math.sqrt(max(0.0, stiffness - aligned_stiffness)) + max(0.0, decay - aligned_decay)


def _state_operator(linear: tuple, h: float) -> tuple:
    """exp(h L) of the blocks of L (:func:`linear_part`, :func:`torque_linear_part`) as one tuple: each block row by
    row, the torsional block first."""
    return tuple(v for block in linear for row in series.phi_sum(block, h, (1.0,)) for v in row)


def _speed_operator(linear: tuple, h: float, coefficients: tuple) -> tuple:
    """sum_k coefficients[k] phi_k(h L) on N's speed columns of the speed-driven rotor's L (:func:`linear_part`) as
    16 numbers: the torsional block's column omega1 (4 rows), then its column omega2, then each lateral block's
    speed column (2 rows)."""
    torsion, *lateral = linear
    t = series.phi_sum(torsion, h, coefficients, (1, 3))
    return tuple([row[0] for row in t] + [row[1] for row in t]
                 + [row[0] for block in lateral for row in series.phi_sum(block, h, coefficients, (1,))])


def _propagators(p: Parameters, h: float) -> tuple:
    """:func:`_propagators_of` p's linear part (:func:`linear_part`) and h."""
    return _propagators_of(p.linear, h)


@functools.lru_cache(maxsize=64)
def _propagators_of(linear: tuple, h: float) -> tuple:
    """The operators of one Krogstad substep of length h (:func:`exponential_step`), memoized (a function of L's
    blocks and h alone; varying steps evict the oldest), from the phi-functions of L's blocks at h/2 and h:
    full-state ones (E(h/2) = exp(h L / 2), E(h) = exp(h L)) as 32 numbers (the torsional
    4x4 row by row, then each lateral 2x2), and ones applied to N (only its speed columns: the torsional columns of
    omega1 and omega2, then each lateral block's speed column) as 16 numbers:
    Q1 = (h/2) phi_1(h L/2), Q2 = h phi_2(h L/2), R1 = h phi_1(h L), R2 = 2 h phi_2(h L),
    S1 = h (2 phi_2 - 4 phi_3)(h L), S2 = h (4 phi_3 - phi_2)(h L)."""
    half = 0.5 * h
    return (_state_operator(linear, half), _speed_operator(linear, half, (0.0, half)),
            _speed_operator(linear, half, (0.0, 0.0, h)), _state_operator(linear, h),
            _speed_operator(linear, h, (0.0, h)), _speed_operator(linear, h, (0.0, 0.0, 2.0 * h)),
            _speed_operator(linear, h, (0.0, 0.0, 2.0 * h, -4.0 * h)),
            _speed_operator(linear, h, (0.0, 0.0, -h, 4.0 * h)))


def _state_op(f: tuple, z: Sequence[float], g: tuple, d: Sequence[float]) -> list:
    """F z + G d: F a full-state operator on the 12 twist coordinates, G a speed-column operator on the speed rows
    d = (omega1, X1', Y1', omega2, X2', Y2') of N (layouts: :func:`_propagators`)."""
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11 = z
    a, dx1, dy1, b, dx2, dy2 = d[:6]
    return [f[0] * z0 + f[1] * z1 + f[2] * z6 + f[3] * z7 + g[0] * a + g[4] * b,
            f[4] * z0 + f[5] * z1 + f[6] * z6 + f[7] * z7 + g[1] * a + g[5] * b,
            f[16] * z2 + f[17] * z3 + g[8] * dx1, f[18] * z2 + f[19] * z3 + g[9] * dx1,
            f[20] * z4 + f[21] * z5 + g[10] * dy1, f[22] * z4 + f[23] * z5 + g[11] * dy1,
            f[8] * z0 + f[9] * z1 + f[10] * z6 + f[11] * z7 + g[2] * a + g[6] * b,
            f[12] * z0 + f[13] * z1 + f[14] * z6 + f[15] * z7 + g[3] * a + g[7] * b,
            f[24] * z8 + f[25] * z9 + g[12] * dx2, f[26] * z8 + f[27] * z9 + g[13] * dx2,
            f[28] * z10 + f[29] * z11 + g[14] * dy2, f[30] * z10 + f[31] * z11 + g[15] * dy2]


def _shift(v: Sequence[float], g: tuple, d: Sequence[float]) -> list:
    """v + G d (G a speed-column operator, d N's speed rows: :func:`_state_op`)."""
    a, dx1, dy1, b, dx2, dy2 = d[:6]
    return [v[0] + g[0] * a + g[4] * b, v[1] + g[1] * a + g[5] * b, v[2] + g[8] * dx1, v[3] + g[9] * dx1,
            v[4] + g[10] * dy1, v[5] + g[11] * dy1, v[6] + g[2] * a + g[6] * b, v[7] + g[3] * a + g[7] * b,
            v[8] + g[12] * dx2, v[9] + g[13] * dx2, v[10] + g[14] * dy2, v[11] + g[15] * dy2]


def _last_stage(v: Sequence[float], g: tuple, d: Sequence[float], e: Sequence[float], k: tuple,
                f: Sequence[float]) -> list:
    """v + G (d + e) + K f: :func:`_shift` by G for the sum of two remainders and by K for a third."""
    a, dx1, dy1, b, dx2, dy2 = d[0] + e[0], d[1] + e[1], d[2] + e[2], d[3] + e[3], d[4] + e[4], d[5] + e[5]
    c, fx1, fy1, q, fx2, fy2 = f[:6]
    return [v[0] + g[0] * a + g[4] * b + k[0] * c + k[4] * q, v[1] + g[1] * a + g[5] * b + k[1] * c + k[5] * q,
            v[2] + g[8] * dx1 + k[8] * fx1, v[3] + g[9] * dx1 + k[9] * fx1,
            v[4] + g[10] * dy1 + k[10] * fy1, v[5] + g[11] * dy1 + k[11] * fy1,
            v[6] + g[2] * a + g[6] * b + k[2] * c + k[6] * q, v[7] + g[3] * a + g[7] * b + k[3] * c + k[7] * q,
            v[8] + g[12] * dx2 + k[12] * fx2, v[9] + g[13] * dx2 + k[13] * fx2,
            v[10] + g[14] * dy2 + k[14] * fy2, v[11] + g[15] * dy2 + k[15] * fy2]


#: no remainder to subtract (:func:`_remainder`)
_NONE = (0.0,) * 8


def _remainder(p: Parameters, phi: float, w: float, alpha: float, z: Sequence[float], tau_load: float,
               less: Sequence[float] = _NONE) -> tuple:
    """N's speed rows (omega1, X1', Y1', omega2, X2', Y2') and the rates of the dissipated energy and input work at
    the input motion (phi, w, alpha) and twist coordinates z, f(r + z) - r' - L z (:func:`rates`,
    :func:`linear_part`), each less the one of ``less`` (a stage's D = N - N_u)."""
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11 = z
    f = rates(p, phi, w, alpha, (phi + z0, w + z1, z2, z3, z4, z5, phi + z6, w + z7, z8, z9, z10, z11, 0.0, 0.0),
              tau_load)
    a0, a1, a2, a3, b0, b1, b2, b3, kx1, cx1, ky1, cy1, kx2, cx2, ky2, cy2 = p.linear_rows
    return (f[1] - alpha - (a0 * z0 + a1 * z1 + a2 * z6 + a3 * z7) - less[0],
            f[3] - (kx1 * z2 + cx1 * z3) - less[1], f[5] - (ky1 * z4 + cy1 * z5) - less[2],
            f[7] - alpha - (b0 * z0 + b1 * z1 + b2 * z6 + b3 * z7) - less[3],
            f[9] - (kx2 * z8 + cx2 * z9) - less[4], f[11] - (ky2 * z10 + cy2 * z11) - less[5],
            f[12] - less[6], f[13] - less[7])


def exponential_substeps(p: Parameters, t_span: float, w_in: float, alpha_in: float) -> int:
    """Substeps of :func:`exponential_step`: each resolves N's own rates (:func:`remainder_rate_bound`) and the
    1x and 2x forcing by the unbalance and the joint, 2 |omega_in|, and keeps h |lambda| <= 1 over L's eigenvalues
    (``rk4.substeps``: h rate <= RATE_STEP = 0.5), so the phi-functions' series converge fast."""
    w_max = max(abs(w_in), abs(w_in + alpha_in * t_span))
    return rk4.substeps(max(p.remainder_rate + 2.0 * w_max, 0.5 * p.linear_rate), t_span)


def exponential_step(p: Parameters, t_span: float, phi_in: float, w_in: float, alpha_in: float,
                     y: Sequence[float], tau_load: float) -> list:
    """Advance the state over t_span (input angle quadratic in time, tau_load held, as :func:`step`) with
    Krogstad's fourth-order exponential Runge-Kutta method (ETDRK4-B: Krogstad, "Generalized integrating factor
    methods for stiff PDEs", J. Comput. Phys. 203, 2005) in twist coordinates: L's part exactly, N by four
    evaluations of :func:`rates` per substep, :func:`exponential_substeps` substeps. Per substep of length h from
    z (N_u = N(t, z), D_i = N(stage i) - N_u, N's time the stage's):
        a = E(h/2) z + Q1 N_u                         (at t + h/2)
        b = a + Q2 D_a                                (at t + h/2)
        c = E(h) z + R1 N_u + R2 D_b                  (at t + h)
        z+ = E(h) z + R1 N_u + S1 (D_a + D_b) + S2 D_c
    (operators: :func:`_propagators`). Order 4 (tests); with L = 0 it is classical RK4, which is how the
    dissipated energy and input work rows are integrated: q+ = q + h (N_u + (D_a + D_b) / 3 + D_c / 6)."""
    n = exponential_substeps(p, t_span, w_in, alpha_in)
    h = t_span / n
    ops = _propagators(p, h)
    z = _twist(y, phi_in, w_in)
    q = [y[12], y[13]]
    for k in range(n):
        t0 = k * h
        nu = _remainder(p, phi_in + t0 * (w_in + 0.5 * alpha_in * t0), w_in + alpha_in * t0, alpha_in, z, tau_load)
        z = _krogstad_substep(p, ops, h, t0, phi_in, w_in, alpha_in, z, tau_load, nu, q)
    return _untwist(z, q, phi_in, w_in, alpha_in, t_span)


def _twist(y: Sequence[float], phi: float, w: float) -> list:
    """The twist coordinates z = y - r of the 12 motion states at the rigid motion r of angle phi, speed w."""
    return [y[0] - phi, y[1] - w, y[2], y[3], y[4], y[5], y[6] - phi, y[7] - w, y[8], y[9], y[10], y[11]]


def _untwist(z: Sequence[float], q: Sequence[float], phi_in: float, w_in: float, alpha_in: float,
             t_span: float) -> list:
    """The state from twist coordinates z and the energy rows q at t_span along the input motion."""
    phi_end, w_end = phi_in + t_span * (w_in + 0.5 * alpha_in * t_span), w_in + alpha_in * t_span
    return [phi_end + z[0], w_end + z[1], z[2], z[3], z[4], z[5], phi_end + z[6], w_end + z[7], z[8], z[9], z[10],
            z[11], q[0], q[1]]


def _krogstad_substep(p: Parameters, ops: tuple, h: float, t0: float, phi_in: float, w_in: float, alpha_in: float,
                      z: Sequence[float], tau_load: float, nu: Sequence[float], q: list) -> list:
    """One substep of :func:`exponential_step` from z at t0 (N_u = nu given): z+, the energy rows q advanced in
    place."""
    e_half, q1, q2, e_full, r1, r2, s1, s2 = ops
    tm, te = t0 + 0.5 * h, t0 + h
    phi_m, w_m = phi_in + tm * (w_in + 0.5 * alpha_in * tm), w_in + alpha_in * tm
    a = _state_op(e_half, z, q1, nu)
    da = _remainder(p, phi_m, w_m, alpha_in, a, tau_load, nu)
    db = _remainder(p, phi_m, w_m, alpha_in, _shift(a, q2, da), tau_load, nu)
    ec = _state_op(e_full, z, r1, nu)
    dc = _remainder(p, phi_in + te * (w_in + 0.5 * alpha_in * te), w_in + alpha_in * te, alpha_in,
                    _shift(ec, r2, db), tau_load, nu)
    q[0] += h * (nu[6] + (da[6] + db[6]) / 3.0 + dc[6] / 6.0)
    q[1] += h * (nu[7] + (da[7] + db[7]) / 3.0 + dc[7] / 6.0)
    return _last_stage(ec, s1, da, db, s2, dc)


# --- the exponential Adams method (the FMU's stepper once it has a history) -------------------------------------
#
# N(t, z) = N_0(t, z) + tau_load G(z) + alpha_in B(t): the load and the input acceleration, held over a step, enter
# N linearly (:func:`_input_columns`), so the history keeps N_0 and G, B per point and each step recombines them
# with its own held inputs: a load step or a change of acceleration is then exact, not extrapolated across.

#: the points of N the method keeps: N at t, t - h, ..., t - 5h
HISTORY_POINTS = 6
#: h times N's own rate bound (:func:`remainder_rate_bound`) at most in a substep of the Adams method: its PEC mode
#: (N at the predicted state joins the history, the corrected state is not evaluated) diverged at h times that
#: bound 0.2-0.3 (joint angles 30-45 deg, shafts of 1e5-1e7 N.m/rad: tests), where ETDRK4-B's steps hold at
#: ``rk4.RATE_STEP`` = 0.5; at 0.15 it held on all of them
ADAMS_RATE_STEP = 0.125


def adams_substeps(p: Parameters, t_span: float, w_in: float, alpha_in: float) -> int:
    """Substeps of :func:`multistep_step`: :func:`exponential_substeps`' rule, and h times N's own rate bound at
    most ``ADAMS_RATE_STEP`` (fewer substeps leave the method unstable at large joint angles and stiff shafts)."""
    w_max = max(abs(w_in), abs(w_in + alpha_in * t_span))
    return rk4.substeps(max(p.remainder_rate + 2.0 * w_max, 0.5 * p.linear_rate,
                            p.remainder_rate * rk4.RATE_STEP / ADAMS_RATE_STEP), t_span)
#: per history point: N_0's 8 rows (N without the held inputs' part, :func:`_input_free`), G's lateral rows (X2', Y2'),
#: the input speed (B's input-work row / J_gb)
_POINT = 11
#: the history (FMU state): substep h, the time the next step starts at, points held, the tau_load and alpha_in
#: of the step that ended there, then the points (newest first)
HISTORY_SIZE = 5 + HISTORY_POINTS * _POINT
#: no history: the next step starts with :func:`exponential_step`'s substeps
NO_HISTORY = (0.0,) * HISTORY_SIZE
#: a change of the held inputs between steps [rad/s^2] (tau_load / J_eff2, alpha_in, omega_in's jump from the
#: speed the newest point extrapolates to / h) above which the history is discarded: N's time derivative jumps with
#: the discs' accelerations, which no polynomial through the history follows (an 18 N.m load step, 1840 rad/s^2,
#: leaves 55x ETDRK4-B's error, so 20 rad/s^2 adds at most about half of it; a PI motor's run-up changes alpha_in
#: by up to 9 rad/s^2 per 1 ms step)
INPUT_JUMP = 20.0


def _input_columns(p: Parameters, theta2: float) -> tuple:
    """(dN/dtau_load of the rows X2'', Y2'') at disc 2's angle: acc2 of :func:`rates` is linear in tau_load with
    slope -1 / J_eff2 and X2'', Y2'' follow it through a sin, -a cos of theta2 + phase_u2 over m2 (paper Eq. 10
    solved for disc 2)."""
    s, c = math.sin(theta2), math.cos(theta2)
    sa, ca = s * p.cos_phase2 + c * p.sin_phase2, c * p.cos_phase2 - s * p.sin_phase2
    k = p.a2 / (p.m2 * p.j_eff2)
    return -k * sa, k * ca


def _history_point(p: Parameters, phi: float, w: float, alpha_in: float, z: Sequence[float], tau_load: float
                   ) -> tuple:
    """(N, point): N (:func:`_remainder`) at the input motion (phi, w, alpha_in), twist z and tau_load, and its
    history point (:func:`_input_free`)."""
    n = _remainder(p, phi, w, alpha_in, z, tau_load)
    return n, _input_free(p, n, _input_columns(p, phi + z[6]), w, tau_load, alpha_in)


def _input_free(p: Parameters, n: Sequence[float], g: Sequence[float], w: float, tau_load: float, alpha_in: float
                ) -> tuple:
    """The history point of N evaluated at tau_load and alpha_in (the layout of ``_POINT``): N_0 = N - tau_load G -
    alpha_in B with G = (0, 0, 0, -1 / J_eff2, G_X2, G_Y2, 0, 0) (g = (G_X2, G_Y2), :func:`_input_columns`) and
    B = (-1, 0, 0, -1, 0, 0, 0, J_gb w) (:func:`rates`: tau_load and alpha_in enter linearly), then g and w."""
    gx, gy = g
    return (n[0] + alpha_in, n[1], n[2], n[3] + tau_load / p.j_eff2 + alpha_in, n[4] - tau_load * gx,
            n[5] - tau_load * gy, n[6], n[7] - alpha_in * p.J_gb * w, gx, gy, w)


def multistep_step(p: Parameters, t: float, t_span: float, phi_in: float, w_in: float, alpha_in: float,
                   y: Sequence[float], tau_load: float, history: Sequence[float]) -> tuple:
    """(state, history) after t_span from t by an exponential Adams predictor-corrector in twist coordinates
    (Hochbruck, Ostermann, "Exponential multistep methods of Adams-type", BIT Numer. Math. 51, 2011; Cox, Matthews,
    "Exponential time differencing for stiff systems", J. Comput. Phys. 176, 2002) in PEC mode: per substep of h
    from z_n, N_j = N(t_n + j h) of the history (j = 0, -1, ..., -5), p the quintic through them, and the
    variation-of-constants integral of the interpolated N taken exactly (L's part exact, as in
    :func:`exponential_step`),
        predict   z* = E(h) z_n + sum_j W_j N_j,       W_j = h sum_m c_jm m! phi_(m+1)(h L)
        evaluate  N_1 = N(t_n + h, z*)                 (ONE evaluation of :func:`rates` per substep)
        correct   z_n+1 = z* + Psi (N_1 - p(1)),       Psi = h sum_m l_m m! phi_(m+1)(h L)
    c_jm the coefficients of theta^m of the Lagrange basis polynomial of node j, l_m those of
    prod_j (theta - j) / prod_j (1 - j), 1 at theta = 1 (the corrector is the Adams-Moulton one through N_1 and the
    six points, in Newton form; :func:`_adams_operators`); N_1 joins the history. The energy rows (L = 0) by the
    same weights, scalar. Observed order 5 from a start (tests: the five ETDRK4-B start steps dominate; the
    predictor alone is of order 6). tau_load and alpha_in enter N linearly, so the points are kept without the held
    inputs' part (:func:`_input_free`) and recombined with each step's held inputs as they are read: no stored point
    changes when the inputs do. A history of another substep length, not ending at t, or across a jump of the
    inputs (``INPUT_JUMP``) is discarded and rebuilt by :func:`exponential_step`'s substeps, each adding its N_u.
    Substeps: :func:`adams_substeps`."""
    n = adams_substeps(p, t_span, w_in, alpha_in)
    h = rk4.kept_substep(t_span / n, history[0], t, n)
    w_next = history[15] + (history[4] * h if history[2] < HISTORY_POINTS else 0.0)   # the newest point's speed
    if (history[0] != h or abs(history[1] - t) > 1e-6 * h or abs(tau_load - history[3]) / p.j_eff2
            + abs(alpha_in - history[4]) + abs(w_in - w_next) / h > INPUT_JUMP):
        history = NO_HISTORY
    count = int(history[2])
    points = history[5:5 + _POINT * count]
    z = _twist(y, phi_in, w_in)
    q = [y[12], y[13]]
    ops = None
    for k in range(n):
        t0 = k * h
        if count < HISTORY_POINTS:
            nu, point = _history_point(p, phi_in + t0 * (w_in + 0.5 * alpha_in * t0), w_in + alpha_in * t0, alpha_in,
                                       z, tau_load)
            points, count = point + points, count + 1
            if count < HISTORY_POINTS:
                if ops is None:
                    ops = _propagators(p, h)
                z = _krogstad_substep(p, ops, h, t0, phi_in, w_in, alpha_in, z, tau_load, nu, q)
                continue
        te = t0 + h
        z, point = _adams_substep(p, h, z, q, points, phi_in + te * (w_in + 0.5 * alpha_in * te),
                                  w_in + alpha_in * te, alpha_in, tau_load)
        points = (point + points)[:_POINT * HISTORY_POINTS]
    history = (h, t + t_span, float(count), tau_load, alpha_in, *points,
               *(0.0,) * (_POINT * (HISTORY_POINTS - count)))
    return _untwist(z, q, phi_in, w_in, alpha_in, t_span), history


def _adams_substep(p: Parameters, h: float, z: Sequence[float], q: list, points: list, phi_e: float, w_e: float,
                   alpha_in: float, tau_load: float) -> tuple:
    """One PEC substep of :func:`multistep_step` from z with the history points (newest, at z, first), the input
    motion (phi_e, w_e) at its end: (z+, the new history point); the energy rows q advanced in place. Each point's N
    is its N_0 plus this step's held inputs' part (:func:`_input_free`)."""
    e, psi, *weights = adams_operators(p, h)
    extrapolation, quadrature, gamma = _ADAMS_SCALARS
    tau_b, work_b = tau_load / p.j_eff2 + alpha_in, alpha_in * p.J_gb   # G, B terms of the rows omega2, input work
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11 = z
    # predictor: E z + sum_j W_j N_j (layouts: _state_op), N extrapolated to the end and the energy rows' quadrature
    r0, r1 = e[0] * z0 + e[1] * z1 + e[2] * z6 + e[3] * z7, e[4] * z0 + e[5] * z1 + e[6] * z6 + e[7] * z7
    r6, r7 = e[8] * z0 + e[9] * z1 + e[10] * z6 + e[11] * z7, e[12] * z0 + e[13] * z1 + e[14] * z6 + e[15] * z7
    r2, r3, r4, r5 = e[16] * z2 + e[17] * z3, e[18] * z2 + e[19] * z3, e[20] * z4 + e[21] * z5, e[22] * z4 + e[23] * z5
    r8, r9 = e[24] * z8 + e[25] * z9, e[26] * z8 + e[27] * z9
    r10, r11 = e[28] * z10 + e[29] * z11, e[30] * z10 + e[31] * z11
    n0 = n1 = n2 = n3 = n4 = n5 = n6 = n7 = q6 = q7 = 0.0
    for i, (g, c, w) in enumerate(zip(weights, extrapolation, quadrature)):
        a, x1, y1, b, x2, y2, dis, work, gx, gy, w_i = points[_POINT * i:_POINT * i + _POINT]
        a, b, x2, y2, work = a - alpha_in, b - tau_b, x2 + tau_load * gx, y2 + tau_load * gy, work + work_b * w_i
        t0, t1, t2, t3, t4, t5, t6, t7, g8, g9, g10, g11, g12, g13, g14, g15 = g
        r0 += t0 * a + t4 * b
        r1 += t1 * a + t5 * b
        r6 += t2 * a + t6 * b
        r7 += t3 * a + t7 * b
        r2 += g8 * x1
        r3 += g9 * x1
        r4 += g10 * y1
        r5 += g11 * y1
        r8 += g12 * x2
        r9 += g13 * x2
        r10 += g14 * y2
        r11 += g15 * y2
        n0 += c * a
        n1 += c * x1
        n2 += c * y1
        n3 += c * b
        n4 += c * x2
        n5 += c * y2
        n6 += c * dis
        n7 += c * work
        q6 += w * dis
        q7 += w * work
    n_1, point = _history_point(p, phi_e, w_e, alpha_in, (r0, r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11),
                                tau_load)
    # corrector: + Psi (N_1 - N extrapolated)
    d = (n_1[0] - n0, n_1[1] - n1, n_1[2] - n2, n_1[3] - n3, n_1[4] - n4, n_1[5] - n5)
    q[0] += h * (q6 + gamma * (n_1[6] - n6))
    q[1] += h * (q7 + gamma * (n_1[7] - n7))
    return _shift((r0, r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11), psi, d), point


_NODES = tuple(-float(j) for j in range(HISTORY_POINTS))
#: (values at theta = 1 of the predictor's Lagrange basis, their integrals over [0, 1], the integral of the
#: corrector's Newton polynomial): the scalar weights at L = 0
_ADAMS_SCALARS = (tuple(sum(c) for c in series.lagrange_coefficients(_NODES)),
                  tuple(sum(c[m] / (m + 1) for m in range(len(c))) for c in series.lagrange_coefficients(_NODES)),
                  sum(c / (m + 1) for m, c in enumerate(series.newton_coefficients(_NODES))))


@functools.lru_cache(maxsize=16)
def _adams_operators(linear: tuple, h: float) -> tuple:
    """(E(h), Psi, W_0, ..., W_-5) of :func:`multistep_step` for L's blocks and h, memoized: E as
    :func:`_state_operator`, the others on N's speed columns (:func:`_speed_operator`)."""
    psi = _speed_operator(linear, h, series.integral_coefficients(h, series.newton_coefficients(_NODES)))
    return (_state_operator(linear, h), psi,
            *(_speed_operator(linear, h, series.integral_coefficients(h, c))
              for c in series.lagrange_coefficients(_NODES)))


def adams_operators(p: Parameters, h: float) -> tuple:
    """:func:`_adams_operators` (p.linear, h), kept on p for the last h: its memo hashes the 32 numbers of L every
    call, this compares one float."""
    memo = p.adams_memo
    if memo is None or memo[0] != h:
        memo = p.adams_memo = h, _adams_operators(p.linear, h)
    return memo[1]


def torque_outputs(p: Parameters, phi_in: float, w_in: float, alpha_in: float, y: Sequence[float]) -> dict:
    """dict of the torques and energy for a state (tau_in = J_gb alpha_in + T1); the joint evaluated once."""
    t1, t2, g, dpsi = shaft_torques(p, phi_in, w_in, y)
    return dict(tau_in=p.J_gb * alpha_in + t1, primary_shaft_torque=t1, secondary_shaft_torque=t2,
                joint_output_angle=g[0], stored_energy=_stored_energy(p, w_in, phi_in - y[0], g[0] - y[6], y))


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

class State(NamedTuple):
    """Disc angles and speeds, disc-centre displacements and velocities, and the energy audit's integrals."""

    theta1: float
    omega1: float
    X1: float
    dX1: float
    Y1: float
    dY1: float
    theta2: float
    omega2: float
    X2: float
    dX2: float
    Y2: float
    dY2: float
    dissipated_energy: float
    input_work: float


Inputs = Drive

#: the discs' lateral motion (the rest is twist, and the energy audit's integrals, which have no mode)
LATERAL_STATES = ("X1", "dX1", "Y1", "dY1", "X2", "dX2", "Y2", "dY2")


def initial_state(p: Parameters, t: float, u: Drive) -> State:
    """:func:`rest_state` at the input motion u."""
    return State(*rest_state(p, u.phi, u.omega))


def derivatives(p: Parameters, t: float, y: State, u: Drive) -> tuple:
    """:func:`rates` at the input motion u."""
    return rates(p, u.phi, u.omega, u.alpha, y, u.tau_load)


def integrate(p: Parameters, t: float, h: float, y: State, u: Drive) -> list:
    """One step without history: :func:`exponential_step` from the input motion u at the step's start (angle quadratic,
    speed linear in time over the step, tau_load held)."""
    return exponential_step(p, h, u.phi, u.omega, u.alpha, y, u.tau_load)


def integrate_with_history(p: Parameters, t: float, h: float, y: State, u: Drive, history: tuple) -> tuple:
    """The FMU's step: (state, history) of :func:`multistep_step` from the input motion u at the step's start
    (angle quadratic, speed linear in time over the step, tau_load held); :func:`integrate` without a history."""
    return multistep_step(p, t, h, u.phi, u.omega, u.alpha, y, u.tau_load, history)


def drive_derivatives(p: Parameters, t: float, y: State, phi: float, omega: float, alpha: float,
        tau_load: float) -> tuple:
    """:func:`derivatives` at the input motion (phi, omega, alpha) and tau_load as plain floats."""
    return rates(p, phi, omega, alpha, y, tau_load)


def rate_bound(p: Parameters, y: State, omega_max: float) -> float:
    """The natural-rate bound plus 4 |omega_in| (the 1x, 2x, 4x forcing by the unbalance and the joint): the
    protocol's RK4 rule, not used by the FMU, which steps with :func:`integrate` (one substep where RK4 takes two).

    The sum, not ``rk4.fastest_rate``'s max: with the max (one substep instead of two at 100 rad/s) the truncation
    error of the run-up energy audit (tests) grows 10x, to 1.2e-7 of the input work, past its bound: the
    combination frequencies of the unbalance and joint forcing with the modes are not small enough here."""
    return p.natural_rate + 4.0 * omega_max


def outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """The discs' motion from the state, the torques and energy as :func:`torque_outputs` gives them:
    :func:`light_outputs` and the two that need the joint, the secondary shaft's torque and the stored energy."""
    out = light_outputs(p, t, y, u)
    _, out["secondary_shaft_torque"], g, _ = shaft_torques(p, u.phi, u.omega, y)
    out["stored_energy"] = _stored_energy(p, u.omega, u.phi - y[0], g[0] - y[6], y)
    return out


#: the outputs without the joint's kinematics (:func:`light_outputs`): the FMU computes only these on a read of only
#: these, about a seventh of the cost of all (a host that reads the ports and the discs' motion)
LIGHT_OUTPUTS = ("phi_disc1", "omega_disc1", "X1", "Y1", "phi_out", "omega_out", "X2", "Y2", "dissipated_energy",
                 "input_work", "tau_in", "primary_shaft_torque")


def light_outputs(p: Parameters, t: float, y: State, u: Drive) -> dict:
    """The ``LIGHT_OUTPUTS`` of :func:`outputs`: the discs' motion and the energy rows from the state, the primary
    shaft's torque T1 = K1T (phi_in - theta1) + C1T (omega_in - theta1') and tau_in = J_gb alpha_in + T1."""
    t1 = p.K1T * (u.phi - y[0]) + p.C1T * (u.omega - y[1])
    return {"phi_disc1": y[0], "omega_disc1": y[1], "X1": y[2], "Y1": y[4], "phi_out": y[6], "omega_out": y[7],
            "X2": y[8], "Y2": y[10], "dissipated_energy": y[12], "input_work": y[13], "tau_in": p.J_gb * u.alpha + t1,
            "primary_shaft_torque": t1}


def speed_jump(p: Parameters, y: State, w_from: float, w_to: float) -> tuple:
    """y with J_gb (w_to^2 - w_from^2) / 2 in its input work: the work the driver does setting the flange from the
    speed the last step extrapolated it to to the host's new omega_in (at a kink of omega_in about J_gb omega
    delta-alpha h), an impulse that tau_in does not carry; the flange's kinetic energy in ``stored_energy`` jumps by
    as much."""
    return (*y[:13], y[13] + 0.5 * p.J_gb * (w_to - w_from) * (w_to + w_from))


def free_output_inertia(p: Parameters) -> float:
    """Disc 2's effective polar inertia J_M2 + m_u2 e^2 - (m_u2 e)^2 / (M2 + m_u2) (``Parameters.j_eff2``, its
    lateral coupling eliminated) behind the secondary shaft's torsional stiffness K2T: what a load on disc 2
    accelerates on its own."""
    return p.j_eff2


def output_free_inputs(p: Parameters) -> tuple:
    """The outputs (:func:`torque_outputs`) and the start do not depend on tau_load, which enters only disc 2's
    equation of motion."""
    return ("tau_load",)


def advice(p: Parameters) -> list:
    """Warnings on valid parameters likely not meant: a joint angle past ``protocol.LARGE_JOINT_ANGLE`` (degrees
    given as radians?)."""
    return joint_angle_advice("beta", p.beta)


def check(p: Parameters) -> list:
    """Every parameter's own range suffices."""
    return []


#: the largest end slope 3 |(X, Y)| / L [rad] either shaft may reach: its linear (Jeffcott) model, restoring force
#: K X with the end slope 3 X / L of a simply supported beam, neglects the slope's square against 1 (Euler-Bernoulli
#: small deflection), 1% at 0.1 rad (README.md, "Validity")
MAX_END_SLOPE = 0.1
#: (MAX_END_SLOPE / 3)^2: the bound of X^2 + Y^2 per L^2 (``check_state``)
_DEFLECTION_BOUND = (MAX_END_SLOPE / 3.0) ** 2


def check_state(p: Parameters, y: State) -> list:
    """Each shaft's end slope 3 sqrt(X^2 + Y^2) / L within MAX_END_SLOPE: a state past it has left the linear shafts'
    validity (an undamped resonance, a large unbalance, a large joint angle's secondary couple), and a step to it is
    refused with the reason instead of run on into a deflection the model cannot describe."""
    bound = _DEFLECTION_BOUND
    r1, r2 = y[2] * y[2] + y[4] * y[4], y[8] * y[8] + y[10] * y[10]
    if r1 <= bound * p.L1 * p.L1 and r2 <= bound * p.L2 * p.L2:
        return []
    i, r, span = (1, r1, p.L1) if r1 > bound * p.L1 * p.L1 else (2, r2, p.L2)
    return [f"the shaft of disc {i} bent to an end slope of {3.0 * math.sqrt(r) / span:.3g} rad (disc {i}'s centre "
            f"{math.sqrt(r):.3g} m off the axis, L{i} = {span:g} m), past the {MAX_END_SLOPE:g} rad within which its "
            "linear (Jeffcott) model holds: the motion has left the model's validity (a resonance with little "
            "damping, a large unbalance, a large joint angle's secondary couple, or a torque beyond what the shafts "
            "carry); results up to here are kept. If the same run at half the communication step does not stop "
            "here, the integration was at fault, not the physics: use that step, and report it"]


# --- the torque-driven rotor (TwinJeffcottRotorTorqueDriven): the input flange free, its motion in the state -------

@dataclass(slots=True, kw_only=True)
class TorqueDrivenParameters(Parameters):
    """TwinJeffcottRotorTorqueDriven's parameters: TwinJeffcottRotor's, the driver's rotor inertia J_drive lumped on
    the gearbox flange [kg.m2] and the flange's speed at the start time [rad/s]; natural_rate is the bound with
    the flange free, :func:`natural_rate_bound` plus the flange on the primary shaft,
    sqrt(K1T / J_in) + C1T / J_in with J_in = J_drive + J_gb (0 where :meth:`TorqueDriven.check` refuses it)."""

    J_drive: float
    omega_in_start: float
    inverse_j_in: float = field(init=False, repr=False)
    torque_linear: tuple = field(init=False, repr=False)
    torque_linear_rows: tuple = field(init=False, repr=False)
    torque_linear_rate: float = field(init=False, repr=False)
    #: (h, :func:`_torque_adams_operators` of torque_linear and h), as Parameters.adams_memo
    torque_adams_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        Parameters.__post_init__(self)
        j_in = self.J_drive + self.J_gb
        self.inverse_j_in = 1.0 / j_in if j_in >= MIN_SHAFT_INERTIA else 0.0   # else refused by the check
        if j_in >= MIN_SHAFT_INERTIA:
            self.natural_rate += math.sqrt(self.K1T / j_in) + self.C1T / j_in
        self.torque_linear = torque_linear_part(self)
        t, *lateral = self.torque_linear   # L's disc speed rows and lateral speed rows, flat for _flange_remainder
        self.torque_linear_rows = t[3] + t[5] + tuple(v for b in lateral for v in b[1])
        self.torque_linear_rate = _rate_of_chain(self.torque_linear)


def input_acceleration(p: TorqueDrivenParameters, y: Sequence[float], tau_in: float) -> float:
    """alpha_in of the free gearbox flange, (J_drive + J_gb) alpha_in = tau_in - T1 with the primary shaft torque
    T1 = K1T (phi_in - theta1) + C1T (omega_in - theta1') (the flange's coordinate in Lagrange's equations, Eq. 8,
    with V and D above); y = (phi_in, omega_in, theta1, theta1', ...)."""
    t1 = p.K1T * (y[0] - y[2]) + p.C1T * (y[1] - y[3])
    return (tau_in - t1) / (p.J_drive + p.J_gb)


# --- the torque-driven rotor's exponential integrator -------------------------------------------------------------
#
# The same splitting as the speed-driven rotor's, with the flange in the state: twist coordinates
# z = y - r(t) about the rigid rotation r(t) = (phi_0 + omega_0 t, omega_0) of the whole rotor at the flange's motion
# at the step's start (every angle, flange included, at phi_0 + omega_0 t, every speed at omega_0, discs centred;
# r'' = 0), z' = L z + N(t, z) with L the flange -- disc 1 -- disc 2 torsional chain (a 6x6 block with a rigid-body
# mode, so L is singular) and the Jeffcott oscillators. The state layout of z is the torque-driven state's:
# (flange, omega_in, theta1, omega1, X1, X1', Y1, Y1', theta2, omega2, X2, X2', Y2, Y2').

def torque_linear_part(p: TorqueDrivenParameters) -> tuple:
    """L of the torque-driven rotor in twist coordinates, block-diagonal: the torsional chain on (z_phi_in, z_omega_in,
    z_theta1, z_omega1, z_theta2, z_omega2), flange J_in = J_drive + J_gb -- K1T, C1T -- J_eff1 -- K2T, C2T -- J_eff2
    (the joint's mean speed ratio 1; :func:`input_acceleration` and :func:`linear_part`'s disc rows), and the Jeffcott
    oscillators of :func:`linear_part`. Its rigid-body mode (every angle and speed equal) has eigenvalue 0."""
    ji, j1, j2 = p.inverse_j_in, 1.0 / p.j_eff1, 1.0 / p.j_eff2
    k1, c1, k2, c2 = p.K1T, p.C1T, p.K2T, p.C2T
    torsion = ((0.0, 1.0, 0.0, 0.0, 0.0, 0.0),
               (-k1 * ji, -c1 * ji, k1 * ji, c1 * ji, 0.0, 0.0),
               (0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
               (k1 * j1, c1 * j1, -(k1 + k2) * j1, -(c1 + c2) * j1, k2 * j1, c2 * j1),
               (0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
               (0.0, 0.0, k2 * j2, c2 * j2, -k2 * j2, -c2 * j2))
    return (torsion, *linear_part(p)[1:])


def _rate_of_chain(blocks: tuple) -> float:
    """Upper bound of the spectral radius of :func:`torque_linear_part`: sqrt of the trace of M^-1 K plus the trace
    of M^-1 C (the diagonal stiffness and damping terms of its speed rows, as :func:`_rate`)."""
    torsion, *lateral = blocks
    stiffness = -torsion[1][0] - torsion[3][2] - torsion[5][4] - sum(b[1][0] for b in lateral)
    decay = -torsion[1][1] - torsion[3][3] - torsion[5][5] - sum(b[1][1] for b in lateral)
    return math.sqrt(stiffness) + decay


def _torque_propagators(p: TorqueDrivenParameters, h: float) -> tuple:
    """:func:`_torque_propagators_of` p's :func:`torque_linear_part` and h (memoized there: the parameters are
    derived once and never change as the FMU steps)."""
    return _torque_propagators_of(p.torque_linear, h)


@functools.lru_cache(maxsize=64)
def _torque_propagators_of(linear: tuple, h: float) -> tuple:
    """The operators of one Krogstad substep of length h (:func:`torque_exponential_step`; the weights of
    :func:`_propagators_of`), memoized, from the phi-functions (``series.phi_sum``) of the blocks of L at h/2 and h
    (the substep rule keeps h |lambda| <= 1 over L's eigenvalues, the rigid-body mode's 0 included, as for
    :func:`_torque_adams_operators`): full-state ones (E(h/2), E(h)) as 52 numbers (the torsional 6x6 row by row in
    the order (phi_in, omega_in, theta1, omega1, theta2, omega2), then each lateral 2x2 in the order X1, Y1, X2, Y2),
    ones applied to N (its speed rows only) as 26 numbers (per torsional row its columns omega_in, omega1, omega2;
    then each lateral block's speed column): Q1 = (h/2) phi_1(h L/2), Q2 = h phi_2(h L/2), R1 = h phi_1(h L),
    R2 = 2 h phi_2(h L), S1 = h (2 phi_2 - 4 phi_3)(h L), S2 = h (4 phi_3 - phi_2)(h L)."""
    half = 0.5 * h
    return (_state_operator(linear, half), _chain_speed_operator(linear, half, (0.0, half), (1, 3, 5)),
            _chain_speed_operator(linear, half, (0.0, 0.0, h), (1, 3, 5)), _state_operator(linear, h),
            _chain_speed_operator(linear, h, (0.0, h), (1, 3, 5)),
            _chain_speed_operator(linear, h, (0.0, 0.0, 2.0 * h), (1, 3, 5)),
            _chain_speed_operator(linear, h, (0.0, 0.0, 2.0 * h, -4.0 * h), (1, 3, 5)),
            _chain_speed_operator(linear, h, (0.0, 0.0, -h, 4.0 * h), (1, 3, 5)))


def _chain_speed_operator(linear: tuple, h: float, coefficients: tuple, columns: tuple) -> tuple:
    """sum_k coefficients[k] phi_k(h L) of the torque-driven rotor's L (:func:`torque_linear_part`) on the
    torsional block's columns given (per row those columns, row by row), then each lateral block's speed column
    (2 rows)."""
    torsion, *lateral = linear
    return tuple([v for row in series.phi_sum(torsion, h, coefficients, columns) for v in row]
                 + [row[0] for block in lateral for row in series.phi_sum(block, h, coefficients, (1,))])


def _chain_state_op(f: tuple, z: Sequence[float], g: tuple, d: Sequence[float]) -> list:
    """F z + G d: F a full-state operator on the 14 twist coordinates, G a speed-column operator on N's speed rows
    d = (omega_in, omega1, X1', Y1', omega2, X2', Y2') (layouts: :func:`_torque_propagators_of`)."""
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11, z12, z13 = z
    a, b, dx1, dy1, c, dx2, dy2 = d[:7]
    return [f[0] * z0 + f[1] * z1 + f[2] * z2 + f[3] * z3 + f[4] * z8 + f[5] * z9 + g[0] * a + g[1] * b + g[2] * c,
            f[6] * z0 + f[7] * z1 + f[8] * z2 + f[9] * z3 + f[10] * z8 + f[11] * z9 + g[3] * a + g[4] * b + g[5] * c,
            f[12] * z0 + f[13] * z1 + f[14] * z2 + f[15] * z3 + f[16] * z8 + f[17] * z9 + g[6] * a + g[7] * b
            + g[8] * c,
            f[18] * z0 + f[19] * z1 + f[20] * z2 + f[21] * z3 + f[22] * z8 + f[23] * z9 + g[9] * a + g[10] * b
            + g[11] * c,
            f[36] * z4 + f[37] * z5 + g[18] * dx1, f[38] * z4 + f[39] * z5 + g[19] * dx1,
            f[40] * z6 + f[41] * z7 + g[20] * dy1, f[42] * z6 + f[43] * z7 + g[21] * dy1,
            f[24] * z0 + f[25] * z1 + f[26] * z2 + f[27] * z3 + f[28] * z8 + f[29] * z9 + g[12] * a + g[13] * b
            + g[14] * c,
            f[30] * z0 + f[31] * z1 + f[32] * z2 + f[33] * z3 + f[34] * z8 + f[35] * z9 + g[15] * a + g[16] * b
            + g[17] * c,
            f[44] * z10 + f[45] * z11 + g[22] * dx2, f[46] * z10 + f[47] * z11 + g[23] * dx2,
            f[48] * z12 + f[49] * z13 + g[24] * dy2, f[50] * z12 + f[51] * z13 + g[25] * dy2]


def _chain_shift(v: Sequence[float], g: tuple, d: Sequence[float]) -> list:
    """v + G d for a difference d of N's speed rows (:func:`_chain_state_op`), whose omega_in row is 0: N's flange
    row is the constant tau_in / J_in (:func:`_flange_remainder`)."""
    b, dx1, dy1, c, dx2, dy2 = d[1:7]
    return [v[0] + g[1] * b + g[2] * c, v[1] + g[4] * b + g[5] * c, v[2] + g[7] * b + g[8] * c,
            v[3] + g[10] * b + g[11] * c, v[4] + g[18] * dx1, v[5] + g[19] * dx1, v[6] + g[20] * dy1,
            v[7] + g[21] * dy1, v[8] + g[13] * b + g[14] * c, v[9] + g[16] * b + g[17] * c, v[10] + g[22] * dx2,
            v[11] + g[23] * dx2, v[12] + g[24] * dy2, v[13] + g[25] * dy2]


def _chain_last_stage(v: Sequence[float], g: tuple, d: Sequence[float], e: Sequence[float], k: tuple,
                      f: Sequence[float]) -> list:
    """v + G (d + e) + K f: :func:`_chain_shift` by G for the sum of two differences and by K for a third."""
    b, dx1, dy1, c, dx2, dy2 = d[1] + e[1], d[2] + e[2], d[3] + e[3], d[4] + e[4], d[5] + e[5], d[6] + e[6]
    q, fx1, fy1, r, fx2, fy2 = f[1:7]
    return [v[0] + g[1] * b + g[2] * c + k[1] * q + k[2] * r, v[1] + g[4] * b + g[5] * c + k[4] * q + k[5] * r,
            v[2] + g[7] * b + g[8] * c + k[7] * q + k[8] * r, v[3] + g[10] * b + g[11] * c + k[10] * q + k[11] * r,
            v[4] + g[18] * dx1 + k[18] * fx1, v[5] + g[19] * dx1 + k[19] * fx1,
            v[6] + g[20] * dy1 + k[20] * fy1, v[7] + g[21] * dy1 + k[21] * fy1,
            v[8] + g[13] * b + g[14] * c + k[13] * q + k[14] * r, v[9] + g[16] * b + g[17] * c + k[16] * q + k[17] * r,
            v[10] + g[22] * dx2 + k[22] * fx2, v[11] + g[23] * dx2 + k[23] * fx2,
            v[12] + g[24] * dy2 + k[24] * fy2, v[13] + g[25] * dy2 + k[25] * fy2]


#: no remainder to subtract (:func:`_flange_remainder`)
_NONE9 = (0.0,) * 9


def _flange_remainder(p: TorqueDrivenParameters, phi: float, w: float, z: Sequence[float], tau_in: float,
                      tau_load: float, less: Sequence[float] = _NONE9) -> tuple:
    """N's speed rows (omega_in, omega1, X1', Y1', omega2, X2', Y2') and the rates of the dissipated energy and input
    work at the twist coordinates z about the rigid rotation (phi, w) (r'' = 0), f(r + z) - L z
    (:meth:`TorqueDriven.derivatives`, :func:`torque_linear_part`), each less the one of ``less``. The flange's row is
    tau_in / J_in: its equation of motion is linear, (tau_in - T1) / J_in with T1 in L."""
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11, z12, z13 = z
    alpha = (tau_in - p.K1T * (z0 - z2) - p.C1T * (z1 - z3)) * p.inverse_j_in
    f = rates(p, phi + z0, w + z1, alpha,
              (phi + z2, w + z3, z4, z5, z6, z7, phi + z8, w + z9, z10, z11, z12, z13, 0.0, 0.0), tau_load)
    a0, a1, a2, a3, a4, a5, b0, b1, b2, b3, b4, b5, kx1, cx1, ky1, cy1, kx2, cx2, ky2, cy2 = p.torque_linear_rows
    return (tau_in * p.inverse_j_in - less[0],
            f[1] - (a0 * z0 + a1 * z1 + a2 * z2 + a3 * z3 + a4 * z8 + a5 * z9) - less[1],
            f[3] - (kx1 * z4 + cx1 * z5) - less[2], f[5] - (ky1 * z6 + cy1 * z7) - less[3],
            f[7] - (b0 * z0 + b1 * z1 + b2 * z2 + b3 * z3 + b4 * z8 + b5 * z9) - less[4],
            f[9] - (kx2 * z10 + cx2 * z11) - less[5], f[11] - (ky2 * z12 + cy2 * z13) - less[6],
            f[12] - less[7], f[13] - less[8])


def torque_exponential_substeps(p: TorqueDrivenParameters, t_span: float, w_max: float) -> int:
    """Substeps of :func:`torque_exponential_step`, the rule of :func:`exponential_substeps` with the flange free:
    h times the larger of N's own rate plus 2 w_max (w_max a bound of |omega_in| over the step) and half the rate
    bound of :func:`torque_linear_part` within ``rk4.RATE_STEP``."""
    return rk4.substeps(max(p.remainder_rate + 2.0 * w_max, 0.5 * p.torque_linear_rate), t_span)


def torque_adams_substeps(p: TorqueDrivenParameters, t_span: float, w_max: float) -> int:
    """Substeps of :func:`torque_multistep_step`: :func:`torque_exponential_substeps`' rule, and h times N's own
    rate bound at most ``ADAMS_RATE_STEP`` (:func:`adams_substeps`)."""
    return rk4.substeps(max(p.remainder_rate + 2.0 * w_max, 0.5 * p.torque_linear_rate,
                            p.remainder_rate * rk4.RATE_STEP / ADAMS_RATE_STEP), t_span)


def torque_exponential_step(p: TorqueDrivenParameters, t_span: float, y: Sequence[float], tau_in: float,
                            tau_load: float) -> list:
    """Advance the torque-driven state y (:attr:`TorqueDriven.State`) over t_span, tau_in and tau_load held, with
    Krogstad's fourth-order ETDRK4-B (:func:`exponential_step`'s stages and weights) in twist coordinates about the
    rigid rotation at the flange's speed at the step's start: L (:func:`torque_linear_part`, flange included) exactly,
    N by four evaluations of the equations per substep (:func:`_flange_remainder`), the dissipated energy and input
    work by classical RK4 (L = 0 on those rows). Order 4 (tests); the rigid-body motion under constant torques
    (uniform acceleration) and the free torsional and lateral vibrations exact. Substeps:
    :func:`torque_exponential_substeps` at |omega_in| + |alpha_in| t_span."""
    phi, w = y[0], y[1]
    n = torque_exponential_substeps(p, t_span, abs(w) + abs(input_acceleration(p, y, tau_in)) * t_span)
    h = t_span / n
    ops = _torque_propagators(p, h)
    z = _chain_twist(y)
    q = [y[14], y[15]]
    for k in range(n):
        nu = _flange_remainder(p, phi + k * h * w, w, z, tau_in, tau_load)
        z = _torque_krogstad_substep(p, ops, h, phi, w, k, z, tau_in, tau_load, nu, q)
    return _chain_untwist(z, q, phi + t_span * w, w)


def _chain_twist(y: Sequence[float]) -> list:
    """The 14 twist coordinates of the torque-driven state y about the rigid rotation at its flange's angle and
    speed (its first two are 0)."""
    phi, w = y[0], y[1]
    return [0.0, 0.0, y[2] - phi, y[3] - w, y[4], y[5], y[6], y[7], y[8] - phi, y[9] - w, y[10], y[11], y[12], y[13]]


def _chain_untwist(z: Sequence[float], q: Sequence[float], end: float, w: float) -> list:
    """The torque-driven state from twist coordinates z about the rigid rotation at angle ``end``, speed w, and the
    energy rows q."""
    return [end + z[0], w + z[1], end + z[2], w + z[3], z[4], z[5], z[6], z[7], end + z[8], w + z[9], z[10], z[11],
            z[12], z[13], q[0], q[1]]


def _torque_krogstad_substep(p: TorqueDrivenParameters, ops: tuple, h: float, phi: float, w: float, k: int,
                             z: Sequence[float], tau_in: float, tau_load: float, nu: Sequence[float], q: list) -> list:
    """Substep k of :func:`torque_exponential_step` from z about the rigid rotation (phi + t w, w), N_u = nu given
    (operators ``ops``: :func:`_torque_propagators`): z+, the energy rows q advanced in place (classical RK4)."""
    e_half, q1, q2, e_full, r1, r2, s1, s2 = ops
    middle = phi + (k + 0.5) * h * w
    a = _chain_state_op(e_half, z, q1, nu)
    da = _flange_remainder(p, middle, w, a, tau_in, tau_load, nu)
    db = _flange_remainder(p, middle, w, _chain_shift(a, q2, da), tau_in, tau_load, nu)
    ec = _chain_state_op(e_full, z, r1, nu)
    dc = _flange_remainder(p, phi + (k + 1) * h * w, w, _chain_shift(ec, r2, db), tau_in, tau_load, nu)
    q[0] += h * (nu[7] + (da[7] + db[7]) / 3.0 + dc[7] / 6.0)
    q[1] += h * (nu[8] + (da[8] + db[8]) / 3.0 + dc[8] / 6.0)
    return _chain_last_stage(ec, s1, da, db, s2, dc)


# --- the torque-driven rotor's exponential Adams method (the FMU's stepper once it has a history) -----------------
#
# The method of :func:`multistep_step` in the torque-driven twist coordinates. L r = r' for every rigid rotation r of
# the whole rotor (every angle at phi_0 + omega_0 t, every speed at omega_0, discs centred): L's angle rows give the
# speeds, and its speed rows vanish on equal angles and equal speeds. So N(t, z) = f(r + z) - r' - L z = f(y) - L y
# depends on the state y = r + z alone, not on the rigid rotation the twist is taken about: a point of N keeps its
# value when the next step takes its twist about another rotation. The inputs enter N linearly (:func:`rates`,
# :func:`_input_columns`):
#     N(y) = N_0(y) + tau_in (e_omega_in + e_work J_gb omega_in) / J_in + tau_load (-e_omega2 / J_eff2 + G_2(theta2))
# (N_0 the remainder at tau_in = tau_load = 0, e_r the unit vector of row r, G_2 the lateral rows of disc 2), so the
# history keeps N_0, G_2 and omega_in per point and each step adds its own held inputs: no point is ever rewritten.

#: per history point: N_0's rows (omega1, X1', Y1', omega2, X2', Y2', dissipation, work), G_2's rows (X2'', Y2''),
#: the flange's speed omega_in (the work row's tau_in column / (J_gb / J_in)); N_0's flange row is 0
_TORQUE_POINT = 11
#: the history (FMU state): substep h, the time the next step starts at, points held, the tau_in and tau_load of
#: the step that left it, then the points (newest first)
TORQUE_HISTORY_SIZE = 5 + HISTORY_POINTS * _TORQUE_POINT
#: no history: the next step starts with :func:`torque_exponential_step`'s substeps
TORQUE_NO_HISTORY = (0.0,) * TORQUE_HISTORY_SIZE
#: a change of the held torques between steps [rad/s^2] (|d tau_in| / J_in + |d tau_load| / J_eff2: the steps of the
#: flange's and disc 2's accelerations) above which the history is discarded: the motion's accelerations jump, so
#: N's time derivative does, which no polynomial through the history follows. The bound of ``INPUT_JUMP``: a 5 N.m
#: step of tau_in (238 rad/s^2) or an 18 N.m load step (1840 rad/s^2) extrapolated across leaves 5.6x and 88x
#: ETDRK4-B's error, a step at the bound 0.46x and 1.8x (0.45x without a step; tests' run at 1 ms)
TORQUE_INPUT_JUMP = INPUT_JUMP


@functools.lru_cache(maxsize=16)
def _torque_adams_operators(linear: tuple, h: float) -> tuple:
    """(E(h), F, Psi, W_0, ..., W_-5) of :func:`torque_multistep_step` for the blocks of :func:`torque_linear_part`
    and h, memoized: E(h) as 52 numbers (the full-state layout of :func:`_torque_propagators_of`); F = h phi_1(hL) on
    the torsional columns omega_in and omega2 as 12 numbers (per torsional row those two columns), which carries the
    constant rows tau_in / J_in and -tau_load / J_eff2 of N; Psi and W_j = h sum_m c_jm m! phi_(m+1)(hL) on N_0's
    speed rows as 20 numbers (per torsional row its columns omega1 and omega2, then each lateral block's speed
    column). phi_0..phi_7 of each block by their Taylor series (``series.phi_sum``): the substep rule keeps
    h |lambda| <= 1 over L's eigenvalues (:func:`torque_exponential_substeps`), the rigid-body mode's 0 included."""
    f = tuple(v for row in series.phi_sum(linear[0], h, (0.0, h), (1, 5)) for v in row)
    psi = _chain_speed_operator(linear, h, series.integral_coefficients(h, series.newton_coefficients(_NODES)),
                                (3, 5))
    return (_state_operator(linear, h), f, psi,
            *(_chain_speed_operator(linear, h, series.integral_coefficients(h, c), (3, 5))
              for c in series.lagrange_coefficients(_NODES)))


def torque_adams_operators(p: TorqueDrivenParameters, h: float) -> tuple:
    """:func:`_torque_adams_operators` (p.torque_linear, h), kept on p for the last h (:func:`adams_operators`)."""
    memo = p.torque_adams_memo
    if memo is None or memo[0] != h:
        memo = p.torque_adams_memo = h, _torque_adams_operators(p.torque_linear, h)
    return memo[1]


def _torque_history_point(p: TorqueDrivenParameters, phi: float, w: float, z: Sequence[float], nu: Sequence[float],
                          tau_in: float, tau_load: float) -> list:
    """The history point (layout ``_TORQUE_POINT``) of N = nu (:func:`_flange_remainder` at tau_in, tau_load) at twist
    z about the rigid rotation (phi, w): nu less the inputs' columns."""
    gx, gy = _input_columns(p, phi + z[8])
    w_in = w + z[1]
    return [nu[1], nu[2], nu[3], nu[4] + tau_load / p.j_eff2, nu[5] - tau_load * gx, nu[6] - tau_load * gy, nu[7],
            nu[8] - p.J_gb * p.inverse_j_in * tau_in * w_in, gx, gy, w_in]


def torque_multistep_step(p: TorqueDrivenParameters, t: float, t_span: float, y: Sequence[float], tau_in: float,
                          tau_load: float, history: Sequence[float]) -> tuple:
    """(state, history) after t_span from t, tau_in and tau_load held, by the exponential Adams predictor-corrector of
    :func:`multistep_step` (Hochbruck, Ostermann, BIT Numer. Math. 51, 2011; Cox, Matthews, J. Comput. Phys. 176,
    2002) in the twist coordinates of :func:`torque_exponential_step`, PEC, per substep of h from z_n:
        predict   z* = E(h) z_n + F (tau_in / J_in, -tau_load / J_eff2) + sum_j W_j N_j
        evaluate  N_1 = N(t_n + h, z*)                 (ONE evaluation of :func:`rates` per substep)
        correct   z_n+1 = z* + Psi (N_1 - p(1))
    N_j the history's N_0 plus this step's inputs' columns (module comment above); the constant rows of N by
    F = h phi_1(hL) = sum_j W_j (the Lagrange basis sums to 1): exact, their part of N_1 - p(1) is 0
    (operators: :func:`_torque_adams_operators`). The energy rows (L = 0) by the same weights, scalar. Observed order
    5 from a start (tests). Without a history, with one of another substep length, not ending at t, or across a
    step of the torques (``TORQUE_INPUT_JUMP``), the substeps are :func:`torque_exponential_step`'s (bitwise), each
    adding its N_u, until HISTORY_POINTS points are held. Substeps: :func:`torque_adams_substeps`."""
    phi, w = y[0], y[1]
    n = torque_adams_substeps(p, t_span, abs(w) + abs(input_acceleration(p, y, tau_in)) * t_span)
    h = rk4.kept_substep(t_span / n, history[0], t, n)
    if (history[0] != h or abs(history[1] - t) > 1e-6 * h or abs(tau_in - history[3]) * p.inverse_j_in
            + abs(tau_load - history[4]) / p.j_eff2 > TORQUE_INPUT_JUMP):
        history = TORQUE_NO_HISTORY
    count = int(history[2])
    points = list(history[5:5 + _TORQUE_POINT * count])
    z = _chain_twist(y)
    q = [y[14], y[15]]
    start_ops = adams_ops = None
    for k in range(n):
        if count < HISTORY_POINTS:
            start = phi + k * h * w
            nu = _flange_remainder(p, start, w, z, tau_in, tau_load)
            points, count = _torque_history_point(p, start, w, z, nu, tau_in, tau_load) + points, count + 1
            if count < HISTORY_POINTS:
                if start_ops is None:
                    start_ops = _torque_propagators(p, h)
                z = _torque_krogstad_substep(p, start_ops, h, phi, w, k, z, tau_in, tau_load, nu, q)
                continue
        if adams_ops is None:
            adams_ops = torque_adams_operators(p, h)
        z, point = _torque_adams_substep(p, adams_ops, h, z, q, points, phi + (k + 1) * h * w, w, tau_in, tau_load)
        points = (point + points)[:_TORQUE_POINT * HISTORY_POINTS]
    history = (h, t + t_span, float(count), tau_in, tau_load, *points,
               *(0.0,) * (_TORQUE_POINT * (HISTORY_POINTS - count)))
    return _chain_untwist(z, q, phi + t_span * w, w), history


def _torque_adams_substep(p: TorqueDrivenParameters, ops: tuple, h: float, z: Sequence[float], q: list,
                          points: list, end: float, w: float, tau_in: float, tau_load: float) -> tuple:
    """One PEC substep of :func:`torque_multistep_step` from z, twist about the rigid rotation at speed w and, at the
    substep's end, angle ``end``, with the history points (newest, at z, first): (z+, its point); the energy rows q
    advanced in place."""
    e, f, psi, *weights = ops
    (e0, e1, e2, e3, e4, e5, e6, e7, e8, e9, e10, e11, e12, e13, e14, e15, e16, e17, e18, e19, e20, e21, e22, e23, e24,
     e25, e26, e27, e28, e29, e30, e31, e32, e33, e34, e35, e36, e37, e38, e39, e40, e41, e42, e43, e44, e45, e46, e47,
     e48, e49, e50, e51) = e
    f0, f1, f2, f3, f4, f5, f6, f7, f8, f9, f10, f11 = f
    extrapolation, quadrature, gamma = _ADAMS_SCALARS
    work_in = p.J_gb * p.inverse_j_in * tau_in   # the work row's tau_in column per unit flange speed
    a, b = tau_in * p.inverse_j_in, -tau_load / p.j_eff2   # N's constant rows omega_in and omega2
    z0, z1, z2, z3, z4, z5, z6, z7, z8, z9, z10, z11, z12, z13 = z
    # predictor: E z + F (a, b) + sum_j W_j N_j (torsional rows in the order of z0, z1, z2, z3, z8, z9)
    r0 = e0 * z0 + e1 * z1 + e2 * z2 + e3 * z3 + e4 * z8 + e5 * z9 + f0 * a + f1 * b
    r1 = e6 * z0 + e7 * z1 + e8 * z2 + e9 * z3 + e10 * z8 + e11 * z9 + f2 * a + f3 * b
    r2 = e12 * z0 + e13 * z1 + e14 * z2 + e15 * z3 + e16 * z8 + e17 * z9 + f4 * a + f5 * b
    r3 = e18 * z0 + e19 * z1 + e20 * z2 + e21 * z3 + e22 * z8 + e23 * z9 + f6 * a + f7 * b
    r8 = e24 * z0 + e25 * z1 + e26 * z2 + e27 * z3 + e28 * z8 + e29 * z9 + f8 * a + f9 * b
    r9 = e30 * z0 + e31 * z1 + e32 * z2 + e33 * z3 + e34 * z8 + e35 * z9 + f10 * a + f11 * b
    r4, r5 = e36 * z4 + e37 * z5, e38 * z4 + e39 * z5
    r6, r7 = e40 * z6 + e41 * z7, e42 * z6 + e43 * z7
    r10, r11 = e44 * z10 + e45 * z11, e46 * z10 + e47 * z11
    r12, r13 = e48 * z12 + e49 * z13, e50 * z12 + e51 * z13
    m1 = mx1 = my1 = m2 = mx2 = my2 = m_dis = m_work = s_dis = s_work = 0.0
    for i, (g, c, quad) in enumerate(zip(weights, extrapolation, quadrature)):
        n1, x1, y1, n2, x2, y2, dis, work, gx, gy, w_in = points[_TORQUE_POINT * i:_TORQUE_POINT * (i + 1)]
        x2 += tau_load * gx
        y2 += tau_load * gy
        work += work_in * w_in
        g0, g1, g2, g3, g4, g5, g6, g7, g8, g9, g10, g11, g12, g13, g14, g15, g16, g17, g18, g19 = g
        r0 += g0 * n1 + g1 * n2
        r1 += g2 * n1 + g3 * n2
        r2 += g4 * n1 + g5 * n2
        r3 += g6 * n1 + g7 * n2
        r8 += g8 * n1 + g9 * n2
        r9 += g10 * n1 + g11 * n2
        r4 += g12 * x1
        r5 += g13 * x1
        r6 += g14 * y1
        r7 += g15 * y1
        r10 += g16 * x2
        r11 += g17 * x2
        r12 += g18 * y2
        r13 += g19 * y2
        m1 += c * n1
        mx1 += c * x1
        my1 += c * y1
        m2 += c * n2
        mx2 += c * x2
        my2 += c * y2
        m_dis += c * dis
        m_work += c * work
        s_dis += quad * dis
        s_work += quad * work
    r = (r0, r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11, r12, r13)
    nu = _flange_remainder(p, end, w, r, 0.0, 0.0)
    gx, gy = _input_columns(p, end + r8)
    w_in = w + r1
    point = [nu[1], nu[2], nu[3], nu[4], nu[5], nu[6], nu[7], nu[8], gx, gy, w_in]
    # corrector: + Psi (N_1 - p(1)) on the rows that vary (the constant ones cancel)
    d1, dx1, dy1, d2 = nu[1] - m1, nu[2] - mx1, nu[3] - my1, nu[4] - m2
    dx2, dy2 = nu[5] + tau_load * gx - mx2, nu[6] + tau_load * gy - my2
    q[0] += h * (s_dis + gamma * (nu[7] - m_dis))
    q[1] += h * (s_work + gamma * (nu[8] + work_in * w_in - m_work))
    (psi0, psi1, psi2, psi3, psi4, psi5, psi6, psi7, psi8, psi9, psi10, psi11, psi12, psi13, psi14, psi15, psi16,
     psi17, psi18, psi19) = psi
    return [r0 + psi0 * d1 + psi1 * d2, r1 + psi2 * d1 + psi3 * d2, r2 + psi4 * d1 + psi5 * d2,
            r3 + psi6 * d1 + psi7 * d2, r4 + psi12 * dx1, r5 + psi13 * dx1, r6 + psi14 * dy1, r7 + psi15 * dy1,
            r8 + psi8 * d1 + psi9 * d2, r9 + psi10 * d1 + psi11 * d2, r10 + psi16 * dx2, r11 + psi17 * dx2,
            r12 + psi18 * dy2, r13 + psi19 * dy2], point


class TorqueDriven:
    """The protocol of the torque-driven rotor: state (phi_in, omega_in) of the gearbox flange, driven by tau_in
    with the driver's rotor inertia J_drive lumped on it (:func:`input_acceleration`), then the speed-driven
    rotor's :class:`State` driven by that motion (:func:`rates`); every other output is the speed-driven rotor's.
    input_work is the work into the rotor through the flange's shaft end, the integral of
    tau_input_shaft omega_in (tau_input_shaft = tau_in - J_drive alpha_in = J_gb alpha_in + T1); stored_energy
    counts J_gb, not J_drive."""

    Parameters = TorqueDrivenParameters
    Inputs = Torques
    LATERAL_STATES = LATERAL_STATES

    #: gearbox flange angle and speed, then the speed-driven rotor's :class:`State`
    State = NamedTuple("State", [("phi_in", float), ("omega_in", float)] + list(State.__annotations__.items()))
    free_output_inertia = staticmethod(free_output_inertia)

    @staticmethod
    def rate_sources(p: TorqueDrivenParameters) -> list:
        """:func:`rate_sources` with the gearbox flange free (J_drive + J_gb)."""
        return rate_sources(p, p.J_drive + p.J_gb)
    @staticmethod
    def initial_state(p: TorqueDrivenParameters, t: float, u: Torques) -> tuple:
        """The flange at phi_in_start turning at omega_in_start, the rotor at :func:`rest_state` of that motion."""
        return TorqueDriven.State(p.phi_in_start, p.omega_in_start, *rest_state(p, p.phi_in_start, p.omega_in_start))

    @staticmethod
    def derivatives(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> tuple:
        """(omega_in, alpha_in of :func:`input_acceleration`) and :func:`rates` at that motion."""
        alpha = input_acceleration(p, y, u.tau_in)
        return (y[1], alpha) + tuple(rates(p, y[0], y[1], alpha, y[2:], u.tau_load))

    @staticmethod
    def rate_bound(p: TorqueDrivenParameters, y: tuple, omega_max: float) -> float:
        """The natural-rate bound with the flange free plus 4 |omega_in| (the 1x, 2x, 4x forcing): the protocol's RK4
        rule, not used by the FMU, which steps with :meth:`integrate_with_history`."""
        return p.natural_rate + 4.0 * omega_max

    #: no history: the next step starts with :func:`torque_exponential_step`'s substeps
    NO_HISTORY = TORQUE_NO_HISTORY

    @staticmethod
    def integrate(p: TorqueDrivenParameters, t: float, h: float, y: tuple, u: Torques) -> list:
        """One step without history: :func:`torque_exponential_step`, tau_in and tau_load held."""
        return torque_exponential_step(p, h, y, u.tau_in, u.tau_load)

    @staticmethod
    def integrate_with_history(p: TorqueDrivenParameters, t: float, h: float, y: tuple, u: Torques,
                               history: tuple) -> tuple:
        """The FMU's step: (state, history) of :func:`torque_multistep_step`, tau_in and tau_load held;
        :meth:`integrate` without a history."""
        return torque_multistep_step(p, t, h, y, u.tau_in, u.tau_load, history)

    @staticmethod
    def input_acceleration(p: TorqueDrivenParameters, y: tuple, u: Torques) -> float:
        """alpha_in of :func:`input_acceleration` at the inputs u (the FMU bounds the flange's speed over a step by
        it before :meth:`integrate_with_history`)."""
        return input_acceleration(p, y, u.tau_in)

    @staticmethod
    def outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """The flange's motion from the state and :func:`input_acceleration`, the rest from :func:`outputs` at that
        motion."""
        alpha = input_acceleration(p, y, u.tau_in)
        return torque_driven_outputs(outputs(p, t, State(*y[2:]), Drive(y[0], y[1], alpha, u.tau_load)), y, alpha)

    @staticmethod
    def load_outputs(p: TorqueDrivenParameters, t: float, y: tuple, u: Torques) -> dict:
        """The outputs that move with the inputs (the FMU recomputes only these when only tau_in changed since the
        outputs were computed): the flange's acceleration and tau_input_shaft = J_gb alpha_in + T1, as
        :meth:`outputs` gives them (every other output is a function of the state)."""
        alpha = input_acceleration(p, y, u.tau_in)
        return {"alpha_in": alpha,
                "tau_input_shaft": p.J_gb * alpha + (p.K1T * (y[0] - y[2]) + p.C1T * (y[1] - y[3]))}

    @staticmethod
    def output_free_inputs(p: TorqueDrivenParameters) -> tuple:
        """:func:`output_free_inputs`: the flange's acceleration (an output) is driven by tau_in and the primary
        shaft torque, not by tau_load."""
        return output_free_inputs(p)

    @staticmethod
    def check(p: TorqueDrivenParameters) -> list:
        """:func:`check`, and the flange needs an inertia to integrate."""
        return check(p) + shaft_inertia_problems("J_drive + J_gb", p.J_drive + p.J_gb, "gearbox flange")

    advice = staticmethod(advice)

    @staticmethod
    def check_state(p: TorqueDrivenParameters, y: tuple) -> list:
        """:func:`check_state` of the rotor's part of the state."""
        return check_state(p, y[2:])
