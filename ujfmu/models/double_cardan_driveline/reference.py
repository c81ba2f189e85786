"""Monolithic reference for Motor -> DoubleCardanDriveline -> Load, and for its torque-driven wiring
MotorController -> DoubleCardanDrivelineTorqueDriven -> Load (the same equations, the rotor inertia from J_drive).

Independent of the co-simulation and of this folder's model.py, it starts again from geometry and energy:
- each joint from vectors (sympy): the driving pin e_A = R_x(b) (-sin x, cos x, 0) in the driven shaft's frame,
  the driven angle y = x + atan2 of e_A's projection (no tan formula), the cross frame (e_A, e_B, e_n) with
  e_B = e_z x e_A / |e_z x e_A|, e_n = e_A x e_B, and the cross's body angular velocity from R^T dR/dt;
- the kinetic energy of every body, the potential and the Rayleigh function of README.md as sympy
  expressions, and Lagrange's equations M(q) q'' + h(q, q') = Q formed by sympy's differentiation
  (q = input angle, output angle, dynamic misalignment; the input angle prescribed for an ideal speed source);
- for the rigid intermediate shaft, the output angle by Newton iteration on phi3(phi4) = phi2 and the input torque
  from d(T)/dt + tau_load w4 = tau_in w1 (closed form along the prescribed motion);
- the motor's PI law and the load's torque written out again (references.common); one scipy DOP853 solve of the
  whole system, rtol 1e-10, split at the speed profile's corners.
"""

import functools

import numpy as np
import sympy as sp

from ...references.common import (check_chain_wiring, check_close, check_energy_balance, drive, drive_name, load_torque,
                                  pi_law, profile, record_table, solve_piecewise, source_motion, source_start_angle,
                                  source_torque, start_integral, torque_driven_names, WiringError)
from ...references.rotations import rx

RTOL, ATOL = 1e-10, 1e-11
_PARAMS = ("beta1", "beta2", "yoke_phase", "joint_plane_angle", "I_input", "I_cross_pin", "I_cross_normal",
           "I_intermediate", "J_load", "k_theta", "xi_theta", "m_s", "k_phi", "xi_phi", "L_c")


def _joint(x, b):
    """(y - x, cross rotation rates per unit dx/dt about e_A, e_B, e_n) for one joint with bend b."""
    e_a = rx(b) * sp.Matrix([-sp.sin(x), sp.cos(x), 0])
    err = sp.atan2(-e_a[0] * sp.cos(x) - e_a[1] * sp.sin(x), e_a[1] * sp.cos(x) - e_a[0] * sp.sin(x))
    e_b = sp.Matrix([-e_a[1], e_a[0], 0]) / sp.sqrt(e_a[0] ** 2 + e_a[1] ** 2)
    e_n = e_a.cross(e_b)
    rot = sp.Matrix.hstack(e_a, e_b, e_n)
    w = rot.T * rot.diff(x)   # skew matrix of the body angular velocity per unit dx/dt
    return err, (w[2, 1], w[0, 2], w[1, 0])


