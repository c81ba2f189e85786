"""Communication step help without a reference: the coupling error estimated by step halving.

For a first-order error in the step h (the explicit scheme; the implicit one where its blend is above 1/2), with
y_h the result at step h and y_h/2 at half of it, y_h - y_exact = 2 (y_h - y_h/2) + O(h^2) (Richardson); a
second-order error (the implicit scheme's where its blend is 1/2) is 4/3 (y_h - y_h/2), so the first-order estimate
errs on the safe side by 1.5x there. ``estimate`` reports the first-order estimate per
recorded signal as a fraction of the signal's range; ``choose`` halves the step until every signal's estimate is
within its allowance. Both only rerun the scenario: no reference is needed. Where the scenario has one with
[reference.extrapolated] bands (on the O(h^2) remainder that the step-halving extrapolation leaves), the
extrapolation is also compared within them, as ``ujfmu run`` does: a step that passes here passes those checks.
"""

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from .build import DEFAULT_FMU_DIR
from .master import CosimulationError, cosimulate
from .scenario_run import RANGE_FLOOR
from .steady import grows

#: allowance per signal when the scenario gives no tolerance: a fraction of the signal's range
DEFAULT_REL_RANGE = 0.02
#: a signal without a tolerance whose range is below this fraction of its magnitude varies by round-off only (a
#: Load's torque held at its law within 1e-10 N.m of 300 N.m): judged in absolute terms, not against that range
ROUND_OFF_RANGE = 1e-9
MAX_HALVINGS = 5
#: a signal's estimate that a halving leaves above this share of itself does not shrink with the step (a first-order
#: error halves, a second-order one quarters): ``choose`` stops there instead of halving on
STALLED = 0.75
#: an estimate of at least this share of a signal's range (whole run or steady part, as judged) says the runs at h
#: and h/2 follow different motions, the step not resolving them yet, not that the error is of a fixed size: in
#: the first ``UNRESOLVED_HALVINGS`` halvings, one from or to it is no stall (an 80 deg joint's PI start-up: 67%,
#: 77%, 72% of range over three steps from 1 ms, then 23%, 4.6% as the step resolved it); after them it is
#: judged as any (a fixed error that large stops there instead of costing every halving)
UNRESOLVED, UNRESOLVED_HALVINGS = 0.25, 2
#: without a tolerance a signal is also judged over its steady part (from steady_from, else the last STEADY_SHARE of
#: the run) against that part's own range, where that range is between STEADY_FLOOR and half of the whole run's: a
#: vibration about a level reached in a start-up (0.4% of the run's range) had passed with 9% of its own
#: peak-to-peak wrong
STEADY_SHARE, STEADY_FLOOR = 0.25, 1e-3
#: communication steps at the start left out of the estimate: a speed-driven FMU starts without a speed history, so
#: its first input accelerations (and the inertia torques they carry) are off by an amount no step shrinks (a joint
#: behind another, at speed from the start: 3.2 N.m at 1 ms, 0.34 N.m at 0.1 ms, where the error at its steady 2x
#: halves), which had made every step look too coarse
START_STEPS = 3


