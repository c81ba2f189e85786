"""Monolithic reference for Motor -> TwinJeffcottRotor(s) -> Load(s).

Independent of the co-simulation and of this folder's model.py, it starts again from geometry and energy:
- the joint from exact rotation matrices (sympy): each bent end section turned by its slope angle about the
  normal to its bending plane, R = I + S K + F K^2 (Rodrigues; K the cross-product matrix of the rotation vector,
  S = sin(a)/a, F = (1 - cos a)/a^2 as functions of a^2 so that they stay regular at zero tilt), the primary end
  R(v1, -u1), the secondary frame R_y(beta) R(-v2, u2), with the bending end slopes u = 3 X / L, v = 3 Y / L; the
  driving pin e1 = R_a R_z(theta1) (0, 1, 0), the driven pin normal to e1 and to the secondary axis, and the output
  angle psi read off in the secondary frame;
- the kinetic energy from the velocities of disc centres and unbalance masses, the potential and the Rayleigh
  function of README.md as sympy expressions, and Lagrange's equations M(q) q'' = f(q, q', t) formed by
  sympy's differentiation (q = theta1, X1, Y1, theta2, X2, Y2; the input angle prescribed for an ideal speed
  source, else the motor's angle as a further coordinate);
- the input work and the dissipated energy as two more ODE states, the motor's PI law and the load's torque
  written out again (references.common); one scipy DOP853 solve of the whole system, split at the speed
  profile's corners.
"""

import functools
import math

import numpy as np
import sympy as sp

from ...references.common import (check_energy_balance, check_integral, drive, drive_name, feeds, load_torque,
                                  machines_and_loads, pi_law, profile, record_table, solve_piecewise, source_torque,
                                  start_integral, torque_driven_names)
from ...references.rotations import ry, rz

RTOL, ATOL = 1e-9, 1e-12
_PARAMS = ("beta", "M1", "M2", "J_M1", "J_M2", "J_gb", "m_u1", "m_u2", "e", "phase_u1", "phase_u2",
           "K1X", "K1Y", "K2X", "K2Y", "C1X", "C1Y", "C2X", "C2Y", "K1T", "K2T", "C1T", "C2T", "L1", "L2")


def _analytic_in_square(series, closed):
    """A numpy function of x = a^2 from its Taylor series (used for x < 1e-3) and its closed form in a (else)."""
    def evaluate(x):
        if np.ndim(x) == 0:   # the ODE right-hand side: scalars, kept cheap
            x = float(x)
            return series(x) if x < 1e-3 else closed(x, math.sqrt(x))
        x = np.asarray(x, float)
        safe = np.maximum(x, 1e-3)
        return np.where(x < 1e-3, series(x), closed(safe, np.sqrt(safe)))
    return evaluate


def _sinc(x, a):
    return np.sin(a) / a


def _versine(x, a):
    return 2 * np.sin(a / 2) ** 2 / x


#: Taylor series in x = a^2 of sin(a)/a, (1 - cos a)/a^2 and their derivatives with respect to x
_SERIES = {"SincSq": lambda x: 1 - x / 6 + x ** 2 / 120 - x ** 3 / 5040 + x ** 4 / 362880,
           "VersineSq": lambda x: 1 / 2 - x / 24 + x ** 2 / 720 - x ** 3 / 40320 + x ** 4 / 3628800,
           "SincSqDx": lambda x: -1 / 6 + x / 60 - x ** 2 / 1680 + x ** 3 / 90720 - x ** 4 / 7983360,
           "VersineSqDx": lambda x: -1 / 24 + x / 360 - x ** 2 / 13440 + x ** 3 / 907200 - x ** 4 / 95800320}
#: the same functions' closed forms in a = sqrt(x), for numpy arrays
_sinc_sq = _analytic_in_square(_SERIES["SincSq"], _sinc)
_versine_sq = _analytic_in_square(_SERIES["VersineSq"], _versine)
_sinc_sq_dx = _analytic_in_square(_SERIES["SincSqDx"], lambda x, a: (np.cos(a) - _sinc(x, a)) / (2 * x))
_versine_sq_dx = _analytic_in_square(_SERIES["VersineSqDx"], lambda x, a: (_sinc(x, a) - 2 * _versine(x, a)) / (2 * x))


def _scalar_in_square(name, closed):
    """The function of x = a^2 named in _SERIES for one float, in plain floats (the ODE's right-hand side)."""
    series = _SERIES[name]
    return lambda x: series(x) if x < 1e-3 else closed(x, math.sqrt(x))


