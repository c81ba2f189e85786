"""Plots of scenario results with their references overlaid (matplotlib, no screen needed)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_scenario(result, reference, path):
    """One panel per plotted signal: co-simulation and reference; error on a twin axis. Returns path."""
    scenario, table = result.scenario, result.table
    names = scenario.plot
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 2.2 * len(names) + 0.6), sharex=True, squeeze=False)
    checks = {c.name: c for c in result.checks}
    for ax, name in zip(axes[:, 0], names):
        ax.plot(table["time"], table[name], lw=1.2, label="co-simulation (fmpy)")
        if reference is not None and name in reference.dtype.names:
            ax.plot(reference["time"], reference[name], "--", lw=1.0, label="reference")
            err = table[name] - np.interp(table["time"], reference["time"], reference[name])
            twin = ax.twinx()
            twin.plot(table["time"], err, color="tab:red", lw=0.6, alpha=0.6)
            twin.set_ylabel("error", color="tab:red", fontsize=8)
            twin.tick_params(axis="y", labelsize=7, colors="tab:red")
        check = checks.get(name)
        title = name + (f"  [{'ok' if check.passed else 'FAIL'}: max|err| {check.max_error:.2e} "
                        f"<= {check.allowed:.2e}]" if check else "")
        ax.set_title(title, fontsize=9, loc="left")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="upper left")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"{scenario.title} — {'PASS' if result.passed else 'FAIL'}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _steady(result):
    table = result.table
    return table[table["time"] >= result.scenario.steady_from - 1e-12]


def plot_orbits(result, path):
    """One panel per [x, y] pair of the scenario's output.orbits (from steady_from on), in mm. Returns path."""
    scenario, table = result.scenario, _steady(result)
    pairs = scenario.orbits
    fig, axes = plt.subplots(1, len(pairs), figsize=(4.2 * len(pairs), 4.4), squeeze=False)
    for ax, (x, y) in zip(axes[0], pairs):
        ax.plot(1e3 * table[x], 1e3 * table[y], lw=0.7)
        ax.plot(1e3 * table[x][-1:], 1e3 * table[y][-1:], "o", ms=4, color="tab:red")
        ax.set_xlabel(f"{x} [mm]")
        ax.set_ylabel(f"{y} [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{scenario.title}\norbits, t >= {scenario.steady_from:g} s (dot: last sample)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_spectra(result, path):
    """Amplitude spectrum of each of the scenario's output.spectra (from steady_from on), frequency in orders of
    the running speed when output.running_speed is given. Returns path."""
    from .analysis import amplitude_spectrum

    scenario, table = result.scenario, _steady(result)
    names = scenario.spectra
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.9 * len(names) + 0.8), sharex=True, squeeze=False)
    scale, unit = 1.0, "Hz"
    if scenario.running_speed:
        scale = 2.0 * np.pi / float(np.mean(table[scenario.running_speed]))
        unit = f"orders of the running speed ({1.0 / scale:.2f} Hz)"
    for ax, name in zip(axes[:, 0], names):
        freq, amp = amplitude_spectrum(table["time"], table[name])
        ax.semilogy(freq * scale, np.maximum(amp, 1e-30), lw=0.9)
        top = amp.max() if amp.max() > 0 else 1.0
        ax.set_ylim(top * 1e-6, top * 3.0)
        ax.set_title(name, fontsize=9, loc="left")
        ax.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlim(0, 6 if scenario.running_speed else None)
    axes[-1, 0].set_xlabel(f"frequency [{unit}]")
    fig.suptitle(f"{scenario.title}\namplitude spectra (Hann window), t >= {scenario.steady_from:g} s", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


#: marker of each sweep point status other than ok (see ujfmu.steady)
STATUS_MARKERS = {"not_steady": ("x", "tab:red", "not steady"), "off_target": ("v", "tab:purple",
                                                                                "operating point not reached")}


def _plot_points_not_ok(ax, sweep, first, out):
    """Mark the max and min of the points whose status is not_steady or off_target (their figures are kept but are
    not steady-state results). Returns whether any were drawn."""
    drawn = False
    for status, (marker, color, text) in STATUS_MARKERS.items():
        rows = [r for r in sweep.table() if r["status"] == status and f"{out}.max" in r]
        if rows:
            x = [first.display(r["point"][first.names[0]]) for r in rows]
            ax.plot(x + x, [r[f"{out}.max"] for r in rows] + [r[f"{out}.min"] for r in rows], marker, color=color,
                    ms=5, ls="none", label=f"{text} ({len(rows)})")
            drawn = True
    return drawn


def plot_sweep(sweep, out_dir):
    """Sweep figures against the first axis (in the unit it was given in): results/<name>.png with max and min of
    every output, one curve per combination of the other axes; results/<name>_orders.png with the order
    amplitudes (order tracks, log scale) and a Campbell-style diagram (frequency of each order against the
    swept value, marker area by amplitude) of the first output. Returns the paths."""
    first, others = sweep.axes[0], sweep.axes[1:]
    records = [r for r in sweep.table() if r["status"] == "ok"]
    groups = {}
    for r in records:
        key = tuple(r["point"][ax.names[0]] for ax in others)
        groups.setdefault(key, []).append(r)

    def label(key):
        return ", ".join(f"{ax.label} = {ax.display(v):.4g}{' ' + ax.unit if ax.unit else ''}"
                         for ax, v in zip(others, key)) or None

    xlabel = f"{first.label} [{first.unit or 'SI'}]"
    outputs, orders = sweep.settings.outputs, sweep.settings.orders
    fig, axes = plt.subplots(len(outputs), 1, figsize=(9, 2.4 * len(outputs) + 0.8), sharex=True, squeeze=False)
    for ax, out in zip(axes[:, 0], outputs):
        for i, (key, rows) in enumerate(sorted(groups.items())):
            rows = sorted(rows, key=lambda r: r["point"][first.names[0]])
            x = [first.display(r["point"][first.names[0]]) for r in rows]
            color = f"C{i % 10}"
            ax.plot(x, [r[f"{out}.max"] for r in rows], ".-", color=color, ms=3, label=label(key))
            ax.plot(x, [r[f"{out}.min"] for r in rows], ".--", color=color, ms=3)
        flagged = _plot_points_not_ok(ax, sweep, first, out)
        ax.set_title(f"{out}: max (solid), min (dashed) in steady state" + (
            "; points not ok marked by status (max and min)" if flagged else ""), fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        if flagged and not others:
            ax.legend(fontsize=7)
    if others:
        axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel(xlabel)
    fig.suptitle(f"{sweep.scenario.title}: sweep of {first.label}", fontsize=10)
    fig.tight_layout()
    main = out_dir / f"{sweep.name}.png"
    fig.savefig(main, dpi=110)
    plt.close(fig)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    out = outputs[0]
    key0, rows = sorted(groups.items())[0] if groups else ((), [])
    rows = sorted(rows, key=lambda r: r["point"][first.names[0]])
    x = np.array([first.display(r["point"][first.names[0]]) for r in rows])
    for k in orders:
        amp = np.array([r[f"{out}.h{k}"] for r in rows])
        ax1.semilogy(x, np.maximum(amp, 1e-300), ".-", ms=3, label=f"{k}x")
    ax1.set_xlabel(xlabel)
    ax1.set_ylabel(f"{out} order amplitude")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3, which="both")
    ax1.set_title("order tracks" + (f" ({label(key0)})" if label(key0) else ""), fontsize=9, loc="left")
    speed_hz = np.array([abs(r["speed_mean"]) / (2 * np.pi) for r in rows])
    top = max((r[f"{out}.h{k}"] for r in rows for k in orders), default=1.0) or 1.0
    for k in orders:
        amp = np.array([r[f"{out}.h{k}"] for r in rows])
        ax2.scatter(x, k * speed_hz, s=2 + 200 * amp / top, alpha=0.6, label=f"{k}x")
    ax2.set_xlabel(xlabel)
    ax2.set_ylabel("frequency [Hz]")
    ax2.set_title(f"Campbell diagram of {out} (marker area ~ amplitude)", fontsize=9, loc="left")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    orders_path = out_dir / f"{sweep.name}_orders.png"
    fig.savefig(orders_path, dpi=110)
    plt.close(fig)
    return [main, orders_path]