@dataclass
class StepEstimate:
    step: float
    errors: dict        # signal -> estimated max |error| at this step / range of the signal (inf: a constant one)
    allowed: dict       # signal -> allowance as a fraction of the range
    failure: str = ""   # the co-simulation at this step (or its half) stopped: why
    absolute: dict = field(default_factory=dict)   # signal -> (max |error|, allowance) for the signals shown so
    sampling: list = field(default_factory=list)   # scenario_run.SamplingCheck per drivetrain component
    extrapolated: list = field(default_factory=list)   # scenario_run.SignalCheck per [reference.extrapolated] band
    steady: dict = field(default_factory=dict)   # signal -> estimate over the steady part / that part's range
    steady_from: float = math.nan                # where that part starts [s]
    at: dict = field(default_factory=dict)       # signal -> the time of its largest estimated error [s]
    skipped: float = math.nan                    # the estimate starts there (``START_STEPS``) [s]
    units: dict = field(default_factory=dict)    # signal -> its unit, for the figures shown in absolute terms
    #: scenario_run.OrderCheck per [reference.orders] signal and order: the run's amplitude over the steady window
    #: against the step-halving extrapolation's (the bands, shares of a signal's whole range, cannot see a vibration's)
    orders: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """No failure, every signal's estimate within its allowance, no record aliasing a model's order (step
        halving compares at the coarse instants, where an aliased record agrees with itself), the
        extrapolation within the scenario's [reference.extrapolated] bands where it has them, and each
        [reference.orders] amplitude within its rel of the extrapolation's (an order its machine carries that the
        step leaves unresolved fails: ``OrderCheck.refused``)."""
        return (not self.failure and all(self.within(n) for n in self.errors)
                and all(c.passed for c in self.sampling + self.extrapolated + self.orders))

    def within(self, name: str) -> bool:
        """The signal's estimate within its allowance (in absolute terms for a signal in ``absolute``), and over its
        steady part within the same share of that part's range where it is judged there (``steady``)."""
        if name in self.steady and not self.steady[name] <= self.allowed[name]:
            return False
        if name in self.absolute:
            error, allowance = self.absolute[name]
            return error <= allowance
        return self.errors[name] <= self.allowed[name]

    def _unit(self, name: str) -> str:
        unit = self.units.get(name, "")
        return f" {unit}" if unit not in ("", "1") else ""

    def lines(self) -> list[str]:
        if self.failure:
            return [f"step {self.step:g} s: {self.failure}"]
        start = (f" from t = {self.skipped:g} s (the first {START_STEPS} steps, where speed-driven FMUs have no speed "
                 "history yet, left out)" if not math.isnan(self.skipped) else "")
        return [f"step {self.step:g} s, estimated coupling error (2 x |y(h) - y(h/2)|) per signal{start}:"] + [
            f"  {'ok  ' if self.within(n) else 'HIGH'} {n:28s} " + (
                f"{self.absolute[n][0]:9.3g}{self._unit(n)} (allowed {self.absolute[n][1]:.3g}{self._unit(n)}; "
                "absolute: the signal hardly varies)"
                if n in self.absolute else
                f"{100 * self.errors[n]:9.3g}% of range (allowed {100 * self.allowed[n]:.3g}%)")
            + (f" at t = {self.at[n]:.4g} s" if n in self.at else "")
            + (f"; {100 * self.steady[n]:.3g}% of its range from t = {self.steady_from:g} s" if n in self.steady
               else "")
            for n in self.errors] + [f"  {'ok  ' if c.passed else 'HIGH'} {c.text}" for c in self.orders
                                     if not c.note or c.refused] + [f"  {c}" for c in self.sampling
                                                                    if not c.passed] + (
            [f"  step-halving extrapolation 2 y(h/2) - y(h) against the reference, outside its "
             f"[reference.extrapolated] band:"] + [f"    {c}" for c in self.extrapolated if not c.passed]
            if not all(c.passed for c in self.extrapolated) else [])