#: the four functions for one float: math's sin and cos, no numpy scalars
_SCALAR = {"SincSq": _scalar_in_square("SincSq", lambda x, a: math.sin(a) / a),
           "VersineSq": _scalar_in_square("VersineSq", lambda x, a: 2 * math.sin(a / 2) ** 2 / x),
           "SincSqDx": _scalar_in_square("SincSqDx", lambda x, a: (math.cos(a) - math.sin(a) / a) / (2 * x)),
           "VersineSqDx": _scalar_in_square(
               "VersineSqDx", lambda x, a: (math.sin(a) / a - 4 * math.sin(a / 2) ** 2 / x) / (2 * x))}


class SincSq(sp.Function):
    """sin(sqrt(x)) / sqrt(x), analytic in x (symbolic stand-in; numbers from _sinc_sq)."""

    def fdiff(self, argindex=1):
        return SincSqDx(self.args[0])


class SincSqDx(sp.Function):
    pass


class VersineSq(sp.Function):
    """(1 - cos(sqrt(x))) / x, analytic in x."""

    def fdiff(self, argindex=1):
        return VersineSqDx(self.args[0])


class VersineSqDx(sp.Function):
    pass


_NUMERIC = {"SincSq": _sinc_sq, "SincSqDx": _sinc_sq_dx, "VersineSq": _versine_sq, "VersineSqDx": _versine_sq_dx}


def _tilt(a, b):
    """Rotation by the vector (a, b, 0): Rodrigues, R = I + S K + F K^2 with K its cross-product matrix."""
    k = sp.Matrix([[0, 0, b], [0, 0, -a], [-b, a, 0]])
    angle_sq = a ** 2 + b ** 2
    return sp.eye(3) + SincSq(angle_sq) * k + VersineSq(angle_sq) * k * k


@functools.lru_cache(maxsize=None)
def _equations():
    """Lambdified output expressions (numpy, for the recorded table) and the right-hand side's terms (floats)."""
    q = th1, x1, y1, th2, x2, y2 = sp.symbols("theta1 X1 Y1 theta2 X2 Y2", real=True)
    qd = sp.symbols("w1 vx1 vy1 w2 vx2 vy2", real=True)
    phi_in, w_in, tau_load = sp.symbols("phi_in w_in tau_load", real=True)
    params = sp.symbols(" ".join(_PARAMS), real=True)
    pr = dict(zip(_PARAMS, params))
    t = sp.Symbol("t")
    # kinetic energy: disc centres and unbalance masses (positions in each shaft's frame; the mid-span disc does
    # not tilt)
    kinetic = 0
    for i, (th, x, y) in enumerate(((th1, x1, y1), (th2, x2, y2)), start=1):
        path = {s: sp.Function(f"{s}_t")(t) for s in (th, x, y)}
        r_disc = sp.Matrix([path[x], path[y]])
        angle = path[th] + pr[f"phase_u{i}"]
        r_unb = r_disc + pr["e"] * sp.Matrix([sp.cos(angle), sp.sin(angle)])
        v_disc, v_unb = r_disc.diff(t), r_unb.diff(t)
        to_symbols = {path[s].diff(t): v for s, v in zip((th, x, y), qd[3 * (i - 1):3 * i])}
        to_symbols.update({path[s]: s for s in (th, x, y)})
        energy = (pr[f"J_M{i}"] * path[th].diff(t) ** 2 + pr[f"M{i}"] * v_disc.dot(v_disc)
                  + pr[f"m_u{i}"] * v_unb.dot(v_unb)) / 2
        kinetic += energy.subs(to_symbols)
    # joint output angle from rotation matrices
    u1, v1 = 3 * x1 / pr["L1"], 3 * y1 / pr["L1"]
    u2, v2 = 3 * x2 / pr["L2"], 3 * y2 / pr["L2"]
    e1 = _tilt(v1, -u1) * rz(th1) * sp.Matrix([0, 1, 0])
    p = (ry(pr["beta"]) * _tilt(-v2, u2)).T * e1
    c, s = sp.cos(th1), sp.sin(th1)
    psi = th1 + sp.atan2(-p[0] * c - p[1] * s, p[1] * c - p[0] * s)
    dpsi = sum(sp.diff(psi, qi) * wi for qi, wi in zip(q, qd))
    twist1, twist2 = phi_in - th1, psi - th2
    potential = (pr["K1T"] * twist1 ** 2 + pr["K2T"] * twist2 ** 2 + pr["K1X"] * x1 ** 2 + pr["K1Y"] * y1 ** 2
                 + pr["K2X"] * x2 ** 2 + pr["K2Y"] * y2 ** 2) / 2
    rayleigh = (pr["C1T"] * (w_in - qd[0]) ** 2 + pr["C2T"] * (dpsi - qd[3]) ** 2 + pr["C1X"] * qd[1] ** 2
                + pr["C1Y"] * qd[2] ** 2 + pr["C2X"] * qd[4] ** 2 + pr["C2Y"] * qd[5] ** 2) / 2
    n = len(q)
    mass = sp.Matrix(n, n, lambda i, j: sp.diff(kinetic, qd[i], qd[j]))
    external = [0, 0, 0, -tau_load, 0, 0]
    force = sp.Matrix([-sum(sp.diff(kinetic, qd[i], q[j]) * qd[j] for j in range(n)) + sp.diff(kinetic, q[i])
                       - sp.diff(potential, q[i]) - sp.diff(rayleigh, qd[i]) + external[i] for i in range(n)])
    shaft1 = sp.diff(potential, phi_in) + sp.diff(rayleigh, w_in)   # generalised force the input must apply
    shaft2 = pr["K2T"] * twist2 + pr["C2T"] * (dpsi - qd[3])
    args = (q, qd, phi_in, w_in, tau_load, params)
    outputs = [shaft1, shaft2, kinetic + potential]
    modules = [_NUMERIC, "numpy"]
    # the right-hand side's terms for one state: M row by row, f, the primary shaft torque and the dissipated
    # power, as one flat list of plain floats (math, common subexpressions shared: 7x numpy on scalars)
    terms = [*mass, *force, shaft1, 2 * rayleigh]
    return sp.lambdify(args, outputs, modules, cse=True), sp.lambdify(args, terms, [_SCALAR, "math"], cse=True)


