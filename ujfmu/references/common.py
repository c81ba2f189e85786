"""Pieces every monolithic reference shares: the Motor FMU's speed profiles and PI law and the Load FMU's torque
law, written out again with numpy (independent of the models' equations)."""

import time
from contextlib import contextmanager

import numpy as np
from scipy.integrate import cumulative_simpson, solve_ivp


def profile(p, t):
    """Speed reference (omega, alpha, angle) of the Motor FMU's profiles, written out independently."""
    t = np.asarray(t, dtype=float)
    prof, w_set, acc, t_step, w0 = p["profile"], p["omega_set"], p["accel"], p["t_step"], p["omega_initial"]
    if prof == 1:   # at rest before t = 0
        te = w_set / acc
        up, rest = t < te, t < 0.0
        return (np.where(rest, 0.0, np.where(up, acc * t, w_set)), np.where(rest | ~up, 0.0, acc),
                np.where(rest, 0.0, np.where(up, 0.5 * acc * t**2, 0.5 * acc * te**2 + w_set * (t - te))))
    if prof == 2:
        before = t < t_step
        return (np.where(before, w0, w_set), np.zeros_like(t),
                np.where(before, w0 * t, w0 * t_step + w_set * (t - t_step)))
    if prof == 3:   # from w0 towards w_set at acc from t_step: the speed clipped between the two
        rate = np.copysign(acc, w_set - w0)
        s = np.clip(t - t_step, 0.0, abs(w_set - w0) / acc)   # time spent ramping so far
        return (w0 + rate * s, np.where((t >= t_step) & (s < abs(w_set - w0) / acc), rate, 0.0),
                w0 * t + rate * s * (t - t_step - 0.5 * s))
    return np.full_like(t, w_set), np.zeros_like(t), w_set * t


def source_start_angle(p, t) -> float:
    """The profile's angle at the grid's first time t[0]: an ideal speed source's angle counts from there."""
    return float(profile(p, t[:1])[2][0])


def source_motion(p, t) -> tuple:
    """(omega, alpha, angle since t[0]) of an ideal speed source following the profile on the grid t."""
    w, a, angle = profile(p, t)
    return w, a, angle - source_start_angle(p, t)


def source_torque(j_rotor, alpha, tau_load):
    """The torque an ideal speed source delivers: its rotor's inertia torque plus the torque it is loaded with
    (the Motor FMU's ideal mode, written out again)."""
    return j_rotor * alpha + tau_load


def drive_name(ideal: bool) -> str:
    """How the references' provenance names the drive."""
    return "ideal speed source" if ideal else "PI motor"


def feeds(scenario, source: str, target: str) -> bool:
    """True if the scenario connects source (``component.output``) to target (``component.input``)."""
    return any(cn.source == source and cn.target == target for cn in scenario.connections)


def corners(p, t0, t1, loads=()):
    """Integration interval cut at the speed profile's corners (ramp start and end, step) and at those of the
    loads' T(t) (loads: their parameter dicts; :func:`load_corners`)."""
    if p["profile"] == 1:
        cuts = [0.0, p["omega_set"] / p["accel"]]
    elif p["profile"] == 2:
        cuts = [p["t_step"]]
    elif p["profile"] == 3:
        cuts = [p["t_step"], p["t_step"] + abs(p["omega_set"] - p["omega_initial"]) / p["accel"]]
    else:
        cuts = []
    cuts = sorted(set(cuts + [c for load in loads if load for c in load_corners(load)]))
    return [t0] + [c for c in cuts if t0 < c < t1] + [t1]


def load_corners(p) -> list:
    """The times where a Load's T(t) jumps or changes its slope (its change's start, and end if ramped)."""
    if not p.get("T_change", 0.0):
        return []
    ramp = p.get("ramp_time", 0.0)
    return [p["t_change"]] if ramp == 0.0 else [p["t_change"], p["t_change"] + ramp]


def load_level(p, t):
    """A Load's T(t): T0, changed by T_change from t_change on, at once or linearly over ramp_time (t a number or
    an array)."""
    change = p.get("T_change", 0.0)
    if not change:
        return p["T0"] + 0.0 * np.asarray(t, dtype=float)
    ramp, start = p.get("ramp_time", 0.0), p["t_change"]
    share = (np.asarray(t) >= start).astype(float) if ramp == 0.0 else np.clip((np.asarray(t) - start) / ramp, 0.0,
                                                                                1.0)
    return p["T0"] + change * share