@functools.lru_cache(maxsize=None)
def _equations():
    """Lambdified M(q, p) and h(q, qd, p) of Lagrange's equations (floats), the output expressions and the rigid
    shaft's kinematics (numpy)."""
    p1, p4, f, w1, w4, v = sp.symbols("phi1 phi4 phi w1 w4 v", real=True)
    (b1, b2, yoke, plane, i_in, i_pin, i_n, i_int, j_load, k_t, xi_t, m_s, k_f, xi_f, l_c) = params = \
        sp.symbols(" ".join(_PARAMS), real=True)
    delta = yoke - plane
    x, b = sp.symbols("x b", real=True)
    err, rates = _joint(x, b)

    def cross_energy(angle, bend):
        wa, wb, wn = (r.subs({x: angle, b: bend}) for r in rates)
        return i_pin * (wa ** 2 + wb ** 2) + i_n * wn ** 2

    # kinetic energy: rotating parts at the static joint angles, lateral mass (README.md)
    phi2_static = p1 + err.subs({x: p1, b: b1})
    phi3_static = p4 + err.subs({x: p4 + delta, b: b2})
    j_in = i_in + cross_energy(p1, b1) + i_int / 2 * sp.diff(phi2_static, p1) ** 2
    j_out = j_load + cross_energy(p4 + delta, b2) + i_int / 2 * sp.diff(phi3_static, p4) ** 2
    lever2 = (l_c * sp.cos(b1)) ** 2
    kinetic = (j_in * w1 ** 2 + j_out * w4 ** 2 + m_s * lever2 * v ** 2) / 2
    # elastic twist with the dynamic joint angles
    phi2 = p1 + err.subs({x: p1, b: b1 + f})
    phi3 = p4 + err.subs({x: p4 + delta, b: b2 + f * sp.cos(plane)})
    twist = phi2 - phi3
    q, qd = (p1, p4, f), (w1, w4, v)
    dtwist = sum(sp.diff(twist, qi) * wi for qi, wi in zip(q, qd))
    potential = (k_t * twist ** 2 + k_f * lever2 * f ** 2) / 2
    rayleigh = (xi_t * k_t * dtwist ** 2 + xi_f * k_f * lever2 * v ** 2) / 2
    mass = sp.Matrix(3, 3, lambda i, j: sp.diff(kinetic, qd[i], qd[j]))
    h = sp.Matrix([sum(sp.diff(kinetic, qd[i], q[j]) * qd[j] for j in range(3)) - sp.diff(kinetic, q[i])
                   + sp.diff(potential, q[i]) + sp.diff(rayleigh, qd[i]) for i in range(3)])
    args = (q, qd, params)
    omega2 = sp.diff(phi2, p1) * w1 + sp.diff(phi2, f) * v
    energy = kinetic + potential
    # rigid shaft: phi3 = phi2 at the static angles, rho = dphi4/dphi1, J_eq(phi1, phi4)
    rho = sp.diff(phi2_static, p1) / sp.diff(phi3_static, p4)
    j_eq = j_in + j_out * rho ** 2
    rigid = [phi2_static, phi3_static, sp.diff(phi3_static, p4), rho, j_eq,
             sp.diff(j_eq, p1) + sp.diff(j_eq, p4) * rho, j_in, sp.diff(j_in, p1), sp.diff(phi2_static, p1),
             sp.diff(rho, p1) + sp.diff(rho, p4) * rho]
    # M row by row and h as one flat list of plain floats for one state (math, shared subexpressions: the solve's
    # inner loop, several times numpy on scalars)
    return (sp.lambdify(args, [*mass, *h], "math", cse=True),
            sp.lambdify(args, [twist, dtwist, omega2, energy], "numpy", cse=True),
            sp.lambdify(((p1, p4), params), rigid, "numpy", cse=True))


class DrivelineReference:
    """The driveline's equations for one parameter set (a dict with the FMU's parameter names)."""

    def __init__(self, pd):
        self.pd = pd
        self.params = tuple(float(pd[n]) for n in _PARAMS)
        self._terms, self._outputs, self._rigid = _equations()

    def accelerations(self, q, qd, known_alpha1=None, tau_drive=0.0, extra_inertia=0.0, tau_load=0.0):
        """Solve Lagrange's equations. With known_alpha1 the input is prescribed and the input-row generalised
        force (tau_in) is returned; else tau_drive acts on phi1 carrying extra_inertia (the motor)."""
        values = self._terms([float(v) for v in q], [float(v) for v in qd], self.params)
        m, h = np.array(values[:9]).reshape(3, 3), np.array(values[9:])
        rhs = -h + np.array([0.0, -tau_load, 0.0])
        if known_alpha1 is not None:
            acc = np.linalg.solve(m[1:, 1:], rhs[1:] - m[1:, 0] * known_alpha1)
            tau_in = m[0, 0] * known_alpha1 + m[0, 1:] @ acc + h[0]
            return np.concatenate([[known_alpha1], acc]), tau_in
        m[0, 0] += extra_inertia
        rhs[0] += tau_drive
        acc = np.linalg.solve(m, rhs)
        return acc, m[0, 0] * acc[0] - extra_inertia * acc[0] + m[0, 1:] @ acc[1:] + h[0]

    def outputs(self, q, qd):
        """(twist, dtwist, omega2, energy)."""
        return self._outputs(q, qd, self.params)

    def rigid_phi4(self, phi1):
        """Output angle for an untwisted shaft: Newton on phi3(phi4) = phi2, started at phi4 = phi2."""
        phi1 = np.asarray(phi1, dtype=float)
        phi2 = self._rigid((phi1, phi1), self.params)[0]
        phi4 = np.array(phi2, dtype=float)
        for _ in range(50):
            _, phi3, dphi3, *_ = self._rigid((phi1, phi4), self.params)
            step = (phi3 - phi2) / dphi3
            phi4 = phi4 - step
            if np.max(np.abs(step)) < 1e-15:
                break
        return phi4

    def rigid(self, phi1):
        """dict of phi2, phi4, rho, J_eq, dJ_eq/dphi1, J_in, dJ_in/dphi1, r1, drho/dphi1 along phi1."""
        phi4 = self.rigid_phi4(phi1)
        phi2, _, _, rho, j_eq, dj_eq, j_in, dj_in, r1, drho = self._rigid((phi1, phi4), self.params)
        return dict(phi2=phi2, phi4=phi4, rho=rho, j_eq=j_eq, dj_eq=dj_eq, j_in=j_in, dj_in=dj_in, r1=r1,
                    drho=drho)


