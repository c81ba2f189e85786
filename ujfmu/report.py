"""``ujfmu report``: docs/validation.md, every quantitative result of the five papers next to ours.

This module is the report engine: sections, rows and verdicts, the published values (each model's
``published.toml``), sweeps whose points are found by their axis values, and the markdown. The sections
themselves are each model's ``validation.py`` (``SECTIONS`` there), in the order of ``VALIDATED``.

Every "ours" number comes from co-simulating the built FMUs (fmpy, the scenarios in scenarios/) through
``ujfmu.sweep``: a sweep point is a full co-simulation run to a checked steady state (``ujfmu.steady``), and a
section uses only points whose status is ok. The closed forms we compare with
are the papers' own equations. The report is generated, never edited: tests/test_report.py regenerates it and
compares the text with the committed file. The derivations behind each verdict are in the per-model docs.
"""

import importlib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .build import DEFAULT_FMU_DIR, PACKAGE_DIR, REPO_DIR
from .scenario import Scenario
from .steady import FLOOR, GROWTH
from .sweep import Sweep, SweepSettings, close_client, dask_client

SCENARIOS = REPO_DIR / "scenarios"
MODELS = PACKAGE_DIR / "models"
RPM = math.pi / 30.0

#: the model folders whose validation.py adds sections to the report, in the report's order
VALIDATED = ("cardan_joint", "double_cardan_driveline", "twin_jeffcott_rotor", "ring_coupling")


@dataclass(frozen=True)
class Published:
    """One published value (a row of a model's published.toml): the paper's key, where it is printed, the report
    row's quantity, the value and its unit, the band (relative to the value) within which ours is reproduced
    (None: compared with a closed form), and the figure's conditions (sweep axis values)."""
    id: str
    paper: str
    figure: str
    quantity: str
    value: float
    unit: str
    band: float | None = None
    conditions: dict = field(default_factory=dict)


def published(stem: str) -> dict:
    """id -> Published of ujfmu/models/<stem>/published.toml."""
    with open(MODELS / stem / "published.toml", "rb") as f:
        return {row["id"]: Published(**row) for row in tomllib.load(f)["published"]}


class Points:
    """The points of a sweep, found by their axis values (to 1e-9 relative, so a value computed again in another
    unit matches), not by exact float keys."""

    def __init__(self, rows: list):
        self.rows = rows

    def where(self, values: dict) -> list:
        """The points whose axis values match values ({"component.parameter": SI value, ...}), in sweep order."""
        return [r for r in self.rows
                if all(math.isclose(r["point"][name], v, rel_tol=1e-9, abs_tol=1e-12) for name, v in values.items())]

    def at(self, values: dict) -> dict:
        """The one point at values; KeyError naming them when there is none or more than one."""
        found = self.where(values)
        if len(found) != 1:
            raise KeyError(f"{len(found)} sweep points at {values}")
        return found[0]

    def sorted_by(self, name: str) -> list:
        """Every point, ordered by the axis value name."""
        return sorted(self.rows, key=lambda r: r["point"][name])


@dataclass
class Section:
    title: str
    intro: str
    rows: list = field(default_factory=list)
    figures: list = field(default_factory=list)   # (file name in docs/figures, caption)
    notes: str = ""

    def row(self, quantity, paper, ours, unit, verdict, paper_text=None, ours_text=None):
        """paper, ours: numbers (or None); the difference is relative to the paper."""
        diff = "" if not isinstance(paper, (int, float)) or not isinstance(ours, (int, float)) or paper == 0 \
            else f"{100.0 * (ours - paper) / abs(paper):+.1f}%"
        self.rows.append((quantity, paper_text or _fmt(paper), ours_text or _fmt(ours), unit, diff, verdict))


def _fmt(value):
    return "-" if value is None else (f"{value:.4g}" if isinstance(value, (int, float)) else str(value))


def below(value):
    """'< 1e-9' for a residual (round-off or what is left of a transient): its decade, not its digits, which a
    different floating-point library would change."""
    return f"< 1e{math.ceil(math.log10(value))}" if value > 0 else "0"


def within(ours, paper, rel):
    return abs(ours - paper) <= rel * abs(paper)


def verdict(ours, paper, rel, trend=None):
    """'reproduced (within rel)' when ours is within rel of paper; else, where trend = (text, holds) names the
    effect the paper shows and whether ours shows it (checked by the caller: a direction, a sign), 'reproduced in
    trend: text' if it holds; otherwise 'not reproduced'."""
    if within(ours, paper, rel):
        return f"reproduced (within {100 * rel:.0f}%)"
    if trend is not None and trend[1]:
        return f"reproduced in trend: {trend[0]}"
    return "not reproduced" + (f": {trend[0]}" if trend is not None else "")


def peak(xs, ys):
    """(x, y) of the maximum of ys, refined by the parabola through the top three points."""
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    i = int(np.argmax(ys))
    if 0 < i < len(ys) - 1:
        y0, y1, y2 = ys[i - 1:i + 2]
        denom = y0 - 2 * y1 + y2
        if denom < 0:
            shift = 0.5 * (y0 - y2) / denom
            return float(xs[i] + shift * (xs[i + 1] - xs[i])), float(y1 - 0.25 * (y0 - y2) * shift)
    return float(xs[i]), float(ys[i])