def load_torque(p, w, t, phi=None):
    """Load FMU torque law tau = T(t) s(w) + c1 w + c2 w |w|_s + T_active + T_h cos(order_h phi + phase_h)
    (:func:`load_level`)
    at time t and the driven shaft's angle phi (needed where T_h is not 0: ValueError without it)."""
    mag = np.sqrt(w * w + p["omega_smooth"] ** 2)
    tau = load_level(p, t) * w / mag + p["c1"] * w + p["c2"] * w * mag + p.get("T_active", 0.0)
    amplitude = p.get("T_h", 0.0)
    if not amplitude:
        return tau
    if phi is None:
        raise ValueError("a Load with T_h != 0 needs the driven shaft's angle")
    return tau + amplitude * np.cos(p.get("order_h", 1.0) * phi + p.get("phase_h", 0.0))


def check_load_angle(scenario, load: str, machine: str) -> None:
    """WiringError unless a Load with a periodic torque (T_h != 0) takes its angle from machine's phi_out, the angle
    the reference integrates (its other Loads use none)."""
    if load and scenario.parameters_with_defaults(load).get("T_h", 0.0) and not feeds(
            scenario, f"{machine}.phi_out", f"{load}.phi"):
        raise WiringError(f"{scenario.path}: {load} has a periodic torque (T_h != 0) but its angle input {load}.phi "
                          f"is not fed from {machine}.phi_out: connect it (the reference takes that angle)")


def start_integral(p) -> float:
    """The PI integral at the start: tau_initial / Ki, so that the law gives tau_initial at the reference speed
    (the Motor FMU's tau_initial, written out again); 0 without an integral gain."""
    return p.get("tau_initial", 0.0) / p["Ki"] if p["Ki"] else 0.0


def pi_law(p, t, w, integral):
    """(tau_motor, d integral/dt) of the PI speed controller with torque limit and conditional integration."""
    e = profile(p, t)[0] - w
    u = p["Kp"] * e + p["Ki"] * integral
    tmax = p["tau_max"]
    di = np.where((u > tmax) & (e > 0) | (u < -tmax) & (e < 0), 0.0, e)
    return np.clip(u, -tmax, tmax), di


class DryRun:
    """While ``active``, solve_piecewise holds the initial state on the grid without solving and check_close checks
    nothing: a generator then returns its columns' names at the cost of its set-up (``ujfmu.references.generate``
    checks a scenario's tolerances against them before the solve)."""
    active = False


@contextmanager
def dry_run():
    """Within the block the generators solve nothing (:class:`DryRun`)."""
    DryRun.active = True
    try:
        yield
    finally:
        DryRun.active = False


class SelfChecks:
    """While ``made`` is a list, each self-check of a reference (``check_close`` and the laws built on it) adds
    (law, its deviation, its allowance), both relative to the law's scale (:func:`collect_checks`)."""
    made = None


@contextmanager
def collect_checks():
    """Within the block, the self-checks the generators pass, as a list of (law, deviation, allowance)."""
    SelfChecks.made = made = []
    try:
        yield made
    finally:
        SelfChecks.made = None


class SolverOverride:
    """Tolerances that replace the generators' own (``ujfmu bench`` solves at rtol 1e-8), and the seconds spent
    in DOP853 since it was set (the equations' symbolic derivation excluded)."""
    rtol = atol = None
    seconds = 0.0
    solves = 0


#: the solve's progress is reported (``solve_progress``) every this many evaluations of the right-hand side
PROGRESS_EVALUATIONS = 2000


class SolveProgress:
    """callback(done, total) in milliseconds of simulated time of the solve under way, or None (``solve_progress``)."""
    callback = None


@contextmanager
def solve_progress(callback):
    """Within the block each solve_piecewise reports how far its solve has come: callback(done, total) in
    milliseconds of simulated time, every ``PROGRESS_EVALUATIONS`` evaluations of its right-hand side."""
    SolveProgress.callback = callback
    try:
        yield
    finally:
        SolveProgress.callback = None


