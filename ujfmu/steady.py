"""Steady state of a running co-simulation: settle until the response repeats, check the operating point, measure.

A sweep point (``ujfmu.sweep.run_point``) settles for ``settle_time``, then records ``revolutions`` whole
revolutions and reduces each output to its figures. Whether it was steady is measured, not assumed:

- **Steady-state criterion.** The figures that do not depend on where the samples fall in a revolution (the mean and
  the amplitudes of the requested running-speed orders of every output and of the running speed, from one least-
  squares fit of orders 0..max(8, 2 x the highest requested), so that other orders do not leak in; an order k the
  samples cannot resolve, with fewer than 4k + 2 a revolution, is NaN and left out: ``unresolved_orders``) are
  measured over back-to-back windows of the same number of revolutions from 3T/4 to T. The point is steady when every
  such figure f of the last window agrees with those of every earlier one, |f(T) - f(t)| <= steady_tol * max(|f(T)|,
  FLOOR * size of that output: its largest figure, or half its peak-to-peak over the window where that is larger, so
  that orders the step does not resolve still count toward its size) (a response that only beats, never settling, then
  shows its variation within the quarter), or the change is within the coupling's own noise, ``coupling_noise``
  (3e-5) of that size under the implicit scheme (whose iteration stops within 3e-4 of a torn input's value). A
  transient decaying as exp(-sigma t) changes by A exp(-sigma T) (exp(sigma
  T/4) - 1) between 3T/4 and T and leaves A exp(-sigma T) at T: once sigma T >= 4 ln 2 = 2.8 the error left is below
  the change measured. Otherwise T grows by GROWTH (1.5x), up to ``max_settle_time`` (default 8x the first T), so any
  decay slower than that shows as a change. T is at least four windows long, and windows are whole revolutions laid
  back to back from 3T/4 until one starts at T or later: the settle time used can pass ``max_settle_time`` (by up to
  two windows: the last growth ends at the cap, and each round of the check records two windows at least; or up to
  four windows when the cap is shorter), and the not_steady message says so. A decay or drift much slower than 1/T
  changes too little within the last quarter to be seen, so the first T must be of the order of the slowest time
  constant: where a model's slowest decay rate is known (``analysis.decay_rates`` of its linearisation), a settle time
  of 2.8 / sigma or more makes the check decisive (the report does this for the twin rotor).
- **Operating point.** Each (signal, set point) pair, e.g. a Motor's ``omega`` and ``omega_ref``, must agree in
  the mean over the measured window within ``operating_tol`` of the set point; a saturated drive that never
  reaches its speed is flagged, not measured as if it had.

Statuses: ``ok``; ``not_steady`` (figures kept, with the residual change); ``off_target`` (figures kept, the
signal and set point named); ``error`` (the point failed; message kept).
"""

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .analysis import one_blas_thread, order_fit

OK, NOT_STEADY, OFF_TARGET, ERROR = "ok", "not_steady", "off_target", "error"
#: statuses whose figures are a result of the requested settings (rerunning gives the same); `error` is reused where
#: the same configuration gives it again (``sweep.repeatable``), else retried
FINAL = (OK, NOT_STEADY, OFF_TARGET)
STATUSES = FINAL + (ERROR,)
#: figures smaller than this fraction of their output's largest figure are compared in absolute terms
FLOOR = 1e-2
FIGURES = ("max", "min", "p2p", "mean", "rms")
#: an order below this share of its signal's size has no phase (NaN): round-off's phase is noise
PHASE_FLOOR = 1e-6
#: factor by which the settle time grows while a point is not steady
GROWTH = 1.5


@dataclass
class Window:
    """One measured window: the running angle and the recorded signals over whole revolutions, and the running
    shaft's own angle at its start (NaN where unknown): what the orders' phases refer to."""
    start: float
    angle: np.ndarray
    table: np.ndarray
    offset: float = math.nan


#: the most steps a measurement window may take (:func:`record_window`): 1e6 rows of a few signals are tens of MB
#: and a minute or more of computing; a slower running speed is refused
MAX_WINDOW_STEPS = 1_000_000


