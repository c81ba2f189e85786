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
