"""Signal analysis of results (numpy): running-speed harmonics (order amplitudes), amplitude spectra, orbits; the
models' natural frequencies (linearisation) and the speeds at which the orders cross them."""

import contextlib
import dataclasses
import math
import threading
from dataclasses import dataclass

import numpy as np


_blas = {"controller": None, "limit": None, "users": 0}
_blas_lock = threading.Lock()


@contextlib.contextmanager
def one_blas_thread():
    """numpy's BLAS limited to one thread (threadpoolctl) while the fits' least-squares problems are solved. With
    more, its helper threads spin after every call: a sweep of fits in one process took 1.13x the CPU of its wall
    time, and two such processes on two cores each took twice as long as one alone (docs/performance.md). The limit
    is the process's: set as the first thread enters, the caller's restored as the last one leaves."""
    with _blas_lock:
        if _blas["users"] == 0:
            if _blas["controller"] is None:
                from threadpoolctl import ThreadpoolController
                _blas["controller"] = ThreadpoolController()
            _blas["limit"] = _blas["controller"].limit(limits=1, user_api="blas")
        _blas["users"] += 1
    try:
        yield
    finally:
        with _blas_lock:
            _blas["users"] -= 1
            if _blas["users"] == 0:
                _blas["limit"].restore_original_limits()


def order_amplitudes(angle, signal, orders):
    """Amplitudes of the given running-speed orders of signal, sampled along the running angle [rad].

    Least-squares fit signal = c0 + sum_k a_k cos(k angle) + b_k sin(k angle) over the samples; amplitude
    sqrt(a_k^2 + b_k^2). Exact for a periodic steady state sampled over whole revolutions, and robust to a slowly
    varying speed because it works on the angle, not on time. Returns (amplitudes, phases) with
    signal ~ amplitude cos(k angle - phase).
    """
    _, amplitudes, phases = order_fit(angle, signal, orders)
    return amplitudes, phases


def order_fit(angle, signal, orders):
    """(c0, amplitudes, phases) of the least-squares fit signal = c0 + sum_k amplitude_k cos(k angle - phase_k).
    ValueError where the samples fall at too few distinct angles to tell the orders apart (a step that is a whole
    fraction of a revolution: the fit would return one of many solutions)."""
    angle, signal = np.asarray(angle, float), np.asarray(signal, float)
    columns = [np.ones_like(angle)]
    for k in orders:
        columns += [np.cos(k * angle), np.sin(k * angle)]
    matrix = np.column_stack(columns)
    with one_blas_thread():
        coef, _, rank, _ = np.linalg.lstsq(matrix, signal, rcond=None)
    if rank < matrix.shape[1]:
        turns = abs(float(angle[-1] - angle[0])) / (2.0 * math.pi) if len(angle) > 1 else 0.0
        per_turn = len(angle) / turns if turns > 0.0 else math.inf
        if turns == 0.0:
            raise ValueError(f"the {len(angle)} samples span no revolution: the running speed is 0 over them, so "
                             f"there are no orders to fit")
        if not (np.all(np.isfinite(angle)) and np.all(np.isfinite(signal))) or per_turn < 4.0:
            raise ValueError(f"the {len(angle)} samples span {turns:.3g} revolutions ({per_turn:.3g} a revolution) "
                             f"and cannot separate the mean and orders {', '.join(map(str, orders))} (rank {rank} of "
                             f"{matrix.shape[1]}): the running speed is far above what the step resolves, or not "
                             "finite; if it is far above the set speed, the run diverged (a smaller step, or the "
                             "implicit coupling)")
        raise ValueError(f"the {len(angle)} samples fall at too few distinct shaft angles to separate the mean and "
                         f"orders {', '.join(map(str, orders))} (rank {rank} of {matrix.shape[1]}): the step is a whole "
                         f"fraction of a revolution; take a step that is not, or more samples per revolution")
    a, b = coef[1::2], coef[2::2]
    return coef[0], np.hypot(a, b), np.arctan2(b, a)


