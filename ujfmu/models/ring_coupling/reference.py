"""References for Motor -> RingCoupling(s) -> Load(s), independent of ujfmu.models.ring_coupling.model.

- generator "ring_coupling_pendulum": the paper's own closed form. With c_s = c_d = tau_load = 0 and a constant
  input speed, y = pi/2 - (phi1 + phi2) obeys y'' + A_e sin y = 0 (Eq. 12), solved with Jacobi elliptic functions:
  in the rotating regime (k1 > 1, Eq. 15) y = s 2 am(sqrt(A_e) k1 t + u0 | 1/k1^2), u0 = F(s y0/2 | 1/k1^2),
  s = sign(y'(0)); in the oscillating regime sin(y/2) = k1 sn(sqrt(A_e) t + u0 | k1^2) (scipy.special).
- generator "ring_coupling": monolithic ODE. Lagrange's equations of L = I1 w1^2/2 + I2 w2^2/2
  + 157 (EI/R^3) e^2 sin(phi1 + phi2) - c_s x_e^2/2 with D = c_d x_e'^2/2, formed by sympy; the motor's PI law
  and the load written out again (references.common); one scipy DOP853 solve.
"""

import functools

import numpy as np
import sympy as sp
from scipy import special

from ...references.common import (check_energy_balance, check_fan_out_wiring, components_with_loads, drive_name, feeds,
                                  load_torque, machines_and_loads, pi_law, profile, record_table, solve_piecewise,
                                  source_torque, start_integral, torque_driven_names, WiringError)
from ...references.common import drive as motor_drive

RTOL, ATOL = 1e-11, 1e-12
_PARAMS = ("R", "d", "E", "e", "I1", "I2", "c_s", "c_d", "phi_in_start", "phi_out_start")


def _mp_amplitude(pr):
    return 157.0 * pr["E"] * np.pi * pr["d"] ** 4 / 64.0 * pr["e"] ** 2 / pr["R"] ** 3


@functools.lru_cache(maxsize=None)
def _equations():
    """Lambdified (generalised force on phi2 without inertia, input torque without inertia, potential)."""
    p1, p2, w1, w2 = sp.symbols("phi1 phi2 w1 w2", real=True)
    amp, c_s, c_d, offset = sp.symbols("amp c_s c_d offset", real=True)
    x_e = p2 - p1 - offset
    potential = -amp * sp.sin(p1 + p2) + c_s * x_e ** 2 / 2
    rayleigh = c_d * (w2 - w1) ** 2 / 2
    force2 = -sp.diff(potential, p2) - sp.diff(rayleigh, w2)        # I2 phi2'' = force2 - tau_load
    drive = sp.diff(potential, p1) + sp.diff(rayleigh, w1)          # tau_in = I1 phi1'' + drive
    args = (p1, p2, w1, w2, amp, c_s, c_d, offset)
    return (sp.lambdify(args, force2, "numpy"), sp.lambdify(args, drive, "numpy"),
            sp.lambdify(args, potential, "numpy"))