@contextmanager
def solver_override(rtol, atol):
    """Within the block every solve_piecewise uses rtol/atol; yields SolverOverride with the time it took."""
    SolverOverride.rtol, SolverOverride.atol, SolverOverride.seconds, SolverOverride.solves = rtol, atol, 0.0, 0
    try:
        yield SolverOverride
    finally:
        SolverOverride.rtol = SolverOverride.atol = None


class ReferenceStallError(RuntimeError):
    """The adaptive solve stopped advancing (``STALL_EVALUATIONS``): the message says where and why."""


#: a solve whose time advances by less than STALL_SHARE of its span over STALL_EVALUATIONS evaluations of the
#: right-hand side (steps of 1e-9 s on a 1 s run; a healthy solve's smallest are 1e-6 s) has stalled
STALL_EVALUATIONS, STALL_SHARE = 20_000, 1e-5


def _watched(rhs, lo, hi, motor_params, span=None):
    """rhs on the piece [lo, hi), raising ReferenceStallError when the solve stalls. At hi itself (a Runge-Kutta
    step's last stage, its dense output's) rhs is taken one float before it: the piece's left limit, where a load
    step or a speed step at hi has not happened yet (evaluated there, the step leaks into the whole last step of
    the piece: 2.8e-3 of a 2 N.m load step's integral at rtol 1e-3). span: the whole solve's (start, end), whose
    progress goes to ``SolveProgress.callback``."""
    seen = {"count": 0, "at": lo}
    left = float(np.nextafter(hi, lo))
    report = SolveProgress.callback
    start, end = span or (lo, hi)

    def f(time_, y):
        seen["count"] += 1
        if report is not None and seen["count"] % PROGRESS_EVALUATIONS == 0:
            report(round(1000.0 * (min(time_, hi) - start)), round(1000.0 * (end - start)))
        if seen["count"] % STALL_EVALUATIONS == 0:
            if time_ - seen["at"] < STALL_SHARE * (hi - lo):
                pi = "Kp" in motor_params and not motor_params.get("ideal_speed_source", False)
                raise ReferenceStallError(
                    f"the reference solve (scipy DOP853) has stalled at t = {time_:.9g} s: {STALL_EVALUATIONS} "
                    f"evaluations since t = {seen['at']:.9g} s, steps of about "
                    f"{(time_ - seen['at']) * 12 / STALL_EVALUATIONS:.2g} s. Its equations switch there faster "
                    "than any step: a discontinuous right-hand side"
                    + (", e.g. the PI motor's torque held at tau_max with its integrator switched on and off at "
                       "every step (conditional integration sliding along the limit; the co-simulation's sampled "
                       "controller steps across it)" if pi else "")
                    + ". This set-up has no monolithic reference: "
                    + ("raise the motor's tau_max so that the drive stays within it, or " if pi else "")
                    + "shorten the run to end before t, or check the scenario without a reference (ujfmu run "
                    "--check-step estimates its coupling error)")
            seen["at"] = time_
        return rhs(time_ if time_ < hi else left, y)
    return f


def solve_piecewise(rhs, y0, t, motor_params, rtol, atol, loads=()):
    """One DOP853 solve of rhs on the grid t, restarted at the speed profile's corners and the loads' (their
    parameter dicts: a load step or ramp); returns y on t. ReferenceStallError where it stops advancing
    (``_watched``)."""
    if DryRun.active:
        return np.repeat(np.asarray(y0, dtype=float)[:, None], len(t), axis=1)
    if SolverOverride.rtol is not None:
        rtol, atol = SolverOverride.rtol, SolverOverride.atol
    started = time.perf_counter()
    pieces, y = [], y0
    cuts = corners(motor_params, t[0], t[-1], loads)
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        sel = (t >= lo) & (t <= hi) if hi == cuts[-1] else (t >= lo) & (t < hi)
        sol = solve_ivp(_watched(rhs, lo, hi, motor_params, (cuts[0], cuts[-1])), (lo, hi), y, method="DOP853",
                        rtol=rtol, atol=atol, t_eval=t[sel], dense_output=True)
        if not sol.success:
            raise RuntimeError(f"reference solve failed: {sol.message}")
        pieces.append(sol.y)
        y = sol.sol(hi)
    SolverOverride.seconds += time.perf_counter() - started
    SolverOverride.solves += 1
    return np.concatenate(pieces, axis=1)