#: the flat-top window's cosine coefficients (Heinzel, Ruediger, Schilling, "Spectrum and spectral density
#: estimation by the Discrete Fourier transform (DFT)", Max-Planck-Institut fuer Gravitationsphysik, 2002: the
#: "flattop" of MATLAB and scipy): its peak reads a sinusoid's amplitude within 0.2% wherever it falls between bins
FLAT_TOP = (0.21557895, 0.41663158, 0.277263158, 0.083578947, 0.006947368)


def periodic_mean(time, signal, speed) -> float:
    """The mean of a signal periodic in the running angle (the integral of speed): the constant of its least-squares
    fit with the orders the steady-state check fits (``steady.fitted_orders``: 1 .. 8, as many as the samples
    resolve). A plain mean over a window of no whole number of revolutions takes in part of the orders: 10x the true
    offset of a rotor's orbit at its critical speed, where the 1x is 60 times the offset. The plain mean where there
    is less than a revolution, a speed that is not finite, or the fit cannot be made."""
    from .steady import Window, fitted_orders, nyquist_order, running_angle
    time, signal, speed = np.asarray(time, float), np.asarray(signal, float), np.asarray(speed, float)
    if len(time) > 1 and np.all(np.isfinite(speed)):
        window = Window(float(time[0]), running_angle(time, speed), None)
        if abs(float(window.angle[-1] - window.angle[0])) >= 2.0 * math.pi and nyquist_order(window) >= 1:
            try:
                return float(order_fit(window.angle, signal, fitted_orders(window, (1,)))[0])
            except ValueError:
                pass
    return float(np.mean(signal))


def amplitude_spectrum(time, signal, mean: float | None = None):
    """(frequency [Hz], single-sided amplitude) of a uniformly sampled signal, its mean removed (given, e.g.
    :func:`periodic_mean`, else the samples'), flat-top window (``FLAT_TOP``) with its coherent gain corrected, so a
    sinusoid of amplitude A shows a peak of A within 0.2% wherever its frequency falls between bins (a Hann
    window's peak reads up to 15% low there)."""
    time, signal = np.asarray(time, float), np.asarray(signal, float)
    n = len(signal)
    phase = 2.0 * np.pi * np.arange(n) / (n - 1)
    window = sum((-1) ** k * a * np.cos(k * phase) for k, a in enumerate(FLAT_TOP))
    spectrum = np.fft.rfft((signal - (signal.mean() if mean is None else mean)) * window)
    amplitude = 2.0 * np.abs(spectrum) / window.sum()
    return np.fft.rfftfreq(n, d=(time[-1] - time[0]) / (n - 1)), amplitude


def jacobian(rhs, y0, step=1e-7) -> np.ndarray:
    """d rhs / d y at y0 by central differences of relative size step."""
    y0 = np.asarray(y0, float)
    jac = np.empty((len(y0), len(y0)))
    for i in range(len(y0)):
        d = step * max(1.0, abs(y0[i]))
        hi, lo = y0.copy(), y0.copy()
        hi[i] += d
        lo[i] -= d
        jac[:, i] = (np.asarray(rhs(hi), float) - np.asarray(rhs(lo), float)) / (2.0 * d)
    return jac


def decay_rates(rhs, y0, step=1e-7):
    """Decay rates -Re(lambda) [1/s] of the linearisation of y' = rhs(y) at y0, slowest first: the eigenvalues
    lambda of the Jacobian (central differences of relative size step). A transient of mode i falls as
    exp(-rate_i t), so the slowest rate bounds how long a run needs to reach its steady state."""
    return np.sort(-np.linalg.eigvals(jacobian(rhs, y0, step)).real)