def estimate(scenario, step: float | None = None, fmu_dir=DEFAULT_FMU_DIR, coarse=None) -> StepEstimate:
    """Estimated coupling error of the scenario at ``step`` (default its own), by a rerun at step/2: the
    distance of y(h) from the step-halving extrapolation 2 y(h/2) - y(h) (scenario_run.extrapolate_step).

    Signals: the toleranced ones with their allowance rel_range (+ abs as a fraction of the range), and their
    [reference.orders] amplitudes over the steady window within their rel (``scenario_run.check_orders``), else every
    recorded signal but those the scenario does not compare (its ``not_compared``, ``--record``'s) with
    DEFAULT_REL_RANGE. coarse: the result at ``step`` if already computed (its sampling is
    the run's own check); else the run records the drivetrain components' input speeds too, for
    ``scenario_run.check_sampling``. With a reference file and [reference.extrapolated] bands, at most the
    scenario's declared step (the bands hold the remainder there), the extrapolation compared within them."""
    from .scenario import ScenarioError
    from .scenario_run import (check_orders, check_sampling, compare, extrapolate_step, sampled_components,
                               window_from)
    run = copy.copy(scenario)
    run.step_size = scenario.step_size if step is None else step
    names = (list(scenario.tolerances) or [n for n in scenario.record if n not in scenario.not_compared]
             or list(scenario.record))
    sampling = []
    try:
        if coarse is None:
            scenario.check_fmus(fmu_dir)   # missing FMUs: a ScenarioError naming the remedy, not a failed estimate
            speeds = [f"{name}.omega_in" for name, _ in sampled_components(run)
                      if f"{name}.omega_in" not in run.record]
            coarse = cosimulate(run.master_components(fmu_dir), run.connections, run.stop_time, run.step_size,
                                run.record + speeds, run.start_time, coupling=run.coupling,
                                output_interval=run.output_interval)
            sampling = check_sampling(run, coarse)
        extrapolated = extrapolate_step(run, fmu_dir, coarse)
    except CosimulationError as exc:
        return StepEstimate(run.step_size, {}, {}, str(exc).splitlines()[0])
    errors, allowed, absolute, steady, at = {}, {}, {}, {}, {}
    time = np.asarray(extrapolated["time"], dtype=float)
    later = time >= scenario.start_time + (START_STEPS - 0.5) * run.step_size
    if np.count_nonzero(later) < 2 or not speed_driven(scenario):   # a run of a few steps, or none starts blind
        later = np.ones_like(time, dtype=bool)
    steady_from = scenario.steady_from or 0.0   # None: unset, as 0
    since = (steady_from if steady_from > scenario.start_time
             else float(time[-1] - STEADY_SHARE * (time[-1] - time[0])))
    window = window_from(time, since)
    for name in names:
        span = float(np.ptp(extrapolated[name]))
        gap = np.abs(extrapolated[name] - coarse[name])[later]
        diff = float(np.max(gap))
        if diff > 0.0:
            at[name] = float(time[later][np.argmax(gap)])
        tol = scenario.tolerances.get(name)
        errors[name] = diff / span if span > 0.0 else (0.0 if diff == 0.0 else math.inf)
        allowed[name] = (tol.rel_range + (tol.abs / span if span > 0.0 else math.inf)) if tol else DEFAULT_REL_RANGE
        allowance = tol.rel_range * span + tol.abs if tol else DEFAULT_REL_RANGE * span
        magnitude = float(np.max(np.abs(extrapolated[name])))
        if span <= RANGE_FLOOR * allowance or span == 0.0 or (not tol and span <= ROUND_OFF_RANGE * magnitude):
            # a (nearly) constant signal: its range says nothing; without a tolerance, 2% of its magnitude
            if not tol:
                allowance = DEFAULT_REL_RANGE * magnitude
            absolute[name] = (diff, allowance)
        elif not tol and not grows(name) and np.count_nonzero(window) >= 4:
            part = float(np.ptp(extrapolated[name][window]))
            if STEADY_FLOOR * span <= part <= 0.5 * span:
                steady[name] = float(np.max(np.abs(extrapolated[name][window] - coarse[name][window]))) / part
    banded = []
    if (scenario.extrapolated_tolerances and scenario.reference_file is not None and scenario.reference_file.is_file()
            and scenario.bands_hold_at(run.step_size)):
        banded = compare(extrapolated, scenario.reference()[0], scenario.extrapolated_tolerances)
    orders = []
    if scenario.order_tolerances:
        try:
            orders = check_orders(run, coarse, extrapolated)
        except ScenarioError:   # a window that cannot be fitted: the run's own order check says so
            orders = []
        for check in orders:
            check.against = "the step-halving extrapolation's"
    return StepEstimate(run.step_size, errors, allowed, absolute=absolute, sampling=sampling, extrapolated=banded,
                        orders=orders,
                        steady=steady, steady_from=float(time[window][0]) if window.any() else math.nan, at=at,
                        skipped=float(time[later][0]) if not later.all() else math.nan,
                        units={name: _unit(scenario, name) for name in absolute})


def _unit(scenario, name: str) -> str:
    """The signal's declared unit, "" where the scenario cannot say (a name set on it by hand)."""
    from .scenario import ScenarioError
    try:
        return scenario.unit(name)
    except ScenarioError:
        return ""


def speed_driven(scenario) -> bool:
    """True where a component follows a speed it is given (``fmu.base.PrescribedInputSlave``): it starts without a
    speed history (``START_STEPS``)."""
    from .build import fmu_class
    from .fmu.base import PrescribedInputSlave
    return any(issubclass(fmu_class(fmu), PrescribedInputSlave) for fmu, _ in scenario.components.values())


def _measure(est: StepEstimate, name: str) -> tuple:
    """(the estimate of a signal as it is judged, its text): over its steady part where that part's figure is over
    the allowance, else absolute for the signals judged so, else the fraction of the range."""
    if name in est.steady and not est.steady[name] <= est.allowed[name]:
        return est.steady[name], f"{100 * est.steady[name]:.3g}% of its range from t = {est.steady_from:g} s"
    if name in est.absolute:
        return est.absolute[name][0], f"{est.absolute[name][0]:.3g}{est._unit(name)}"
    return est.errors[name], f"{100 * est.errors[name]:.3g}% of range"


def _kind(est: StepEstimate, name: str) -> str:
    """Which figure :func:`_measure` judges a signal by: 'steady', 'absolute' or 'range'."""
    if name in est.steady and not est.steady[name] <= est.allowed[name]:
        return "steady"
    return "absolute" if name in est.absolute else "range"