def generate(scenario):
    """Reference for the chain of exactly three components named motor, driveline, load, refused (WiringError
    naming what differs) for any other wiring:

    - speed-driven: motor (Motor), driveline (DoubleCardanDriveline), load (Load); connections motor.omega ->
      driveline.omega_in, driveline.tau_in -> motor.tau_load, driveline.omega_out -> load.omega,
      load.tau -> driveline.tau_load;
    - torque-driven: motor (MotorController), driveline (DoubleCardanDrivelineTorqueDriven), load (Load);
      connections driveline.omega_in -> motor.omega, motor.tau_motor -> driveline.tau_in,
      driveline.omega_out -> load.omega, load.tau -> driveline.tau_load.
    """
    check_chain_wiring(scenario, "double_cardan_driveline", "driveline", "DoubleCardanDriveline")
    pd, pl = scenario.parameters_with_defaults("driveline"), scenario.parameters_with_defaults("load")
    pm, jm, w1_0, torque_driven = drive(scenario, "motor", "driveline")
    ref = DrivelineReference(pd)
    t = scenario.time_grid()
    ideal = pm["ideal_speed_source"]
    phi1_0 = pd["phi_in_start"]
    cols, tau_m, dissipation = {}, None, 0.0

    if pd["rigid_intermediate_shaft"]:
        if not ideal or torque_driven:
            raise WiringError(f"{scenario.path}: the rigid-shaft reference needs an ideal speed source")
        w1, a1, phi_m = source_motion(pm, t)
        phi1 = phi1_0 + phi_m
        rg = ref.rigid(phi1)
        w4 = rg["rho"] * w1
        tau_l = load_torque(pl, w4, t, rg["phi4"])
        tau_in = rg["j_eq"] * a1 + 0.5 * rg["dj_eq"] * w1 ** 2 + rg["rho"] * tau_l
        cols.update({
            "driveline.phi_out": rg["phi4"], "driveline.omega_out": w4, "driveline.tau_in": tau_in,
            "driveline.twist": 0.0 * t, "driveline.dynamic_misalignment": 0.0 * t,
            "driveline.omega_intermediate": rg["r1"] * w1,
            "driveline.shaft_torque": (tau_in - rg["j_in"] * a1 - 0.5 * rg["dj_in"] * w1 ** 2) / rg["r1"],
            "driveline.stored_energy": 0.5 * rg["j_eq"] * w1 ** 2,
            "driveline.tau_out": pd["J_load"] * (rg["rho"] * a1 + rg["drho"] * w1 ** 2) + tau_l,
        })
        how = ("closed form along the prescribed input (rigid shaft): output angle by Newton on the vector "
               "kinematics, tau_in from d(T)/dt + tau_load w4 with T from the bodies' angular velocities (sympy)")
    else:
        phi4_0 = float(ref.rigid_phi4(np.array(phi1_0)))
        rho_0 = float(ref.rigid(np.array(phi1_0))["rho"])
        y = [phi4_0, rho_0 * w1_0, 0.0, 0.0]

        if ideal:
            def rhs(time, y):
                w1, a1, ang = profile(pm, time)
                q = (phi1_0 + ang - ang0, y[0], y[2])
                qd = (float(w1), y[1], y[3])
                acc, _ = ref.accelerations(q, qd, known_alpha1=float(a1),
                                           tau_load=load_torque(pl, y[1], time, y[0]))
                return [y[1], acc[1], y[3], acc[2]]
            ang0 = source_start_angle(pm, t)
        else:
            y = [0.0, w1_0, start_integral(pm)] + y

            def rhs(time, y):
                q, qd = (phi1_0 + y[0], y[3], y[5]), (y[1], y[4], y[6])
                tau_m, di = pi_law(pm, time, y[1], y[2])
                acc, _ = ref.accelerations(q, qd, tau_drive=float(tau_m), extra_inertia=jm,
                                           tau_load=load_torque(pl, y[4], time, y[3]))
                return [y[1], acc[0], float(di), y[4], acc[1], y[6], acc[2]]

        ys = solve_piecewise(rhs, y, t, pm, RTOL, ATOL, [pl])
        if ideal:
            w1, a1, phi_m = source_motion(pm, t)
            phi4, w4, f, v = ys
        else:
            phi_m, w1, integral, phi4, w4, f, v = ys
            tau_m, _ = pi_law(pm, t, w1, integral)
        phi1 = phi1_0 + phi_m
        tau_l = load_torque(pl, w4, t, phi4)
        tau_in, a4 = np.empty_like(t), np.empty_like(t)
        if not ideal:
            a1 = np.empty_like(t)
        for i in range(len(t)):
            q, qd = (phi1[i], phi4[i], f[i]), (w1[i], w4[i], v[i])
            if ideal:
                acc, tau_in[i] = ref.accelerations(q, qd, known_alpha1=float(a1[i]), tau_load=tau_l[i])
            else:
                acc, tau_in[i] = ref.accelerations(q, qd, tau_drive=float(tau_m[i]), extra_inertia=jm,
                                                   tau_load=tau_l[i])
                a1[i] = acc[0]
            a4[i] = acc[1]
        twist, dtwist, w2, energy = ref.outputs((phi1, phi4, f), (w1, w4, v))
        dissipation = (pd["xi_theta"] * pd["k_theta"] * dtwist ** 2
                       + pd["xi_phi"] * pd["k_phi"] * (pd["L_c"] * np.cos(pd["beta1"])) ** 2 * v ** 2)
        cols.update({
            "driveline.phi_out": phi4, "driveline.omega_out": w4, "driveline.tau_in": tau_in,
            "driveline.twist": twist, "driveline.dynamic_misalignment": f, "driveline.omega_intermediate": w2,
            "driveline.shaft_torque": pd["k_theta"] * twist + pd["xi_theta"] * pd["k_theta"] * dtwist,
            "driveline.stored_energy": energy, "driveline.tau_out": pd["J_load"] * a4 + tau_l,
        })
        how = (f"monolithic ODE of {drive_name(ideal)} + driveline + load, Lagrange's "
               f"equations formed by sympy from vector kinematics and energies, scipy DOP853 rtol={RTOL:g} "
               f"atol={ATOL:g}")
    cols.update({"motor.omega": w1, "motor.phi": phi_m, "load.tau": tau_l, "driveline.phi_in": phi1,
                 "driveline.alpha_in": a1})
    cols["motor.tau_motor"] = source_torque(jm, a1, cols["driveline.tau_in"]) if ideal else tau_m
    self_check(scenario, t, cols, dissipation)
    if torque_driven:
        cols = torque_driven_names("driveline", cols)
    table = record_table(scenario, t, cols)
    return table, f"{__name__}: {how}"