def natural_frequencies(rhs, y0, step=1e-7) -> np.ndarray:
    """Undamped natural frequencies [rad/s] of the linearisation of y' = rhs(y) at y0, ascending: |lambda| of each
    eigenvalue pair lambda = -zeta w_n +- i w_n sqrt(1 - zeta^2) of the Jacobian (|lambda| = w_n); real
    eigenvalues (rigid-body motion, integrators, overdamped modes) have none, and neither has a pair within 1e-6 of
    the largest |lambda| (a rigid-body motion through a coupling, whose double eigenvalue 0 the finite differences
    split into a pair near 0: the ring coupling's at 1.4e-6 rad/s)."""
    lam = np.linalg.eigvals(jacobian(rhs, y0, step))
    return np.sort(np.abs(lam[_oscillating(lam)]))


def _oscillating(lam: np.ndarray) -> np.ndarray:
    """Indices of the eigenvalues lam of the upper half plane that are modes (``natural_frequencies``), by |lam|."""
    size = np.max(np.abs(lam), initial=0.0)
    keep = np.flatnonzero((lam.imag > 1e-9 * np.maximum(1.0, np.abs(lam))) & (np.abs(lam) > 1e-6 * size))
    return keep[np.argsort(np.abs(lam[keep]), kind="stable")]


def mode_participation(rhs, y0, step=1e-7) -> tuple:
    """(``natural_frequencies``, their participation factors, their damping ratios): column i holds mode i's
    |w_ki v_ki| over the states k (v its right eigenvector, w its left one, the rows of V^-1), normalised to sum 1;
    the damping ratio of an eigenvalue lambda is -Re(lambda) / |lambda|. Participation factors do not depend on the
    states' units (a state scaled by s scales v_k by s and w_k by 1/s), so they compare an angle with a
    displacement. A defective Jacobian (no eigenvector basis) takes V's pseudo-inverse."""
    lam, right = np.linalg.eig(jacobian(rhs, y0, step))
    keep = _oscillating(lam)
    try:
        left = np.linalg.inv(right)
    except np.linalg.LinAlgError:
        left = np.linalg.pinv(right)
    participation = np.abs(right * left.T)[:, keep]
    return (np.abs(lam[keep]), participation / np.maximum(participation.sum(axis=0), 1e-300),
            -lam[keep].real / np.abs(lam[keep]))


def natural_modes(rhs, y0, selected, step=1e-7) -> tuple:
    """(``natural_frequencies``, the share of each mode in the states whose indices are in selected): its
    participation factors (``mode_participation``) summed over them. A one-degree-of-freedom oscillator in the
    selected states has share 1, one outside them 0."""
    frequencies, participation, _ = mode_participation(rhs, y0, step)
    return frequencies, participation[list(selected)].sum(axis=0)


#: most modes tracked across the input angle by their shapes (``_track``); more are paired by rank
TRACKED_MODES = 7


def _track(previous: np.ndarray, frequencies: np.ndarray, participation: np.ndarray) -> list:
    """The order of this angle's modes that follows the previous angle's (participation columns ``previous``): the
    permutation with the most similar participation (cosines of the columns), then the nearest frequencies; by
    rank beyond ``TRACKED_MODES`` modes. Two modes whose frequencies cross between the angles keep their shapes
    (Omar's lateral mode at 143 rad/s inside the torsional one's 138-148 rad/s span had been blended with it)."""
    import itertools
    n = len(frequencies)
    if n > TRACKED_MODES:
        return list(range(n))
    unit = participation / np.maximum(np.linalg.norm(participation, axis=0), 1e-300)
    before = previous / np.maximum(np.linalg.norm(previous, axis=0), 1e-300)
    similarity = before.T @ unit   # [previous mode, this mode]
    return list(max(itertools.permutations(range(n)),
                    key=lambda order: round(sum(similarity[i, j] for i, j in enumerate(order)), 6)))


#: input angles per period of a model's excitation order at which ``model_natural_frequency_range`` linearises
ANGLE_SAMPLES = 8