def record_table(scenario, t, columns):
    """Structured array 'time' + every recorded signal the reference computes, on the grid t."""
    names = ["time"] + [n for n in scenario.record if n in columns]
    return np.rec.fromarrays([t] + [np.asarray(columns[n], dtype=float) * np.ones_like(t) for n in names[1:]],
                             names=names)


class WiringError(ValueError):
    """A scenario's components or connections are not the system its reference generator models."""


def _arrows(pairs) -> str:
    return ", ".join(f"{a} -> {b}" for a, b in pairs)


def check_wiring(scenario, generator: str, expects: str, components: dict, connections, optional=(),
                 problems=()) -> None:
    """WiringError unless the scenario has exactly the given components (name -> tuple of allowed FMU names), every
    one of the given connections ((from, to) pairs), no connection outside them and optional, and no problems
    found by the caller. The message names the scenario, the generator, the topology it models (expects, a
    sentence) and every difference, so nothing is solved for a system the reference does not describe."""
    have = {name: fmu for name, (fmu, _) in scenario.components.items()}
    wired = [(cn.source, cn.target) for cn in scenario.connections]
    problems = list(problems)
    for name, fmus in components.items():
        if name not in have:
            problems.append(f"no component '{name}' ({' or '.join(fmus)})")
        elif have[name] not in fmus:
            problems.append(f"component '{name}' is a {have[name]}, not a {' or '.join(fmus)}")
    extra = [f"'{name}' ({fmu})" for name, fmu in have.items() if name not in components]
    if extra:
        problems.append(f"component(s) {', '.join(extra)} not part of it")
    missing = [pair for pair in connections if pair not in wired]
    if missing:
        problems.append(f"connection(s) missing: {_arrows(missing)}")
    allowed = set(connections) | set(optional)
    unexpected = [pair for pair in wired if pair not in allowed]
    if unexpected:
        problems.append(f"connection(s) it does not model: {_arrows(unexpected)}")
    if problems:
        raise WiringError(f"{scenario.path}: reference generator '{generator}' models {expects}; this scenario "
                          f"differs: {'; '.join(problems)}. Wire the scenario so; this generator's reference "
                          "cannot check another system (without a [reference] table a scenario runs unchecked)")


#: the speed-driven and torque-driven connections of motor -> machine -> load, '{m}' the machine's name
CHAIN_CONNECTIONS = {
    False: (("motor.omega", "{m}.omega_in"), ("{m}.tau_in", "motor.tau_load"), ("{m}.omega_out", "load.omega"),
            ("load.tau", "{m}.tau_load")),
    True: (("{m}.omega_in", "motor.omega"), ("motor.tau_motor", "{m}.tau_in"), ("{m}.omega_out", "load.omega"),
           ("load.tau", "{m}.tau_load")),
}


def chain_topology(machine: str, fmu: str) -> str:
    """The sentence that names the motor -> machine -> load chain check_chain_wiring requires."""
    speed, torque = ([(a.format(m=machine), b.format(m=machine)) for a, b in CHAIN_CONNECTIONS[k]]
                     for k in (False, True))
    return (f"the chain of components 'motor', '{machine}', 'load', either speed-driven (Motor, {fmu}, Load; "
            f"connections {_arrows(speed)}) or torque-driven (MotorController, {fmu}TorqueDriven, Load; "
            f"connections {_arrows(torque)})")


def check_chain_wiring(scenario, generator: str, machine: str, fmu: str, torque_driven_variant: bool = True) -> None:
    """check_wiring for the three-component chain motor -> machine -> load of chain_topology: the machine's FMU
    (fmu or, where the model has one, its TorqueDriven variant) chooses the wiring."""
    entry = scenario.components.get(machine)
    variant = fmu + "TorqueDriven" if torque_driven_variant else None
    torque_driven = entry is not None and entry[0] == variant
    components = {"motor": ("MotorController",) if torque_driven else ("Motor",),
                  machine: (variant,) if torque_driven else (fmu, variant) if variant else (fmu,),
                  "load": ("Load",)}
    connections = [(a.format(m=machine), b.format(m=machine)) for a, b in CHAIN_CONNECTIONS[torque_driven]]
    check_wiring(scenario, generator, chain_topology(machine, fmu), components, connections,
                 optional=[(f"{machine}.phi_out", "load.phi")])
    check_load_angle(scenario, "load", machine)