def record_window(cosim, running_speed: str, revolutions: float, angle_signal: str = "") -> Window:
    """Record ``revolutions`` revolutions of the running speed read at the current point (at least 8 steps); with
    angle_signal, the running shaft's angle, the window's offset: that angle less the window's running angle, its
    mean from the fit of the orders (a joint's output angle ripples at 2x, and a window is no whole number of its
    revolutions: a plain mean had biased a phase by up to 0.03 rad)."""
    now = np.empty(len(cosim.columns))
    cosim.read(now)
    speed = now[cosim.columns.index(running_speed)]
    if not (math.isfinite(speed) and abs(speed) > 1e-9):
        raise ValueError(f"running speed {running_speed} = {float(speed)!r} rad/s at t = {cosim.time:g} s: no "
                         "revolutions to measure over")
    h = cosim.step_size
    start = cosim.time
    steps = max(8, math.ceil(revolutions * 2.0 * math.pi / abs(speed) / h))
    if steps > MAX_WINDOW_STEPS:
        raise ValueError(f"running speed {running_speed} = {speed_text(speed)} at t = {cosim.time:g} s: "
                         f"{revolutions:g} revolutions take {steps * h:.4g} s, {steps:.3g} steps of {h:g} s, over the "
                         f"{MAX_WINDOW_STEPS:.0e} a window may hold (its table in memory): measure fewer revolutions "
                         "(--revolutions), take a larger step (--step) or leave out speeds this slow")
    table = cosim.run(steps)
    window = Window(start, running_angle(table["time"], table[running_speed]), table)
    if angle_signal:   # the angle's own ripple fitted out (the window is no whole number of its revolutions)
        window.offset = float(order_fit(window.angle, table[angle_signal] - window.angle,
                                        fitted_orders(window, (1,)))[0])
    return window


#: orders of the smooth running angle's own ripple fitted with it (:func:`running_angle`), at most
RIPPLE_ORDERS = 8


