"""Monolithic reference for Motor -> CardanJoint -> Load, and for its torque-driven wiring
MotorController -> CardanJointTorqueDriven -> Load (the same ODE, the rotor inertia taken from J_drive).

Independent of the co-simulation and of ujfmu.models.cardan_joint.model:
- joint kinematics from sympy: e1 = C (-sin t1, cos t1, 0) and K = C e_z with C = R_y(-gamma) R_x(-beta) R_y(delta)
  R_x(phi) (the matrices that reproduce Feng's Eqs. (1), (9)); theta2 from atan2 of e1's projection (unwrapped),
  the velocity ratio r = d(theta2)/d(theta1) and r' by symbolic differentiation (not the model's K_z/xi^2 identity);
- the transmitted moment from numpy cross products, e_n = e1 x e2 (Eqs. 3-4, 10);
- the coupled system as one ODE, Lagrange with T = (J_m + J1 + J2 r^2) omega1^2 / 2:
      (J_m + J1 + J2 r^2) alpha1 = tau_motor - J2 r r' omega1^2 - r tau_load(r omega1)
  with the driven angle integrated as a state (d theta2/dt = r omega1), the PI law with anti-windup written out
  again here, solved with scipy DOP853 at rtol 1e-11 and split at profile corners;
- with an ideal speed source, closed form: theta1, omega1, alpha1 from the profile.
"""

import functools

import numpy as np
import sympy as sp

from ...references.common import (check_chain_wiring, check_close, check_energy_balance, drive, load_torque, pi_law,
                                  record_table, solve_piecewise, source_motion, source_torque, start_integral,
                                  torque_driven_names)
from ...references.rotations import rx, ry

RTOL, ATOL = 1e-11, 1e-12


@functools.lru_cache(maxsize=None)
def _kinematics():
    t1, phi, delta, beta, gamma = sp.symbols("theta1 phi delta beta gamma", real=True)
    c = ry(-gamma) * rx(-beta) * ry(delta) * rx(phi)
    e1 = c * sp.Matrix([-sp.sin(t1), sp.cos(t1), 0])
    k = c * sp.Matrix([0, 0, 1])
    theta2 = sp.atan2(-e1[0], e1[1])
    r = sp.diff(theta2, t1)
    dr = sp.diff(r, t1)
    args = (t1, phi, delta, beta, gamma)
    return (sp.lambdify(args, list(e1), "numpy"), sp.lambdify(args, list(k), "numpy"),
            sp.lambdify(args, r, "numpy"), sp.lambdify(args, dr, "numpy"))


class JointKinematics:
    def __init__(self, angles):
        self.angles = angles
        self._e1, self._k, self._r, self._dr = _kinematics()

    def ratio(self, theta1):
        return self._r(theta1, *self.angles), self._dr(theta1, *self.angles)

    def driven_angle(self, theta1):
        """theta2 by atan2 of the pin projection, unwrapped against theta1 (for the initial value)."""
        e1 = self._e1(theta1, *self.angles)
        raw = np.arctan2(-np.asarray(e1[0]), np.asarray(e1[1]))
        return theta1 + (raw - theta1 + np.pi) % (2 * np.pi) - np.pi

    def driving_axis(self, theta1):
        """K = C e_z (Eq. 9), the driving shaft's axis in the driven frame, as three arrays like theta1."""
        return np.broadcast_arrays(*self._k(theta1, *self.angles), theta1)[:3]

    def moment(self, theta1, m_z):
        """(M_x, M_y) from Eq. (10): M = M_z / e_n,z along e_n = e1 x e2, e2 = e3 x e1 / |e3 x e1|."""
        e1 = np.array(np.broadcast_arrays(*self._e1(theta1, *self.angles)))
        e3 = np.array([0.0, 0.0, 1.0])[:, None] * np.ones_like(e1[0])
        e2 = np.cross(e3, e1, axis=0)
        e2 /= np.linalg.norm(e2, axis=0)
        en = np.cross(e1, e2, axis=0)
        m = m_z / en[2]
        return m * en[0], m * en[1]