def declared_parameters(model) -> dict:
    """{name: start value} of the parameters the FMU over model (``MODEL``) declares."""
    from .build import FMUS, fmu_class
    for name in FMUS:
        cls = fmu_class(name)
        if cls.MODEL is model:
            return {v.name: v.start for v in cls.VARIABLES if v.causality == "parameter"}
    raise ValueError(f"no FMU of ujfmu is over the model {model!r}")


def model_natural_frequency_range(model, parameters: dict) -> tuple:
    """(mean, lowest, highest) natural frequencies [rad/s] of a model (a module or class of the
    ``ujfmu.models.protocol``) at parameters (by name; those missing take the start values its FMU declares, e.g.
    the unbalances' phases beside a twin rotor's ``rig_parameters()``), linearised about its initial state at rest
    with its inputs zero (input shaft held, no load): ``natural_frequencies`` of ``derivatives``. A speed-driven
    model (an input angle phi) is linearised at ``ANGLE_SAMPLES`` input angles over one period of its
    ``EXCITATION_ORDER``, each mode followed by its shape from angle to angle (``_track``): a joint's
    speed ratio and its derivative vary with the angle (Omar's torsional mode spans 138-148 rad/s at beta0 = 15 deg,
    mean 143.1 = sqrt(k/J) of the paper's 684 rpm critical speed; the linearisation at 0 deg alone is 3.5% high).
    A torque-driven model, its input angle a state, is linearised at 0 only. Empty arrays for a model without a
    state of its own or held kinematically."""
    return model_modes(model, parameters)[:3]


def model_modes(model, parameters: dict) -> tuple:
    """``model_natural_frequency_range``'s (mean, lowest, highest) natural frequencies [rad/s], and each mode's
    mean lateral share over the input angle: its participation (``natural_modes``) in the states the model declares
    lateral (``LATERAL_STATES``: bending displacements and their rates; none, a model of rotations only), and its
    mean damping ratio (``mode_participation``)."""
    import dataclasses
    names = [f.name for f in dataclasses.fields(model.Parameters) if f.init]
    if any(name not in parameters for name in names):
        parameters = {**declared_parameters(model), **parameters}
    p = model.Parameters(**{name: parameters[name] for name in names})
    if not model.State._fields or (hasattr(model, "kinematic") and model.kinematic(p)):
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
    lateral = [i for i, name in enumerate(model.State._fields) if name in getattr(model, "LATERAL_STATES", ())]
    fields = model.Inputs._fields
    period = 2.0 * np.pi / getattr(model, "EXCITATION_ORDER", 1)
    angles = [k * period / ANGLE_SAMPLES for k in range(ANGLE_SAMPLES)] if "phi" in fields else [0.0]
    samples = []
    for angle in angles:
        u = model.Inputs(*[angle if name == "phi" else 0.0 for name in fields])
        y0 = np.asarray(model.initial_state(p, 0.0, u), float)
        samples.append(mode_participation(lambda y, u=u: model.derivatives(p, 0.0, model.State(*y), u), y0))
    if len({len(w) for w, _, _ in samples}) != 1:   # a mode over-damped at some angles only: no pairing, keep 0 deg
        samples = [samples[0]]
    tracked = [samples[0]]   # each angle's modes in the order of the first angle's, followed by their shapes
    for frequencies, participation, damping in samples[1:]:
        order = _track(tracked[-1][1], frequencies, participation)
        tracked.append((frequencies[order], participation[:, order], damping[order]))
    frequencies = np.array([w for w, _, _ in tracked])
    shares = np.array([participation[lateral].sum(axis=0) for _, participation, _ in tracked])
    zeta = np.array([damping for _, _, damping in tracked]).mean(axis=0)
    mean = frequencies.mean(axis=0)
    order = np.argsort(mean, kind="stable")
    return (mean[order], frequencies.min(axis=0)[order], frequencies.max(axis=0)[order], shares.mean(axis=0)[order],
            zeta[order])


