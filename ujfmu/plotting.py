"""Plots of scenario results with their references overlaid, and of sweeps (matplotlib, no screen needed).

Units: every axis carries one. A quantity has one display unit in every figure: SI, except lengths in mm
(``DISPLAY_UNITS``); a sweep's abscissa is shown in the unit it was given in (rpm, deg). Tick labels never use
an offset (``1e-12+2.999999999e-2``): a signal constant to within round-off gets a readable band around its value.
"""

import math
import re
import textwrap

from .extras import require

require("matplotlib", "plot", "plotting results")
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
import numpy as np  # noqa: E402

#: SI unit -> (unit shown in plots, factor from SI); units not listed are shown as they are
DISPLAY_UNITS = {"m": ("mm", 1.0e3)}
#: plot title width in characters (wrapped to stay inside the figure)
TITLE_WIDTH = {9: 105, 12: 140}

plt.rcParams.update({"axes.formatter.useoffset": False, "axes.formatter.limits": (-4, 5)})


def display(unit):
    """(label, factor): the unit a quantity in SI unit is shown in, and the factor from SI."""
    shown, factor = DISPLAY_UNITS.get(unit, (unit, 1.0))
    return shown or "1", factor


#: 'name = value unit' and 'value unit' in a title, kept on one line when it wraps
_UNBROKEN = re.compile(r"\S+ = [-+.\w]+(?: (?:deg|rpm|rad/s|rad|N\.m|Hz|kg|mm|m|s)\b)?|\d[\d.]* (?:deg|rpm|rad/s|N\.m|Hz)\b")


def _title(fig, text, width_in):
    glued = _UNBROKEN.sub(lambda m: m.group(0).replace(" ", "\0"), text)
    wrapped = textwrap.fill(glued, TITLE_WIDTH.get(width_in, int(11.5 * width_in)), break_on_hyphens=False)
    fig.suptitle(wrapped.replace("\0", " "), fontsize=9)


def _readable_limits(ax, *series):
    """No offset labels: a (nearly) constant signal gets a band of +-1e-6 of its value (or +-1e-12) around it."""
    values = np.concatenate([np.asarray(s, dtype=float).ravel() for s in series])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return
    lo, hi = values.min(), values.max()
    floor = max(1e-6 * max(abs(lo), abs(hi)), 1e-12)
    if hi - lo < floor:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - floor, mid + floor)