def running_angle(t: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """The running angle a window's orders are fitted against, from 0 at its first sample: the trapezoidal integral
    of the running speed without the speed's own ripple. A PI motor's speed carries the joints' 2x: against its
    instantaneous angle, a signal's 2x would modulate into a false 4x and shift the mean (omega_out's 4x 0.035 rad/s
    where an FFT of the record gives 0.0088). The smooth part is a quadratic in time (a steady speed's angle is
    linear, a constant run-up's quadratic), fitted by least squares together with the ripple's orders
    1..``RIPPLE_ORDERS`` of it (as many as the samples resolve), twice: a quadratic alone takes part of a ripple over
    a window that is no whole number of its periods into its slope (2.2e-3 rad/s of 60 for a 3.4 rad/s 2x ripple,
    enough to leak a 75 N.m 2x into a 1x 1000 times the true one)."""
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))))
    if len(t) < 3:
        return angle
    tau = t - t[0]
    with one_blas_thread():
        smooth = np.polyval(np.polyfit(tau, angle, 2), tau)
        turns = abs(float(smooth[-1] - smooth[0])) / (2.0 * math.pi)
        orders = min(RIPPLE_ORDERS, int(len(t) / max(turns, 1e-300) / 2.0) - 1, (len(t) - 4) // 2)
        if not (turns > 0.0 and orders >= 1):
            return smooth
        for _ in range(2):
            ripple = [f(k * smooth) for k in range(1, orders + 1) for f in (np.cos, np.sin)]
            matrix = np.column_stack([np.ones_like(tau), tau, tau * tau] + ripple)
            coef = np.linalg.lstsq(matrix, angle, rcond=None)[0]
            smooth = coef[0] + coef[1] * tau + coef[2] * tau * tau
    return smooth - smooth[0]


def samples_per_revolution(window: Window) -> float:
    """Samples per revolution of the running angle over the window."""
    return len(window.angle) * 2.0 * math.pi / max(abs(window.angle[-1] - window.angle[0]), 1e-300)


def nyquist_order(window: Window) -> int:
    """The highest order the window's fit may take: int(samples per revolution / 2) - 1 (below the sampling's
    Nyquist order, with one order to spare)."""
    return int(samples_per_revolution(window) / 2.0) - 1


def full_fit(orders) -> int:
    """K of :func:`fitted_orders` where the samples allow: max(8, 2 max(orders)), so that unrequested orders do not
    leak into the requested ones or the mean."""
    return max(8, 2 * max(orders))


def fitted_orders(window: Window, orders) -> range:
    """Orders 1..K fitted together: K = :func:`full_fit`, fewer if a revolution has too few samples
    (``nyquist_order``, at least 1)."""
    return range(1, max(1, min(full_fit(orders), nyquist_order(window))) + 1)


def unresolved_orders(window: Window, orders) -> tuple:
    """The orders k of ``orders`` the window cannot resolve: the fit does not reach 2k (``fitted_orders``' margin,
    which needs at least 4k + 2 samples a revolution), so the orders above it, which a joint's response carries,
    alias onto k. Their amplitudes are NaN in the figures and the steady-state check leaves them out."""
    top = nyquist_order(window)
    return tuple(k for k in orders if 2 * k > top)


def resolving_step(order: int, speed: float) -> float:
    """The longest communication step [s] that resolves ``order`` at ``speed`` [rad/s]: 4 order + 2 samples a
    revolution (``unresolved_orders``)."""
    return 2.0 * math.pi / (abs(speed) * (4 * order + 2))


def _amplitudes(amps, orders, unresolved: tuple) -> list:
    """The amplitudes of the orders (the fit reaches each resolved one), NaN for the unresolved."""
    return [math.nan if k in unresolved else float(amps[k - 1]) for k in orders]


def figures(window: Window, outputs, orders, fits: dict | None = None, phases_wanted: bool = False) -> dict:
    """{"out.max", "out.min", "out.p2p", "out.mean", "out.rms", "out.h<k>"} of a window: extremes of the samples;
    mean and order amplitudes from the fit of ``fitted_orders`` (exact for a periodic signal, wherever the
    window's ends fall); RMS, mean included, of the fit by Parseval, sqrt(c0^2 + sum_k a_k^2 / 2), with the mean
    square of what the fit leaves (so rms >= |mean|, and rms^2 - mean^2 is the vibration's, wherever the window's
    ends fall: the samples' own RMS over a window of a whole number of steps, not of revolutions, is not); NaN for
    the ``unresolved_orders``. fits, when given, receives each output's fitted amplitudes (orders
    ``fitted_orders``). phases_wanted: also "out.ph<k>", the phase [rad] of order k against the running shaft's own
    angle (the window's offset added: signal ~ mean + sum h_k cos(k angle - ph_k)), in (-pi, pi]."""
    result = {}
    fitted, unresolved = fitted_orders(window, orders), unresolved_orders(window, orders)
    for out in outputs:
        y = window.table[out]
        c0, amps, phases = order_fit(window.angle, y, fitted)
        fit = c0 + sum(a * np.cos(k * window.angle - p) for k, a, p in zip(fitted, amps, phases))
        rms = math.sqrt(c0 * c0 + 0.5 * float(np.sum(amps * amps)) + float(np.mean((y - fit) ** 2)))
        if fits is not None:
            fits[out] = amps
        values = dict(max=y.max(), min=y.min(), p2p=np.ptp(y), mean=c0, rms=rms)
        values.update({f"h{k}": a for k, a in zip(orders, _amplitudes(amps, orders, unresolved))})
        if phases_wanted:   # against the shaft's own angle: k angle - p = k (offset + angle) - (p + k offset);
            # none for an order of round-off size (its phase is noise)
            size = max(float(np.max(amps, initial=0.0)), abs(c0), 0.5 * float(np.ptp(y)))
            absolute = [math.remainder(p + k * window.offset, 2.0 * math.pi) if a > PHASE_FLOOR * size else math.nan
                        for k, a, p in zip(fitted, amps, phases)]
            values.update({f"ph{k}": a for k, a in zip(orders, _amplitudes(np.array(absolute), orders, unresolved))})
        result.update({f"{out}.{k}": float(v) for k, v in values.items()})
    return result


class Periodic(NamedTuple):
    """One signal's figures over a window (``periodic_figures``): [mean, amplitude of each order] (NaN for an
    unresolved order), and its size, the larger of those and half its samples' peak-to-peak (which counts the
    orders the step does not resolve): the steady-state check's scale, not itself compared."""
    figures: list
    size: float


def periodic_figures(window: Window, signals, orders) -> dict:
    """{signal: Periodic} from one fit of ``fitted_orders`` (criterion above); NaN for the
    ``unresolved_orders``."""
    fitted, unresolved = fitted_orders(window, orders), unresolved_orders(window, orders)
    result = {}
    for name in signals:
        y = window.table[name]
        c0, amplitudes, _ = order_fit(window.angle, y, fitted)
        values = [float(c0)] + _amplitudes(amplitudes, orders, unresolved)
        size = max([abs(v) for v in values if not math.isnan(v)] + [0.5 * float(np.ptp(y))])
        result[name] = Periodic(values, size)
    return result


def steady_change(new: dict, old: dict, orders=None, noise: float = 0.0) -> tuple:
    """(largest change relative to its allowance, 'signal figure', what the change is relative to) between two
    windows' ``periodic_figures`` of these orders; <= steady_tol means steady (module docstring). A change of at
    most noise times the signal's size is the coupling's resolution (:func:`coupling_noise`), not a change."""
    worst, name, against = 0.0, "", "itself"
    for signal, (figures_new, scale) in new.items():
        for i, (f_new, f_old) in enumerate(zip(figures_new, old[signal].figures)):
            if math.isnan(f_new) or math.isnan(f_old):   # an unresolved order: not a figure
                continue
            allowance = max(abs(f_new), FLOOR * scale)
            change = abs(f_new - f_old)
            if change <= noise * scale:
                continue
            relative = change / allowance if allowance > 0 else (0.0 if change == 0 else math.inf)
            if not relative <= worst:
                figure = "mean" if i == 0 else f"{orders[i - 1]}x order amplitude" if orders else "order amplitude"
                against = (f"itself ({abs(f_new):.3g}; the change {change:.3g})" if abs(f_new) >= FLOOR * scale else
                           f"{allowance:.3g}, {FLOOR:g} of the signal's size {scale:.3g} (its largest figure, or "
                           f"half its peak-to-peak), as the figure itself is smaller ({f_new:.3g}; the change "
                           f"{change:.3g})")
                worst, name = relative, f"{signal} {figure}"
    return worst, name, against


#: the orders whose amplitudes (and the mean) :func:`halves_change` compares
HALVES_ORDERS = (1, 2, 4)


def halves_change(angle, table, signals, orders=HALVES_ORDERS, noise: float = 0.0) -> tuple:
    """``steady_change`` between the first and the second half of a record (angle: the running angle of each
    sample, table: a structured array with the signals; noise: the coupling's, :func:`coupling_noise`): for a test
    that waited a fixed time, whether its record repeats."""
    half = len(angle) // 2
    first, second = (Window(0.0, np.asarray(angle[part]), table[part]) for part in (slice(0, half), slice(half, None)))
    return steady_change(periodic_figures(second, signals, orders), periodic_figures(first, signals, orders), orders,
                         noise)


def is_running_angle(signal: str) -> bool:
    """True for a shaft's angle, continuous over revolutions (``comp.phi``, ``comp.phi_out``, ...): it grows with
    time in any steady state, so the steady-state check leaves it out (the running speed stands for it)."""
    return signal.partition(".")[2].startswith("phi")


#: outputs that integrate power since the start (the twin rotor's energy audit): they grow in any steady state
ENERGY_INTEGRALS = ("input_work", "dissipated_energy")


def grows(signal: str) -> bool:
    """True for a signal that grows with time in any steady state: a running angle (:func:`is_running_angle`) or
    an energy integral (``ENERGY_INTEGRALS``). The steady-state check leaves it out, and a sweep reduces it only
    when named (its max, min and orders over a window say nothing)."""
    return is_running_angle(signal) or signal.partition(".")[2] in ENERGY_INTEGRALS


#: the noise of a window's figures under the implicit scheme, as a fraction of its iteration tolerance
#: ``master.COUPLING_RTOL`` (the per-step residual, relative to a torn input's largest value): a fit over a window's
#: hundreds of samples averages it down; measured 2e-5 of the signal's size (0.07 of the tolerance) on a truck
#: driveline's shaft torque
FIGURE_NOISE = 0.1


def coupling_noise(iterates: bool) -> float:
    """The relative size of the noise the co-simulation's coupling leaves in a window's figures: the implicit scheme
    ends its iteration within ``master.COUPLING_RTOL`` (3e-4) of a torn input's largest value, and the figures move
    between windows by up to ``FIGURE_NOISE`` of that times the signal's size (3e-5) without any change of the motion
    (a 1x order of 1e-5 of a shaft torque's mean, absent from the monolithic solve and from the explicit scheme,
    wanders by twice itself: no settle time makes it steady); 0 where the steps do not iterate (iterates False: the
    explicit scheme, or nothing to close, ``Cosimulation.iterates``)."""
    from .master import COUPLING_RTOL
    return FIGURE_NOISE * COUPLING_RTOL if iterates else 0.0


def settle_and_measure(cosim, settings) -> dict:
    """Settle the co-simulation, check steadiness and the operating point, measure; returns the record fields:
    the figures, ``status``, ``error`` (the reason for a status other than ok), ``settled_s`` (the settle time
    used) and ``steady_change`` (the criterion's value, <= steady_tol when steady)."""
    s = settings
    h = cosim.step_size
    record = {}
    if not s.steady_tol:   # no steady-state check asked for (a measurement during a transient)
        cosim.advance(int(round(s.settle_time / h)))
        window = record_window(cosim, s.running_speed, s.revolutions, s.running_angle)
        record.update(_measured(window, s), settled_s=window.start - cosim.start_time, steady_change=math.nan)
        return _check_operating_point(window, s, record)
    signals = [x for x in dict.fromkeys(s.outputs + [s.running_speed]) if not grows(x)]
    noise = coupling_noise(cosim.iterates)
    start = cosim.time
    settle, cap = s.settle_time, None
    while True:
        cosim.advance(max(0, int(round((start + 0.75 * settle - cosim.time) / h))))
        window = record_window(cosim, s.running_speed, s.revolutions, s.running_angle)
        first = window.start - start
        if cap is None:   # the first window fixes the shortest settle time and the default cap
            length = window.table["time"][-1] - window.table["time"][0]
            settle = max(settle, 4.0 * length)
            cap = s.max_settle_time if s.max_settle_time is not None else 8.0 * settle
        earlier = [periodic_figures(window, signals, s.orders)]
        while True:   # back-to-back windows until one starts at T or later
            window = record_window(cosim, s.running_speed, s.revolutions, s.running_angle)
            earlier.append(periodic_figures(window, signals, s.orders))
            if window.start >= start + settle - 0.5 * h:
                break
        change, worst, against = max(steady_change(earlier[-1], old, s.orders, noise) for old in earlier[:-1])
        if change <= s.steady_tol or settle >= cap * (1.0 - 1e-9) or window.start - start >= cap - 0.5 * h:
            break
        settle = min(GROWTH * settle, cap)   # the last growth ends at the cap itself
    record.update(_measured(window, s), settled_s=window.start - start, steady_change=change)
    if change <= s.steady_tol:
        record.update(status=OK, error="")
    else:
        message = not_steady_message(window.start - start, first, cap, length, s, worst, change, against)
        if unresolved_orders(window, s.orders):   # aliases of the unresolved orders move between windows
            message += (f"; but at this step the fit reaches only order {nyquist_order(window)} "
                        f"({samples_per_revolution(window):.3g} samples a revolution): the orders above alias onto "
                        "the ones below and differ from window to window, so a smaller step (--step: the note "
                        "gives one) is the likelier remedy")
        record.update(status=NOT_STEADY, error=message)
    return _check_operating_point(window, s, record)


def not_steady_message(settled: float, earlier_start: float, cap: float, length: float, s, worst: str,
                       change: float, against: str = "itself") -> str:
    """Why a point is not steady, with the settle time actually used (the start of the measured window) and, when
    that is past ``max_settle_time`` (cap), why: the criterion needs T >= 4 windows (module docstring), and
    windows are whole revolutions laid back to back from 3T/4, so the last starts up to one window after T."""
    text = (f"not steady after {settled:.4g} s of settling: the {worst} changed by {change:.3g} times {against} "
            f"since {earlier_start:.4g} s (allowed: {s.steady_tol:g} times)")
    if settled > cap * (1.0 + 1e-9):
        windows = (f"measurement windows of {s.revolutions:g} revolution{'' if s.revolutions == 1 else 's'} of "
                   f"{s.running_speed} "
                   f"({length:.3g} s each)")
        if 4.0 * length > cap * (1.0 + 1e-9):
            return text + (f"; that is past max_settle_time = {cap:g} s because the check needs a settle time of at "
                           f"least four {windows}: raise max_settle_time (--max-settle) above "
                           f"{4.0 * length:.3g} s or measure fewer revolutions (--revolutions), or check for an "
                           "unstable or non-periodic response")
        text += (f"; that is past max_settle_time = {cap:g} s by {settled - cap:.3g} s because the check lays whole "
                 f"{windows} back to back")
    return text + "; raise max_settle_time (--max-settle) or check for an unstable or non-periodic response"


def _measured(window, s):
    fits = {}
    out = figures(window, s.outputs, s.orders, fits, phases_wanted=bool(s.running_angle))
    speed = window.table[s.running_speed]
    out["speed_mean"] = float(order_fit(window.angle, speed, fitted_orders(window, s.orders))[0])
    out["note"] = "; ".join(n for n in (unresolved_note(window, s.orders, out["speed_mean"]),
                                        peak_note(window, fits, s.orders, out["speed_mean"])) if n)
    return out


#: a sampled extreme may fall short of a sinusoid's peak by 1 - cos(pi / n) of its amplitude, n samples a period:
#: the max, min and p2p are noted where that exceeds PEAK_SHORTFALL of the order that shapes them
PEAK_SHORTFALL = 0.01
#: the orders that shape a signal's extremes: fitted amplitudes at least this share of its largest
SHAPING_ORDER = 0.05


#: how :func:`peak_note`'s note starts (``Sweep.coarse_peaks`` finds the points by it)
PEAK_NOTE = "max, min and p2p are sample extremes"


def peak_note(window: Window, fits: dict, orders, speed: float) -> str:
    """Why the max, min and p2p may fall short of the peaks ("" when they cannot by more than PEAK_SHORTFALL):
    they are the extremes of the samples at the communication points, and the highest order that shapes an output
    (``SHAPING_ORDER``, of its amplitudes in fits: ``figures``) is read n times a period; the output where that
    costs most, with the step that reads it often enough."""
    steps = (len(window.angle) - 1) * 2.0 * math.pi / max(abs(window.angle[-1] - window.angle[0]), 1e-300)
    fitted, worst = fitted_orders(window, orders), None
    for out, amps in fits.items():
        if grows(out):
            continue
        size = float(np.max(np.abs(window.table[out]))) if out in window.table.dtype.names else 0.0
        if not len(amps) or not amps.max() > PHASE_FLOOR * size:   # nothing, or round-off (no phase either)
            continue
        k = max(j for j, a in zip(fitted, amps) if a >= SHAPING_ORDER * amps.max())
        n = steps / k   # reads a period
        shortfall = 1.0 - math.cos(math.pi / n) if n > 2.0 else 1.0
        if shortfall > PEAK_SHORTFALL and (worst is None or shortfall > worst[0]):
            worst = shortfall, out, k, n
    if worst is None:
        return ""
    shortfall, out, k, n = worst
    step = 2.0 * math.pi / (abs(speed) * k) * math.acos(1.0 - PEAK_SHORTFALL) / math.pi if speed else math.nan
    return (f"{PEAK_NOTE}: {out}'s {k}x order is read {n:.3g} times a period, so they "
            f"may fall short of its peaks by up to {100.0 * shortfall:.2g}% of its amplitude (the fitted order "
            f"amplitudes do not); a step of at most {step:.3g} s (--step) reads it within "
            f"{100.0 * PEAK_SHORTFALL:g}%")


def unresolved_note(window: Window, orders, speed: float) -> str:
    """What a point's NaN order amplitudes mean and how to resolve them ("" when every order is resolved)."""
    unresolved = unresolved_orders(window, orders)
    if not unresolved:
        return ""
    h = float(window.table["time"][1] - window.table["time"][0])
    top = max(unresolved)
    names = ", ".join(f"{k}x" for k in unresolved)
    return (f"order{'s' if len(unresolved) > 1 else ''} {names} not resolved (NaN): "
            f"{samples_per_revolution(window):.3g} samples a revolution at {speed_text(speed)} with a step of "
            f"{h:g} s, where the {top}x order needs at least {4 * top + 2} (its fit must reach order {2 * top}, or "
            f"the orders above alias onto it); take a step of at most {resolving_step(top, speed):.3g} s (--step) "
            "or leave the order out (--orders)")


def speed_text(value: float) -> str:
    """A speed for a human-facing message: SI, with rpm in parentheses (rpm = rad/s * 30 / pi)."""
    return f"{value:.6g} rad/s ({value * 30.0 / math.pi:.6g} rpm)"


def _check_operating_point(window, s, record):
    """Flag the point when a signal's mean misses its set point's mean by more than operating_tol (the pairs are
    drive speeds, rad/s)."""
    record.setdefault("status", OK)
    record.setdefault("error", "")
    for signal, target in s.operating_point:
        value, goal = float(window.table[signal].mean()), float(window.table[target].mean())
        if not abs(value - goal) <= s.operating_tol * max(abs(goal), 1e-12):
            miss = 100.0 * (value - goal) / max(abs(goal), 1e-12)
            message = (f"operating point not reached: {signal} = {speed_text(value)} (mean) against its set point "
                       f"{target} = {speed_text(goal)} ({miss:+.1f}%, allowed "
                       f"{100.0 * s.operating_tol:g}%); a drive at its torque limit cannot hold the speed: raise "
                       "its torque limit or lower the load")
            record["error"] = "; ".join(m for m in (message, record["error"]) if m)
            record["status"] = OFF_TARGET
    return record