def stalled(est: StepEstimate, previous: StepEstimate, early: bool = False) -> list[str]:
    """The signals over their allowance at est and at previous (the step before the halving) whose estimate, as
    each is judged (:func:`_measure`), the halving left above ``STALLED`` of itself: an error that does not shrink
    with the step. In an early halving (``UNRESOLVED_HALVINGS``), not a signal whose estimate, as a share of its
    range, is ``UNRESOLVED`` at either step."""
    return [n for n in est.errors if not est.within(n) and n in previous.errors and not previous.within(n)
            and _kind(est, n) == _kind(previous, n)
            and _measure(est, n)[0] > STALLED * _measure(previous, n)[0]
            and not (early and _kind(est, n) != "absolute"
                     and max(_measure(est, n)[0], _measure(previous, n)[0]) >= UNRESOLVED)]


def _allowance(est: StepEstimate, name: str) -> float:
    """The allowance in the terms :func:`_measure` gives the estimate in."""
    return est.absolute[name][1] if _kind(est, name) == "absolute" else est.allowed[name]


def choose(scenario, fmu_dir=DEFAULT_FMU_DIR, progress=None) -> tuple[float, list[StepEstimate]]:
    """The largest of step, step/2, step/4, ... (step the scenario's) whose estimate passes; (step, estimates).

    Raises CosimulationError naming the last estimate when MAX_HALVINGS halvings do not reach the allowance, or as
    soon as a halving leaves a signal's estimate over its allowance without shrinking it (:func:`stalled`): each
    halving doubles the cost, and no smaller step would reach it."""
    step, tried = scenario.step_size, []
    for _ in range(MAX_HALVINGS + 1):
        est = estimate(scenario, step, fmu_dir)
        tried.append(est)
        if progress:
            progress("\n".join(est.lines()))
        if est.passed:
            return step, tried
        stuck = (stalled(est, tried[-2], early=len(tried) - 1 <= UNRESOLVED_HALVINGS)
                 if len(tried) > 1 and not est.failure else [])
        if stuck:
            before, after = tried[-2], est
            figures = ", ".join(f"{n} {_measure(before, n)[1]} -> {_measure(after, n)[1]}" for n in stuck)
            cause = ("(e.g. a speed-driven model's torque, whose inertia term estimates the input acceleration from "
                     "the held speeds, for two steps after a jump of that acceleration: a load step, a drive's torque "
                     "limit). `ujfmu run --check-step` shows where it is; the torque-driven wiring integrates the "
                     "input shaft instead (README, \"Choose the wiring for the host\")" if speed_driven(scenario) else
                     "(e.g. a torque held over a step that jumps or switches within it: a load step, a drive's "
                     "torque limit, a controller's clamp). `ujfmu run --check-step` shows where it is")
            raise CosimulationError(
                f"--step auto: halving the step from {before.step:g} s to {after.step:g} s did not shrink the "
                f"estimated coupling error of {figures} (a first-order error halves): an error of a fixed "
                f"size over a few steps, which no smaller step removes {cause}:\n" + "\n".join(est.lines()))
        step /= 2.0
    last, before = tried[-1], tried[-2] if len(tried) > 1 else None
    failing = [n for n in last.errors if not last.within(n)]
    shrinking = (before is not None and not last.failure and not before.failure and failing
                 and all(n in before.errors and _kind(last, n) == _kind(before, n)
                         and 0.0 < _measure(last, n)[0] <= 0.5 * _measure(before, n)[0]
                         and _allowance(last, n) > 0.0 for n in failing))
    hint = ""
    if shrinking:   # the halvings the failing estimates need at the rate the last one shrank them
        more = max(math.ceil(math.log(_allowance(last, n) / _measure(last, n)[0])
                             / math.log(_measure(last, n)[0] / _measure(before, n)[0]) - 1e-9) for n in failing)
        hint = (" (the last halving shrank the failing estimates, "
                + ", ".join(f"{n} {_measure(before, n)[1]} -> {_measure(last, n)[1]}" for n in failing)
                + f": at that rate {more} more halving{'s reach' if more > 1 else ' reaches'} the allowance, --step "
                f"{last.step / 2.0 ** more:g}; each halving doubles the run's time)")
    raise CosimulationError(f"--step auto: no step down to {last.step:g} s keeps the estimated coupling error "
                            f"within the allowance{hint}:\n" + "\n".join(last.lines()))
