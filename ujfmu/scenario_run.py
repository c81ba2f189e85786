"""Run scenarios, compare them with their references, write results, plots and JUnit reports."""

import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy.util import validate_result, write_csv

from .build import DEFAULT_FMU_DIR
from .master import CosimulationError, cosimulate
from .references import read_reference
from .scenario import Scenario

DEFAULT_OUT_DIR = Path("results")


@dataclass
class SignalCheck:
    name: str
    max_error: float
    allowed: float
    reference_range: float

    @property
    def passed(self):
        return bool(self.max_error <= self.allowed)

    def __str__(self):
        verdict = "ok  " if self.passed else "FAIL"
        return (f"{verdict} {self.name:20s} max|err| = {self.max_error:.3e}  allowed {self.allowed:.3e}  "
                f"({100 * self.max_error / self.reference_range if self.reference_range else 0:.4f}% of range)")


@dataclass
class ScenarioResult:
    scenario: Scenario
    table: np.ndarray
    checks: list = field(default_factory=list)
    extrapolated_checks: list = field(default_factory=list)   # step-halving extrapolation, [reference.extrapolated]
    fmpy_outlier_fraction: float = float("nan")
    wall_time: float = 0.0
    csv: Path = None
    plot: Path = None
    extra_plots: list = field(default_factory=list)   # orbits and spectra, when the scenario asks for them

    @property
    def passed(self):
        return all(c.passed for c in self.checks + self.extrapolated_checks)

    def summary(self):
        head = (f"{'PASS' if self.passed else 'FAIL'} {self.scenario.name}: {self.scenario.title} "
                f"({self.wall_time:.1f} s wall)")
        lines = [head] + [f"  {c}" for c in self.checks]
        if self.extrapolated_checks:
            lines.append(f"  step-halving extrapolation 2 y(h/2) - y(h), h = {self.scenario.step_size:g} s:")
            lines += [f"  {c}" for c in self.extrapolated_checks]
        lines += [f"  not compared: {name}: {why}" for name, why in self.scenario.not_compared.items()]
        lines.append(f"  fmpy.util.validate_result: fraction of samples outside fmpy's band = "
                     f"{self.fmpy_outlier_fraction:.4f}")
        return "\n".join(lines)


def compare(table, reference, tolerances):
    """Check each toleranced signal: max |result - reference| <= rel_range*(range of reference) + abs, the
    reference interpolated linearly to the result's times."""
    checks = []
    for name, tol in tolerances.items():
        if name not in reference.dtype.names:
            raise KeyError(f"signal '{name}' has a tolerance but is not in the reference")
        y_ref = np.interp(table["time"], reference["time"], reference[name])
        span = float(np.ptp(reference[name]))
        err = float(np.max(np.abs(table[name] - y_ref)))
        checks.append(SignalCheck(name, err, tol.rel_range * span + tol.abs, span))
    return checks


def extrapolate_step(scenario: Scenario, fmu_dir=DEFAULT_FMU_DIR, coarse: np.ndarray | None = None) -> np.ndarray:
    """Richardson extrapolation 2 y(h/2) - y(h) of the recorded signals on the scenario's grid (step h).

    It cancels a coupling error c*h + O(h^2) (inputs held over each step), leaving O(h^2). coarse: the run at h
    when it is already at hand.
    """
    h = scenario.step_size
    if coarse is None:
        coarse = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time, h,
                            scenario.record, scenario.start_time, coupling=scenario.coupling)
    fine = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time, h / 2,
                      scenario.record, scenario.start_time, coupling=scenario.coupling)[::2]
    out = coarse.copy()
    for name in scenario.record:
        out[name] = 2.0 * fine[name] - coarse[name]
    return out


def run_scenario(path, fmu_dir=DEFAULT_FMU_DIR, out_dir=DEFAULT_OUT_DIR, plot=True, progress=True):
    """Co-simulate a scenario, compare with its reference; write CSV (and PNG) into out_dir.

    Returns a ScenarioResult whose .table is the result (structured array, 'time' + 'comp.var' columns).
    """
    scenario = path if isinstance(path, Scenario) else Scenario(path)
    scenario.check_fmus(fmu_dir)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=int(round((scenario.stop_time - scenario.start_time) / scenario.step_size)),
                   desc=scenario.name, unit="step", leave=False)

    def report(done, total):
        bar.update(done - bar.n)

    start = time.perf_counter()
    try:
        table = cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time,
                           scenario.step_size, scenario.record, scenario.start_time,
                           progress=report if bar else None, coupling=scenario.coupling)
    except CosimulationError as exc:
        if exc.partial is not None and out_dir is not None:
            _write_partial(scenario, exc, Path(out_dir), plot)
        raise
    finally:
        if bar:
            bar.close()
    result = ScenarioResult(scenario, table, wall_time=time.perf_counter() - start)
    reference = None
    if scenario.reference_file is not None:
        reference, _ = read_reference(scenario.reference_file)
        result.checks = compare(table, reference, scenario.tolerances)
        # fmpy's band scales with each signal's range: a signal constant to within its absolute tolerance (say the
        # output speed of a constant-velocity layout) is checked by compare() alone
        compared = ["time"] + [c.name for c in result.checks if c.reference_range > scenario.tolerances[c.name].abs]
        result.fmpy_outlier_fraction = float(validate_result(table[compared], reference[compared]))
        if scenario.extrapolated_tolerances:
            result.extrapolated_checks = compare(extrapolate_step(scenario, fmu_dir, table), reference,
                                                 scenario.extrapolated_tolerances)
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        result.csv = out_dir / f"{scenario.name}.csv"
        write_csv(result.csv, table)
        if plot:
            from .plotting import plot_orbits, plot_scenario, plot_spectra
            result.plot = plot_scenario(result, reference, out_dir / f"{scenario.name}.png")
            if scenario.orbits:
                result.extra_plots.append(plot_orbits(result, out_dir / f"{scenario.name}_orbits.png"))
            if scenario.spectra:
                result.extra_plots.append(plot_spectra(result, out_dir / f"{scenario.name}_spectra.png"))
    return result


def _write_partial(scenario, exc, out_dir, plot):
    """Write the results up to a failure (CSV, plot) and name them in the error's message."""
    out_dir.mkdir(parents=True, exist_ok=True)
    csv = out_dir / f"{scenario.name}.csv"
    write_csv(csv, exc.partial)
    written = [f"results up to t = {float(exc.partial['time'][-1])!r}: {csv}"]
    if plot and len(exc.partial) > 1:
        from .plotting import plot_scenario
        written.append(f"plot: {plot_scenario(ScenarioResult(scenario, exc.partial), None, out_dir / f'{scenario.name}.png')}")
    exc.args = (f"{exc.args[0] if exc.args else exc}\n" + "\n".join(written),)


def write_junit(results, path):
    """JUnit XML: one test case per scenario, a failure element carrying the error figures."""
    suite = ET.Element("testsuite", name="ujfmu scenarios", tests=str(len(results)),
                       failures=str(sum(not r.passed for r in results)), errors="0",
                       time=f"{sum(r.wall_time for r in results):.3f}")
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="ujfmu.scenarios", name=r.scenario.name,
                             time=f"{r.wall_time:.3f}")
        if not r.passed:
            failure = ET.SubElement(case, "failure", message="signal outside tolerance of the reference")
            failure.text = r.summary()
        ET.SubElement(case, "system-out").text = r.summary()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
    return path