class RotorReference:
    """The rotor's equations for one parameter set (a dict with the FMU's parameter names)."""

    def __init__(self, pr):
        self.pr = pr
        self.params = tuple(float(pr[n]) for n in _PARAMS)
        self._outputs, self._terms = _equations()

    def rates(self, y, phi_in, w_in, tau_load):
        """(q'', primary shaft torque, dissipated power) at the state y = (q, q') (one float evaluation of M, f and
        the two outputs)."""
        values = self._terms(y[:6], y[6:12], phi_in, w_in, tau_load, self.params)
        acc = np.linalg.solve(np.array(values[:36]).reshape(6, 6), np.array(values[36:42]))
        return acc, values[42], values[43]

    def outputs(self, q, qd, phi_in, w_in):
        """(primary shaft torque, secondary shaft torque, energy without the gearbox flange)."""
        return self._outputs(q, qd, phi_in, w_in, 0.0, self.params)


def _rotor_rhs(ref, y, phi_in, w_in, alpha_in, tau_load, rates=None):
    """d/dt of (q, q', input work, dissipated energy) for the rotor; rates: ``ref.rates`` at y if known."""
    acc, shaft1, dissipation = rates or ref.rates(y[:12].tolist(), phi_in, w_in, tau_load)
    return np.concatenate([y[6:12], acc, [(ref.pr["J_gb"] * alpha_in + shaft1) * w_in, dissipation]])


def _initial(ref, phi_in, w_in):
    """Untwisted, centred, turning with the input: psi(theta1) and dpsi/dtheta1 from the exact joint."""
    c, s, cb = np.cos(phi_in), np.sin(phi_in), np.cos(ref.pr["beta"])
    psi = phi_in + np.arctan2(-(-cb * s) * c - c * s, c * c + cb * s * s)
    ratio = cb / (c * c + cb * cb * s * s)
    return np.array([phi_in, 0, 0, psi, 0, 0, w_in, 0, 0, ratio * w_in, 0, 0, 0, 0], dtype=float)