def generate(scenario):
    """Monolithic reference for a Motor named motor driving one or more RingCoupling components (any names), each
    with or without a Load (any name; without one its tau_load input must be 0), refused (WiringError naming what
    differs) for any other wiring. Connections, for every coupling C and its load L: motor.omega -> C.omega_in,
    C.omega_out -> L.omega, L.tau -> C.tau_load. An ideal speed source drives any number of couplings
    (C.tau_in -> motor.tau_load optional, for one of them); a PI motor exactly one, with C.tau_in -> motor.tau_load."""
    rings = machines_and_loads(scenario, "ring_coupling", "coupling", "RingCoupling", load_optional=True)
    pm, j_motor, w_start, torque_driven = motor_drive(scenario, "motor", rings[0][0])
    force2, drive, potential = _equations()
    ideal = pm["ideal_speed_source"]
    t = scenario.time_grid()
    w_m, a_m, ang = profile(pm, t)
    ang0 = float(ang[0])
    cols = {}
    for name, load in rings:
        pr = scenario.parameters_with_defaults(name)
        pl = scenario.parameters_with_defaults(load) if load else None
        k = (_mp_amplitude(pr), pr["c_s"], pr["c_d"], pr["phi_out_start"] - pr["phi_in_start"])
        w2_0 = w_start if pr["start_at_input_speed"] else pr["omega_out_start"]

        def tau_l(w2, time, phi2, pl=pl):
            return load_torque(pl, w2, time, phi2) if pl else 0.0 * w2

        if ideal:
            def rhs(time, y, pr=pr, k=k, tau_l=tau_l):
                w, _, angle = profile(pm, time)
                phi1 = pr["phi_in_start"] + float(angle) - ang0
                return [y[1], (force2(phi1, y[0], float(w), y[1], *k) - tau_l(y[1], time, y[0])) / pr["I2"]]
            ys = solve_piecewise(rhs, [pr["phi_out_start"], w2_0], t, pm, RTOL, ATOL, [pl])
            phi2, w2 = ys
            phi_m, w1, a1 = ang - ang0, w_m, a_m
        else:
            def rhs(time, y, pr=pr, k=k, tau_l=tau_l):
                phi_m, w, integral, phi2, w2 = y
                tau_m, di = pi_law(pm, time, w, integral)
                phi1 = pr["phi_in_start"] + phi_m
                a = (float(tau_m) - drive(phi1, phi2, w, w2, *k)) / (j_motor + pr["I1"])
                return [w, a, float(di), w2, (force2(phi1, phi2, w, w2, *k) - tau_l(w2, time, phi2)) / pr["I2"]]
            y0 = [0.0, w_start, start_integral(pm), pr["phi_out_start"], w2_0]
            ys = solve_piecewise(rhs, y0, t, pm, RTOL, ATOL, [pl])
            phi_m, w1, integral, phi2, w2 = ys
            tau_m, _ = pi_law(pm, t, w1, integral)
            phi1 = pr["phi_in_start"] + phi_m
            a1 = (tau_m - drive(phi1, phi2, w1, w2, *k)) / (j_motor + pr["I1"])
            cols["motor.tau_motor"] = tau_m
        phi1 = pr["phi_in_start"] + phi_m
        tau_in = pr["I1"] * a1 + drive(phi1, phi2, w1, w2, *k)
        m_p = k[0] * np.cos(phi1 + phi2)
        cols.update({f"{name}.phi_out": phi2, f"{name}.omega_out": w2, f"{name}.tau_in": tau_in,
                     f"{name}.x_e": phi2 - phi1 - k[3], f"{name}.M_p": m_p,
                     f"{name}.transmitted_torque": force2(phi1, phi2, w1, w2, *k) * np.ones_like(t),
                     f"{name}.stored_energy": 0.5 * (pr["I1"] * w1 ** 2 + pr["I2"] * w2 ** 2)
                     + potential(phi1, phi2, w1, w2, *k), f"{name}.phi_in": phi1,
                     f"{name}.alpha_in": a1 * np.ones_like(t)})
        if load:
            cols[f"{load}.tau"] = tau_l(w2, t, phi2)
        if ideal and feeds(scenario, f"{name}.tau_in", "motor.tau_load"):
            cols["motor.tau_motor"] = source_torque(j_motor, a1, tau_in)
    cols.update({"motor.omega": w1, "motor.phi": phi_m})
    for name, load in rings:
        self_check(scenario, t, cols, name, load)
    if torque_driven:
        cols = torque_driven_names("coupling", cols)
    how = (f"monolithic ODE of {drive_name(ideal)} + coupling + load, Lagrange's "
           f"equations formed by sympy from the ring's potential, scipy DOP853 rtol={RTOL:g} atol={ATOL:g}")
    return record_table(scenario, t, cols), f"{__name__}: {how}"


def pendulum_angle(a_e, y0, v0, t):
    """(y, y') of y'' + a_e sin y = 0 with y(0) = y0, y'(0) = v0, from Jacobi elliptic functions (Eqs. 13-16)."""
    k2 = np.sin(y0 / 2) ** 2 + v0 ** 2 / (4 * a_e)                   # Eq. (15)
    root = np.sqrt(a_e)
    if k2 > 1.0:                                                      # rotating
        k = np.sqrt(k2)
        m = 1.0 / k2
        s = 1.0 if v0 >= 0 else -1.0
        u0 = special.ellipkinc(s * y0 / 2, m)
        u = root * k * t + u0
        period = 2.0 * special.ellipk(m)                              # am(u + 2K) = am(u) + pi
        turns = np.floor(u / period)
        _, _, dn, am = special.ellipj(u - turns * period, m)
        return s * 2.0 * (am + turns * np.pi), s * 2.0 * root * k * dn
    k = np.sqrt(k2)                                                   # oscillating
    u0 = special.ellipkinc(np.arcsin(np.clip(np.sin(y0 / 2) / k, -1, 1)), k2)
    u0 = u0 if v0 >= 0 else 2 * special.ellipk(k2) - u0
    sn, cn, dn, _ = special.ellipj(root * t + u0, k2)
    y = 2.0 * np.arcsin(k * sn)
    return y, 2.0 * k * root * cn * dn / np.cos(y / 2)