#: FMUs whose eigenvalues are not modes of the driveline (the drive's speed loop, a load law)
DRIVES_AND_LOADS = ("Motor", "MotorController", "Load")
#: an order crossing within this fraction of a drive's set speed is reported as near it (``ujfmu modes``)
NEAR_CRITICAL = 0.1
#: the share of a mode's participation in twist (or bending) from which it is called torsional (or lateral)
PURE_MODE = 0.9


@dataclass
class Mode:
    """A natural frequency of a machine component of a scenario (``scenario_modes``): its mean over the input
    angle omega [rad/s], the number of modes merged into it (within 0.5% and of one kind: the X and Y modes of a
    round shaft), the range low-high the linearisation spans over the input angle, the orders of the input speed
    the component's outputs carry at its parameters (:func:`carried_orders`: a joint's 2x), and its lateral share
    (``model_modes``: 0 a twist, 1 a bending)."""
    component: str
    omega: float
    count: int
    low: float
    high: float
    orders: tuple
    lateral: float = 0.0
    damping: float = math.nan   # its damping ratio, mean over the input angle (of the first where modes merged)

    @property
    def kind(self) -> str:
        """"torsional" or "lateral" where at least ``PURE_MODE`` of the mode's participation is in twist or in
        bending; else "lateral-torsional" with its lateral share."""
        if self.lateral <= 1.0 - PURE_MODE:
            return "torsional"
        if self.lateral >= PURE_MODE:
            return "lateral"
        return f"lateral-torsional, {100 * self.lateral:.0f}% lateral"

    def critical_speed(self, order: int) -> float:
        """The input speed [rad/s] whose order-th harmonic is at this frequency (a Campbell diagram's crossing):
        omega / order."""
        return self.omega / order


def scenario_modes(scenario, point: dict | None = None) -> list[Mode]:
    """The natural frequencies of every machine component of scenario (drives and loads left out) at its
    parameters with point's {"component.parameter": value} applied: ``model_natural_frequency_range`` (the model's
    own linearisation at rest, no load), frequencies within 0.5% of each other and of one ``Mode.kind`` merged. A
    speed-driven component's input shaft is held where an ideal speed source drives it; where a PI Motor does, it
    is free with the motor's rotor inertia on it (the model's torque-driven variant with J_drive = J_rotor; the
    speed loop left out), as a torque-driven component's is with its own J_drive."""
    return _modes(scenario, point, held=False)


def held_input_modes(scenario, point: dict | None = None) -> list[Mode]:
    """The other bound of the modes of the components a PI Motor or a MotorController drives (``scenario_modes`` has
    them with the input free, the speed loop left out): their input shaft held, as a speed loop far stiffer than the
    mode holds it (a stiff loop, Kp = 840 N.m.s/rad on 2.5 kg.m^2, shows the held-input mode's resonance, none at the
    free-input one). A proportional loop's mode lies between the two; the integral action can move it outside."""
    return _modes(scenario, point, held=True)