def generate(scenario):
    """Reference for the chain of exactly three components named motor, joint, load, refused (WiringError naming
    what differs) for any other wiring:

    - speed-driven: motor (Motor), joint (CardanJoint), load (Load); connections motor.omega -> joint.omega_in,
      joint.tau_in -> motor.tau_load, joint.omega_out -> load.omega, load.tau -> joint.tau_load;
    - torque-driven: motor (MotorController), joint (CardanJointTorqueDriven), load (Load); connections
      joint.omega_in -> motor.omega, motor.tau_motor -> joint.tau_in, joint.omega_out -> load.omega,
      load.tau -> joint.tau_load.
    """
    check_chain_wiring(scenario, "cardan_joint", "joint", "CardanJoint")
    pl, pj = scenario.parameters_with_defaults("load"), scenario.parameters_with_defaults("joint")
    pm, jm, w0, torque_driven = drive(scenario, "motor", "joint")
    kin = JointKinematics((pj["bend_angle"], pj["bend_plane_angle"], pj["error_angle_beta"],
                           pj["error_angle_gamma"]))
    j1, j2 = pj["J1"], pj["J2"]
    t = scenario.time_grid()
    theta20 = float(kin.driven_angle(np.array(pj["phi_in_start"])))

    if pm["ideal_speed_source"]:
        w1, a1, ang = source_motion(pm, t)
        theta1 = pj["phi_in_start"] + ang
        theta2 = kin.driven_angle(theta1)
        phi_motor = ang
        how = "closed form (ideal speed source): theta1 from the profile, theta2 by atan2 of the pin projection"
    else:
        def rhs(time, y):
            _, w, integral, _ = y
            th1 = y[0] + pj["phi_in_start"]
            r, dr = kin.ratio(th1)
            tau_m, di = pi_law(pm, time, w, integral)
            a = (tau_m - j2 * r * dr * w * w - r * load_torque(pl, r * w, time, y[3])) / (jm + j1 + j2 * r * r)
            return [w, a, di, r * w]

        y = [0.0, w0, start_integral(pm), theta20]
        ys = solve_piecewise(rhs, y, t, pm, RTOL, ATOL, [pl])
        phi_motor, w1, integral, theta2 = ys
        theta1 = pj["phi_in_start"] + phi_motor
        r, dr = kin.ratio(theta1)
        tau_m, _ = pi_law(pm, t, w1, integral)
        a1 = (tau_m - j2 * r * dr * w1 * w1 - r * load_torque(pl, r * w1, t, theta2)) / (jm + j1 + j2 * r * r)
        how = (f"monolithic ODE of motor+joint+load (Lagrange, sympy kinematics), scipy DOP853 "
               f"rtol={RTOL:g} atol={ATOL:g}")

    r, dr = kin.ratio(theta1)
    w2 = r * w1
    tau_load = load_torque(pl, w2, t, theta2)
    a2 = r * a1 + dr * w1 * w1
    m_z = j2 * a2 + tau_load
    tau_in = j1 * a1 + r * m_z
    m_x, m_y = kin.moment(theta1, m_z)
    if pm["ideal_speed_source"]:
        tau_motor = source_torque(jm, a1, tau_in)
    else:
        tau_motor = tau_m
    columns = {
        "motor.omega": w1, "motor.phi": phi_motor, "motor.tau_motor": tau_motor,
        "joint.omega_out": w2, "joint.phi_out": theta2, "joint.tau_in": tau_in, "joint.phi_in": theta1,
        "joint.M_x": m_x, "joint.M_y": m_y, "joint.M_z": m_z, "load.tau": tau_load, "joint.alpha_in": a1,
    }
    self_check(scenario, t, columns)
    if torque_driven:
        columns = torque_driven_names("joint", columns)
    table = record_table(scenario, t, columns)
    return table, f"{__name__}: {how}"


def self_check(scenario, t: np.ndarray, columns: dict) -> None:
    """The reference's own laws, checked before it is written (ReferenceCheckError otherwise):

    - energy: (J_m + J1) w1^2/2 + J2 w2^2/2 (J_m the rotor inertia: Motor's J_rotor, or the torque-driven joint's
      J_drive) changes by the work of tau_motor on w1 less that of the load on w2
      (checks the Lagrange equation, its r r' term and the solve);
    - torque balance about the driving axis: M . K = tau_in - J1 alpha1 (the moment vector of Eq. 10, built from
      cross products, against the torque built from the sympy velocity ratio);
    - closed-form limit of a single joint: cos(theta) <= omega2/omega1 <= 1/cos(theta), cos(theta) = K_z.
    columns: 'motor.omega', 'motor.tau_motor', 'joint.omega_out', 'joint.phi_in', 'joint.alpha_in',
    'joint.tau_in', 'joint.M_x', 'joint.M_y', 'joint.M_z', 'load.tau' on the grid t.
    """
    pj, j_motor = scenario.parameters_with_defaults("joint"), drive(scenario, "motor", "joint")[1]
    c = columns
    w1, w2 = c["motor.omega"], c["joint.omega_out"]
    stored = 0.5 * (j_motor + pj["J1"]) * w1 ** 2 + 0.5 * pj["J2"] * w2 ** 2
    check_energy_balance(scenario, "kinetic energy against the work of motor and load", t, stored,
                         c["motor.tau_motor"] * w1, c["load.tau"] * w2, 1e-6)
    kin = JointKinematics((pj["bend_angle"], pj["bend_plane_angle"], pj["error_angle_beta"],
                           pj["error_angle_gamma"]))
    k = kin.driving_axis(np.asarray(c["joint.phi_in"], dtype=float))
    check_close(scenario, "torque balance about the driving axis, M . K = tau_in - J1 alpha1",
                c["joint.M_x"] * k[0] + c["joint.M_y"] * k[1] + c["joint.M_z"] * k[2],
                c["joint.tau_in"] - pj["J1"] * c["joint.alpha_in"], float(np.max(np.abs(c["joint.tau_in"]))),
                1e-9)
    moving = np.abs(w1) > 1e-9 * max(float(np.max(np.abs(w1))), 1e-300)
    ratio, cos_angle = w2[moving] / w1[moving], float(k[2].flat[0])
    check_close(scenario, "velocity ratio within [cos(theta), 1/cos(theta)]",
                np.clip(ratio, cos_angle, 1.0 / cos_angle), ratio, 1.0, 1e-12)