class Report:
    """Runs the sweeps (sharing one dask client) and collects the sections."""

    def __init__(self, fmu_dir=DEFAULT_FMU_DIR, work_dir=Path("results") / "report", workers=None,
                 progress=None):
        self.fmu_dir, self.work_dir = Path(fmu_dir), Path(work_dir)
        self.workers, self.progress = workers, progress
        self.client = None
        self.sweeps = {}

    def sweep(self, scenario: str, name: str, axes: list, **settings) -> tuple:
        """Run (or resume) a sweep of scenarios/<scenario>.toml over axes (ujfmu.sweep.Axis); returns its Points and
        the Sweep."""
        sc = Scenario(SCENARIOS / f"{scenario}.toml")
        sw = Sweep(sc, axes, SweepSettings.from_scenario(sc, **settings),
                   out_dir=self.work_dir, name=name, fmu_dir=self.fmu_dir)
        if self.client is None and self.workers != 0:
            self.client = dask_client(self.workers)
        sw.run(workers=self.workers, progress=self.progress, client=self.client)
        failed = sw.failed()
        if failed:
            raise RuntimeError(f"sweep {name}: {len(failed)} points not ok ({failed[0]['status']}), first: "
                               f"{failed[0]['error']}")
        self.sweeps[name] = sw
        return Points(sw.table()), sw

    def close(self):
        if self.client is not None:
            close_client(self.client)
            self.client = None


def settled_text(sweep):
    """'1.9 s' or '1.9-3.8 s': the settle times the points of a sweep needed."""
    times = sorted({round(r["settled_s"], 2) for r in sweep.table()})
    return f"{times[0]:g} s" if len(times) == 1 else f"{times[0]:g}-{times[-1]:g} s"


def section_functions() -> list:
    """The section functions of every validated model, in the report's order."""
    return [section for stem in VALIDATED
            for section in importlib.import_module(f"ujfmu.models.{stem}.validation").SECTIONS]


def write_report(path=Path("docs") / "validation.md", fmu_dir=DEFAULT_FMU_DIR, work_dir=None, workers=None,
                 progress=None):
    """Run every section's sweeps and write the report (and its figures in docs/figures next to it).

    It runs the scenarios of the ujfmu clone (an editable install); paths are relative to the current directory.
    progress: optional callable(points_done, points_total) of each sweep. Returns the Report, with ``.sections``
    and ``.sweeps`` (name -> Sweep) for inspection."""
    if not SCENARIOS.is_dir():
        raise FileNotFoundError(f"the report runs the scenarios of a ujfmu clone ({SCENARIOS} not found): run it "
                                "from a clone with an editable install (pip install -e '.[report]')")
    path = Path(path)
    rep = Report(fmu_dir, work_dir or Path("results") / "report", workers, progress)
    rep.figure_dir = path.parent / "figures"
    rep.figure_dir.mkdir(parents=True, exist_ok=True)
    try:
        sections = [section(rep) for section in section_functions()]
    finally:
        rep.close()
    path.write_text(render(sections))
    rep.path, rep.sections = path, sections
    return rep


def render(sections):
    counts = {}
    for s in sections:
        for row in s.rows:
            key = row[5].split(" (")[0].split(":")[0].split(";")[0]
            counts[key] = counts.get(key, 0) + 1
    lines = ["# Validation against the papers", "",
             "Generated by `ujfmu report`; do not edit by hand (tests/test_report.py regenerates it and compares). "
             "\"Paper\" is the published value, \"ours\" comes from co-simulating the built FMUs with fmpy "
             "(`ujfmu.sweep`: every point a full co-simulation run to steady state); the difference is relative to "
             "the paper. Verdicts: reproduced (within the stated band), reproduced in trend (the effect and its "
             "direction, checked, not the value), not reproduced (the reason is in the notes and the model docs); "
             "consistent (a closed form or identity of the paper's own inputs, or arithmetic on ours: it checks our "
             "reading of the paper, not the model against a published result), no published value (ours only).", "",
             "Steady state is checked, not assumed (`ujfmu.steady`): a point's figures (the mean and the "
             "running-speed order amplitudes of every output) over the measuring window at the settle time T "
             "must agree with those over every window back to 3T/4 (back-to-back windows) within "
             f"{SweepSettings.steady_tol:g} of themselves (or of {FLOOR:g} x the output's size: its largest "
             f"figure, or half its peak-to-peak where larger); otherwise T grows by {GROWTH:g}x, up to 8 times the "
             "first. A transient "
             "decaying as exp(-sigma t) leaves less than the change measured once sigma T >= 4 ln 2. Only points "
             "that pass, and whose motor reached its set speed, enter the tables; a section says where a "
             "measurement is deliberately taken without the check.", "",
             "Verdict count: " + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) + ".", ""]
    for s in sections:
        lines += [f"## {s.title}", "", s.intro, "",
                  "| quantity | paper | ours | unit | difference | verdict |", "| --- | --- | --- | --- | --- | --- |"]
        lines += ["| " + " | ".join(row) + " |" for row in s.rows]
        lines.append("")
        if s.notes:
            lines += [s.notes, ""]
        for name, caption in s.figures:
            lines += [f"![{caption}](figures/{name})", ""]
    return "\n".join(lines)