def plot_scenario(result, reference, path):
    """Per plotted signal two panels: the co-simulation with the reference, and below it the error (result -
    reference) with the allowed error when the signal is compared. Returns path."""
    from .scenario_run import shared_instants
    scenario, table = result.scenario, result.table
    # the plotted signals the run recorded (a caller may have recorded fewer since), else every recorded one
    names = [n for n in scenario.plot if n in table.dtype.names] or list(table.dtype.names[1:])
    has_ref = [reference is not None and name in reference.dtype.names for name in names]
    ratios = [r for name, ref in zip(names, has_ref) for r in ((3, 1.4) if ref else (3,))]
    fig, axes = plt.subplots(len(ratios), 1, figsize=(9, 0.75 * sum(ratios) + 1.2), sharex=True, squeeze=False,
                             gridspec_kw={"height_ratios": ratios}, layout="constrained")
    axes = list(axes[:, 0])
    checks = {c.name: c for c in result.checks}
    # a Model Exchange run's tight bands (no step to halve there) are its own: a failing one marks the panel
    banded = {c.name: c for c in result.extrapolated_checks} if result.model_exchange else {}
    t = table["time"]
    for name, ref in zip(names, has_ref):
        label, k = display(scenario.unit(name))
        ax = axes.pop(0)
        ax.plot(t, k * table[name], lw=1.2,
                label="Model Exchange (CVode)" if result.model_exchange else "co-simulation (fmpy)")
        series = [k * table[name]]
        if ref:
            ax.plot(reference["time"], k * reference[name], "--", lw=1.0, label="reference")
            series.append(k * reference[name])
        _readable_limits(ax, *series)
        ax.set_ylabel(f"[{label}]", fontsize=8)
        check = checks.get(name)
        verdict = (f"  ({'ok' if check.passed else 'FAIL'}: max |error| {k * check.max_error:.3g} {label}, allowed "
                   f"{k * check.allowed:.3g} {label})" if check else "  (not compared)" if ref else "")
        if name in banded and not banded[name].passed:
            verdict += f"  (FAIL: its tight band {k * banded[name].allowed:.3g} {label})"
        failed_orders = [c for c in result.order_checks if c.name == name and not c.passed]
        if failed_orders:   # the vibration's check, which the error panel does not show
            verdict += "  (FAIL: " + ", ".join(
                f"{c.order}x order not resolved by the reference" if c.refused else
                f"{c.order}x order {100 * (c.amplitude / c.reference_amplitude - 1):+.3g}%, allowed "
                f"{100 * c.rel:.3g}%" for c in failed_orders) + ")"
        ax.set_title(f"{name}{verdict}", fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        if ref:
            err_ax = axes.pop(0)
            # at the instants both hold, as the check compares (a coarser reference interpolated between its
            # samples would draw its own interpolation error)
            mine, theirs, shared = shared_instants(t, reference["time"])
            at, err = ((t[mine], table[name][mine] - reference[name][theirs]) if shared else
                       (t, table[name] - np.interp(t, reference["time"], reference[name])))
            err_ax.plot(at, k * err, color="tab:red", lw=0.8)
            if check:
                for sign in (1, -1):
                    err_ax.axhline(sign * k * check.allowed, color="0.4", lw=0.8, ls=":")
                # symmetric about zero, the allowance always in view (an error of exactly 0 left matplotlib's
                # default +-0.05 around it, the 1e-9 allowance lines on the zero line)
                reach = max(1.25 * check.allowed, 1.05 * float(np.nanmax(np.abs(err), initial=0.0)))
                if reach > 0.0 and math.isfinite(reach):
                    err_ax.set_ylim(-k * reach, k * reach)
            err_ax.set_ylabel(f"error [{label}]", fontsize=8, color="tab:red")
            err_ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=False)
            err_ax.grid(alpha=0.3)
    fig.axes[-1].set_xlabel("time [s]")
    # the verdict first: after a wrapped title it had read as the title's last words' ("load / step: FAIL")
    _title(fig, f"{result.verdict}: {scenario.title}" + ("  (dotted: allowed error)" if result.checks else ""), 9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _steady(result):
    table = result.table
    return table[table["time"] >= result.scenario.steady_from - 1e-12]


def plot_orbits(result, path):
    """One panel per [x, y] pair of the scenario's output.orbits (from steady_from on). Returns path."""
    scenario, table = result.scenario, _steady(result)
    pairs = scenario.orbits
    fig, axes = plt.subplots(1, len(pairs), figsize=(4.2 * len(pairs), 4.6), squeeze=False, layout="constrained")
    for ax, (x, y) in zip(axes[0], pairs):
        (xl, kx), (yl, ky) = display(scenario.unit(x)), display(scenario.unit(y))
        ax.plot(kx * table[x], ky * table[y], lw=0.7)
        ax.plot(kx * table[x][-1:], ky * table[y][-1:], "o", ms=4, color="tab:red")
        ax.set_xlabel(f"{x} [{xl}]")
        ax.set_ylabel(f"{y} [{yl}]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    _title(fig, f"{scenario.title}: orbits, t >= {scenario.steady_from:g} s (dot: last sample)", 4 * len(pairs))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_spectra(result, path):
    """Amplitude spectrum of each of the scenario's output.spectra (from steady_from on), mean removed (each panel
    names it; with output.running_speed the mean of its fit with the running speed's orders, ``periodic_mean``),
    frequency in orders of the running speed when output.running_speed is given; the panels of one
    output of several components (the aligned and the misaligned rotor's X2) on one scale. Returns path."""
    from .analysis import amplitude_spectrum, periodic_mean

    scenario, table = result.scenario, _steady(result)
    names = scenario.spectra
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.9 * len(names) + 1.0), sharex=True, squeeze=False,
                             layout="constrained")
    scale, unit = 1.0, "Hz"
    if scenario.running_speed:
        scale = 2.0 * np.pi / float(np.mean(table[scenario.running_speed]))
        unit = f"orders of the running speed, 1 = {1.0 / scale:.2f} Hz"
    means = {name: periodic_mean(table["time"], table[name], table[scenario.running_speed]) if scenario.running_speed
             else float(np.mean(table[name])) for name in names}
    spectra = {name: amplitude_spectrum(table["time"], table[name], means[name]) for name in names}
    tops = {}
    for name, (_, amp) in spectra.items():   # the largest amplitude of each output over the components
        key = name.partition(".")[2]
        tops[key] = max(tops.get(key, 0.0), display(scenario.unit(name))[1] * float(amp.max()))
    for ax, name in zip(axes[:, 0], names):
        label, k = display(scenario.unit(name))
        freq, amp = spectra[name]
        amp = k * amp
        ax.semilogy(freq * scale, np.maximum(amp, 1e-30), lw=0.9)
        top = tops[name.partition(".")[2]] or 1.0
        ax.set_ylim(top * 1e-6, top * 3.0)
        ax.set_ylabel(f"amplitude, zero-to-peak [{label}]", fontsize=8)
        ax.set_title(f"{name}, mean {k * means[name]:.4g} {label} (removed)", fontsize=9, loc="left")
        ax.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlim(0, 6 if scenario.running_speed else None)
    axes[-1, 0].set_xlabel(f"frequency [{unit}]")
    _title(fig, f"{scenario.title}: amplitude spectra about the mean (flat-top window), t >= {scenario.steady_from:g} s", 9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


#: marker of each sweep point status other than ok (see ujfmu.steady)
STATUS_MARKERS = {"not_steady": ("x", "tab:red", "not steady"), "off_target": ("v", "tab:purple",
                                                                                "operating point not reached")}


def _plot_points_not_ok(ax, sweep, xs, out, k):
    """Mark the max and min of the points whose status is not_steady or off_target (their figures are kept but are
    not steady-state results), and with a vertical line the points with no figures (an error, not yet computed);
    xs maps records to the first axis' values, k scales to the display unit. Returns whether any were drawn."""
    drawn = False
    for status, (marker, color, text) in STATUS_MARKERS.items():
        rows = [r for r in sweep.records() if r["status"] == status and f"{out}.max" in r]
        if rows:
            x = list(xs(rows))
            ax.plot(x + x, [k * r[f"{out}.max"] for r in rows] + [k * r[f"{out}.min"] for r in rows], marker, color=color,
                    ms=5, ls="none", label=f"{text} ({len(rows)})")
            drawn = True
    empty = [r for r in sweep.records() if r["status"] != "ok" and f"{out}.max" not in r]
    for i, x in enumerate(xs(empty)):
        ax.axvline(x, color="tab:gray", ls=":", lw=1.2,
                   label=None if i else f"no result: error or missing ({len(empty)}, see the CSV)")
        drawn = True
    return drawn


#: the order tracks' log axis reaches down to this fraction of the output's largest order amplitude or |value|:
#: an order that vanishes by symmetry (1e-13 of the others, round-off) sits on this floor instead of stretching
#: the axis over a dozen decades
ORDER_TRACK_FLOOR = 1e-6
#: the share of a Campbell diagram's height each legend row takes, left empty above the data
LEGEND_ROW_SHARE = 0.065
#: outputs the order figure shows at most (a row each), the first of the sweep's
ORDER_FIGURE_OUTPUTS = 6
#: the sweep's order tracks draw up to this many values of the other axes, one line style each
GROUP_STYLES = ("-", "--", ":", "-.")
#: their markers where the points are not joined (sampled rows, a Boolean axis)
GROUP_MARKERS = ("o", "s", "^", "D")
ORDER_FIGURE_GROUPS = len(GROUP_STYLES)
#: at most this many curves (combinations of the other axes) are named in a legend inside the first panel; more
#: go beside the panels, ``LEGEND_COLUMN_ROWS`` to a column
LEGEND_INSIDE, LEGEND_COLUMN_ROWS = 8, 24


def _boolean_axis(axis) -> bool:
    """Whether a sweep axis sets Boolean parameters (its values true and false)."""
    return any(isinstance(v, bool) for v in axis.values)


def plot_sweep(sweep, out_dir):
    """Sweep figures against the first axis (a swept speed if any; in the unit it was given in): results/<name>.png
    with max and min of every output, one curve per combination of the other axes; results/<name>_orders.png with,
    per output, its order amplitudes (order tracks, log scale down to ``ORDER_TRACK_FLOOR`` of the largest) and,
    when the first axis is a speed, a Campbell diagram (frequency of each order against the swept speed, marker area by
    amplitude, with the machines' natural frequencies as labelled lines: a critical speed is where an order
    crosses one) for the first ``ORDER_FIGURE_OUTPUTS`` outputs: the tracks of the first ``ORDER_FIGURE_GROUPS``
    combinations of the other axes (a line style each), the Campbell diagram of the first. Returns the paths."""
    scenario = sweep.scenario
    # a Boolean axis (two values) keys the curves, not the abscissa, unless it is the only axis; sampled points,
    # then a swept speed on x (the orders figure draws only ``ORDER_FIGURE_GROUPS`` curves: a speed among the
    # others would leave most of its resonances out, and the Campbell diagram needs it)
    ordered = sorted(sweep.axes, key=lambda axis: (_boolean_axis(axis), not axis.sampled,
                                                   scenario.unit(axis.names[0]) != "rad/s"))
    first, others = ordered[0], ordered[1:]
    on_off = _boolean_axis(first)
    records = [r for r in sweep.records() if r["status"] == "ok"]
    groups = {}
    for r in records:
        key = tuple(r["point"][ax.names[0]] for ax in others)
        groups.setdefault(key, []).append(r)
    first_si = scenario.unit(first.names[0])

    def axis_unit(ax):
        return ax.unit or display(scenario.unit(ax.names[0]))[0]

    def axis_value(ax, value):
        return ax.display(value) if ax.unit else display(scenario.unit(ax.names[0]))[1] * value

    def value_text(ax, v):
        return str(v).lower() if isinstance(v, bool) else f"{axis_value(ax, v):.4g} {axis_unit(ax)}"

    def label(key):
        return ", ".join(f"{ax.label} = {value_text(ax, v)}" for ax, v in zip(others, key)) or None

    shared = first.sampled and len({row[0] for row in first.values}) < len(first.values)
    xlabel = (first.label if on_off else f"{first.names[0]} [{axis_unit(first)}] (of each sampled point"
              + ("; points sharing it stand on one vertical" if shared else "") + ")"
              if first.sampled else f"{first.label} [{axis_unit(first)}]")
    # the scenario's title may name the value swept here ("30 deg joint"): the figures name the sweep instead
    swept = "; ".join(f"{ax.label} {', '.join(str(v).lower() for v in ax.values)}" if _boolean_axis(ax) else
                      f"{len(ax.values)} sampled points of ({ax.label})" if ax.sampled else
                      f"{ax.label} {axis_value(ax, min(ax.values)):.4g}..{axis_value(ax, max(ax.values)):.4g} "
                      f"{axis_unit(ax)}" for ax in sweep.axes)
    fixed = ", ".join(scenario.change_text(k, v) for k, v in sweep.fixed_parameters().items())   # --set, unswept
    heading = (f"{sweep.name}: {swept}, the rest as in scenario {scenario.name}"
               + (f" ({fixed})" if fixed else ""))

    def xs(rows):
        return np.array([axis_value(first, r["point"][first.names[0]]) for r in rows])

    outputs, orders = sweep.settings.outputs, sweep.settings.orders
    beside = 2.6 * (1 + len(groups) // LEGEND_COLUMN_ROWS) if others and len(groups) > LEGEND_INSIDE else 0.0
    rows = min(len(groups), LEGEND_COLUMN_ROWS) if beside else 0   # the legend's column fits below the title
    fig, axes = plt.subplots(len(outputs), 1, figsize=(9 + beside, max(2.4 * len(outputs), 0.17 * rows) + 1.0),
                             sharex=True, squeeze=False, layout="constrained")
    for ax, out in zip(axes[:, 0], outputs):
        unit, k = display(scenario.unit(out))
        for i, (key, rows) in enumerate(sorted(groups.items())):
            rows = sorted(rows, key=lambda r: r["point"][first.names[0]])
            color = f"C{i % 10}"
            # false and true, or sampled points: markers, not a line between them
            points = on_off or first.sampled
            # past ten curves the colours repeat: each ten then has markers of its own
            mark = "." if i < 10 else GROUP_MARKERS[(i // 10 - 1) % len(GROUP_MARKERS)]
            dot = GROUP_MARKERS[(i // 10) % len(GROUP_MARKERS)]   # "o" for the first ten
            line, size = (dot, 5 if on_off else 3) if points else (f"{mark}-", 3)
            ax.plot(xs(rows), [k * r[f"{out}.max"] for r in rows], line, color=color, ms=size, label=label(key))
            ax.plot(xs(rows), [k * r[f"{out}.min"] for r in rows], line if points else f"{mark}--", color=color,
                    ms=size, mfc="none" if points else None)
        flagged = _plot_points_not_ok(ax, sweep, xs, out, k)
        ax.set_ylabel(f"[{unit}]", fontsize=8)
        extremes = "max (filled), min (open)" if on_off or first.sampled else "max (solid), min (dashed)"
        ax.set_title(f"{out}: {extremes} in steady state over the measured revolutions" + (
            "\npoints not ok marked (legend)" if flagged else ""), fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        if flagged and not others:
            ax.legend(fontsize=7)
    if others and len(groups) > LEGEND_INSIDE:   # beside the panels, in columns, clear of the data
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside right lower", fontsize=6,
                   ncol=1 + len(labels) // LEGEND_COLUMN_ROWS)
    elif others:
        axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel(xlabel)
    if on_off:
        axes[-1, 0].set_xticks([0, 1], ["false", "true"])
        axes[-1, 0].set_xlim(-0.5, 1.5)
    _title(fig, heading, 9)
    main = out_dir / f"{sweep.name}.png"
    fig.savefig(main, dpi=110)
    plt.close(fig)

    campbell = first_si == "rad/s"   # a frequency axis only makes sense against a speed
    shown = outputs[:ORDER_FIGURE_OUTPUTS]
    fig, panels = plt.subplots(len(shown), 2 if campbell else 1, figsize=(12 if campbell else 8,
                               3.6 * len(shown) + 0.8), squeeze=False, layout="constrained")
    # the tracks of up to ORDER_FIGURE_GROUPS values of the other axes (a line style each), the Campbell diagram of
    # the first
    tracked = [(key, sorted(rows, key=lambda r: r["point"][first.names[0]]))
               for key, rows in sorted(groups.items())[:ORDER_FIGURE_GROUPS]] or [((), [])]
    key0, rows = tracked[0]
    x = xs(rows)
    speed_hz = np.array([abs(r["speed_mean"]) / (2 * np.pi) for r in rows])
    if campbell:
        from .analysis import scenario_modes
        modes = sorted(scenario_modes(scenario, rows[0]["point"] if rows else {}), key=lambda m: m.omega)
    else:
        modes = []
    def group_style(g: int) -> dict:
        """A line style per combination of the other axes; unjoined markers where the points are sampled rows or
        false and true (a line between them would read as a trend)."""
        if on_off or first.sampled:
            return dict(ls="none", marker=GROUP_MARKERS[g], ms=4, mfc="none" if g else None)
        return dict(ls=GROUP_STYLES[g], marker="." if len(tracked[g][1]) <= 40 else None, ms=3)

    for (ax1, *ax2), out in zip(panels, shown):
        unit, k = display(scenario.unit(out))
        amplitudes = {order: np.array([r[f"{out}.h{order}"] for r in rows], dtype=float) for order in orders}
        # the axis floor from the largest order or |value| (an order of round-off on a constant is not a track)
        every = [r for _, group in tracked for r in group]
        top = float(np.nanmax([r[f"{out}.h{order}"] for r in every for order in orders] or [0.0], initial=0.0))
        scale = max([top] + [max(abs(r[f"{out}.max"]), abs(r[f"{out}.min"])) for r in every])
        floor = k * scale * ORDER_TRACK_FLOOR if scale > 0.0 else 1e-300
        clipped = False
        unresolved = sorted({order for r in every for order in orders if np.isnan(r[f"{out}.h{order}"])})
        for g, (key, group) in enumerate(tracked):
            for i, order in enumerate(orders):
                amp = np.array([r[f"{out}.h{order}"] for r in group], dtype=float)
                clipped |= bool(np.any(k * amp < floor))
                ax1.semilogy(xs(group), np.maximum(k * amp, floor), color=f"C{i % 10}", **group_style(g))
        if scale > 0.0:
            ax1.set_ylim(bottom=0.5 * floor)
            if clipped:   # the floor shaded and named, so that a track on it does not read as a small order
                ax1.axhspan(0.5 * floor, floor * 1.05, color="0.88", zorder=0)
                ax1.text(0.01, floor * 1.15, f"floor: {ORDER_TRACK_FLOOR:g} of the largest", fontsize=7,
                         color="0.35", transform=ax1.get_yaxis_transform())
        ax1.set_xlabel(xlabel)
        if on_off:
            ax1.set_xticks([0, 1], ["false", "true"])
            ax1.set_xlim(-0.5, 1.5)
        ax1.set_ylabel(f"order amplitude, zero-to-peak [{unit}]")
        # orders by colour, in one legend placed clear of the data; with several values of the other axes, those by
        # line style in a second legend at the foot (two legends placed "best" are each blind to the other: one
        # legend of both covered a grid's tracks), or, for unjoined markers (which may sit anywhere, the floor's
        # corners too), by marker in the one legend
        handles = [Line2D([], [], color=f"C{i % 10}") for i in range(len(orders))]
        names = [f"{order}x" for order in orders]
        styles = ([Line2D([], [], color="0.3", **group_style(g)) for g in range(len(tracked))],
                  [label(key) for key, _ in tracked]) if len(tracked) > 1 else ([], [])
        if on_off or first.sampled or not styles[0]:
            ax1.legend(handles + styles[0], names + styles[1], fontsize=7, loc="best")
        else:
            ax1.add_artist(ax1.legend(handles, names, fontsize=8, loc="upper right"))
            ax1.legend(*styles, fontsize=7, loc="lower right")
        ax1.grid(alpha=0.3, which="both")
        ax1.set_title(f"{out}: order tracks" + (f" ({label(key0)})" if label(key0) and len(tracked) == 1 else "")
                      + (f"\norders below {ORDER_TRACK_FLOOR:g} of its largest order or |value| drawn on the floor"
                         if clipped else "")
                      + (f"\n{', '.join(f'{o}x' for o in unresolved)} missing where the step does not resolve it "
                         "(NaN in the table)" if unresolved else ""), fontsize=9, loc="left")
        if campbell:
            ax2 = ax2[0]
            for order, amp in amplitudes.items():
                seen = np.where(k * amp >= floor, amp, 0.0)   # those on the tracks' floor: the smallest marker
                resolved = ~np.isnan(amp)                       # unresolved orders: no marker
                ax2.scatter(x[resolved], order * speed_hz[resolved], s=2 + 200 * seen[resolved] / (top or 1.0),
                            alpha=0.6, label=f"{order}x")
            banded = False
            span = max(np.ptp(ax2.get_ylim()), 1e-12)
            # a label goes below its line where the next mode's line is close above (its label goes above)
            below = [b.omega - a.omega < 0.04 * span * 2 * np.pi for a, b in zip(modes, modes[1:])] + [False]
            for i, mode in enumerate(modes):
                component, omega_n, count, low, high = mode.component, mode.omega, mode.count, mode.low, mode.high
                f_n = omega_n / (2 * np.pi)
                ax2.axhline(f_n, color="0.35", ls=":", lw=0.9,
                            label="natural frequencies (at rest; input held: mean over the input angle, "
                                  "free: at angle 0)" if i == 0 else None)
                if high > 1.005 * low:   # the range the linearisation spans over the input angle
                    ax2.axhspan(low / (2 * np.pi), high / (2 * np.pi), color="0.5", alpha=0.15, lw=0,
                                label=None if banded else "their range over the input angle")
                    banded = True
                ax2.annotate(f"{component}: {f_n:.4g} Hz ({omega_n:.4g} rad/s, {mode.kind.partition(',')[0]})"
                             + (f", {count} modes" if count > 1 else ""),
                             xy=(0.99, f_n), xycoords=("axes fraction", "data"), ha="right",
                             va="top" if below[i] else "bottom", fontsize=6, color="0.25",
                             bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none", alpha=0.7))   # over markers
            ax2.set_xlabel(xlabel)
            ax2.set_ylabel("frequency [Hz]")
            ax2.set_title(f"Campbell diagram of {out} (marker area ~ amplitude)"
                          + (f"\n{label(key0)}" if len(tracked) > 1 else ""), fontsize=9, loc="left")
            ax2.grid(alpha=0.3)
            # the legend in a band left empty above the markers and the modes' lines (upper left had covered an
            # order's markers where they rise across the top, and a mode's label), its markers of one size (the
            # first point's had set each)
            legend_rows = len(amplitudes) + (1 if modes else 0) + (1 if banded else 0)
            low, high = ax2.get_ylim()
            ax2.set_ylim(low, high + LEGEND_ROW_SHARE * legend_rows / (1.0 - LEGEND_ROW_SHARE * legend_rows)
                         * (high - low))
            legend = ax2.legend(fontsize=7, loc="upper left")
            for handle in legend.legend_handles:
                if hasattr(handle, "set_sizes"):
                    handle.set_sizes([20.0])
    names = ", ".join(shown) + (f" (the first {len(shown)} of {len(outputs)} outputs; --output chooses)"
                                if len(shown) < len(outputs) else "")
    left_out = [f"{len(groups) - len(tracked)} other value(s) of {', '.join(ax.label for ax in others)}"] \
        if len(groups) > len(tracked) else []
    not_ok = [r for r in sweep.records() if r["status"] != "ok"]
    left_out += [f"{len(not_ok)} point(s) not ok (marked in {sweep.name}.png)"] if not_ok else []
    _title(fig, f"{heading}: running-speed orders of {names}"
           + (f"; not drawn: {', '.join(left_out)} (all in {sweep.name}.csv)" if left_out else ""),
           12 if campbell else 8)
    orders_path = out_dir / f"{sweep.name}_orders.png"
    fig.savefig(orders_path, dpi=110)
    plt.close(fig)
    return [main, orders_path]