def _modes(scenario, point: dict | None, held: bool) -> list[Mode]:
    """``scenario_modes`` (held False) or ``held_input_modes`` (held True: only the components a PI Motor or a
    MotorController drives, their speed-driven model with the input held)."""
    from .build import FMUS, fmu_class
    rotors, controlled = {}, set()   # the rotor inertia of the PI Motor driving a component's omega_in; the
    for conn in scenario.connections:   # torque-driven components a MotorController's tau_motor drives
        driver, _, out = conn.source.partition(".")
        driven, _, port = conn.target.partition(".")
        if out == "omega" and port == "omega_in" and scenario.components.get(driver, ("",))[0] == "Motor":
            motor = scenario.parameters_with_defaults(driver)
            if not motor["ideal_speed_source"]:
                rotors[driven] = float(motor["J_rotor"])
        if out == "tau_motor" and port == "tau_in" and scenario.components.get(driver, ("",))[0] == "MotorController":
            controlled.add(driven)
    modes = []
    for name, (fmu, _) in scenario.components.items():
        speed_driven = fmu.removesuffix("TorqueDriven")
        pi_driven = (name in rotors and fmu + "TorqueDriven" in FMUS
                     or name in controlled and fmu != speed_driven and speed_driven in FMUS)
        if fmu in DRIVES_AND_LOADS or held and not pi_driven:
            continue
        parameters = scenario.parameters_with_defaults(name)
        parameters.update({k.partition(".")[2]: v for k, v in (point or {}).items() if k.partition(".")[0] == name})
        cls = fmu_class(fmu)
        model = cls.MODEL
        if held and name in controlled:   # the speed-driven model: its input held
            model = fmu_class(speed_driven).MODEL
        elif not held and name in rotors and fmu + "TorqueDriven" in FMUS:
            model = fmu_class(fmu + "TorqueDriven").MODEL
            parameters.update(J_drive=rotors[name], omega_in_start=0.0)
        orders = carried_orders(cls.PHYSICS, cls.MODEL.Parameters(
            **{f.name: parameters[f.name] for f in dataclasses.fields(cls.MODEL.Parameters) if f.init}))
        merged = []
        for omega, low, high, lateral, zeta in zip(*model_modes(model, parameters)):
            mode = Mode(name, float(omega), 1, float(low), float(high), orders, float(lateral), float(zeta))
            if (merged and omega <= merged[-1].omega * 1.005
                    and mode.kind.partition(",")[0] == merged[-1].kind.partition(",")[0]):
                merged[-1].count += 1
                merged[-1].low, merged[-1].high = min(merged[-1].low, float(low)), max(merged[-1].high, float(high))
            else:
                merged.append(mode)
        modes += merged
    return modes


def carried_orders(physics, p) -> tuple:
    """The orders of the input speed a model's outputs carry at full size at its parameters p: its
    ``excited_orders(p)``, else 1 to its ``excitation_order(p)`` (or ``EXCITATION_ORDER``; 1 without one)."""
    if hasattr(physics, "excited_orders"):
        return tuple(physics.excited_orders(p))
    highest = getattr(physics, "EXCITATION_ORDER", 1)
    if hasattr(physics, "excitation_order"):
        highest = physics.excitation_order(p)
    return tuple(range(1, highest + 1))


def load_orders(scenario) -> dict:
    """{machine component: [(Load component, order_h), ...]} of the Loads with a torque periodic in the angle of a
    machine's output shaft (T_h != 0, phi fed from its phi_out): an excitation at order_h times that shaft's speed,
    which a machine with a mean speed ratio 1 turns at the input speed."""
    found = {}
    for conn in scenario.connections:
        machine, _, out = conn.source.partition(".")
        load, _, port = conn.target.partition(".")
        if out == "phi_out" and port == "phi" and scenario.components.get(load, ("",))[0] == "Load":
            values = scenario.parameters_with_defaults(load)
            if values.get("T_h") and values.get("order_h", 0.0) > 0.0:
                found.setdefault(machine, []).append((load, float(values["order_h"])))
    return found


def excitations(m: Mode, loads: dict) -> list:
    """[(order, what excites it beyond the machine)] of mode m: the machine's own orders, then its Loads' periodic
    torques' (``load_orders``' entries, ``loads``)."""
    return ([(k, "") for k in m.orders]
            + [(k, f" ({load}'s periodic torque)") for load, k in loads.get(m.component, [])])