def generate(scenario):
    """Reference for a Motor named motor driving one or more TwinJeffcottRotor components (any names), each with
    a Load (any name), refused (WiringError naming what differs) for any other wiring. Connections, for every
    rotor R and its load L: motor.omega -> R.omega_in, R.omega_out -> L.omega, L.tau -> R.tau_load. An ideal
    speed source drives any number of rotors (R.tau_in -> motor.tau_load optional, for one of them); a PI motor
    drives exactly one, with R.tau_in -> motor.tau_load."""
    load_of = dict(machines_and_loads(scenario, "twin_jeffcott_rotor", "rotor", "TwinJeffcottRotor",
                                      load_optional=False))
    rotors = list(load_of)
    pm, j_motor, w_start, torque_driven = drive(scenario, "motor", rotors[0])
    ideal = pm["ideal_speed_source"]
    t = scenario.time_grid()
    w_m, a_m, ang = profile(pm, t)
    ang0 = float(ang[0])
    cols = {}
    for name in rotors:
        pr = scenario.parameters_with_defaults(name)
        pl = scenario.parameters_with_defaults(load_of[name])
        ref = RotorReference(pr)
        phi0 = pr["phi_in_start"]
        y0 = _initial(ref, phi0, w_start)
        if ideal:
            def rhs(time, y, ref=ref, pl=pl, phi0=phi0):
                w, a, angle = profile(pm, time)
                return _rotor_rhs(ref, y, phi0 + float(angle) - ang0, float(w), float(a),
                                  float(load_torque(pl, y[9], time, y[3])))
            ys = solve_piecewise(rhs, y0, t, pm, RTOL, ATOL, [pl])
            phi_m, w_in, a_in = ang - ang0, w_m, a_m
        else:
            def rhs(time, y, ref=ref, pl=pl, phi0=phi0):
                phi_m, w, integral = y[14:].tolist()
                tau_m, di = pi_law(pm, time, w, integral)
                rates = ref.rates(y[:12].tolist(), phi0 + phi_m, w, float(load_torque(pl, y[9], time, y[3])))
                a = (float(tau_m) - rates[1]) / (j_motor + ref.pr["J_gb"])
                rot = _rotor_rhs(ref, y[:14], phi0 + phi_m, w, a, None, rates)
                return np.concatenate([rot, [w, a, float(di)]])
            y0 = np.concatenate([y0, [0.0, w_start, start_integral(pm)]])
            ys = solve_piecewise(rhs, y0, t, pm, RTOL, ATOL, [pl])
            phi_m, w_in, integral = ys[14:]
            tau_m, _ = pi_law(pm, t, w_in, integral)
        q, qd = ys[:6], ys[6:12]
        phi_in = phi0 + phi_m
        shaft1, shaft2, energy = ref.outputs(q, qd, phi_in, w_in)
        if not ideal:
            a_in = (tau_m - shaft1) / (j_motor + pr["J_gb"])
            cols["motor.tau_motor"] = tau_m
        tau_in = pr["J_gb"] * a_in + shaft1
        tau_l = load_torque(pl, qd[3], t, q[3])
        cols.update({f"{name}.{k}": v for k, v in dict(
            phi_disc1=q[0], X1=q[1], Y1=q[2], phi_out=q[3], X2=q[4], Y2=q[5], omega_disc1=qd[0], omega_out=qd[3],
            tau_in=tau_in, primary_shaft_torque=shaft1, secondary_shaft_torque=shaft2,
            stored_energy=energy + 0.5 * pr["J_gb"] * w_in ** 2, input_work=ys[12], dissipated_energy=ys[13],
            phi_in=phi_in, alpha_in=a_in * np.ones_like(t)).items()})
        cols[f"{load_of[name]}.tau"] = tau_l
        if ideal and feeds(scenario, f"{name}.tau_in", "motor.tau_load"):
            cols["motor.tau_motor"] = source_torque(j_motor, a_in, tau_in)
    cols.update({"motor.omega": w_in, "motor.phi": phi_m})
    for name in rotors:
        energy_audit(scenario, t, cols, name, load_of[name])
    if torque_driven:
        cols = torque_driven_names("rotor", cols)
    table = record_table(scenario, t, cols)
    how = (f"monolithic ODE of {drive_name(ideal)} + rotor + load, Lagrange's "
           f"equations formed by sympy from rotation matrices and energies, scipy DOP853 rtol={RTOL:g} atol={ATOL:g}")
    return table, f"{__name__}: {how}"


def energy_audit(scenario, t: np.ndarray, columns: dict, rotor: str, load: str, motor: str = "motor") -> None:
    """The rotor's energy audit, checked before the reference is written (ReferenceCheckError otherwise):

    - input_work (an ODE state) = integral of tau_in * omega_in dt (tau_in with the gearbox flange's J_gb alpha);
    - stored_energy(t) - stored_energy(t0) = input_work - integral of tau_load * omega_out dt - dissipated_energy.
    columns: '<motor>.omega', '<rotor>.tau_in', '.input_work', '.stored_energy', '.dissipated_energy',
    '.omega_out' and '<load>.tau' on the grid t.
    """
    c = {k.split(".", 1)[1]: v for k, v in columns.items() if k.startswith(rotor + ".")}
    w_in = columns[f"{motor}.omega"]
    check_integral(scenario, f"{rotor}: input_work against the integral of tau_in * omega_in", t, c["input_work"],
                   c["tau_in"] * w_in, 1e-6)
    check_energy_balance(scenario, f"{rotor}: stored energy against input work - load work - dissipated", t,
                         c["stored_energy"] + c["dissipated_energy"], c["tau_in"] * w_in,
                         columns[f"{load}.tau"] * c["omega_out"], 1e-6)