def check_fan_out_wiring(scenario, generator: str, fmu: str, load_optional: bool) -> None:
    """check_wiring for a Motor named 'motor' driving components of fmu (any names), each with a Load (any name)
    fed from its omega_out and feeding its tau_load (optional where load_optional: without one, its tau_load must be
    set to 0). An ideal speed source drives any number and may take one's tau_in as its tau_load; a PI motor drives
    exactly one, whose tau_in loads it."""
    machines = components_with_loads(scenario, fmu)
    motor = scenario.components.get("motor", ("",))[0] == "Motor"
    ideal = not motor or bool(scenario.parameters_with_defaults("motor")["ideal_speed_source"])
    components = {"motor": ("Motor",)}
    connections, optional, problems = [], [], []
    for name, load in machines:
        components[name] = (fmu,)
        connections.append(("motor.omega", f"{name}.omega_in"))
        (optional if ideal else connections).append((f"{name}.tau_in", "motor.tau_load"))
        if load:
            components[load] = ("Load",)
            connections += [(f"{name}.omega_out", f"{load}.omega"), (f"{load}.tau", f"{name}.tau_load")]
            optional.append((f"{name}.phi_out", f"{load}.phi"))
        elif not load_optional:
            problems.append(f"{name} has no Load fed from {name}.omega_out")
        elif scenario.inputs.get(name, {}).get("tau_load", 0.0) != 0.0:
            problems.append(f"{name} has no Load, so its tau_load must be 0, not {scenario.inputs[name]['tau_load']}")
    if not machines:
        problems.append(f"no {fmu} component")
    elif not ideal and len(machines) != 1:
        problems.append(f"a PI motor (ideal_speed_source = false) drives {len(machines)} {fmu} components")
    load = "with or without a Load (tau_load = 0 without)" if load_optional else "each with a Load"
    expects = (f"a Motor named 'motor' driving {fmu} components (any names), {load}: connections motor.omega -> "
               f"X.omega_in, X.omega_out -> L.omega, L.tau -> X.tau_load for each {fmu} X and its Load L; an ideal "
               "speed source drives any number of them (X.tau_in -> motor.tau_load optional, for one), a PI motor "
               "exactly one, with X.tau_in -> motor.tau_load (X.phi_out -> L.phi optional, needed for a Load's "
               "periodic torque)")
    check_wiring(scenario, generator, expects, components, connections, optional, problems)
    for name, load in machines:
        check_load_angle(scenario, load, name)


def machines_and_loads(scenario, generator: str, machine: str, fmu: str, load_optional: bool) -> list:
    """[(machine component, its Load component or None)] once the wiring is checked: the torque-driven chain
    motor -> machine -> load of check_chain_wiring when the scenario holds fmu's TorqueDriven variant, else a
    Motor driving fmu components of any names (check_fan_out_wiring)."""
    if any(name == fmu + "TorqueDriven" for name, _ in scenario.components.values()):
        check_chain_wiring(scenario, generator, machine, fmu)
        return [(machine, "load")]
    check_fan_out_wiring(scenario, generator, fmu, load_optional)
    return components_with_loads(scenario, fmu)


def components_with_loads(scenario, fmu):
    """[(component, its Load component or None)] for every component of the given FMU, the load being the
    component whose omega input is fed from the component's omega_out."""
    load_of = {cn.source.split(".")[0]: cn.target.split(".")[0] for cn in scenario.connections
               if cn.source.endswith(".omega_out") and cn.target.endswith(".omega")}
    return [(c, load_of.get(c)) for c, (name, _) in scenario.components.items() if name == fmu]