def self_check(scenario, t: np.ndarray, columns: dict, dissipation=0.0) -> None:
    """The reference's own laws, checked before it is written (ReferenceCheckError otherwise):

    - energy: stored_energy changes by the work of tau_in on the input less the load's work on the output and
      the Rayleigh loss (dissipation: the power 2D of README.md, 0 for the rigid shaft);
    - closed-form limit: a rigid shaft with equal joint angles and the yokes in the joint plane (Z layout, in
      phase) is a constant-velocity joint, omega_out = omega_in.
    columns: 'motor.omega', 'driveline.omega_out', 'driveline.tau_in', 'driveline.stored_energy', 'load.tau'.
    """
    c, pd = columns, scenario.parameters_with_defaults("driveline")
    w1, w4 = c["motor.omega"] * np.ones_like(t), c["driveline.omega_out"]
    check_energy_balance(scenario, "stored energy against the work of tau_in, load and damping", t,
                         c["driveline.stored_energy"], c["driveline.tau_in"] * w1, c["load.tau"] * w4 + dissipation,
                         1e-6)
    if pd["rigid_intermediate_shaft"] and pd["beta1"] == pd["beta2"] and pd["yoke_phase"] == pd["joint_plane_angle"]:
        check_close(scenario, "constant-velocity layout: omega_out = omega_in", w4, w1,
                    max(float(np.max(np.abs(w1))), 1e-300), 1e-12)