@dataclass
class Crossing:
    """A drive's set speed [rad/s] (``name`` its "component.omega_set") and the nearest order crossing of a mode
    (:func:`nearest_crossings`): ``order`` times the speed meets ``mode``, held where it is the mode with the input
    held (``held_input_modes``)."""
    name: str
    speed: float
    mode: Mode
    order: float
    held: bool = False

    @property
    def margin(self) -> float:
        """|speed| over the crossing's speed, less 1 (> 0 above it)."""
        return abs(self.speed) / self.mode.critical_speed(self.order) - 1.0

    @property
    def near(self) -> bool:
        """Within ``NEAR_CRITICAL`` of the crossing."""
        return abs(self.margin) < NEAR_CRITICAL

    def text(self) -> str:
        """"the 2x order's with driveline's 154.71 rad/s torsional mode, at 77.357 rad/s"."""
        return (f"the {self.order:g}x order's with {self.mode.component}'s {self.mode.omega:.5g} rad/s "
                f"{self.mode.kind.partition(',')[0]} mode{' (input held)' if self.held else ''}, at "
                f"{self.mode.critical_speed(self.order):.5g} rad/s")


def driven_components(scenario, drive: str) -> set:
    """The components the drive component ``drive`` turns: those its outputs feed, and on through their outputs."""
    found, frontier = set(), [drive]
    while frontier:
        source = frontier.pop()
        for conn in scenario.connections:
            target = conn.target.partition(".")[0]
            if conn.source.partition(".")[0] == source and target not in found:
                found.add(target)
                frontier.append(target)
    return found


def nearest_crossings(scenario, modes: list | None = None, held: list | None = None) -> dict:
    """{"component.omega_set": the nearest :class:`Crossing`, or None where no order excites a mode} of each drive's
    nonzero set speed (``drive_speeds``) over the modes of the components it turns (:func:`driven_components`)
    among the scenario's modes and its held-input modes (computed where not given) and the orders that excite them
    (:func:`excitations`)."""
    modes = scenario_modes(scenario) if modes is None else modes
    held = held_input_modes(scenario) if held is None else held
    loads = load_orders(scenario)
    found = {}
    for name, speed in drive_speeds(scenario).items():
        if speed == 0.0:
            continue
        driven = driven_components(scenario, name.partition(".")[0])
        crossings = [Crossing(name, speed, m, k, bound) for m, bound in [(m, False) for m in modes]
                     + [(m, True) for m in held] if m.component in driven for k, _ in excitations(m, loads)]
        found[name] = min(crossings, key=lambda c: abs(c.margin), default=None)
    return found


def near_crossing_notes(scenario) -> list[str]:
    """One line per drive whose set speed lies within ``NEAR_CRITICAL`` of an order's crossing with a mode (a
    resonance where that order drives the mode's shape): ``ujfmu run`` says it before the run."""
    notes = []
    for c in nearest_crossings(scenario).values():
        if c is not None and c.near:
            notes.append(f"{c.name} = {c.speed:.6g} rad/s is{' in magnitude' if c.speed < 0 else ''} "
                         f"{100 * abs(c.margin):.1f}% "
                         f"{'above' if c.margin > 0 else 'below'} the speed {c.mode.critical_speed(c.order):.5g} "
                         f"rad/s at which the {c.order:g}x order meets {c.mode.component}'s {c.mode.omega:.5g} rad/s "
                         f"{c.mode.kind.partition(',')[0]} mode{' (input held)' if c.held else ''}: resonant "
                         "where that order acts on the mode's shape (`ujfmu modes` lists every crossing)")
    return notes


def drive_speeds(scenario) -> dict:
    """{"component.omega_set": speed [rad/s]} of the scenario's drives (Motor, MotorController): the speed each
    profile settles at; a step profile's omega_initial too."""
    speeds = {}
    for name, (fmu, _) in scenario.components.items():
        if fmu in ("Motor", "MotorController"):
            values = scenario.parameters_with_defaults(name)
            speeds[f"{name}.omega_set"] = float(values["omega_set"])
            if int(values.get("profile", 0)) in (2, 3):
                speeds[f"{name}.omega_initial"] = float(values["omega_initial"])
    return speeds