def drive(scenario, motor: str, machine: str) -> tuple:
    """(motor parameters, driver inertia, input speed at the start, torque_driven) of a motor driving machine.

    Speed-driven wiring: a Motor with its rotor J_rotor, starting at its reference speed. Torque-driven wiring:
    a MotorController, the rotor inertia lumped into the machine's J_drive, starting at its omega_in_start.
    """
    pm, pj = scenario.parameters_with_defaults(motor), scenario.parameters_with_defaults(machine)
    if "J_drive" in pj:
        return dict(pm, ideal_speed_source=False), pj["J_drive"], pj["omega_in_start"], True
    t0 = np.array([scenario.start_time])
    return pm, pm["J_rotor"], float(profile(pm, t0)[0][0]), False


def torque_driven_names(machine: str, columns: dict) -> dict:
    """columns (named as in the speed-driven wiring) with the torque-driven machine's names: its input speed
    omega_in (the motor's speed) and tau_input_shaft (the torque into its input shaft, the speed-driven tau_in)."""
    renamed = dict(columns)
    renamed[f"{machine}.tau_input_shaft"] = renamed.pop(f"{machine}.tau_in")
    renamed[f"{machine}.omega_in"] = columns["motor.omega"]
    return renamed


class ReferenceCheckError(AssertionError):
    """A reference violates its own conservation law or closed-form limit (it is not written)."""


def work(t: np.ndarray, power: np.ndarray) -> np.ndarray:
    """Cumulative integral of power over the grid t from t[0] (Simpson's rule), e.g. the work of a torque."""
    return cumulative_simpson(np.asarray(power, dtype=float), x=t, initial=0.0)


def check_close(scenario, what: str, actual, expected, scale: float, rtol: float) -> float:
    """ReferenceCheckError naming the scenario and the law unless max |actual - expected| <= rtol * scale;
    returns the deviation relative to scale."""
    if DryRun.active:
        return 0.0
    deviation = float(np.max(np.abs(np.asarray(actual) - np.asarray(expected))))
    if not deviation <= rtol * scale:
        raise ReferenceCheckError(f"{scenario.path}: reference self-check failed: {what}: max deviation "
                                  f"{deviation:.3g} > {rtol:g} x {scale:.3g}")
    if SelfChecks.made is not None:
        SelfChecks.made.append((what, deviation / scale, rtol))
    return deviation / scale


def simpson_error(t: np.ndarray, power) -> float:
    """An estimate of the error of Simpson's rule integrating power over the grid t: (t_end - t0) max|h^4 P| / 180,
    h^4 P the fourth differences (negligible on a grid that resolves the motion, a stiff shaft sampled at 1 ms needs
    it; conservative while the grid has more than two samples a period of the power's fastest content, not
    where it aliases it)."""
    return (t[-1] - t[0]) * float(np.max(np.abs(np.diff(np.asarray(power, dtype=float), 4)), initial=0.0)) / 180.0


def check_integral(scenario, what: str, t: np.ndarray, integral, power, rtol: float) -> float:
    """An integrated state (e.g. the work put in) against Simpson's rule on power over the grid t: within rtol of
    its largest magnitude plus the quadrature's error (``simpson_error``)."""
    scale = max(float(np.max(np.abs(integral))), 1e-300)
    return check_close(scenario, what, integral, work(t, power), scale, rtol + simpson_error(t, power) / scale)


def check_energy_balance(scenario, what: str, t: np.ndarray, stored, power_in, power_out, rtol: float) -> float:
    """Energy balance stored(t) - stored(t0) = integral of (power_in - power_out) dt; the scale is the larger of
    the largest stored energy and the largest work put in. Allowed: rtol * scale plus the quadrature error of
    Simpson's rule on the grid, (t_end - t0) max|h^4 P| / 180 with h^4 P the fourth differences of the net
    power (negligible on a grid that resolves the motion; a stiff shaft sampled at 1 ms needs it)."""
    supplied = work(t, power_in)
    scale = max(float(np.max(np.abs(stored))), float(np.max(np.abs(supplied))), 1e-300)
    quadrature = simpson_error(t, np.asarray(power_in, dtype=float) - np.asarray(power_out, dtype=float))
    return check_close(scenario, what, stored - stored[0], supplied - work(t, power_out), scale,
                       rtol + quadrature / scale)
