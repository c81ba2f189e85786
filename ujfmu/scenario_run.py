"""Run scenarios, compare them with their references, write results, plots and JUnit reports.

A scenario's verdict is one of three: ``PASS`` (every toleranced signal within its tolerance), ``FAIL`` (at least
one outside, a drive short of its set point, or a record that aliases a model's excitation order), ``NOT CHECKED``
(nothing compared: no ``[reference]``, or no ``[reference.tolerance]`` entry, and nothing failed). A scenario that
was not checked never counts as passed: the JUnit report marks it skipped.
"""

import math
import os
import re
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy.util import write_csv

from .analysis import DRIVES_AND_LOADS, carried_orders, load_orders
from .build import DEFAULT_FMU_DIR, fmu_class
from .build3 import DEFAULT_FMU3_DIR
from .extras import available, preload
from .fmu.base import MIN_SAMPLES_PER_PERIOD, RESOLVING_SAMPLES_PER_PERIOD, samples_per_period, sampling_interval
from .master import (COUPLING_ATOL, COUPLING_RTOL, STALL_FACTOR, CosimulationError, CouplingInstabilityError,
                     Interrupted, RunStopped, cosimulate, is_ideal_speed_source)
from .scenario import Scenario, ScenarioError, description_attribute, running_angle_of
from .steady import PEAK_SHORTFALL, speed_text

DEFAULT_OUT_DIR = Path("results")
preload()   # before any FMU is loaded (see extras.preload)


@dataclass
class SignalCheck:
    name: str
    max_error: float
    allowed: float
    reference_range: float
    note: str = ""   # what the figures mean, where the tolerance's form does not suit the reference
    unit: str = ""   # of the signal, printed beside the errors
    rms_error: float = math.nan   # RMS of the error over the compared samples (shown, not judged)
    #: the band is at least half the reference's range, or of the signal's steady peak-to-peak
    #: (``mark_vibration_blind``): it checks the level, not the course
    level_only: bool = False
    at: float = math.nan   # the time of the largest error

    @property
    def passed(self):
        return bool(self.max_error <= self.allowed)

    @property
    def fraction_of_allowed(self):
        """max |error| / allowed error: <= 1 passes."""
        return self.max_error / self.allowed if self.allowed > 0 else (0.0 if self.max_error == 0 else math.inf)

    def __str__(self):
        verdict = "ok  " if self.passed else "FAIL"
        unit = f" {self.unit}" if self.unit and self.unit != "1" else ""
        rms = "" if math.isnan(self.rms_error) else f", RMS {self.rms_error:.3e}{unit}"
        at = "" if math.isnan(self.at) or self.max_error == 0.0 else f" at t = {self.at:.6g} s"
        text = (f"{verdict} {self.name:20s} max|err| = {self.max_error:.3e}{unit}{at}  allowed "
                f"{self.allowed:.3e}{unit}  ({self.fraction_of_allowed:.3g} of allowed{rms}")
        # the error relative to the reference's range means something only when the reference varies
        if self.reference_range > RANGE_FLOOR * self.allowed:
            text += f", {100 * self.max_error / self.reference_range:.3g}% of the reference's range"
        return text + ")" + (f": {self.note}" if self.note else "")


#: a reference whose range is at most this fraction of its magnitude is constant: rel_range gives it no allowance
CONSTANT_REFERENCE = 1e-9


#: a failure the start of a speed-driven run dominates: its error in the first steps at least this many times the
#: largest after them (a start-up's first steps, without the input's acceleration: 30x in a fresh-eyes trial's; a
#: coarse step's error merely peaking there, 1.5x, is the step's)
START_DOMINANCE = 3.0


#: what a band at least half its reference's range checks (a flat line through the middle passes it)
LEVEL_ONLY = "checks the level only"
#: a steady vibration (half the peak-to-peak over the steady window, the run's or the reference's) of at least this
#: fraction of the reference's range is a feature of the signal's course, which a band at least as wide cannot see:
#: a Cardan joint's 2x speed swing at 3 deg, +-0.14% of the speed, in a run-up from rest (its range the speed)
VISIBLE_VIBRATION = 0.001


#: a reference range below this multiple of the allowed error counts as constant (no "% of range" figure)
RANGE_FLOOR = 10.0
#: operating point: a drive's mean speed over the end window within this fraction of its set point (as sweeps)
OPERATING_TOL = 0.01
#: a drive below this fraction of its set speed where a run failed had nearly stopped (``stalled_drive_hint``)
STALLED = 0.1
#: end window of the operating-point check when the scenario has no steady_from: this fraction of the run
END_WINDOW = 0.1


@dataclass
class OperatingPointCheck:
    """A drive's speed against its set point over the end of the run (from steady_from, else the last 10%):
    mean |speed - set point| within OPERATING_TOL of the set point, or of the largest set point of the run where
    the drive is to stop (a braking to rest: 0 allows nothing). ``target`` is nan when the set point still moves in
    the window (a run that ends during its ramp): then nothing is checked."""
    signal: str
    set_point: str
    value: float
    target: float
    since: float
    #: where the set point moves in the window: the time from which it holds its last value (nan: it moves to the end)
    holds_from: float = math.nan
    #: the largest |set point| over the run [rad/s], the scale of a stop's tolerance
    top: float = 0.0
    #: the drive's PI has no integral action (Ki = 0) and is off its torque limit: a load leaves a steady offset
    #: T / Kp (at the limit the limit is the cause, which the torque-limit note says)
    proportional: bool = False
    #: where the set point moves to the end: (the profile's last corner [s], its final set point [rad/s]), the
    #: time it reaches that value (nan where unknown)
    reaches: tuple = (math.nan, math.nan)

    @property
    def checked(self) -> bool:
        return not math.isnan(self.target)

    @property
    def scale(self) -> float:
        """What the tolerance is a share of: |target|, or the run's largest set point where the target is 0."""
        return abs(self.target) or self.top or 1.0

    @property
    def passed(self) -> bool:
        return not self.checked or abs(self.value - self.target) <= OPERATING_TOL * self.scale

    def __str__(self):
        if not self.checked and not math.isnan(self.holds_from):
            return (f"not checked {self.signal}: its set point {self.set_point} reaches its final value only at t = "
                    f"{self.holds_from:g} s, inside the window the check averages over (from t = {self.since:g} s): "
                    f"lengthen stop_time, or set [output] steady_from (where the window starts) past t = "
                    f"{self.holds_from:g} s, to leave the drive a settling time after it")
        if not self.checked:
            at, final = self.reaches
            return (f"not checked {self.signal}: its set point {self.set_point} still moves after t = "
                    f"{self.since:g} s (the run ends before the profile does" + (
                        f": it reaches its final {speed_text(final)} only at t = {at:.4g} s; lengthen stop_time past "
                        "that and the drive's settling to check the operating point, or lower omega_set or raise "
                        "accel, unless the run ends during the ramp on purpose)" if not math.isnan(at) else ")"))
        head = "ok  " if self.passed else "FAIL"
        text = (f"{head} operating point {self.signal}: mean {speed_text(self.value)} from t = {self.since:g} s "
                f"against its set point {self.set_point} = {speed_text(self.target)} "
                f"({100.0 * (self.value - self.target) / self.scale:+.3g}%"
                + (f" of the run's top set point {speed_text(self.scale)}" if not self.target else "")
                + f", allowed {100.0 * OPERATING_TOL:g}%)")
        if not self.passed and abs(self.value) > abs(self.target):
            text += (": the drive runs above its set point at the end (an overshoot still settling, or a loop "
                     "oscillating about it); lengthen stop_time, or check the controller's gains against the "
                     "inertia it drives")
        elif not self.passed and self.proportional:
            text += (": the drive's PI has no integral action (Ki = 0), so a load leaves it short of its set point by "
                     "load / Kp for good; give it an integral gain Ki, or a larger Kp for a smaller offset")
        elif not self.passed:
            text += (": the set point is not reached by the end; lengthen stop_time, or give the drive more torque "
                     "(tau_max) or gain, or lower the load")
        return text


@dataclass
class TorqueLimitNote:
    """A drive that ran at its torque limit (|tau_motor| within ``AT_LIMIT`` of tau_max) for part of the run: where
    it did, its speed followed the limit, not its profile (a run-up's acceleration, hence the speed at which it
    passes a resonance, is then the limit's). A note, never a failure."""
    drive: str
    tau_max: float
    first: float   # the first and last instants at the limit [s]
    last: float
    duration: float   # the time at the limit [s]
    lag: float   # the largest |set point - speed| while at the limit [rad/s]
    passed = True

    def __str__(self):
        return (f"note drive {self.drive}: at its torque limit tau_max = {self.tau_max:g} N.m for "
                f"{self.duration:.3g} s between t = {self.first:g} and {self.last:g} s, up to {speed_text(self.lag)} behind its set point "
                "there: its speed followed the limit, not the profile (a run-up's pace through a resonance is the "
                "limit's); raise tau_max, or ease the profile (accel), where the profile was meant")


#: the fraction of tau_max within which a drive's torque counts as at its limit (``TorqueLimitNote``)
AT_LIMIT = 1e-6


def at_limit(torque: np.ndarray, tau_max: float) -> np.ndarray:
    """Where a drive's torque samples are at its limit tau_max (within ``AT_LIMIT`` of it)."""
    return np.abs(torque) >= (1.0 - AT_LIMIT) * tau_max


def torque_limit_notes(scenario: Scenario, table: np.ndarray) -> list:
    """A :class:`TorqueLimitNote` per drive of ``operating_pairs`` whose tau_motor (in table) reached its tau_max."""
    notes = []
    t = table["time"]
    for speed, set_point in operating_pairs(scenario):
        drive = speed.partition(".")[0]
        torque = f"{drive}.tau_motor"
        if len(t) < 2 or not {speed, set_point, torque} <= set(table.dtype.names):
            continue
        tau_max = float(scenario.parameters_with_defaults(drive)["tau_max"])
        at = at_limit(table[torque], tau_max)
        if not at.any():
            continue
        dt = np.diff(t)
        duration = float(np.sum(dt[at[:-1]]))
        notes.append(TorqueLimitNote(drive, tau_max, float(t[at][0]), float(t[at][-1]), duration,
                                     float(np.max(np.abs(table[set_point][at] - table[speed][at])))))
    return notes


#: a steady window's figures may differ between its two halves by this fraction of themselves (as a sweep's
#: default steady_tol, ``ujfmu.steady``)
STEADY_WINDOW_TOL = 1e-3


@dataclass
class SteadyWindowCheck:
    """Whether the run repeats from ``output.steady_from`` on, the window its orbits and spectra are drawn from: the
    mean and the 1x, 2x, 4x running-speed order amplitudes of every recorded signal (but running angles and energy
    integrals) in the window's first and second halves (``ujfmu.steady.halves_change``)."""
    since: float
    change: float
    worst: str
    against: str
    note: str = ""   # why the halves could not be compared (then the check fails: nothing says the run is steady)
    #: where the record reads too few samples a revolution for the fit's full set of orders: what it reads, the
    #: highest order the halves' fits take (the orders above leak into the figures compared) and the remedy
    sampling: str = ""

    @property
    def passed(self) -> bool:
        return not self.note and self.change <= STEADY_WINDOW_TOL

    def __str__(self):
        if self.note:
            return f"FAIL steady from t = {self.since:g} s (output.steady_from): {self.note}"
        if not self.worst:   # no figure moved past the coupling's noise (``ujfmu.steady.coupling_noise``)
            return (f"ok   steady from t = {self.since:g} s (output.steady_from): every figure repeats between the "
                    "window's halves (to the coupling's resolution: ujfmu.steady.coupling_noise)")
        text = (f"{'ok  ' if self.passed else 'FAIL'} steady from t = {self.since:g} s (output.steady_from): the "
                f"{self.worst} differs between the window's halves by {self.change:.3g} times {self.against} "
                f"(allowed: {STEADY_WINDOW_TOL:g} times)")
        if not self.passed and self.sampling:
            text += (f"; the record may be the cause: {self.sampling} before taking the response for "
                     "unsteady")
        elif not self.passed:
            text += ("; the response is not steady there, so the orbits and spectra drawn from it show a transient: "
                     "move steady_from later or lengthen stop_time, or look for a response that grows (no damping at "
                     "a resonance) or never settles")
        return text


def _steady_window(scenario: Scenario, table: np.ndarray) -> tuple | None:
    """(rows from output.steady_from on, the recorded signals there but those that grow, the running angle over
    them) where the scenario has a steady window and its running speed is in table; None otherwise, or for a
    window of fewer than 16 rows or without such signals."""
    from .steady import grows, running_angle
    if not (scenario.steady_from > scenario.start_time and scenario.running_speed in table.dtype.names):
        return None
    window = table[table["time"] >= scenario.steady_from - 1e-9]
    signals = [n for n in scenario.record if not grows(n) and n in table.dtype.names]
    if len(window) < 16 or not signals:
        return None
    return window, signals, running_angle(window["time"], window[scenario.running_speed])