def generate_pendulum(scenario):
    """Closed form for couplings with c_s = c_d = 0, no load and an ideal constant speed source: the wiring of
    ``generate`` (checked the same way) with motor an ideal speed source at constant speed."""
    check_fan_out_wiring(scenario, "ring_coupling_pendulum", "RingCoupling", load_optional=True)
    pm = scenario.parameters_with_defaults("motor")
    if not (pm["ideal_speed_source"] and pm["profile"] == 0):
        raise WiringError(f"{scenario.path}: the pendulum closed form needs an ideal constant speed source")
    t = scenario.time_grid()
    w1 = pm["omega_set"]
    cols = {"motor.omega": np.full_like(t, w1), "motor.phi": w1 * (t - t[0])}
    for name, load in components_with_loads(scenario, "RingCoupling"):
        pr = scenario.parameters_with_defaults(name)
        pl = scenario.parameters_with_defaults(load) if load else {"T0": 0.0, "c1": 0.0, "c2": 0.0}
        if (pr["c_s"] != 0 or pr["c_d"] != 0 or any(pl.get(k, 0.0) != 0 for k in
                                                      ("T0", "T_change", "c1", "c2", "T_active", "T_h"))):
            raise WiringError(f"{scenario.path}: {name}: the pendulum closed form needs c_s = c_d = 0 and no load")
        amp = _mp_amplitude(pr)
        a_e = amp / pr["I2"]
        w2_0 = w1 if pr["start_at_input_speed"] else pr["omega_out_start"]
        y, dy = pendulum_angle(a_e, np.pi / 2 - pr["phi_in_start"] - pr["phi_out_start"], -(w1 + w2_0), t - t[0])
        phi1 = pr["phi_in_start"] + w1 * (t - t[0])
        phi2 = np.pi / 2 - y - phi1
        w2 = -w1 - dy
        m_p = amp * np.cos(phi1 + phi2)
        cols.update({f"{name}.phi_out": phi2, f"{name}.x_e": phi2 - phi1 - (pr["phi_out_start"] - pr["phi_in_start"]),
                     f"{name}.M_p": m_p, f"{name}.omega_out": w2, f"{name}.phi_in": phi1,
                     f"{name}.tau_in": -m_p, f"{name}.transmitted_torque": m_p})
        if load:
            cols[f"{load}.tau"] = np.zeros_like(t)
    for name, load in components_with_loads(scenario, "RingCoupling"):
        self_check(scenario, t, cols, name, load)
    how = ("closed form: the pendulum y'' + A_e sin y = 0 of Eq. (12) solved with Jacobi elliptic functions "
           "(scipy.special.ellipj, ellipkinc)")
    return record_table(scenario, t, cols), f"{__name__}: {how}"


def self_check(scenario, t: np.ndarray, columns: dict, coupling: str, load: str | None) -> None:
    """Energy balance of one coupling, checked before the reference is written (ReferenceCheckError otherwise):
    E = I1 w1^2/2 + I2 w2^2/2 - 157 (EI/R^3) e^2 sin(phi1 + phi2) + c_s x_e^2/2 (Eqs. 5-9, written out again
    from the columns) changes by the work of tau_in on w1 less the load's work on w2 and the damping loss
    c_d (w2 - w1)^2. For the pendulum closed form (c_s = c_d = 0, no load, constant speed) this is the first
    integral of y'' + A_e sin y = 0.
    columns: 'motor.omega', '<coupling>.phi_in', '.phi_out', '.omega_out', '.x_e', '.tau_in' and '<load>.tau'.
    """
    pr = scenario.parameters_with_defaults(coupling)
    c = {k.split(".", 1)[1]: v for k, v in columns.items() if k.startswith(coupling + ".")}
    w1, w2 = columns["motor.omega"] * np.ones_like(t), c["omega_out"]
    stored = (0.5 * (pr["I1"] * w1 ** 2 + pr["I2"] * w2 ** 2) - _mp_amplitude(pr) * np.sin(c["phi_in"] + c["phi_out"])
              + 0.5 * pr["c_s"] * c["x_e"] ** 2)
    lost = (columns[f"{load}.tau"] * w2 if load else 0.0 * t) + pr["c_d"] * (w2 - w1) ** 2
    check_energy_balance(scenario, f"{coupling}: energy against the work of tau_in, load and damping", t, stored,
                         c["tau_in"] * w1, lost, 1e-6)