def check_steady_window(scenario: Scenario, table: np.ndarray, iterated: bool = False) -> list:
    """A SteadyWindowCheck where the scenario has a steady_from and a running speed (its window's angle), else none;
    iterated: the run's steps iterated its torn inputs (``Cosimulation.iterates``), whose noise is no change."""
    from .steady import (HALVES_ORDERS, Window, coupling_noise, full_fit, halves_change, nyquist_order,
                         samples_per_revolution)
    steady = _steady_window(scenario, table)
    if steady is None:
        return []
    window, signals, angle = steady
    turns = abs(float(angle[-1] - angle[0])) / (2.0 * math.pi)
    if not turns >= MIN_WINDOW_TURNS:
        speed = float(np.mean(np.abs(window[scenario.running_speed])))
        return [SteadyWindowCheck(scenario.steady_from, math.nan, "", "", note=(
            f"the window spans {turns:.3g} revolutions of {scenario.running_speed} ({speed_text(speed)}), too few "
            f"to compare its halves' orders (at least {MIN_WINDOW_TURNS:g}): make it longer (an earlier "
            "steady_from or a later stop_time), or leave steady_from out at a speed this slow"))]
    try:
        change, worst, against = halves_change(angle, window, signals, noise=coupling_noise(iterated))
    except ValueError as exc:   # samples at too few distinct angles to fit the orders
        return [SteadyWindowCheck(scenario.steady_from, math.nan, "", "", note=f"cannot be judged: {exc}")]
    half = Window(0.0, np.asarray(angle[:len(angle) // 2]), window[:len(angle) // 2])
    top, wanted = nyquist_order(half), full_fit(HALVES_ORDERS)
    denser = ("a smaller --output-interval or [experiment] output_interval, or none"
              if (scenario.output_interval or 1) > 1 else "a smaller communication step, --step: the record takes "
              "every one")
    sampling = (f"it reads {samples_per_revolution(half):.3g} samples a revolution of {scenario.running_speed}, and "
                f"the halves' fits take orders up to {max(top, 1)} (of {wanted}), so the orders above leak into the "
                f"figures compared: judge it at a denser record ({denser})" if top < wanted else "")
    return [SteadyWindowCheck(scenario.steady_from, change, worst, against, sampling=sampling)]


def steady_orders(scenario: Scenario, table: np.ndarray, orders=(1, 2, 4)) -> dict:
    """{signal: (mean, amplitudes of orders)} of the recorded signals (but those that grow) over the steady window
    (``output.steady_from`` on), from one least-squares fit against the running angle (``steady.periodic_figures``;
    NaN for an order the record does not resolve); {} without a steady window or a running speed in table."""
    from .steady import Window, periodic_figures
    steady = _steady_window(scenario, table)
    if steady is None:
        return {}
    window, signals, angle = steady
    try:
        figures = periodic_figures(Window(float(window["time"][0]), angle, window), signals, orders)
    except ValueError:   # too few distinct angles for the fit: the steady window's check says so
        return {}
    return {name: (f.figures[0], f.figures[1:]) for name, f in figures.items()}


#: the fewest revolutions a steady window spans for its halves' orders to be compared (each half one at least)
MIN_WINDOW_TURNS = 2.0


#: the running-speed orders [reference.orders] compares
CHECKED_ORDERS = (1, 2, 4)
#: an order below this fraction of the signal's largest checked order, in the run and in the reference, carries too
#: little of its vibration to be compared as a fraction of itself
SIGNIFICANT_ORDER = 0.01
#: a signal whose largest checked order is below this fraction of its size (its mean or half its peak-to-peak) has
#: no vibration but round-off (a constant speed's 1e-14 of itself): nothing of it is compared
NEGLIGIBLE_ORDER = 1e-9


@dataclass(frozen=True)
class SteadyOrders:
    """One recorded signal over a run's steady window (``output.steady_from`` on): its mean and the zero-to-peak
    amplitudes of the running speed's orders (``amplitudes[k]``, k = 1, 2, 4; NaN for an order the record does not
    resolve), in the signal's unit, from one least-squares fit against the running angle (:func:`steady_orders`)."""
    name: str
    unit: str
    mean: float
    amplitudes: dict


@dataclass
class OrderCheck:
    """One running-speed order of a signal over the steady window (``output.steady_from`` on) against the
    reference's over the same instants, by the same least-squares fit (``ujfmu.steady.periodic_figures``): a
    vibration's amplitude, which [reference.tolerance]'s bands, scaled by the signal's whole range, cannot see."""
    name: str
    order: int
    amplitude: float
    reference_amplitude: float
    rel: float
    note: str = ""   # why nothing was compared (an order the step does not resolve, a signal without vibration)
    #: the note says why it cannot be compared where it should be (the reference's samples do not resolve an order
    #: the run carries): a failure
    refused: bool = False
    #: what the amplitude is compared with, as the line says it
    against: str = "the reference's"

    @property
    def passed(self) -> bool:
        return not self.refused and bool(
            self.note or abs(self.amplitude - self.reference_amplitude) <= self.rel * self.reference_amplitude)

    @property
    def text(self) -> str:
        """What was compared and how far off, or the note: the line without its verdict."""
        if self.note:
            return f"{self.name}: {self.note}"
        off = (self.amplitude - self.reference_amplitude) / self.reference_amplitude
        return (f"{self.name} {self.order}x order amplitude {self.amplitude:.4g} against {self.against} "
                f"{self.reference_amplitude:.4g} ({100 * off:+.3g}%, allowed {100 * self.rel:.3g}%)")

    def __str__(self):
        verdict = ("FAIL" if self.refused else "--  ") if self.note else "ok  " if self.passed else "FAIL"
        return f"{verdict} {self.text}"


def machines(scenario) -> list:
    """The scenario's machines: its components that are neither a drive nor a load (``DRIVES_AND_LOADS``), the
    models under test."""
    return [name for name, (fmu, _) in getattr(scenario, "components", {}).items() if fmu not in DRIVES_AND_LOADS]


def machine_orders(scenario) -> dict:
    """{machine component: the running-speed orders it carries at its parameters (``analysis.carried_orders``: a
    Cardan joint's 2x, an unbalance's 1x) and those of the Loads' periodic torques on it (``analysis.load_orders``),
    a Load's own under its name}; {} for an object without components."""
    components = getattr(scenario, "components", {})
    orders = {name: set(carried_orders(fmu_class(components[name][0]).PHYSICS, scenario.model_parameters(name)))
              for name in machines(scenario)}
    for machine, loads in (load_orders(scenario) if components else {}).items():
        for load, k in loads:
            orders.setdefault(machine, set()).add(k)
            orders.setdefault(load, set()).add(k)
    return orders


def check_orders(scenario: Scenario, table: np.ndarray, reference: np.ndarray) -> list:
    """An OrderCheck per signal of [reference.orders] and per order of ``CHECKED_ORDERS`` the window resolves whose
    amplitude in the run or in the reference is at least ``SIGNIFICANT_ORDER`` of the largest of them (the vibration,
    not the signal's mean, is the scale: a speed's orders are a small fraction of the speed; a spurious order of the
    run counts too): both fitted against the run's running angle, each over its own samples from steady_from to the
    run's end (where the reference's grid is not the run's, the angle interpolated to its instants: the reference
    interpolated to a finer run's instants would lose its higher orders, a 4x by 4% at a quarter of its step, where
    the angle, the speed's integral, interpolates within its curvature). An order the step does not resolve,
    or a signal whose orders are round-off (``NEGLIGIBLE_ORDER`` of its size), gets a check with a note instead;
    ScenarioError where the window cannot be fitted."""
    from .steady import Window, periodic_figures, running_angle
    if not scenario.order_tolerances:
        return []
    rows = table["time"] >= scenario.steady_from - 1e-9
    window, t = table[rows], table["time"][rows]
    angle = running_angle(t, window[scenario.running_speed])
    names = list(scenario.order_tolerances)
    end = float(t[-1]) if len(t) else 0.0
    span = 1e-9 * max(1.0, abs(end))
    first = float(t[0]) if len(t) else scenario.steady_from   # the run's window: a coarser record starts it later
    kept = (reference["time"] >= first - span) & (reference["time"] <= end + span)
    their_t = reference["time"][kept]
    if len(their_t) == len(t) and np.all(np.abs(their_t - t) <= span):   # one grid
        their_t, their_angle = t, angle
    else:
        their_angle = np.interp(their_t, t, angle)
    theirs = np.rec.fromarrays([their_t] + [reference[n][kept] for n in names], names=["time"] + names)
    try:
        for count in (len(t), len(their_t)):
            if count < 16:
                raise ValueError(f"the window holds {count} samples" + ("" if count == len(t) else
                                                                        " of the reference"))
        mine = periodic_figures(Window(float(t[0]), angle, window), names, CHECKED_ORDERS)
        ref = periodic_figures(Window(float(their_t[0]), their_angle, theirs), names, CHECKED_ORDERS)
    except ValueError as exc:
        raise ScenarioError(f"{scenario.path}: [reference.orders]: the orders of {scenario.running_speed} cannot be "
                            f"fitted over the window from output.steady_from = {scenario.steady_from:g} s: {exc} "
                            "(a window of whole revolutions at a running speed: move steady_from earlier or "
                            "lengthen stop_time)") from None
    checks, orders = [], machine_orders(scenario)
    every_n = getattr(scenario, "output_interval", None) or 1
    # what leaves an order unresolved, and its remedy: the step, or a record of every n-th step
    at, remedy = (("at this record's interval", f"record more often (output_interval = {every_n} steps now), and "
                   "take a smaller step where one step is too long already (the sampling note says at most how far "
                   "apart the samples may be)") if every_n > 1 else
                  ("at this step", "take a smaller step (the sampling note says which)"))
    for name in names:
        rel, runs, refs = scenario.order_tolerances[name], mine[name].figures[1:], ref[name].figures[1:]
        # the orders the signal's machine carries; a drive's signal (or another's) carries every machine's
        carried = orders.get(name.partition(".")[0], set().union(*orders.values()))
        size = max(mine[name].size, ref[name].size)
        resolved = [max(a, b) for a, b in zip(runs, refs) if not (math.isnan(a) or math.isnan(b))]
        largest = max(resolved, default=0.0)
        floor = SIGNIFICANT_ORDER * max([largest] + [x for x in runs if not math.isnan(x)])
        theirs_blind = [k for k, a, a_ref in zip(CHECKED_ORDERS, runs, refs) if not math.isnan(a) and math.isnan(a_ref)
                        and a >= floor and a > NEGLIGIBLE_ORDER * size]
        every = float(np.median(np.diff(their_t))) if len(their_t) > 1 else math.nan
        for k in theirs_blind:   # the run resolves it, the reference file's samples do not: it cannot be checked
            checks.append(OrderCheck(name, k, runs[CHECKED_ORDERS.index(k)], math.nan, rel, refused=True, note=(
                f"its {k}x order, which the run carries, is not resolved by the reference file's samples (every "
                f"{every:.3g} s: too few a revolution there), so it cannot be checked; give a reference sampled more "
                "finely, or leave the signal out of [reference.orders]")))
        if not resolved and theirs_blind:
            continue
        # the signal's vibration, half its peak-to-peak about its trend, in the run or the reference (:func:`_swing`)
        swing = max(_swing(t, window[name]), _swing(their_t, theirs[name]))
        vibrates = swing > NEGLIGIBLE_ORDER * size
        if not resolved:   # failed where its machine carries a checked order: its vibration goes unchecked
            missed = [k for k in CHECKED_ORDERS if k in carried] if vibrates else []
            checks.append(OrderCheck(name, 0, math.nan, math.nan, rel, refused=bool(missed), note=(
                f"no order is resolved {at} (too few samples a revolution): nothing compared" + (
                    f"; the {' and '.join(f'{k}x' for k in missed)} its machine carries cannot be checked: {remedy}"
                    if missed else ""))))
            continue
        if not largest > NEGLIGIBLE_ORDER * size:
            checks.append(OrderCheck(name, 0, math.nan, math.nan, rel, note=(
                f"no order above round-off (the largest {largest:.3g}, of a signal of size {size:.3g}): nothing "
                "compared")))
            continue
        # where an order is not resolved, the resolved ones are judged against the signal's whole vibration: the
        # unresolved one may carry it, and a run's spurious 1e-5 of it is no order to compare
        unresolved = [k for k, a, a_ref in zip(CHECKED_ORDERS, runs, refs)
                      if k not in theirs_blind and (math.isnan(a) or math.isnan(a_ref))]
        vibration = swing if unresolved else 0.0
        for k, a, a_ref in zip(CHECKED_ORDERS, runs, refs):
            if k in theirs_blind:
                continue
            if k in unresolved:   # failed where a machine carries it: the vibration the check is for goes unchecked
                missed = k in carried and vibrates
                checks.append(OrderCheck(name, k, a, a_ref, rel, refused=missed, note=(
                    f"its {k}x order is not resolved {at} (too few samples a revolution): not compared" + (
                        f"; its machine carries it (its share of the signal's vibration, {vibration:.3g} half its "
                        f"peak-to-peak about its trend, cannot be checked): {remedy}" if missed else ""))))
            elif max(a, a_ref) >= SIGNIFICANT_ORDER * max(largest, vibration):   # in the run or in the reference
                checks.append(OrderCheck(name, k, a, a_ref, rel))
    return checks


@dataclass
class SamplingCheck:
    """A drivetrain component's record against the highest order of the input speed its outputs carry at full size
    (its model's ``EXCITATION_ORDER``: a joint's 2x): samples per period of that order at the run's largest
    |omega_in|, the record taken every ``interval`` s. At MIN_SAMPLES_PER_PERIOD or fewer the record aliases it: a
    record step of a whole number of its periods samples one phase of it and shows a constant, and a reference
    sampled at the same instants agrees with it. Above, a passing check still says where the record's extremes
    may fall short of the order's peaks by more than ``steady.PEAK_SHORTFALL`` of its amplitude (1 - cos(pi / n),
    n samples a period)."""
    component: str
    order: int
    omega: float   # the largest |omega_in| recorded [rad/s]
    interval: float   # the record's step [s]

    @property
    def samples(self) -> float:
        """Samples per period of the order at omega (``ujfmu.fmu.base.samples_per_period``)."""
        return samples_per_period(self.order, self.omega, self.interval)

    @property
    def passed(self) -> bool:
        return self.samples > MIN_SAMPLES_PER_PERIOD

    def __str__(self):
        hertz = self.order * self.omega / (2.0 * math.pi)
        what = (f"sampling {self.component}: its {self.order}x order (up to {hertz:.4g} Hz at omega_in = "
                f"{speed_text(self.omega)})")
        if self.passed:
            shortfall = 1.0 - math.cos(math.pi / self.samples)
            short = "" if shortfall <= PEAK_SHORTFALL else (
                f"; the record's extremes may fall short of the order's peaks by up to {100.0 * shortfall:.3g}% of "
                f"its amplitude: record at most every "
                f"{sampling_interval(math.pi / math.acos(1.0 - PEAK_SHORTFALL), self.order, self.omega):.3g} s to "
                f"read them within {100.0 * PEAK_SHORTFALL:g}%")
            head = "note" if short else "ok  "   # passed: it does not alias; a note where its peaks may be missed
            return (f"{head} {what}, {self.samples:.3g} samples a period (more than {MIN_SAMPLES_PER_PERIOD:g})"
                    + short)
        resolving = sampling_interval(RESOLVING_SAMPLES_PER_PERIOD, self.order, self.omega)
        lower = [f"its {k}x ({samples_per_period(k, self.omega, self.interval):.3g} samples a period)"
                 for k in range(self.order - 1, 0, -1)
                 if samples_per_period(k, self.omega, self.interval) <= MIN_SAMPLES_PER_PERIOD]
        also = f"; so does {' and '.join(lower)}" if lower else ""
        return (f"FAIL {what}, {self.samples:.3g} samples a period at a record step of {self.interval:g} s, at most "
                f"{MIN_SAMPLES_PER_PERIOD:g} (Nyquist): the record aliases the order (a step of a whole number of its "
                f"periods samples one phase of it and shows a constant, and a reference sampled at the same instants "
                f"agrees with it){also}; record at most every {resolving:.3g} s to sample it "
                f"{RESOLVING_SAMPLES_PER_PERIOD:g} times a period (step_size, and output_interval)")


@dataclass
class ReferenceSamplingCheck(SamplingCheck):
    """A reference file sampled more coarsely than the run's record (a logger's rate, bench data) against the order
    of the input speed a drivetrain component's outputs carry (:class:`SamplingCheck`, ``interval`` the file's
    largest time step over the compared span): at MIN_SAMPLES_PER_PERIOD or fewer samples a period it aliases the
    order, and compared (interpolated linearly between its samples) it is no measure of the model; above, a note
    where the interpolation can miss the order's peaks by more than ``steady.PEAK_SHORTFALL`` of its amplitude."""

    def __str__(self):
        hertz = self.order * self.omega / (2.0 * math.pi)
        what = (f"sampling of the reference file against {self.component}'s {self.order}x order (up to {hertz:.4g} Hz "
                f"at omega_in = {speed_text(self.omega)})")
        resolving = sampling_interval(RESOLVING_SAMPLES_PER_PERIOD, self.order, self.omega)
        if self.passed:
            shortfall = 1.0 - math.cos(math.pi / self.samples)
            if shortfall <= PEAK_SHORTFALL:
                return f"ok   {what}, {self.samples:.3g} samples a period"
            return (f"note {what}, {self.samples:.3g} samples a period: interpolated between them it can miss the "
                    f"order's peaks by up to {100.0 * shortfall:.3g}% of its amplitude, which the comparison counts "
                    f"as the model's error; a file sampled at least every {resolving:.3g} s does not")
        return (f"FAIL {what}, {self.samples:.3g} samples a period at its step of {self.interval:g} s, at most "
                f"{MIN_SAMPLES_PER_PERIOD:g} (Nyquist): the file aliases the order, so interpolated between its "
                f"samples it is not the motion it recorded, and its errors say nothing of the model; give a reference "
                f"sampled at least every {resolving:.3g} s (a logger at {1.0 / resolving:.4g} Hz or more), or "
                "filter the order out of both before comparing")


def check_reference_sampling(scenario: Scenario, table: np.ndarray, reference: np.ndarray) -> list:
    """A ReferenceSamplingCheck per component of :func:`sampled_components` whose omega_in is in table, where
    :func:`compare` interpolates the reference (it shares too few instants with the record), its largest time step
    over the run's span, the samples bracketing it included, is larger than the record's (compared at shared
    instants, or on a grid as fine, the record's own check covers it) and a compared column varies by more than its
    band (a tachometer's flat speed is interpolated without loss)."""
    t, times = table["time"], np.asarray(reference["time"], dtype=float)
    if len(t) < 2 or len(times) < 2:
        return []
    first = max(int(np.searchsorted(times, t[0] - 1e-9, side="right")) - 1, 0)   # the sample at or before t[0]
    last = min(int(np.searchsorted(times, t[-1] + 1e-9, side="left")) + 1, len(times))   # at or after t[-1]
    times = times[first:last]
    if len(times) < 2 or shared_instants(t, reference["time"])[2]:
        return []
    interval = float(np.max(np.diff(times)))
    if interval <= float(np.max(np.diff(t))) * (1.0 + 1e-9):
        return []
    spans = {name: float(np.ptp(reference[name][first:last])) for name in scenario.tolerances
             if name in reference.dtype.names}
    if not any(spans[name] > tol.rel_range * spans[name] + tol.abs for name, tol in scenario.tolerances.items()
               if name in spans):
        return []
    return [ReferenceSamplingCheck(name, order, float(np.max(np.abs(table[f"{name}.omega_in"]))), interval)
            for name, order in sampled_components(scenario) if f"{name}.omega_in" in table.dtype.names]


@dataclass
class ModeSampling:
    """A note, not a check: a machine component's fastest natural mode (``analysis.scenario_modes``: linearised at
    rest, the top of the range it spans over the input angle) against the record's step, where the record's
    extremes of its ringing may fall short of its peaks by more than ``steady.PEAK_SHORTFALL`` of its amplitude
    (1 - cos(pi / n), n samples a period), or alias it. The mode rings only where something excites it (a load step,
    a start, a torque limit), which the record's step does not see: the order check above covers the input speed's
    orders alone. Peaks and the ranges a cycle count takes from the record fall short with it."""
    component: str
    omega: float   # the mode [rad/s]
    interval: float   # the record's step [s]
    passed: bool = True

    @property
    def samples(self) -> float:
        return 2.0 * math.pi / (self.omega * self.interval)

    def __str__(self):
        within = sampling_interval(math.pi / math.acos(1.0 - PEAK_SHORTFALL), 1, self.omega)
        what = (f"note sampling {self.component}: its fastest natural mode, {self.omega / (2.0 * math.pi):.4g} Hz "
                f"({self.omega:.4g} rad/s, linearised at rest: `ujfmu modes`), is read {self.samples:.3g} times a "
                f"period: where it rings (a load step, a start, a torque limit)")
        if self.samples <= MIN_SAMPLES_PER_PERIOD:
            return (f"{what}, the record aliases its ringing (the states at the communication points stay as "
                    f"accurate as the step allows); record at most every {within:.3g} s to read its peaks within "
                    f"{100.0 * PEAK_SHORTFALL:g}%")
        shortfall = 1.0 - math.cos(math.pi / self.samples)
        return (f"{what}, the record's extremes, and the ranges a cycle count takes from it, may fall short of its "
                f"peaks by up to {100.0 * shortfall:.3g}% of the ringing's amplitude; record at most every "
                f"{within:.3g} s to read them within {100.0 * PEAK_SHORTFALL:g}%")


def mode_sampling(scenario: Scenario, interval: float) -> list:
    """A :class:`ModeSampling` per machine component whose fastest mode the record's step of ``interval`` s reads
    too few times a period for its peaks (``steady.PEAK_SHORTFALL``); none where the modes cannot be computed. A
    lateral mode of a component that carries no order (a double Cardan with straight joints, whose shaft torque
    does not bend it) is left out: nothing excites it."""
    from .analysis import scenario_modes
    try:
        modes = scenario_modes(scenario)
    except Exception:   # a note only: a model the linearisation cannot take leaves it out
        return []
    fastest = {}
    for mode in modes:
        if mode.kind == "lateral" and not mode.orders:   # straight joints: no torque bends the shaft, it never rings
            continue
        fastest[mode.component] = max(fastest.get(mode.component, 0.0), mode.high)
    notes = [ModeSampling(name, omega, interval) for name, omega in fastest.items() if 0.0 < omega < math.inf]
    return [n for n in notes if 1.0 - math.cos(math.pi / n.samples) > PEAK_SHORTFALL or n.samples <= 2.0]


#: a held sinusoid's fundamental keeps sin(x) / x of its amplitude and lags by x, half its phase advance over a
#: step: the lag [rad] past which a periodic load torque's hold is noted (0.05 rad: 2.9 deg, 0.04% of amplitude;
#: near a resonance the lag moves the response more than the amplitude: 3.6% of Omar's twist at 0.11 rad)
HOLD_LAG = 0.05


#: steps a period of a Load's periodic torque below which a failed run names it first (the coupling's chatter or
#: growth on the load's torque then follows from the hold)
HOLD_FAILING_STEPS = 4.0


@dataclass
class LoadOrderHold:
    """A Load's torque periodic in its shaft's angle (T_h, order_h) against the communication step over which the
    co-simulation holds it: a held sinusoid of order k at speed omega drives the machine with sinc(x) of its
    amplitude, x = k omega h / 2 rad late; past ``HOLD_LAG`` a note, at 2 steps a period or fewer a failure (the
    step cannot carry it at all: it aliases)."""
    load: str
    order: float
    omega: float   # the largest speed of the shaft it acts on [rad/s]
    step: float

    @property
    def steps(self) -> float:
        """Communication steps a period of the order."""
        return 2.0 * math.pi / (self.order * self.omega * self.step)

    @property
    def lag(self) -> float:
        """x = k omega h / 2 [rad]: the held torque's lag, in the order's own phase."""
        return 0.5 * self.order * self.omega * self.step

    @property
    def kept(self) -> float:
        return math.sin(self.lag) / self.lag if self.lag else 1.0

    @property
    def passed(self) -> bool:
        return self.steps > MIN_SAMPLES_PER_PERIOD

    def __str__(self):
        return f"{'note' if self.passed else 'FAIL'} {self.text()}"

    def text(self) -> str:
        """What the hold does and the step that keeps it within ``HOLD_LAG``, without the line's note/FAIL head (a
        warning before a run, a hint after a failure)."""
        within = 2.0 * HOLD_LAG / (self.order * self.omega)
        what = (f"{self.load}'s periodic torque: its {self.order:g}x order at up to {speed_text(self.omega)} is held "
                f"over steps of {self.step:g} s, {self.steps:.3g} a period")
        if not self.passed:
            return (f"{what}: the step cannot carry it (it aliases, and the coupling may chatter on it); take a step "
                    f"of at most {within:.3g} s")
        return (f"{what}: it drives the machine with at most {100.0 * self.kept:.4g}% of its amplitude (the hold's "
                f"images take more at few steps a period), {self.lag:.3g} rad ({math.degrees(self.lag):.3g} deg) of "
                f"its phase late (half a step), which near a resonance moves the response by more; a step of at most "
                f"{within:.3g} s keeps the lag within {HOLD_LAG:g} rad (--check-step estimates the error)")


def load_order_holds(scenario: Scenario, table: np.ndarray | None = None) -> list:
    """A :class:`LoadOrderHold` per Load with a periodic torque whose hold over the scenario's step lags by more than
    ``HOLD_LAG``, at the largest speed of the shaft it acts on in table (its machine's omega_out; before a run, table
    None: the drives' set speeds)."""
    from .analysis import drive_speeds
    holds = []
    for machine, loads in load_orders(scenario).items():
        speed = f"{machine}.omega_out"
        omega = (float(np.max(np.abs(table[speed]))) if table is not None and speed in table.dtype.names
                 else max((abs(w) for w in drive_speeds(scenario).values()), default=0.0))
        for load, order in loads:
            hold = LoadOrderHold(load, order, omega, scenario.step_size)
            if omega > 0.0 and (hold.lag > HOLD_LAG or not hold.passed):
                holds.append(hold)
    return holds


def sampled_components(scenario: Scenario) -> list:
    """(component, order) of the scenario's components whose model declares an ``EXCITATION_ORDER``, at its
    parameters where the model says (``excitation_order(p)``: none for straight joints)."""
    from .build import fmu_class
    pairs = []
    for name, (fmu, _) in scenario.components.items():
        physics = fmu_class(fmu).PHYSICS
        order = getattr(physics, "EXCITATION_ORDER", None)
        if order and hasattr(physics, "excitation_order"):
            try:
                order = physics.excitation_order(scenario.model_parameters(name))
            except (ArithmeticError, ValueError):   # the FMU itself refuses such parameters
                pass
        if order:
            pairs.append((name, order))
    return pairs


def check_sampling(scenario: Scenario, table: np.ndarray) -> list:
    """A SamplingCheck per component of :func:`sampled_components` whose omega_in is in table (two rows or more)."""
    t = table["time"]
    if len(t) < 2:
        return []
    interval = float(np.max(np.diff(t)))
    return [SamplingCheck(name, order, float(np.max(np.abs(table[f"{name}.omega_in"]))), interval)
            for name, order in sampled_components(scenario) if f"{name}.omega_in" in table.dtype.names]


def ideal_speed_source(scenario: Scenario, name: str) -> bool:
    """The component is a Motor that is an ideal speed source (its speed follows its profile, whatever torque acts
    on it)."""
    return is_ideal_speed_source(scenario.components[name][0],
                                 scenario.parameters_with_defaults(name).get("ideal_speed_source"))


def annotate_bonds(scenario: Scenario, bonds: list) -> list:
    """The bonds (``ujfmu.master.BondEnergy``), each whose speed comes from an ideal speed source noted: its speed
    ignores the torque, so the held torque moves no energy in any model, and the residual sums only how much the
    torque changes within the steps (its size says nothing about the coupling's accuracy); and each whose torque
    comes from a Load that does not depend on the speed (:func:`speed_free_load`), whose held torque is exact away
    from rest."""
    for bond in bonds:
        source, sink = bond.components
        if ideal_speed_source(scenario, source):
            bond.note = (f"no coupling error: {source} is an ideal speed source, whose speed ignores the torque; the "
                         f"figure sums the torque's change within the steps")
        elif scenario.components.get(sink, ("",))[0] == "Load" and speed_free_load(scenario, sink):
            bond.note = (f"no coupling error away from rest: {sink}'s torque is constant (c1 = c2 = 0, no periodic "
                         "torque, no change of T0; T0 reverses only within omega_smooth of rest), so the torque held "
                         "over a step is the one it gives; the figure sums the speed's change within the steps")
    return bonds


def speed_free_load(scenario: Scenario, load: str) -> bool:
    """True for a Load whose torque is constant away from rest: c1 = c2 = 0, no periodic torque (T_h = 0) and no
    change of T0 (T_change = 0: a step or ramp of it is held over a step too); T0 and T_active are constant there."""
    values = scenario.parameters_with_defaults(load)
    return (values["c1"] == 0.0 and values["c2"] == 0.0 and not values.get("T_h", 0.0)
            and not values.get("T_change", 0.0))


def operating_pairs(scenario: Scenario) -> list:
    """(speed, set point) signal pairs of the scenario's drives: every Motor that is not an ideal speed source
    (omega, omega_ref) and every MotorController (its measured speed input omega, omega_ref)."""
    pairs = []
    for name, (fmu, _) in scenario.components.items():
        if fmu == "Motor" and not ideal_speed_source(scenario, name):
            pairs.append((f"{name}.omega", f"{name}.omega_ref"))
        elif fmu == "MotorController":
            pairs.append((f"{name}.omega", f"{name}.omega_ref"))
    return pairs


def drive_angle(scenario: Scenario, speed: str) -> str:
    """The angle output whose rate is a drive's speed signal of :func:`operating_pairs` (a Motor's phi, a
    MotorController's measured shaft's phi_in through the connection into its omega), "" where there is none."""
    fed = {c.target: c.source for c in scenario.connections}
    return running_angle_of(scenario, fed.get(speed, speed))


def mean_speed(table: np.ndarray, speed: str, angle: str, window: np.ndarray) -> float:
    """The mean of a speed over the window's span: its angle's advance over the span where the angle is in table
    (exact whatever the samples: a record of every n-th step that meets the joints' 2x ripple in phase had
    biased a plain mean by 1%), else the samples' mean."""
    t = table["time"][window]
    if angle in table.dtype.names and len(t) > 1 and t[-1] > t[0]:
        phi = table[angle][window]
        return float((phi[-1] - phi[0]) / (t[-1] - t[0]))
    return float(np.mean(table[speed][window]))


def window_from(t: np.ndarray, since: float) -> np.ndarray:
    """The instants of t from since on (a host's rounding of since forgiven: 1e-9 of it)."""
    return t >= since - 1e-9 * max(1.0, abs(since))


def check_operating_points(scenario: Scenario, table: np.ndarray) -> list:
    """An OperatingPointCheck per drive whose speed and set point are in table."""
    t = table["time"]
    since = scenario.steady_from if scenario.steady_from > scenario.start_time else \
        float(t[-1] - END_WINDOW * (t[-1] - t[0]))
    window = window_from(t, since)
    checks = []
    for signal, set_point in operating_pairs(scenario):
        if signal not in table.dtype.names or set_point not in table.dtype.names or not window.any():
            continue
        ref = table[set_point][window]
        moving = float(np.ptp(ref)) > 1e-9 * max(1.0, float(np.max(np.abs(ref))))
        holds_from = math.nan
        if moving:   # the time from which it holds its last value, where that is before the end
            off = np.flatnonzero(np.abs(ref - ref[-1]) > 1e-9 * max(1.0, float(np.max(np.abs(ref)))))
            if off.size and off[-1] < len(ref) - 2:
                holds_from = float(t[window][off[-1] + 1])
        name = signal.partition(".")[0]
        drive, torque = scenario.parameters_with_defaults(name), f"{name}.tau_motor"
        reaches = (math.nan, math.nan)
        if moving and math.isnan(holds_from):   # the profile's end, past the run's
            from types import SimpleNamespace

            from .models.motor.model import profile_corners
            try:
                corners = profile_corners(SimpleNamespace(**drive))
            except (AttributeError, TypeError, ZeroDivisionError):   # not a Motor's profile
                corners = ()
            if corners and max(corners) > float(t[-1]):
                reaches = (max(corners), float(drive["omega_set"]))
        limited = torque in table.dtype.names and bool(
            at_limit(table[torque][window], drive.get("tau_max", math.inf)).any())
        checks.append(OperatingPointCheck(signal, set_point, mean_speed(table, signal, drive_angle(scenario, signal),
                                                                    window),
                                          math.nan if moving else float(ref[-1]), float(t[window][0]), holds_from,
                                          float(np.max(np.abs(table[set_point]))),
                                          drive.get("Ki", 1.0) == 0.0 and not limited, reaches))
    return checks


#: fmpy.util.validate_signal's band: dx samples of its default 1000 wide (2% of the run), dy of the range high
FMPY_BAND_SAMPLES, FMPY_BAND_DX = 1000, 20


def fmpy_outlier_fraction(table: np.ndarray, reference: np.ndarray) -> float:
    """``fmpy.util.validate_result``'s figure, the largest fraction of a signal's samples outside fmpy's band (2%
    of the run wide, 10% of the reference's range high, ``validate_signal``), with the band built on the
    reference's own samples when it has more than fmpy's 1000: resampled to 1000 points, a record of more than
    a few hundred periods (a rotor at 100 rad/s for 17 s) loses its peaks between the samples and its own
    values fall outside the band."""
    from fmpy.util import validate_signal
    num = max(FMPY_BAND_SAMPLES, len(reference))
    dx = max(FMPY_BAND_DX, int(round(FMPY_BAND_DX * num / FMPY_BAND_SAMPLES)))
    worst = 0.0
    for name in table.dtype.names[1:]:
        if name in reference.dtype.names:
            outside = validate_signal(table["time"], table[name], np.array(reference["time"], dtype=float),
                                      reference[name], num=num, dx=dx)[3]
            worst = max(worst, float(np.mean(outside)))
    return worst


@dataclass
class ScenarioResult:
    """What ``run_scenario`` returns: the run's ``table`` (a structured array: time and one column per recorded
    ``component.variable``) and its checks against the reference (``checks``, per signal), the operating point,
    sampling and steady-window checks, the power bonds' energy figures, and the files written (``csv``, ``plot``).
    ``verdict`` is PASS, FAIL or NOT CHECKED; ``passed`` and ``failed`` say the same as booleans (a run that
    compared nothing is neither); ``summary()`` is the text the command line prints."""
    scenario: Scenario
    table: np.ndarray
    checks: list = field(default_factory=list)
    extrapolated_checks: list = field(default_factory=list)   # step-halving extrapolation, [reference.extrapolated]
    fmpy_outlier_fraction: float = float("nan")
    wall_time: float = 0.0   # the co-simulation's wall seconds
    total_time: float = 0.0   # the whole run's: step-halving rerun, comparison, files and plots included
    csv: Path = None
    plot: Path = None
    extra_plots: list = field(default_factory=list)   # orbits and spectra, when the scenario asks for them
    operating_checks: list = field(default_factory=list)   # OperatingPointCheck per drive
    sampling_checks: list = field(default_factory=list)   # SamplingCheck per drivetrain component, ModeSampling notes
    steady_checks: list = field(default_factory=list)   # SteadyWindowCheck of output.steady_from, if any
    order_checks: list = field(default_factory=list)   # OrderCheck of [reference.orders], if any
    bonds: list = field(default_factory=list)   # ujfmu.master.BondEnergy per power bond (co-simulation only)
    model_exchange: bool = False   # run under CVode (ujfmu.model_exchange) instead of co-simulated
    skipped_bands: str = ""   # why the [reference.extrapolated] bands were not checked, if they were not
    fmu_dir: Path = None   # where the run's FMUs came from (named in a suggested command when not the default)
    reference_method: str | None = None   # how the reference compared against was made (its provenance line)
    reference_end: float = math.nan   # the compared reference's last time [s]
    #: what the run warned of ('component: text'): the models' advice on their parameters and a load's order held
    #: too coarsely (said before it runs: ``Scenario.model_advice``, ``load_order_holds``), then the FMUs' warnings
    #: (each also warned as a ``master.FmuWarning``); a JUnit case carries them
    warnings: list = field(default_factory=list)

    def __repr__(self) -> str:   # the dataclass's would print the whole table
        rows = 0 if self.table is None else len(self.table)
        return f"<ScenarioResult {self.scenario.name}: {self.verdict}, {rows} rows, csv={self.csv}>"

    def unit(self, column: str) -> str:
        """The unit of a column of ``table`` ("s" for time): the scenario's declared one (``Scenario.unit``)."""
        return self.scenario.unit(column)

    @property
    def checked(self) -> bool:
        """True when at least one signal was compared with a reference."""
        return bool(self.checks)

    @property
    def compared(self) -> list:
        """Names of the signals compared with the reference."""
        return [c.name for c in self.checks]

    @property
    def level_only_bands(self) -> list:
        """Names of the compared signals whose band checks their level only (``SignalCheck.level_only``; step-halving
        bands marked "(extrapolated)")."""
        return ([c.name for c in self.checks if c.level_only]
                + [f"{c.name} (extrapolated)" for c in self.extrapolated_checks if c.level_only])

    @property
    def machines_unchecked(self) -> list:
        """The scenario's machines (components neither a drive nor a load: the models under test) where it compares
        signals but none of theirs: a run that compares only its drive's speed and its load's torque (an ideal
        source's own set speed, a constant load) checks no model; [] otherwise."""
        if not self.checks:
            return []
        models = machines(self.scenario)
        compared = {c.name.partition(".")[0] for c in self.checks + self.order_checks}
        return [] if compared & set(models) else models

    @property
    def identical(self) -> bool:
        """Every compared signal equals the reference to the last digit, a machine's varying output among them: a
        copy of a run under a provenance line, or signals a closed form repeats exactly (angles at a binary-exact
        step)."""
        models = machines(self.scenario)
        return (self.table is not None and len(self.table) > 2 and bool(self.checks)
                and all(c.max_error == 0.0 for c in self.checks)
                and any(c.name.partition(".")[0] in models and c.reference_range > 0.0 for c in self.checks))

    @property
    def part_compared(self) -> str:
        """'compared to t = ... of the ... s its reference was made for: ...% of it' where the run ends before its
        generated reference (a stop time cut short), else ''."""
        if not (self.checks and self.scenario.reference_generator
                and self.reference_end > self.scenario.stop_time + 0.5 * self.scenario.step_size):
            return ""
        span = self.scenario.stop_time - self.scenario.start_time
        return (f"compared to t = {self.scenario.stop_time:g} s of the {self.reference_end:g} s its reference was "
                f"made for: {100 * span / (self.reference_end - self.scenario.start_time):.3g}% of it")

    @property
    def strict_problems(self) -> list:
        """Why ``ujfmu check --strict`` fails this run though its checks pass: bands that check the level only
        (:attr:`level_only_bands`), no output of its machines compared (:attr:`machines_unchecked`), only a part of
        its reference's run compared (:attr:`part_compared`), every compared signal equal to the reference to the
        last digit (:attr:`identical`)."""
        return ([f"band(s) that check the level only: {', '.join(self.level_only_bands)}"]
                if self.level_only_bands else []) + (
            [f"no output of its machines ({', '.join(self.machines_unchecked)}) compared, only its drive's and "
             "load's"] if self.machines_unchecked else []) + (
            [f"only a part of its reference's run: {self.part_compared}"] if self.part_compared else []) + (
            ["every compared signal equals the reference to the last digit, its machines' included: a copy of a "
             "run's output (a provenance line can be copied too), or only signals a closed form repeats exactly "
             "(an angle at a binary-exact step); compare one the reference computes on its own (a torque, a "
             "twist)"] if self.identical else [])

    @property
    def uncompared(self) -> list:
        """Recorded signals that were not compared (no tolerance given for them)."""
        done = set(self.compared)
        return [name for name in self.scenario.record if name not in done]

    @property
    def passed(self) -> bool:
        """Checked, and every compared signal within its tolerance."""
        return self.checked and all(c.passed for c in self.checks + self.extrapolated_checks + self.order_checks)

    @property
    def failed(self) -> bool:
        return any(not c.passed for c in self.checks + self.extrapolated_checks + self.operating_checks
                   + self.sampling_checks + self.steady_checks + self.order_checks)

    @property
    def verdict(self) -> str:
        return "FAIL" if self.failed else "PASS" if self.passed else "NOT CHECKED"

    def _fmu_dir_option(self) -> str:
        """The options that run the same FMUs again: " --fmi 3" for FMI 3.0 FMUs (results in results/fmi3/) and
        " --fmu-dir DIR" for FMUs from another folder than their version's default; "" for the default FMI 2.0."""
        if self.fmu_dir is None:
            return ""
        here = Path(self.fmu_dir).resolve()
        first = next(iter(self.scenario.components.values()))[0]
        fmi3 = (here == Path(DEFAULT_FMU3_DIR).resolve()
                or description_attribute(here / f"{first}.fmu", "fmiVersion") == "3.0")
        elsewhere = here != Path(DEFAULT_FMU3_DIR if fmi3 else DEFAULT_FMU_DIR).resolve()
        return (" --fmi 3" if fmi3 else "") + (f" --fmu-dir {self.fmu_dir}" if elsewhere else "")

    def _record_sampling(self) -> list:
        """The sampling checks of the run's own record (not of a reference file's: ReferenceSamplingCheck), which
        its steady window's figures depend on."""
        return [c for c in self.sampling_checks if not isinstance(c, ReferenceSamplingCheck)]

    def steady_orders(self) -> dict:
        """{signal: SteadyOrders} of the recorded signals (but those that grow: angles, energies) over the steady
        window, the figures the summary prints. ValueError naming the cause and the remedy where there are none to
        trust: no steady window (set the scenario's ``steady_from`` and ``running_speed``), or a window that the
        steady-window or sampling check failed (a transient's, or an aliased record's, figures)."""
        if self.table is None:
            raise ValueError(f"{self.scenario.name}: no results (the run did not complete)")
        failed = [str(c) for c in self.steady_checks + self._record_sampling() if not c.passed]
        if failed:
            raise ValueError(f"{self.scenario.name}: no orders over the steady window, as its check failed: "
                             + "; ".join(failed))
        figures = steady_orders(self.scenario, self.table)
        if not figures:
            raise ValueError(f"{self.scenario.name}: no steady window to fit orders over: set the scenario's "
                             "steady_from (s, the window's start, at least two revolutions before stop_time) and "
                             "running_speed (a recorded 'component.omega...' signal) before running it")
        return {name: SteadyOrders(name, self.scenario.unit(name), float(mean),
                                   {k: float(a) for k, a in zip(CHECKED_ORDERS, amplitudes)})
                for name, (mean, amplitudes) in figures.items()}

    def _steady_order_lines(self) -> list:
        """The recorded signals' mean and 1x, 2x, 4x amplitudes over the steady window (:func:`steady_orders`)."""
        if self.table is None:
            return []
        figures = steady_orders(self.scenario, self.table)
        if not figures:
            return []
        if not all(c.passed for c in self.steady_checks + self._record_sampling()):
            return [f"  orders over the steady window from t = {self.scenario.steady_from:g} s: not given, as the "
                    "steady-window or sampling check above failed (a transient's, or an aliased record's, figures)"]
        width = max(len(name) for name in figures)
        lines = [f"  orders over the steady window from t = {self.scenario.steady_from:g} s, against the angle of "
                 f"{self.scenario.running_speed} (mean, zero-to-peak orders; '-': not resolved by the record):"]
        for name, (mean, amplitudes) in figures.items():
            unit = self.scenario.unit(name)
            orders = ", ".join(f"{k}x " + ("-" if math.isnan(a) else f"{a:.4g}") for k, a in zip((1, 2, 4), amplitudes))
            lines.append(f"    {name:{width}s}  mean {mean:.4g}, {orders}{' ' + unit if unit and unit != '1' else ''}")
        return lines

    def _start_failures(self) -> tuple:
        """(names, text): the failing compared signals of a speed-driven run whose largest error falls in its first
        START_STEPS steps and which pass after them, by a margin (their error there at least ``START_DOMINANCE``
        times the largest after), and their figures after them ([] and '' otherwise)."""
        from .stepsize import START_STEPS, speed_driven
        h, t0 = self.scenario.step_size, self.scenario.start_time
        early = [c for c in self.checks if not c.passed and c.at <= t0 + (START_STEPS - 0.5) * h]
        if not early or self.table is None or not speed_driven(self.scenario):
            return [], ""
        rows = self.table[self.table["time"] > t0 + (START_STEPS - 0.5) * h]
        if len(rows) < 2:   # a run of a few steps: nothing after its start to compare
            return [], ""
        later = {c.name: c for c in compare(rows, self.scenario.read_reference(),
                                            {c.name: self.scenario.tolerances[c.name] for c in early})}
        passing = [c for c in early if later[c.name].passed
                   and c.max_error >= START_DOMINANCE * later[c.name].max_error]
        return ([c.name for c in passing],
                ", ".join(f"{c.name} {later[c.name].fraction_of_allowed:.3g} of allowed" for c in passing))

    def not_checked_reason(self, step_check_follows: bool = False) -> str:
        """Why nothing was compared ("" where something was); step_check_follows: the step-halving estimate is
        printed after the summary (``ujfmu run --check-step``), so it is named instead of suggested."""
        if self.checked:
            return ""
        if self.scenario.reference_file is None:
            estimate = ("a Model Exchange run has no communication step, so no coupling error to estimate; a "
                        "reference (`ujfmu references` for a scenario of a bundled wiring) checks the solver's "
                        "tolerance and the model" if self.model_exchange else
                        "the step-halving estimate of the coupling error at this step follows" if step_check_follows
                        else "--check-step on the same command line (`ujfmu run ... --set ...`), or "
                        "ujfmu.stepsize.estimate(scenario, fmu_dir=...).lines(), estimates the coupling error "
                        "at this step" if self.scenario.name != self.scenario.path.stem
                        else f"ujfmu run {self.scenario.path} --check-step{self._fmu_dir_option()} estimates the "
                        "coupling error at this step")
            what = ("the run is not compared with the scenario file's [reference], made for the file's setup (a "
                    "changed copy runs without it)" if self.scenario.file_reference is not None
                    else "the scenario has no [reference]")
            return f"{what}: nothing was compared, and the result's accuracy is unknown ({estimate})"
        return "the scenario's [reference.tolerance] names no signal: nothing was compared"

    def _signal_figures(self) -> list:
        """Lines of each recorded signal's min, max (at the recorded instants), mean and RMS (time averages,
        trapezoidal: whole periods give a periodic signal's own, so over the steady window's whole revolutions of the
        running speed where it has one) in SI units over the steady window (from steady_from) or the whole run, the
        figures a run without a reference answers with; a signal that grows in any steady state (an angle, an
        energy integral) by its last value."""
        from .steady import grows, running_angle
        t = self.table["time"]
        steady = self.scenario.steady_from > self.scenario.start_time
        window = window_from(t, self.scenario.steady_from) if steady else np.ones(len(t), dtype=bool)
        times = np.asarray(t[window], dtype=float)
        span = float(times[-1] - times[0]) if len(times) > 1 else 0.0
        end, turns = span, 0   # the averages' end: the window's, or its last whole revolution's
        speed = self.scenario.running_speed
        if steady and speed in self.table.dtype.names and len(times) > 2:
            angle = np.abs(running_angle(times, np.asarray(self.table[speed][window], dtype=float)))
            turns = int(angle[-1] / (2.0 * math.pi))
            if turns >= 1 and np.all(np.diff(angle) > 0.0):   # a speed of one sign: the revolutions are its angle's
                end = float(np.interp(turns * 2.0 * math.pi, angle, times)) - float(times[0])
            else:
                turns = 0
        over = (f"over its first {turns} whole revolution{'s' if turns > 1 else ''} of {speed}, " if turns else
                "over time, ")
        lines = [f"  recorded signals {f'from t = {self.scenario.steady_from:g} s' if steady else 'over the run'} "
                 f"(min, max at the recorded instants; mean, RMS {over}trapezoidal):"]

        def average(values):
            """The time average of values over [times[0], times[0] + end] (trapezoidal, the value at its end
            interpolated; the one value of a single instant): over whole revolutions, a periodic signal's orders
            cancel (over 15.9 revolutions a twin rotor's 25 N.m 2x moves tau_in's time average by 6%)."""
            if not end > 0.0:
                return float(np.mean(values))
            inside = times - times[0] < end
            tail = np.append(times[inside], times[0] + end)
            samples = np.append(values[inside], np.interp(times[0] + end, times, values))
            return float(np.sum(0.5 * (samples[1:] + samples[:-1]) * np.diff(tail)) / end)
        width = max(len(name) for name in self.table.dtype.names[1:])
        for name in self.table.dtype.names[1:]:
            values = np.asarray(self.table[name][window], dtype=float)
            unit = self.scenario.unit(name)
            unit = f" {unit}" if unit and unit != "1" else ""
            if grows(name):
                lines.append(f"    {name:{width}s}  last {float(self.table[name][-1]):.6g}{unit}")
                continue
            lines.append(f"    {name:{width}s}  {np.min(values):.6g} .. {np.max(values):.6g}, mean "
                         f"{average(values):.6g}, RMS {math.sqrt(average(values * values)):.6g}{unit}")
        return lines

    def summary(self, step_check_follows: bool = False) -> str:
        """The verdict and every check, one per line; step_check_follows as in :meth:`not_checked_reason`."""
        span = self.scenario.stop_time - self.scenario.start_time
        head = (f"{self.verdict} {self.scenario.name}: {self.scenario.title} ({self.wall_time:.1f} s wall time for "
                f"{span:g} s simulated)")
        if self.passed and self.strict_problems:   # the verdict line is what a log is scanned for
            head += f" (check --strict fails it: {'; '.join(self.strict_problems)})"
        if self.part_compared and not self.passed:   # a passing run says it among --strict's reasons above
            # a part of the run the reference was made for (a stop_time cut short, a smoke test): said, not hidden
            head += f" ({self.part_compared})"
        lines = [head]
        if self.checks:
            lines.append(f"  against {shown_path(self.scenario.reference_file)}"
                         + (f": {self.reference_method}" if self.reference_method else ""))
        lines += [f"  {c}" for c in self.checks]
        if self.extrapolated_checks:
            lines.append("  Model Exchange run (no communication step) against the [reference.extrapolated] bands:"
                         if self.model_exchange else
                         f"  step-halving extrapolation 2 y(h/2) - y(h), h = {self.scenario.step_size:g} s:")
            lines += [f"  {c}" for c in self.extrapolated_checks]
        if self.skipped_bands:
            lines.append(f"  {self.skipped_bands}")
        if self.order_checks:
            lines.append(f"  running-speed orders of {self.scenario.running_speed} from t = "
                         f"{self.scenario.steady_from:g} s ([reference.orders]):")
            lines += [f"  {c}" for c in self.order_checks]
        lines += [f"  not compared: {name}: {why}" for name, why in self.scenario.not_compared.items()]
        lines += [f"  {c}" for c in self.operating_checks]
        lines += [f"  {c}" for c in self.sampling_checks]
        lines += [f"  {c}" for c in self.steady_checks]
        lines += self._steady_order_lines()
        lines += [f"  {b}" for b in self.bonds]
        figures = ("[reference.tolerance] holds figures chosen for the scenario's own parameters (a few times the "
                   "error its run reaches there): a copy with other parameters needs figures of its own, the accuracy "
                   "its study needs")
        own_step, own_coupling = self.scenario.file_step_size, self.scenario.file_coupling
        if (self.scenario.step_size, self.scenario.coupling) != (own_step, own_coupling):
            figures += (f"; and for its own step and coupling ({own_step:g} s, {own_coupling}): at "
                        f"{self.scenario.step_size:g} s, {self.scenario.coupling}, a FAIL holds this run to the file's "
                        "accuracy, so judge the error figures (% of the range) against what your study needs")
        if any(not c.passed and not c.refused for c in self.order_checks) and not self.model_exchange:
            lines.append("  an order amplitude outside its tolerance: a vibration the coupling or the step distorts "
                         "shows here first (the bands above scale with each signal's whole range); the implicit "
                         "scheme or a smaller step (--step) resolves it if the error shrinks with the step")
        if any(not c.passed for c in self.checks + self.extrapolated_checks) and self.model_exchange:
            lines.append("  a signal outside its tolerance: a Model Exchange run has no communication step and no "
                         "coupling error (the host's solver integrates the equations to its own tolerance), so the "
                         "model or its parameters differ from what the reference solves, or the solver's tolerance "
                         f"is too loose for the band. {figures}")
        elif any(not c.passed for c in self.checks + self.extrapolated_checks):
            estimate = ("the step-halving estimate below gives it per signal" if step_check_follows else
                        f"ujfmu run {self.scenario.path} --check-step{self._fmu_dir_option()} estimates it per "
                        "signal")
            if not self.scenario.reference_generator:
                lines.append("  a signal outside its tolerance against a reference the scenario names no generator "
                             "for (a measured or hand-made file): the model or its parameters likely differ from what "
                             "the file holds, or the file's noise exceeds the band (the RMS error beside the max shows "
                             "the fit under noise); a coupling error is the other cause, if the error shrinks with the "
                             f"step ({estimate})")
            else:
                from .stepsize import START_STEPS
                at_start, later = self._start_failures()
                if at_start:
                    lines.append(f"  {', '.join(at_start)}: the largest error is in the first {START_STEPS} steps, "
                                 f"and after them {later}: a speed-driven FMU starts without a speed history, so "
                                 "the inertia torques in its outputs miss its input's acceleration at the start (a "
                                 "drive whose speed changes from the first step: e.g. a PI motor starting at speed "
                                 "with no torque against a load), which no step removes (--check-step leaves these "
                                 "steps out). Start where the input does not accelerate (a ramp from rest, or a PI "
                                 "drive in equilibrium: its tau_initial the load's torque at the drive) or wire the "
                                 "model torque-driven (README, \"Choose the wiring for "
                                 "the host\")")
                if len(at_start) < sum(not c.passed for c in self.checks + self.extrapolated_checks):
                    lines.append(f"  a signal outside its tolerance: if the error shrinks with the step it is the "
                                 f"coupling's ({estimate}, --step auto picks a step); if it does not, it is the "
                                 "FMUs' own integration, or the model or its parameters differ from what the "
                                 f"reference solves. {figures}")
        if not self.checks and self.table is not None and len(self.table) > 1:
            lines += self._signal_figures()
        if not self.checked:
            lines.append(f"  {self.not_checked_reason(step_check_follows)}")
        elif math.isnan(self.fmpy_outlier_fraction):
            pass   # fmpy's band needs scipy; the command line says so once per run (SCIPY_NOTE)
        else:
            lines.append(f"  fmpy.util.validate_result: fraction of samples outside fmpy's band = "
                         f"{self.fmpy_outlier_fraction:.4f} (fmpy's own band about the reference, a share of each "
                         "signal's range, widened where it moves fast: a second opinion; the verdict is the "
                         "tolerances')")
        return "\n".join(lines)


#: said once per command when fmpy's validate_result band could not be computed
SCIPY_NOTE = "fmpy.util.validate_result: not computed (it needs scipy: pip install 'ujfmu[references]')"


#: fewest instants the result and the reference must share to be compared there rather than by interpolation
MIN_COMMON_INSTANTS = 20


def common_instants(t: np.ndarray, t_ref: np.ndarray, slack: float) -> tuple:
    """(indices into t, indices into t_ref) of the instants both grids hold (to slack)."""
    k = np.clip(np.searchsorted(t_ref, t), 1, len(t_ref) - 1)
    nearest = np.where(np.abs(t_ref[k - 1] - t) <= np.abs(t_ref[k] - t), k - 1, k)
    hit = np.abs(t_ref[nearest] - t) <= slack
    return np.nonzero(hit)[0], nearest[hit]


def shared_instants(t: np.ndarray, t_ref: np.ndarray) -> tuple:
    """(indices into t, into t_ref, whether compared there) of :func:`common_instants` at the rounding of t's
    times: :func:`compare` compares at them where they are at least MIN_COMMON_INSTANTS (or all of t), else it
    interpolates the reference."""
    mine, theirs = common_instants(t, t_ref, 1e-9 * max(1.0, abs(float(t[-1]))))
    return mine, theirs, len(mine) >= min(MIN_COMMON_INSTANTS, len(t))


#: (factor, what it suggests, the signal units it can apply to; None: any) for a measured reference column that is
#: the run's signal times the factor (:func:`unit_slip`)
UNIT_SLIPS = ((30.0 / math.pi, "rpm where rad/s is meant", ("rad/s",)),
              (180.0 / math.pi, "degrees where rad is meant", ("rad", "rad/s", "rad/s2")),
              (1.0 / (2.0 * math.pi), "revolutions (rev, rev/s) where rad is meant", ("rad", "rad/s", "rad/s2")),
              (1000.0, "thousandths (mm, N.mm) where the SI unit is meant", None),
              (1e-3, "thousands (kN.m, km) where the SI unit is meant", None),
              (-1.0, "the opposite sign convention (README, \"Port and sign conventions\")", None))
#: the share by which the fitted factor and the fit's RMS residual (of the reference's RMS) may miss for a slip
SLIP_FIT = 0.03


def unit_slip(values: np.ndarray, reference: np.ndarray, unit: str = "") -> str:
    """A note where a measured reference varies and is the run's values times one of the ``UNIT_SLIPS`` that can
    apply to the signal's unit (least-squares factor within SLIP_FIT of it, the fit's residual within SLIP_FIT of
    the reference's RMS; for the opposite sign, a mean of at least half the RMS: a zero-mean wave half a period
    late is no sign slip), else ""."""
    values, reference = np.asarray(values, dtype=float), np.asarray(reference, dtype=float)
    power = float(np.dot(values, values))
    rms = float(np.sqrt(np.mean(np.square(reference)))) if len(reference) else 0.0
    if not power > 0.0 or not np.all(np.isfinite(reference)) or not np.ptp(reference) > 1e-6 * rms:
        return ""
    factor = float(np.dot(reference, values)) / power
    for slip, what, units in UNIT_SLIPS:
        if units is not None and unit not in units:
            continue
        if slip < 0.0 and not abs(float(np.mean(reference))) >= 0.5 * rms:
            continue
        if (abs(factor / slip - 1.0) <= SLIP_FIT
                and float(np.sqrt(np.mean(np.square(reference - factor * values)))) <= SLIP_FIT * rms):
            return (f"the reference is {factor:.4g} times the run here, as if the file held {what} (the file's "
                    "columns are in the run's SI units and sign conventions), or the scenario's parameters differ "
                    "from the measured setup's by that factor")
    return ""


def compare(table, reference, tolerances, units: dict | None = None, measured: bool = False) -> list:
    """Check each toleranced signal: max |result - reference| <= rel_range*(range of reference) + abs; the range
    is the reference's over the result's time span (a reference longer than the run does not widen the band).
    units: {signal: unit} printed beside its errors. measured: the reference is a file of measurements (it names
    no generator): a failing signal that is the file's times a unit's factor says so (:func:`unit_slip`).

    The two are compared at the instants both grids hold (any step that divides the reference's, or a multiple of
    it): interpolating a sampled reference between its points would add its own error (a 2x-per-revolution ripple
    sampled at 1 ms is 0.3 rad/s off at the half steps in cardan_startup, several times the tolerance). Only when
    they share fewer than MIN_COMMON_INSTANTS is the reference interpolated linearly to the result's times."""
    checks = []
    t = table["time"]
    slack = 1e-9 * max(1.0, abs(float(t[-1])))
    window = (reference["time"] >= t[0] - slack) & (reference["time"] <= t[-1] + slack)
    mine, theirs, shared = shared_instants(t, reference["time"])
    for name, tol in tolerances.items():
        if name not in reference.dtype.names:
            raise KeyError(f"signal '{name}' has a tolerance but is not in the reference")
        values = table[name][mine] if shared else table[name]
        if shared:
            error, times = values - reference[name][theirs], t[mine]
        else:
            error, times = values - np.interp(t, reference["time"], reference[name]), t
        err = float(np.max(np.abs(error)))
        span = float(np.ptp(reference[name][window])) if window.any() else 0.0
        check = SignalCheck(name, err, tol.rel_range * span + tol.abs, span, unit=(units or {}).get(name, ""),
                            rms_error=float(np.sqrt(np.mean(np.square(error)))),
                            at=float(times[np.argmax(np.abs(error))]))
        magnitude = float(np.max(np.abs(reference[name][window]))) if window.any() else 0.0
        if tol.abs == 0.0 and 0.0 < magnitude and span <= CONSTANT_REFERENCE * magnitude:
            check.note = (f"the reference is constant ({magnitude:.6g}, range {span:.3g}), so rel_range allows next to "
                          f"nothing; give this signal an abs tolerance")
        elif check.allowed >= 0.5 * span > CONSTANT_REFERENCE * magnitude:
            check.level_only = True
            check.note = (f"{LEVEL_ONLY}: the band, {check.allowed:.3g}{' ' + check.unit if check.unit else ''}, is "
                          f"at least half the reference's range ({span:.3g}), so a flat line through its middle would "
                          "pass; tighten it where the course matters (`ujfmu run --check-step` estimates this step's "
                          "error)")
        if measured and not check.passed and not check.note:
            check.note = unit_slip(values, values - error, check.unit)
        checks.append(check)
    return checks


#: without a steady window, :func:`mark_vibration_blind` looks at this share of the run at its end, where the
#: drive's speed's peak-to-peak there is at most TAIL_STEADY of its mean |value|: a drive held at its set speed (at
#: 5%, ten of the coupling battery's set-ups, still settling from their run-ups there, had their 2% bands marked)
TAIL_SHARE, TAIL_STEADY = 0.25, 0.01


def _swing(t: np.ndarray, x: np.ndarray) -> float:
    """Half the peak-to-peak of x about its least-squares quadratic in t: a vibration's, without the trend of a
    signal still settling (which is no vibration a band could miss)."""
    if len(x) < 4:
        return 0.5 * float(np.ptp(x))
    span = float(t[-1] - t[0]) or 1.0
    s = (np.asarray(t, dtype=float) - float(t[0])) / span
    return 0.5 * float(np.ptp(x - np.polyval(np.polyfit(s, x, 2), s)))


def mark_vibration_blind(scenario: Scenario, table: np.ndarray, reference: np.ndarray, checks: list) -> None:
    """Mark as checking the level only (``SignalCheck.level_only``, its note saying why) each check whose band is at
    least half the signal's peak-to-peak (about its trend, :func:`_swing`) over the steady window
    (``output.steady_from`` on), in the run or in the reference, where that vibration is at least ``VISIBLE_VIBRATION``
    of the reference's range and its orders are not compared ([reference.orders]): a flat line through the window's
    middle, a signal or a reference without the vibration, passes such a band. Signals that grow (running angles, energy
    integrals: ``steady.grows``) have no steady vibration and are left out, as the steady window's figures leave them
    out. A scenario without a steady window is looked at over the last ``TAIL_SHARE`` of its run instead where its
    running speed (else its Motor's or a driven input shaft's) holds within ``TAIL_STEADY`` of itself there (a copy of a
    scenario without steady_from, at a constant speed, had passed with bands wider than its torque's whole 2x ripple); a
    run still ramping or settling there is not looked at (its trend is no vibration)."""
    from .steady import grows
    steady = _steady_window(scenario, table)
    if steady is not None:
        window, steady_signals = steady[0], set(steady[1])   # running angles and energy integrals grow: left out
        over = "the steady window"
    else:
        window = table[table["time"] >= scenario.stop_time - TAIL_SHARE * (scenario.stop_time - scenario.start_time)]
        steady_signals = {n for n in scenario.record if not grows(n) and n in table.dtype.names}
        over = f"the run's last {100 * TAIL_SHARE:g}%"
        # the running speed, else a Motor's speed or a driven input shaft's, as recorded
        drives = ([scenario.running_speed] + [f"{name}.omega" for name, (fmu, _) in scenario.components.items()
                                              if fmu == "Motor"]
                  + [n for n in scenario.record if n.endswith(".omega_in")])
        speed = next((window[n] for n in drives if n and n in table.dtype.names), None)
        if (len(window) < 16 or speed is None
                or not float(np.ptp(speed)) <= TAIL_STEADY * float(np.mean(np.abs(speed)))):
            return
    since = float(window["time"][0])
    end = float(window["time"][-1]) + 1e-9 * max(1.0, abs(float(window["time"][-1])))
    theirs = reference[(reference["time"] >= since - 1e-9 * max(1.0, abs(since))) & (reference["time"] <= end)]
    orders = steady_orders(scenario, table)
    for check in checks:
        if check.level_only or check.name in scenario.order_tolerances or check.name not in steady_signals:
            continue
        swings = [(_swing(t, x), what) for t, x, what in ((window["time"], window[check.name], "the run"),
                                                           (theirs["time"], theirs[check.name], "the reference"))
                  if len(x)]
        swing, where = max(swings)
        size = max((float(np.max(np.abs(x))) for x in (window[check.name], theirs[check.name]) if len(x)), default=0.0)
        if not (swing >= VISIBLE_VIBRATION * check.reference_range and check.allowed >= swing > 0.0
                and swing > CONSTANT_REFERENCE * size):   # a constant's round-off is no vibration
            continue
        unit = f" {check.unit}" if check.unit and check.unit != "1" else ""
        amplitudes = orders.get(check.name, (None, ()))[1]
        largest = max(((a, k) for k, a in zip(CHECKED_ORDERS, amplitudes) if not math.isnan(a)), default=None)
        order = f"; the run's largest order there {largest[1]}x, {largest[0]:.3g}{unit}" if largest else ""
        check.level_only = True
        blind = (f"{LEVEL_ONLY} over {over} from t = {since:g} s: the band, {check.allowed:.3g}"
                 f"{unit}, is at least half the signal's peak-to-peak about its trend there ({swing:.3g}{unit} in "
                 f"{where}{order}), so "
                 "a flat line through its middle, a signal without that vibration, would pass; compare its orders "
                 f"([reference.orders] \"{check.name}\" = {{ rel = 0.05 }}) or tighten the band below it")
        check.note = f"{check.note}; {blind}" if check.note else blind   # a failure's likely cause stays first


def milliseconds_hint(scenario: Scenario, reference: np.ndarray) -> str:
    """'; its times look like milliseconds ...' for a reference that names no generator whose times, read as
    milliseconds, span the experiment (to 5% of it) and run past 100 times its end, sampled at least 100 times
    more coarsely than the run's step (a logger's millisecond clock read as seconds); "" otherwise (a long log in
    seconds samples finely)."""
    t0, t1 = float(reference["time"][0]), float(reference["time"][-1])
    span = scenario.stop_time - scenario.start_time
    steps = np.diff(np.asarray(reference["time"], dtype=float))
    if (scenario.reference_generator or not len(steps) or not float(np.median(steps)) >= 100.0 * scenario.step_size
            or not t1 > 100.0 * max(abs(scenario.stop_time), span)
            or not 1e-3 * t0 <= scenario.start_time + 0.05 * span
            or not scenario.stop_time - 0.05 * span <= 1e-3 * t1 <= scenario.stop_time + span):
        return ""
    return (f"; its times look like milliseconds (in seconds they would run from {1e-3 * t0:g} to {1e-3 * t1:g} s): "
            "the time column is in seconds, as every column is in SI units")


def check_reference_span(scenario: Scenario, reference: np.ndarray) -> None:
    """The reference must cover the experiment's [start_time, stop_time] (to half a step): beyond its ends it
    would be held at its end values and the comparison would be meaningless. (A run shorter than a generated
    reference is compared over its own span, which its verdict line says: :meth:`ScenarioResult.summary`.)"""
    t0, t1 = float(reference["time"][0]), float(reference["time"][-1])
    slack = 0.5 * scenario.step_size
    if t0 > scenario.start_time + slack or t1 < scenario.stop_time - slack:
        remedy = (f"regenerate the reference (`ujfmu references {scenario.path}`)" if scenario.reference_generator
                  else "extend the file (it names no generator: a measured or hand-made reference)")
        remedy += milliseconds_hint(scenario, reference)
        raise ScenarioError(f"{scenario.path}: the reference {scenario.reference_file_text} covers t = {t0:g} to "
                            f"{t1:g} s, the experiment runs from {scenario.start_time:g} to "
                            f"{scenario.stop_time:g} s: set the scenario's [experiment] start_time and stop_time "
                            f"within the reference's span (a run with --stop-time is a changed copy, not compared), "
                            f"or {remedy}")


def extrapolate_step(scenario: Scenario, fmu_dir=DEFAULT_FMU_DIR, coarse: np.ndarray | None = None,
                     progress: Callable[[int, int], bool | None] | None = None,
                     diagnostics: dict | None = None) -> np.ndarray:
    """Richardson extrapolation 2 y(h/2) - y(h) of the recorded signals on the scenario's grid (step h).

    It cancels a coupling error c*h + O(h^2) (inputs held over each step), leaving O(h^2). coarse: the run at h
    when it is already at hand. progress, diagnostics: as ``cosimulate``'s, for the run at h/2 (its own steps).
    """
    h, every = scenario.step_size, scenario.output_interval
    if coarse is None:
        coarse = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time, h,
                            scenario.record, scenario.start_time, coupling=scenario.coupling, output_interval=every)
    fine = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time, h / 2,
                      scenario.record, scenario.start_time, coupling=scenario.coupling, output_interval=2 * every,
                      progress=progress, diagnostics=diagnostics)
    out = coarse.copy()
    for name in scenario.record:
        out[name] = 2.0 * fine[name] - coarse[name]
    return out


def run_scenario(path: str | os.PathLike | Scenario, fmu_dir: str | os.PathLike = DEFAULT_FMU_DIR,
                 out_dir: str | os.PathLike | None = DEFAULT_OUT_DIR, plot: bool = True,
                 progress: Callable[[int, int], bool | None] | None = None,
                 model_exchange: bool = False) -> ScenarioResult:
    """Co-simulate a scenario, compare with its reference; write CSV (and PNG) into out_dir (None: write nothing).

    fmu_dir and out_dir default to fmus/ and results/ of the current directory. progress: optional
    callable(steps_done, steps_total), called now and then (the command line draws a progress bar with it); where
    the scenario's [reference.extrapolated] bands rerun it at half the step, the total counts the rerun's steps too
    and the rerun continues the count; returning False stops the run (``master.RunStopped``).
    Returns a ScenarioResult whose .table is the result (structured array, 'time' + 'comp.var' columns).
    model_exchange=True runs the FMI 3.0 Model Exchange FMUs of fmu_dir together under CVode
    (``ujfmu.model_exchange``) instead of co-simulating, output at the scenario's step; with no step error to
    remove, the [reference.extrapolated] bands then apply to that run itself; the FMUs then come from fmus/fmi3/
    where fmu_dir is left at fmus/ (as ``--model-exchange``).
    """
    begun = time.perf_counter()
    if model_exchange and Path(fmu_dir) == Path(DEFAULT_FMU_DIR):
        fmu_dir = Path(DEFAULT_FMU_DIR) / "fmi3"
    scenario = path if isinstance(path, Scenario) else Scenario(path)
    scenario.check_experiment()
    scenario.check_setup()   # what a caller changed after reading: refused before anything runs, as a file's
    scenario.check_fmus(fmu_dir)
    if out_dir is not None:   # the folder, or the nearest of its parents that exists, must be a folder
        existing = next(p for p in (Path(out_dir).absolute(), *Path(out_dir).absolute().parents) if p.exists())
        if not existing.is_dir():
            raise ScenarioError(f"out_dir {Path(out_dir).absolute()}: {existing} is a file: give a folder for the "
                                "results (the command line's --out)")
    reference, provenance = None, ""
    if scenario.reference_file is not None:   # a missing reference file is an error before anything runs
        reference, provenance = scenario.reference()
        check_reference_span(scenario, reference)
    start = time.perf_counter()
    said = scenario.model_advice() + ([] if model_exchange else [h.text() for h in load_order_holds(scenario)])
    warned = []   # the FMUs' warnings as logged (Model Exchange); a co-simulation's come in its diagnostics
    diagnostics = {"fmu_warnings": warned}
    # a step-halving rerun follows ([reference.extrapolated]): its 2n steps count in the progress's total
    steps = int(round((scenario.stop_time - scenario.start_time) / scenario.step_size))
    rerun_steps = 2 * steps if (not model_exchange and scenario.compares and scenario.extrapolated_tolerances
                                and scenario.bands_hold_at(scenario.step_size)) else 0
    counted = (lambda done, total: progress(done, total + rerun_steps)) if progress and rerun_steps else progress
    # the drives' speeds and set points ride along for the operating-point check, the drivetrain components' input
    # speeds for the sampling check, then leave the table
    extra = [x for pair in operating_pairs(scenario) for x in pair if x not in scenario.record]
    extra += [f"{s.partition('.')[0]}.tau_motor" for s, _ in operating_pairs(scenario)
              if f"{s.partition('.')[0]}.tau_motor" not in scenario.record + extra]
    extra += [a for a in (drive_angle(scenario, s) for s, _ in operating_pairs(scenario))
              if a and a not in scenario.record + extra]
    extra += [f"{name}.omega_in" for name, _ in sampled_components(scenario)
              if f"{name}.omega_in" not in scenario.record + extra]
    # and the speeds a Load that may chatter near rest acts on, to tell whether a failure came near rest
    chatter = [c for c in scenario.load_chatter() if c.ratio > 1.0]
    extra += [f"{c.driven}.omega_out" for c in chatter if f"{c.driven}.omega_out" not in scenario.record + extra]
    # and the speeds a Load's periodic torque turns with
    extra += [f"{m}.omega_out" for m in load_orders(scenario) if f"{m}.omega_out" not in scenario.record + extra]
    try:
        if model_exchange:
            from .model_exchange import simulate_scenario_me
            table = simulate_scenario_me(scenario, fmu_dir, extra=extra, warned=warned)
        else:
            table = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time,
                               scenario.step_size, scenario.record + extra, scenario.start_time,
                               progress=counted or None, coupling=scenario.coupling,
                               output_interval=scenario.output_interval, diagnostics=diagnostics)
    except CosimulationError as exc:
        # a Load that chatters near rest is the likelier cause, where it came near rest (a run that never stepped,
        # failing at its setup, has nothing to do with it)
        chatter = [c for c in chatter if exc.partial is not None
                   and came_near_rest(c, exc.partial, scenario.output_interval or 1)]
        hint = "" if isinstance(exc, RunStopped) else "\n".join(f"hint: {c.text()}" for c in chatter) or (
            torque_driven_hint(scenario, str(exc.args[0]) if exc.args else ""))
        if exc.partial is not None and not isinstance(exc, RunStopped):
            oscillating = "" if isinstance(exc, CouplingInstabilityError) else oscillation_hint(scenario, exc.partial)
            if oscillating and not model_exchange:   # the coupling's, or the model's own: the step tells them apart
                oscillating = step_dependence_hint(scenario, fmu_dir, float(exc.partial["time"][-1]), oscillating,
                                                   str(exc))
            stalled = "" if oscillating else stalled_drive_hint(scenario, exc.partial)
            coarse = [] if model_exchange else [h for h in load_order_holds(scenario, exc.partial)
                                                if h.steps < HOLD_FAILING_STEPS]   # Model Exchange holds nothing
            held = "\n".join(f"hint: {h.text()}: a periodic torque the step can hardly carry makes the coupling "
                             "chatter or grow on its own; take the smaller step first" for h in coarse)
            hint = "\n".join(h for h in (driving_load_hint(scenario), held, oscillating, stalled, hint) if h)
        took = "\n".join(f"note: {line}" for line in stalled_lines(diagnostics.get("stalled")))
        hint = "\n".join(h for h in (took, hint) if h)   # steps taken outside the tolerance before it failed
        if hint:
            exc.args = (f"{exc.args[0]}\n{hint}",) + exc.args[1:]
        _keep_partial(scenario, exc, extra, out_dir, plot, model_exchange)
        raise
    except Interrupted as exc:   # a Ctrl-C or SIGTERM: the results up to there, as a failed run's
        _keep_partial(scenario, exc, extra, out_dir, plot, model_exchange)
        raise
    operating, sampling = check_operating_points(scenario, table), check_sampling(scenario, table)
    operating += torque_limit_notes(scenario, table)
    if len(table) > 1:
        sampling += mode_sampling(scenario, float(np.max(np.diff(table["time"]))))
        if not model_exchange:   # a host's solver holds no input over a step
            sampling += load_order_holds(scenario, table)
    steady = check_steady_window(scenario, table, diagnostics.get("iterates", False))
    if scenario.compares:   # a reference coarser than the record (bench data) against the orders it must carry
        sampling += check_reference_sampling(scenario, table, reference)
    if extra:
        table = _without(table, extra)
    result = ScenarioResult(scenario, table, wall_time=time.perf_counter() - start, fmu_dir=Path(fmu_dir),
                            warnings=said + fmu_warning_lines(diagnostics["fmu_warnings"], said)
                            + stalled_lines(diagnostics.get("stalled")),
                            operating_checks=operating,
                            sampling_checks=sampling, steady_checks=steady,
                            bonds=annotate_bonds(scenario, diagnostics.get("bonds", [])),
                            model_exchange=model_exchange)
    if scenario.compares:   # its reference read above
        units = {name: scenario.unit(name) for name in {**scenario.tolerances, **scenario.extrapolated_tolerances}}
        result.checks = compare(table, reference, scenario.tolerances, units,
                                measured=not scenario.reference_generator)
        slip = milliseconds_hint(scenario, reference).replace("; its times", "the reference file's times", 1)
        for check in result.checks if slip else ():   # the likely cause of every failure, first
            if not check.passed:
                check.note = slip + (f"; {check.note}" if check.note else "")
        from .references import method_of, setup_of
        if setup_of(provenance) is None and len(table) > 2 and all(c.max_error == 0.0 for c in result.checks):
            raise ScenarioError(f"{scenario.path}: [reference] file {scenario.reference_file} equals this run to the "
                                "last digit in every compared signal and does not say how it was made (no '#' "
                                "provenance line with the setup it was made for): it is a copy of a co-simulation's "
                                "output, and comparing a run with itself checks nothing. A reference comes from an "
                                "independent computation: a closed form or a monolithic solve (README, \"Scenario "
                                "format\")")
        result.reference_method = method_of(provenance)
        result.reference_end = float(reference["time"][-1])
        result.order_checks = check_orders(scenario, table, reference)
        mark_vibration_blind(scenario, table, reference, result.checks)
        # fmpy's band scales with each signal's range: a signal constant to within its absolute tolerance (say the
        # output speed of a constant-velocity layout) is checked by compare() alone
        compared = ["time"] + [c.name for c in result.checks if c.reference_range > scenario.tolerances[c.name].abs]
        if available("scipy") and len(compared) > 1:   # fmpy's band filter needs scipy (an extra) and a signal that
            # varies beyond its abs band; the verdict comes from compare()
            result.fmpy_outlier_fraction = fmpy_outlier_fraction(table[compared], reference[compared])
        coarser = not model_exchange and not scenario.bands_hold_at(scenario.step_size)
        if scenario.extrapolated_tolerances and coarser:
            result.skipped_bands = (f"[reference.extrapolated] bands not checked: they hold the O(h^2) remainder "
                                    f"at the scenario's step {scenario.declared_step:g} s, and this run's "
                                    f"{scenario.step_size:g} s is coarser ([reference.tolerance] checked)")
        elif scenario.extrapolated_tolerances:
            try:
                # the rerun's steps continue the run's count (its total counted them from the start)
                rerun = {}
                extrapolated = table if model_exchange else extrapolate_step(
                    scenario, fmu_dir, table, diagnostics=rerun,
                    progress=(lambda done, total: progress(steps + done, steps + total)) if progress else None)
                # the rerun's warnings too, once with the run's (the same warning at another time is the same)
                result.warnings = (said + fmu_warning_lines(diagnostics["fmu_warnings"]
                                                            + rerun.get("fmu_warnings", []), said)
                                   + stalled_lines(diagnostics.get("stalled"))
                                   + stalled_lines(rerun.get("stalled"), "its step-halving rerun at half the step"))
            except (Interrupted, RunStopped) as exc:   # the run itself is whole: kept, as a stopped run's
                exc.args = ("stopped in the step-halving rerun at half the step ([reference.extrapolated] bands); "
                            "the run at the scenario's step is complete and kept, its comparison not made",)
                exc.partial = table
                _keep_partial(scenario, exc, [], out_dir, plot, model_exchange)
                raise
            result.extrapolated_checks = compare(extrapolated, reference, scenario.extrapolated_tolerances, units)
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        result.csv = out_dir / f"{scenario.name}.csv"
        write_table(result.csv, table)
        write_columns(scenario, result.csv, table.dtype.names, model_exchange)
        if plot:
            from .plotting import plot_orbits, plot_scenario, plot_spectra
            result.plot = plot_scenario(result, reference, out_dir / f"{scenario.name}.png")
            if scenario.orbits:
                result.extra_plots.append(plot_orbits(result, out_dir / f"{scenario.name}_orbits.png"))
            if scenario.spectra:
                result.extra_plots.append(plot_spectra(result, out_dir / f"{scenario.name}_spectra.png"))
    result.total_time = time.perf_counter() - begun
    result.table.flags.writeable = False   # its checks, figures and steady_orders() read it: copy it to change it
    return result


def _without(table: np.ndarray, names: list) -> np.ndarray:
    """A copy of a structured table without the named columns."""
    keep = [n for n in table.dtype.names if n not in names]
    return np.rec.fromarrays([table[n] for n in keep], names=keep)


#: speed-driven FMU -> the bundled scenario that wires its torque-driven variant
TORQUE_DRIVEN_EXAMPLES = {"CardanJoint": "cardan_heavy_torque_driven",
                          "DoubleCardanDriveline": "double_cardan_stiff_torque_driven",
                          "TwinJeffcottRotor": "twin_jeffcott_torque_driven",
                          "RingCoupling": "ring_coupling_torque_driven"}


def shown_path(path: Path) -> str:
    """A file's path as a message shows it: relative to the current directory where it lies below it (as the
    results' paths are), else absolute (a reference's path in the scenario file is relative to that file)."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def torque_driven_hint(scenario: Scenario, message: str) -> str:
    """'' unless message (a coupling failure) names a speed-driven component's tau_in connection to its driver:
    then the remedy beside a smaller step, the torque-driven wiring, which does not return the driven side's
    inertia torque to the driver (README, "Choose the wiring for the host")."""
    for conn in scenario.connections:
        comp, _, port = conn.source.partition(".")
        driver, _, target = conn.target.partition(".")
        fmu = scenario.components.get(comp, ("", {}))[0]
        if (port == "tau_in" and target == "tau_load" and fmu in TORQUE_DRIVEN_EXAMPLES and conn.source in message
                and not ideal_speed_source(scenario, driver)):   # an ideal source's speed ignores the torque
            rotor = scenario.parameters_with_defaults(driver).get("J_rotor")
            return (f"hint: {comp} ({fmu}) follows the speed {driver} sets and returns, through {conn.source} -> "
                    f"{conn.target}, the torque its driven side's inertia needs. If that driven side is heavier "
                    f"than {driver}'s rotor" + (f" (J_rotor = {rotor:g} kg.m2)" if rotor is not None else "")
                    + f" or its shaft stiff (else the step is too coarse for the loop), wire it torque-driven "
                    f"instead: {fmu}TorqueDriven driven by a "
                    f"MotorController ({driver}.tau_motor -> {comp}.tau_in, {comp}.omega_in -> {driver}.omega, "
                    f"the rotor inertia as {comp}'s J_drive), as scenarios/{TORQUE_DRIVEN_EXAMPLES[fmu]}.toml does "
                    "(README, \"Choose the wiring for the host\")")
    return ""


#: steps before a failure that ``oscillation_hint`` looks at, and the growth of the step-to-step change over its
#: last third (against its first half) and the reversals there that make an oscillation growing at the step rate
OSCILLATION_WINDOW, OSCILLATION_GROWTH, OSCILLATION_REVERSALS = 24, 10.0, 2


def came_near_rest(chatter, partial: np.ndarray, every: int = 1) -> bool:
    """Whether the speed a chattering Load acts on (``Scenario.load_chatter``) reversed near rest, both sides
    within twice the speed one step of its torque moves the inertia, or of its omega_smooth, over the last
    ``OSCILLATION_WINDOW`` rows of the results up to a failure (a single row, or rows recorded every ``every`` > 1
    steps, which a reversal at every step need not change the sign of: came within it; True where they do not hold
    that speed): the load's torque reverses with the speed, so its chatter shows as the speed's reversals at rest. A
    run that started from rest and failed at speed, or whose coupling diverged through rest from far outside that
    band (a truck propshaft's run-up at too large a step), is not its."""
    speed = f"{chatter.driven}.omega_out"
    if speed not in partial.dtype.names or len(partial) == 0:
        return True
    band = 2.0 * max(chatter.torque * chatter.step / chatter.inertia, chatter.smooth)
    recent = np.asarray(partial[speed][-OSCILLATION_WINDOW:], dtype=float)
    near = np.abs(recent) <= band
    if len(recent) == 1 or every != 1:
        return bool(near.any())
    return bool(np.any(near[1:] & near[:-1] & (recent[1:] * recent[:-1] < 0.0)))


def oscillation_hint(scenario: Scenario, partial: np.ndarray) -> str:
    """'' unless a connected signal of the partial results (recorded at every step) oscillated over the steps
    before a failure with a step-to-step change that grew ``OSCILLATION_GROWTH``-fold, reversing at least
    ``OSCILLATION_REVERSALS`` times: a coupling diverging over a period of a few steps, which the master's per-step
    watch (a sign change at every step) does not catch, and which then shows as an FMU's refusal (an input past
    its range, a model past its validity). Then what that means and the remedies."""
    if len(partial) < OSCILLATION_WINDOW or (scenario.output_interval or 1) != 1:
        return ""
    connected = {name for c in scenario.connections for name in (c.source, c.target)}
    third = OSCILLATION_WINDOW // 3
    worst = None
    for name in partial.dtype.names:
        if name not in connected:
            continue
        change = np.diff(np.asarray(partial[name][-OSCILLATION_WINDOW:], dtype=float))
        before = float(np.max(np.abs(change[:OSCILLATION_WINDOW // 2])))
        late = change[-third:]
        growth = float(np.max(np.abs(late))) / max(before, 1e-12 * float(np.max(np.abs(partial[name]))), 1e-300)
        reversals = int(np.sum(late[1:] * late[:-1] < 0.0))
        if growth >= OSCILLATION_GROWTH and reversals >= OSCILLATION_REVERSALS and (worst is None or growth > worst[1]):
            worst = (name, growth, reversals)
    if worst is None:
        return ""
    name, growth, reversals = worst
    return (f"hint: over the last {third} steps before it failed, {name} oscillated with a step-to-step change "
            f"{growth:.3g}x that of the {OSCILLATION_WINDOW // 2} steps before, reversing {reversals} times: a "
            f"coupling going unstable over a period of a few steps, not the model (the FMU's refusal follows from "
            f"its inputs). Remedy: a smaller step (`ujfmu run {scenario.path} --step auto` picks one)"
            + ("" if scenario.coupling == "implicit" else ", the implicit coupling (the default)")
            + ", or, for a driven side heavier than its driver or a stiff shaft, the torque-driven wiring (README, "
            "\"Choose the wiring for the host\")")


#: half-step steps :func:`step_dependence_hint` takes at most to tell a coupling's instability from the model's own
STEP_DEPENDENCE_STEPS = 50_000
#: a failure at half the step within this share of the time to the first one of it is "at the same time"
SAME_TIME = 0.2


def _refusing(message: str) -> str | None:
    """The component a failure's message says refused a step (None for another failure)."""
    found = re.match(r"component '([^']+)' refused the step", message)
    return found.group(1) if found else None


def step_dependence_hint(scenario: Scenario, fmu_dir, failed_at: float, hint: str, failure: str = "") -> str:
    """An :func:`oscillation_hint` (hint) checked by a rerun at half the step up to 1.5x the failure time
    (``STEP_DEPENDENCE_STEPS`` at most): a coupling's instability grows by a factor per step, so at half the step it
    fails at about half the time, later or not at all; a motion of the model's own that grows (a support too soft
    for the torque it carries, say) fails at the same time whatever the step. hint (with what the rerun found)
    unless the rerun's failure is the same component's refusal (failure: the first one's message) within
    ``SAME_TIME`` of the time to the first; then what that means. A Ctrl-C or SIGTERM during the rerun ends it,
    leaving the first failure to be reported (and its results written)."""
    span = failed_at - scenario.start_time
    half = scenario.step_size / 2.0
    steps = math.ceil(1.5 * span / half)
    if not 0 < steps <= STEP_DEPENDENCE_STEPS:
        return hint
    rerun = scenario.with_values({})
    rerun.step_size, rerun.stop_time = half, min(scenario.stop_time, scenario.start_time + steps * half)
    try:
        rerun._check_steps()
        cosimulate(rerun.master_components(fmu_dir), rerun.connections, rerun.stop_time, half, rerun.record[:1],
                   rerun.start_time, coupling=rerun.coupling)
    except CouplingInstabilityError as again:
        return hint + f" (at half the step, {half:g} s, the coupling went unstable: {str(again).splitlines()[0]})"
    except CosimulationError as again:
        if again.partial is None or len(again.partial) == 0:
            return hint
        there, same = float(again.partial["time"][-1]), _refusing(str(again)) == _refusing(failure)
    except ScenarioError:
        return hint
    except KeyboardInterrupt:
        return hint + " (the check at half the step was interrupted)"
    else:
        return hint + f" (at half the step, {half:g} s, it ran to t = {rerun.stop_time:g} s without failing)"
    if not same or abs(there - failed_at) > SAME_TIME * span:
        return hint + f" (at half the step, {half:g} s, it failed too, at t = {there:g} s)"
    return (f"hint: at half the step ({half:g} s) it fails the same way at t = {there:g} s ({failed_at:g} s at "
            f"{scenario.step_size:g} s): a growth that does not depend on the step is the model's own motion, not "
            "the coupling's (a coupling's instability grows by a factor per step: at half the step it fails at about "
            "half the time, later, or not at all). A smaller step or another wiring will not help: check the "
            "parameters of the component that refused the step against what it carries (a support or shaft too "
            "soft or too lightly damped for its torque or speed, a joint angle near its limit)")


def driving_load_hint(scenario: Scenario) -> str:
    """'' unless a Load of the scenario has a negative damping coefficient (c1 or c2 < 0, its own warning at
    initialization): then that a run away under it is the load's physics, whatever the coupling."""
    lines = []
    for name, (fmu, _) in scenario.components.items():
        if fmu == "Load":
            values = scenario.parameters_with_defaults(name)
            negative = [f"{k} = {values[k]:g} {unit}" for k, unit in (("c1", "N.m.s/rad"), ("c2", "N.m.s2/rad2"))
                        if values[k] < 0.0]
            if negative:
                lines.append(f"hint: {name}'s {' and '.join(negative)} is a negative damping: the load feeds energy "
                             "into the motion it should resist, and a machine it drives faster and faster runs away "
                             "at any step, which is the load's physics, not the coupling's; set it >= 0 for a "
                             "resisting load")
    return "\n".join(lines)


def stalled_drive_hint(scenario: Scenario, partial: np.ndarray) -> str:
    """'' unless a drive of the scenario had nearly stopped, below a tenth of its set speed, where a run failed (the
    last row of its partial results, the drives' speeds and set points among them), at its torque limit over the
    last steps where its torque is recorded (a drive just starting a ramp, short of its limit, is not stalled), and
    not gaining on its set point over them by more than 1% of it (a launch at the limit is accelerating): then what
    that means."""
    for speed, set_point in operating_pairs(scenario):
        if len(partial) < 2 or speed not in partial.dtype.names or set_point not in partial.dtype.names:
            continue
        value, target = float(partial[speed][-1]), float(partial[set_point][-1])
        gained = (value - float(partial[speed][-10:][0])) * math.copysign(1.0, target) if target else 0.0
        if abs(target) > 0.0 and abs(value) < STALLED * abs(target) and gained <= 0.01 * abs(target):
            drive = speed.partition(".")[0]
            limit = scenario.parameters_with_defaults(drive).get("tau_max")
            torque = f"{drive}.tau_motor"
            if limit is not None and torque in partial.dtype.names and not (
                    np.max(np.abs(partial[torque][-10:])) >= 0.95 * limit):   # short of its limit: not stalled by it
                continue
            return (f"hint: when it failed, {speed} = {speed_text(value)} against its set point {set_point} = "
                    f"{speed_text(target)}: the drive had nearly stopped, as one at its torque limit"
                    + (f" (tau_max = {limit:g} N.m)" if limit is not None else "") + " does against a larger "
                    "load, and a load's torque reversing about zero speed chatters; if so, give the drive more "
                    "torque (tau_max) or lower the load")
    return ""


def stalled_lines(stalled: tuple | None, run: str = "") -> list:
    """A warning line where the implicit scheme took steps at their best iterate (``cosimulate``'s diagnostics
    "stalled": the count, the largest residual in tolerances, the steps in all) in the run (or the one named):
    those steps' coupling error is up to that many times its tolerance, unlike every other step's."""
    if not stalled or not stalled[0]:
        return []
    count, worst, steps = stalled
    return [f"{run + ': ' if run else ''}the implicit coupling took {count} of {steps} steps at its best iterate, "
            f"their coupling residual up to "
            f"{worst:.3g}x its tolerance ({COUPLING_RTOL:g} of each torn signal's largest value plus "
            f"{COUPLING_ATOL:g}; within "
            f"{STALL_FACTOR:g}x it is taken, not refused): a torque limit switching or a friction's knee inside "
            "those steps; their error is not the run's stated accuracy there (a smaller step, or --check-step, "
            "says how large it is)"]


def fmu_warning_lines(entries: list, said: list = ()) -> list:
    """The FMUs' logged warnings (``[warning] Model 'instance': text``) as 'component: text' lines, once each (a
    step-halving rerun's repeats, at other times, left out), but for what was said in other terms (said: the
    models' advice given before the run; the outputs read too seldom for an order, which the run's sampling check
    reports)."""
    advice = [s.partition(": ")[2] or s for s in said]
    lines, seen = [], set()
    for entry in entries:
        text = str(entry).removeprefix("[warning] ")
        name, _, rest = text.partition(": ")
        _, own, message = rest.partition(f" '{name}': ")
        line = (f"{name}: {message}" if own else text).removesuffix(" (Said once per instance.)")
        key = name, re.sub(r"(?<![\w.])[-+]?\d[\d.]*(e[-+]?\d+)?", "#", message or text)   # times, figures
        if key in seen or "reads the outputs" in line or any(s and s in line for s in advice):
            continue
        seen.add(key)
        lines.append(line)
    return lines


def _keep_partial(scenario, exc, extra, out_dir, plot, model_exchange=False):
    """A stopped run's results up to there (``exc.partial``) without the ride-along columns extra, written into
    out_dir (None: not written) as a failed run's and named in the exception's message."""
    if exc.partial is not None and extra:
        exc.partial = _without(exc.partial, extra)
    if exc.partial is not None and out_dir is not None:
        _write_partial(scenario, exc, Path(out_dir), plot, model_exchange)


def _replace_written(path: Path, write: Callable[[Path], None]) -> None:
    """write(a temporary file beside path), then put it in path's place at once (``os.replace``): a reader, or
    another process writing the same name (two runs of one changed copy's name), sees one whole file or the other,
    never the two interleaved."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{time.monotonic_ns()}.tmp")
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_table(path: Path, table: np.ndarray) -> Path:
    """A run's table as CSV (fmpy's ``write_csv``), written whole (:func:`_replace_written`)."""
    _replace_written(path, lambda temporary: write_csv(temporary, table))
    return Path(path)


def write_columns(scenario: Scenario, csv_path: Path, names, model_exchange: bool = False,
                  stopped: str = "") -> Path:
    """``<name>.columns.csv`` beside a run's CSV: column, unit, meaning (the FMU's description of the variable; the
    time's: the communication step and coupling, or the Model Exchange solve's, the scenario file and the
    parameters set instead of its own), so a spreadsheet or a script reads the units and the setup with the
    numbers; stopped: what a failed or stopped run's results are (said in the time's meaning)."""
    import csv
    from .build import fmu_class
    path = Path(csv_path).with_suffix(".columns.csv")
    every = scenario.step_size * (scenario.output_interval or 1)
    rows = []
    for name in names:
        if name == "time":
            how = ("Model Exchange FMUs under CVode" if model_exchange else
                   f"communication step {scenario.step_size:g} s, {scenario.coupling} coupling")
            setup = f"scenario file {scenario.path.name}, until {scenario.stop_time:g} s" + (
                "; parameters set instead of the file's: "
                + ", ".join(scenario.change_text(k, v) for k, v in scenario.changes.items()) if scenario.changes
                else "")
            rows.append(["time", "s", f"simulation time, a row every {every:g} s ({how}; {setup})"
                         + (f"; {stopped}" if stopped else "")])
            continue
        comp, _, var = name.partition(".")
        fmu = scenario.components[comp][0]
        description = next((v.description for v in fmu_class(fmu).VARIABLES if v.name == var), "")
        rows.append([name, scenario.unit(name), f"{description} ({comp}, {fmu})"])

    def write(temporary):
        with open(temporary, "w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["column", "unit", "meaning"])
            writer.writerows(rows)
    _replace_written(path, write)
    return path


def _write_partial(scenario, exc, out_dir, plot, model_exchange=False):
    """Write the results up to a failure (CSV, plot) and name them in the error's message."""
    out_dir.mkdir(parents=True, exist_ok=True)
    csv = out_dir / f"{scenario.name}.csv"
    write_table(csv, exc.partial)
    end = float(exc.partial["time"][-1]) if len(exc.partial) else scenario.start_time
    first = str(exc.args[0] if exc.args else exc).splitlines()[0] if str(exc) else type(exc).__name__
    whole = end >= scenario.stop_time - 1e-9 * max(1.0, abs(scenario.stop_time))
    write_columns(scenario, csv, exc.partial.dtype.names, model_exchange,
                  stopped=(f"the run is whole, its checks not made ({first})" if whole else
                           f"the run stopped early: results up to t = {end!r} s of {scenario.stop_time!r} s "
                           f"({first})"))
    written = [f"results up to t = {float(exc.partial['time'][-1])!r}: {csv}"]
    if plot and len(exc.partial) > 1:
        from .plotting import plot_scenario
        written.append(f"plot: {plot_scenario(ScenarioResult(scenario, exc.partial), None, out_dir / f'{scenario.name}.png')}")
    exc.args = (f"{exc.args[0] if exc.args else exc}\n" + "\n".join(written),)


def write_junit(results: list, path: str | os.PathLike, errors: dict | None = None, skipped: dict | None = None,
                kind: str = "", unchecked_fail: bool = False, level_only_fail: bool = False) -> Path:
    """JUnit XML: one test case per scenario, a failure element carrying the error figures and naming the
    signals outside their bands; a scenario that compared nothing, or that was skipped (skipped: its name -> why),
    is a skipped test case (a failure where ``unchecked_fail``: ``check --strict``, or nothing checked at all, which
    fail the command), and one that could not run (errors: its name -> the message) an error case. Where
    ``level_only_fail`` (``check --strict``), a passing scenario with a band that checks the level only
    (``ScenarioResult.level_only_bands``) is a failure naming those bands. A case's system-out is the summary and
    the run's warnings (``ScenarioResult.warnings``). A case's
    time is its whole run (ScenarioResult.total_time). kind (e.g. "fmi3", "model_exchange") goes into the suite's
    and the cases' class names, so that reports of several runs merged in CI stay apart."""
    errors, skipped = errors or {}, skipped or {}
    classname = "ujfmu.scenarios" + (f".{kind}" if kind else "")
    unchecked = sum(not r.checked and not r.failed for r in results)
    loose = sum(bool(level_only_fail and not r.failed and r.strict_problems) for r in results)
    suite = ET.Element("testsuite", name="ujfmu scenarios" + (f" ({kind})" if kind else ""),
                       tests=str(len(results) + len(errors) + len(skipped)),
                       failures=str(sum(r.failed for r in results) + (unchecked if unchecked_fail else 0) + loose),
                       errors=str(len(errors)), skipped=str((0 if unchecked_fail else unchecked) + len(skipped)),
                       time=f"{sum(r.total_time for r in results):.3f}")
    for r in results:
        case = ET.SubElement(suite, "testcase", classname=classname, name=r.scenario.name,
                             time=f"{r.total_time:.3f}")
        if r.failed:
            outside = [c.name for c in r.checks if not c.passed]
            extrapolated = [c.name for c in r.extrapolated_checks if not c.passed]
            why = [w for w, bad in (("signal outside tolerance of the reference: " + ", ".join(dict.fromkeys(outside)),
                                     bool(outside)),
                                    ("step-halving error estimate outside [reference.extrapolated]: "
                                     + ", ".join(dict.fromkeys(extrapolated)), bool(extrapolated)),
                                    ("operating point not reached", any(not c.passed for c in r.operating_checks)),
                                    ("running-speed order amplitude outside [reference.orders]",
                                     any(not c.passed for c in r.order_checks)),
                                    ("record or reference file aliases a model's excitation order, or the step a "
                                     "Load's periodic torque",
                                     any(not c.passed for c in r.sampling_checks)),
                                    ("not steady from output.steady_from",
                                     any(not c.passed for c in r.steady_checks)))
                   if bad]
            failure = ET.SubElement(case, "failure", message="; ".join(why))
            failure.text = r.summary()
        elif level_only_fail and r.level_only_bands:
            ET.SubElement(case, "failure", message="band that checks the level only, not the course (--strict): "
                          + ", ".join(r.level_only_bands)).text = r.summary()
        elif level_only_fail and r.machines_unchecked:
            ET.SubElement(case, "failure", message="compares no output of its machines, "
                          f"{', '.join(r.machines_unchecked)}, only its drive's and load's (--strict)"
                          ).text = r.summary()
        elif level_only_fail and r.part_compared:
            ET.SubElement(case, "failure", message=f"{r.part_compared}, not its whole course (--strict)"
                          ).text = r.summary()
        elif level_only_fail and r.identical:
            ET.SubElement(case, "failure", message="every compared signal equals the reference to the last digit: "
                          "nothing independent compared (--strict)").text = r.summary()
        elif not r.checked and unchecked_fail:
            ET.SubElement(case, "failure", message=f"not checked: {r.not_checked_reason()} (a gate that compares "
                          "nothing fails it)").text = r.summary()
        elif not r.checked:
            ET.SubElement(case, "skipped", message=f"not checked: {r.not_checked_reason()}")
        ET.SubElement(case, "system-out").text = r.summary() + "".join(f"\n  warning {w}" for w in r.warnings)
    for name, reason in skipped.items():
        case = ET.SubElement(suite, "testcase", classname=classname, name=name, time="0")
        ET.SubElement(case, "skipped", message=f"skipped: {reason.splitlines()[0] if reason else ''}")
    for name, message in errors.items():
        case = ET.SubElement(suite, "testcase", classname=classname, name=name, time="0")
        ET.SubElement(case, "error", message=message.splitlines()[0] if message else "error").text = message
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
    return path
