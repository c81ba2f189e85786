"""Command line: ujfmu build | run | check | references | sweep | modes | variables | export-ssp | bench | battery |
report | mutate.

The folders fmus/, scenarios/ and results/ are those of the current directory. The common options (--fmu-dir,
--out, --quiet) go before or after the command. The library reports progress through callbacks; this module
alone draws progress bars (tqdm, on a terminal; sweeps off a terminal print plain progress lines)."""

import argparse
import atexit
import contextlib
import difflib
import math
import os
import re
import signal
import sys
import time
import traceback
import warnings
from pathlib import Path

from .build import DEFAULT_FMU_DIR, FMUS, PACKAGE_DIR, REPO_DIR
from .extras import MissingExtraError, available, require

DEFAULT_SCENARIO_DIR = Path("scenarios")
DEFAULT_OUT_DIR = Path("results")


class UsageError(Exception):
    """A command-line mistake: printed as an error with exit status 2."""


def _scenarios(paths, left_out: list | None = None):
    """The scenario files named, a folder standing for its *.toml files (not its subfolders', which a note names
    and left_out gets as (subfolder, how many scenario files)); default: scenarios/*.toml."""
    if paths:
        found = []
        for path in map(Path, paths):
            if path.is_dir():
                inside = sorted(path.glob("*.toml"))
                if not inside:
                    raise UsageError(f"{path} is a folder without scenario files (*.toml)")
                found += inside
                (left_out if left_out is not None else []).extend(_note_subfolders(path, paths))
            else:
                found.append(path)
        return found
    found = sorted(DEFAULT_SCENARIO_DIR.glob("*.toml"))
    if not found:
        raise UsageError(f"no scenario files (*.toml) in {DEFAULT_SCENARIO_DIR.absolute()}: name scenario files, "
                         "or run this in a folder that has a scenarios/ folder")
    (left_out if left_out is not None else []).extend(_note_subfolders(DEFAULT_SCENARIO_DIR, []))
    return found


def _note_subfolders(folder: Path, named) -> list:
    """A note on stderr naming the subfolders of folder that hold scenario files not taken (a folder stands for its
    own *.toml), unless named too; the bundled coupling battery (``ujfmu battery`` runs it) goes unsaid. Returns
    them, (subfolder, how many scenario files)."""
    from .battery import BATTERY_DIR
    named = {Path(p).resolve() for p in named}
    left = [(sub, len(list(sub.rglob("*.toml")))) for sub in sorted(folder.iterdir())
            if sub.is_dir() and sub.resolve() not in named and sub.resolve() != BATTERY_DIR.resolve()
            and any(sub.rglob("*.toml"))]
    if left:
        print("note: not included, a folder standing for its own *.toml only: " + ", ".join(
            f"{sub} ({count} scenario file{'s' if count > 1 else ''})" for sub, count in left)
              + "; name a subfolder to include it", file=sys.stderr)
    return left


#: off a terminal (a CI log), sweeps say their progress in a line at each tenth of their points and at the end of a
#: point PLAIN_PROGRESS_EVERY s or more after the last line
PLAIN_PROGRESS_EVERY = 60.0
#: a reference's solve off a terminal says its progress so only from this many seconds on (most take a few)
PLAIN_PROGRESS_AFTER = 10.0
#: computed points (at least; three rounds of the workers) after which a sweep off a terminal says the time to go
#: once, where it is a minute or more (on a terminal the bar shows it), at the pace of the points after the first
#: round (which also pays the workers' start and first imports)
PACE_AFTER_POINTS = 4


@contextlib.contextmanager
def _progress(args, desc, unit, clock=time.perf_counter):
    """A progress callback(done, total) drawing a tqdm bar on stderr; off a terminal (CI logs), for sweep points and a
    reference's solve (ms of simulated time), a plain line now and then instead (``PLAIN_PROGRESS_EVERY``; for
    points with the pace), for anything else nothing; None with --quiet."""
    if args.quiet or (not sys.stderr.isatty() and unit not in ("point", "ms")):
        yield None
        return
    if not sys.stderr.isatty():
        started, said = clock(), {"tenth": 0, "at": clock(), "first": None, "paced": False, "round": None}
        workers = getattr(args, "workers", None)   # points finish together on parallel workers: rounds of them
        parallel = (os.cpu_count() or 1) if workers is None else max(workers, 1)
        pace_after = max(PACE_AFTER_POINTS, 3 * parallel)

        def say(done, total):
            now, tenth = clock(), (10 * done) // max(total, 1)
            if tenth < said["tenth"]:   # a count that starts again (a reference's next solve): its tenths anew
                said["tenth"] = 0
            if said["first"] is None:   # the points reused from a journal are done at once
                said["first"] = done
            if (done and (tenth > said["tenth"] or now - said["at"] >= PLAIN_PROGRESS_EVERY)
                    and (unit == "point" or now - started >= PLAIN_PROGRESS_AFTER)):
                said.update(tenth=tenth, at=now)
                print(f"  {desc}: {done} of {total} {unit if unit == 'ms' else unit + 's'} done "
                      f"({now - started:.0f} s)", file=sys.stderr, flush=True)
            computed = done - said["first"]
            if said["round"] is None and computed >= parallel:   # the first round's end: (points, time)
                said["round"] = computed, now
            if (unit == "point" and not said["paced"] and computed >= pace_after and done < total
                    and computed > said["round"][0]):
                said["paced"] = True
                pace = (now - said["round"][1]) / (computed - said["round"][0])
                if pace * (total - done) >= PLAIN_PROGRESS_EVERY:
                    print(f"  {desc}: about {pace * (total - done) / 60.0:.2g} min to go at the pace of its "
                          f"{computed - said['round'][0]} {unit}s after the first {said['round'][0]} ({pace:.3g} s "
                          f"each, wall; a {unit} that settles slowly takes longer)", file=sys.stderr, flush=True)
        yield say
        return
    from tqdm import tqdm
    bar = tqdm(desc=desc, unit=unit, leave=False, file=sys.stderr)

    def update(done, total):
        bar.total = total
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()


#: after PACE_AFTER s of a run's stepping, a run projected to take more than PACE_LONG s in all gets one note
PACE_AFTER, PACE_LONG = 10.0, 60.0


def _paced(args, step_size, progress):
    """progress(done, total) (None: no bar), plus, unless --quiet, one note on stderr when after PACE_AFTER s the
    run's pace projects more than PACE_LONG s in all: the pace, the time to go and what sets it."""
    if args.quiet:
        return progress
    first = []   # (time, steps done) at the first report: the FMUs are loaded and stepping by then
    said = False

    def update(done, total):
        nonlocal said
        if progress is not None:
            progress(done, total)
        now = time.monotonic()
        if not first:
            first.append((now, done))
            return
        t0, k0 = first[0]
        steps = done - k0
        if said or steps <= 0 or now - t0 < PACE_AFTER:
            return
        said = True
        per_step = (now - t0) / steps
        if per_step * total <= PACE_LONG:
            return
        note = (f"  note: this run steps at {per_step / step_size:.3g} s per simulated second ({step_size:g} s "
                f"steps), about {per_step * (total - done) / 60.0:.1f} min to go. The FMUs' substeps per step grow "
                f"with their fastest rate: a stiff or strongly damped shaft (k_theta, c_theta, xi_theta), a light "
                f"inertia against a stiff element. docs/cosimulation.md, 'What a communication step costs', gives "
                f"each model's rule; `ujfmu bench` compares a scenario with the cost of the FMI calls alone.")
        if progress is not None:
            from tqdm import tqdm
            tqdm.write(note, file=sys.stderr)
        else:
            print(note, file=sys.stderr, flush=True)
    return update


def _say(args, text):
    if not args.quiet:
        print(text)


def cmd_build(args):
    from .build import archive_date, build_all
    try:
        archive_date()   # a malformed SOURCE_DATE_EPOCH is refused before any FMU is written
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    unknown = [n for n in args.names if n not in FMUS]
    if unknown:
        raise UsageError(f"unknown FMU {', '.join(unknown)}; known: {', '.join(FMUS)} (a new model is registered in "
                         "ujfmu/build.py FMUS: docs/contributing.md)")
    names = args.names or list(FMUS)
    fmu_dir = args.fmu_dir
    if args.fmi == 3:   # FMI 3.0 (pythonfmu3)
        from .build3 import build_all3 as build_all
    if not args.quiet:
        print(f"building from the sources of {PACKAGE_DIR}", file=sys.stderr)
    with _progress(args, "building FMUs", "fmu") as progress:
        for i, name in enumerate(names):
            path = build_all(fmu_dir, [name])[0]
            _say(args, f"built {path}")
            if progress:
                progress(i + 1, len(names))
    return 0


def other_checkout(cwd: Path | None = None) -> Path | None:
    """The ujfmu package of another checkout in the current directory (cwd/ujfmu) than the one this command runs
    from, else None: its build, run and check use this one's sources, not that checkout's."""
    here = (cwd or Path.cwd()) / "ujfmu"
    if (here / "__init__.py").is_file() and here.resolve() != PACKAGE_DIR:
        return here
    return None


def _sources_digest(package: Path) -> str:
    """SHA-256 of every Python source of a ujfmu package (relative path and content, in path order)."""
    import hashlib
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _own_checkout(paths) -> None:
    """UsageError where the current directory or a scenario of paths lies in a ujfmu checkout whose sources differ
    from those this command runs from (``foreign_checkout``): a gate there would check other code than the
    checkout's, and pass on it."""
    foreign = foreign_checkout([Path.cwd(), *paths])
    if foreign is not None:
        raise UsageError(f"{foreign.parent} is a ujfmu checkout whose sources differ from those of the ujfmu this "
                         f"command runs from ({PACKAGE_DIR}): its FMUs would be built, and its scenarios checked, "
                         f"with the latter's code, not the checkout's. Install the checkout (`pip install -e "
                         f"{foreign.parent}` in a venv of its own, fresh for each CI job) and run its `ujfmu`; "
                         "or, for scenarios of your own that only lie inside that checkout, move them out of it")


def foreign_checkout(paths) -> Path | None:
    """The ujfmu package of a checkout that holds one of paths (a checkout: a folder with pyproject.toml and
    ujfmu/__init__.py, searched up from each path) whose sources differ from those this command runs from, else
    None. A gate that ran there would check the installed ujfmu's code, not that checkout's."""
    seen = set()
    for path in paths:
        for folder in [Path(path).resolve(), *Path(path).resolve().parents]:
            package = folder / "ujfmu"
            if (package / "__init__.py").is_file() and (folder / "pyproject.toml").is_file():
                if package.resolve() != PACKAGE_DIR and package not in seen:
                    seen.add(package)
                    if _sources_digest(package) != _sources_digest(PACKAGE_DIR):
                        return package
                break
    return None


def _check_fmi3(scenario, fmu_dir) -> None:
    """UsageError unless every FMU of the scenario in fmu_dir is an FMI 3.0 FMU (--fmi 3, --model-exchange)."""
    from fmpy import read_model_description
    for fmu in sorted({fmu for fmu, _ in scenario.components.values()}):
        path = Path(fmu_dir) / f"{fmu}.fmu"
        if not path.is_file():
            raise UsageError(f"{path} not found: build the FMI 3.0 FMUs with `ujfmu build --fmi 3 --fmu-dir "
                             f"{fmu_dir}`")
        if not read_model_description(str(path)).fmiVersion.startswith("3"):
            own = Path(fmu_dir) / "fmi3"
            raise UsageError(f"{path} is an FMI 2.0 FMU; --fmi 3 and --model-exchange run FMI 3.0 FMUs, which "
                             f"`ujfmu build --fmi 3` puts in a folder of their own: give --fmu-dir {own} (build "
                             f"them there with `ujfmu build --fmi 3 --fmu-dir {own}`), or leave --fmu-dir out "
                             "(fmus/fmi3/); building them into this folder would replace its FMI 2.0 FMUs")


def _run_one(args, path, scenario=None):
    from .master import FmuWarning
    from .scenario import Scenario
    from .scenario_run import run_scenario
    plot = not args.no_plot and available("matplotlib")
    scenario = scenario if scenario is not None else Scenario(path)
    if args.fmi == 3:
        _check_fmi3(scenario, args.fmu_dir)
    if args.output_interval is not None:
        scenario.output_interval = args.output_interval
    # `check` runs many: its lines name the scenario (a CI log may keep stderr apart from the verdicts)
    tag = f"{scenario.name}: " if args.command == "check" else ""
    advice = scenario.model_advice()
    said = list(advice)
    for message in advice:
        print(f"  warning {tag}{message}", file=sys.stderr)
    if args.command == "run":   # a design study's operating point at a resonance, said before the run
        from .analysis import near_crossing_notes
        for note in [] if args.quiet else near_crossing_notes(scenario):
            print(f"  note: {note}", file=sys.stderr)
    if not args.model_exchange:   # a periodic load torque the step holds too coarsely, said before the run
        from .scenario_run import load_order_holds
        for hold in load_order_holds(scenario):
            said.append(hold.text())
            print(f"  warning {tag}{hold.text()}", file=sys.stderr)
    with _progress(args, Path(path).stem, "step") as progress, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FmuWarning)
        result = run_scenario(scenario, fmu_dir=args.fmu_dir, out_dir=args.out, plot=plot,
                              progress=_paced(args, scenario.step_size, progress),
                              model_exchange=args.model_exchange)
    for w in caught:   # the FMUs' are in the result, once each; any other is warned again
        if not issubclass(w.category, FmuWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    for line in result.warnings[len(said):]:
        print(f"  warning {tag}{line}", file=sys.stderr)
    print(result.summary(step_check_follows=getattr(args, "check_step", False)))
    if result.csv and not result.plot:   # --no-plot (or no matplotlib): an earlier run's figures stay as they were
        figures = (Path(result.csv).with_name(f"{scenario.name}{suffix}.png") for suffix in ("", "_orbits", "_spectra"))
        stale = [str(figure) for figure in figures if figure.is_file()]
        if stale:
            print(f"  figures of an earlier run, not redrawn for this one: {', '.join(stale)}", file=sys.stderr)
    return result


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number >= 1")
    return value


def _band_missing(results) -> None:
    """Say once that fmpy's validate_result band was not computed for want of scipy (not where it was left out
    because no compared signal varies beyond its abs band)."""
    from .scenario_run import SCIPY_NOTE
    if not available("scipy") and any(r.checked and math.isnan(r.fmpy_outlier_fraction) for r in results):
        print(f"  {SCIPY_NOTE}", file=sys.stderr)


def _level_only(results) -> None:
    """Name once the bands that check the level only: at least half their reference's range, or at least half the
    signal's steady peak-to-peak (a flat line would pass them there)."""
    loose = [f"{r.scenario.name}: {c.name}{kind}" for r in results
             for checks, kind in ((r.checks, ""), (r.extrapolated_checks, " (extrapolated)")) for c in checks
             if c.level_only]
    if loose:
        print(f"  {len(loose)} band(s) check the level only, not the course (at least half the reference's range, "
              f"or of the steady peak-to-peak: a flat line would pass): {'; '.join(loose)}", file=sys.stderr)


def _plots_missing(args):
    if not args.no_plot and not available("matplotlib"):
        print("  no plots: matplotlib is not installed (pip install 'ujfmu[plot]'; --no-plot silences this)",
              file=sys.stderr)


def _step_size(text: str, auto: bool = False) -> float:
    """--step SECONDS as a float, or UsageError unless it is a finite number > 0 (auto: the option also takes
    `auto`, and the message says so)."""
    try:
        step = float(text)
    except ValueError:
        step = math.nan
    if not (math.isfinite(step) and step > 0):
        raise UsageError(f"--step {text}: the communication step must be a number of seconds > 0"
                         + (", or auto (the step halved until the estimated coupling error is within the "
                            "tolerances)" if auto else ""))
    return step


def cmd_run(args):
    from . import stepsize
    from .scenario import Scenario
    _own_checkout([args.scenario])
    scenario = _with_set(Scenario(args.scenario), args.set)
    if args.step is not None and args.step != "auto":   # before --stop-time, which must be whole steps of it
        scenario.step_size = _step_size(args.step, auto=True)
    if args.stop_time is not None:
        scenario = scenario.with_stop_time(args.stop_time)
    for name in args.record or []:   # ride along: the setup, and so the reference, stay the file's
        scenario._check_signal(name, "--record")
        if name not in scenario.record:
            scenario.record.append(name)
            scenario.not_compared.setdefault(name, "recorded with --record")
    _with_coupling(scenario, args.coupling)
    if args.model_exchange and (args.step == "auto" or args.check_step):
        raise UsageError("--step auto and --check-step estimate a co-simulation's coupling error; a Model Exchange "
                         "run (--model-exchange) has none: its accuracy is the solver's (rtol 1e-8)")
    if args.check_step and args.no_check_step:
        raise UsageError("--check-step and --no-check-step: give one")
    # a run that compares nothing estimates its coupling error instead (an 80 deg joint's changed copy had passed
    # 8% off its monolithic solution with exit status 0 and "accuracy unknown" among its summary's lines)
    estimated = (not scenario.compares and not args.check_step and not args.no_check_step and not args.model_exchange
                 and args.step != "auto")
    args.check_step = args.check_step or estimated
    if args.step == "auto":
        scenario.check_fmus(args.fmu_dir)
        scenario.step_size, _ = stepsize.choose(scenario, args.fmu_dir,
                                                progress=(lambda *a: None) if args.quiet else print)
        print(f"--step auto: step_size = {scenario.step_size:g} s")
    if not math.isclose(scenario.step_size, scenario.declared_step, rel_tol=1e-9):   # beside the file's results
        scenario.name = f"{scenario.name}_step{scenario.step_size:g}"
    if args.name is not None:
        scenario.name = _run_name(args.name)
    result = _run_one(args, args.scenario, scenario)
    _say(args, f"  results: {Path(result.csv).absolute()}"
         + (f"\n  plot:    {Path(result.plot).absolute()}" if result.plot else ""))
    for extra in result.extra_plots:
        _say(args, f"  plot:    {Path(extra).absolute()}")
    _plots_missing(args)
    _band_missing([result])
    step_ok = True
    if args.check_step:
        if estimated:
            print("  the run compares nothing, so its coupling error is estimated by a rerun at half the step "
                  "(--no-check-step skips it):")
        estimate = stepsize.estimate(scenario, fmu_dir=args.fmu_dir, coarse=result.table)
        print("\n".join(estimate.lines()))
        step_ok = estimate.passed
        if estimate.failure:
            print(f"ujfmu: the step check's rerun at half the step stopped, so the coupling error at "
                  f"{scenario.step_size:g} s is not known (the line above says why)", file=sys.stderr)
        elif any(not estimate.within(name) for name in estimate.errors):
            wiring = (", or the torque-driven wiring where a speed-driven joint reflects a large inertia (README, "
                      "\"Choose the wiring for the host\")" if stepsize.speed_driven(scenario) else "")
            print(f"ujfmu: the estimated coupling error at {scenario.step_size:g} s is above the allowance (HIGH "
                  "above): the results are not that accurate; take a smaller step (--step, or --step auto to "
                  f"find one){wiring}", file=sys.stderr)
        elif any(not c.passed for c in estimate.orders):
            print(f"ujfmu: the estimated coupling error of an order amplitude at {scenario.step_size:g} s is above "
                  "its [reference.orders] rel, or the step does not resolve an order its machine carries (HIGH "
                  "above): take a smaller step (--step, or --step auto to find one)", file=sys.stderr)
        elif not step_ok:
            print("ujfmu: the step check failed: the lines above say where (a record that aliases a model's order, "
                  "or the step-halving extrapolation outside its [reference.extrapolated] band)", file=sys.stderr)
    return 1 if result.failed or not step_ok else 0


#: the JUnit report's one case until ``ujfmu check`` writes its own: a run that never gets there fails
UNFINISHED = ("did not finish: interrupted, killed, or stopped by an error before writing its report (its output "
              "says which); this placeholder stands until a run completes")


def cmd_check(args):
    from .scenario import ScenarioError
    from .scenario_run import write_junit
    kind = "model_exchange" if args.model_exchange else "fmi3" if getattr(args, "fmi", 2) == 3 else ""
    if args.junit:   # a report of an earlier run must not stand for this one, whatever becomes of it
        if Path(args.junit).is_dir():
            raise UsageError(f"--junit {args.junit} is a folder: give the report's file name, e.g. "
                             f"{Path(args.junit) / 'report.xml'}")
        write_junit([], args.junit, {"ujfmu check": UNFINISHED}, kind=kind)
    try:
        return _check(args, kind)
    except (UsageError, ScenarioError, FileNotFoundError, MissingExtraError) as exc:
        with contextlib.suppress(OSError):   # refused before the run's own report replaced the placeholder
            if args.junit and UNFINISHED in Path(args.junit).read_text():
                write_junit([], args.junit, {"ujfmu check": f"refused: {exc}"}, kind=kind)
        raise


def _check(args, kind: str) -> int:
    """`ujfmu check` after its JUnit placeholder (:func:`cmd_check`)."""
    from .master import CosimulationError
    from .scenario import ScenarioError
    from .scenario_run import write_junit
    results, skipped, errors = [], {}, {}
    _own_checkout(list(args.scenarios or []))
    left_out = []
    paths = _scenarios(args.scenarios, left_out)
    names = {}
    for path in paths:
        names.setdefault(Path(path).stem, []).append(str(path))
    twice = {name: where for name, where in names.items() if len(where) > 1}
    if twice:
        raise UsageError("scenarios of the same name would share their results and JUnit case: "
                         + "; ".join(f"{name}: {', '.join(where)}" for name, where in twice.items())
                         + " (rename one, or check them in separate runs with their own --out and --junit)")
    for path in paths:
        try:
            if args.model_exchange:
                from .model_exchange import ModelExchangeError
                try:
                    results.append(_run_one(args, path))
                except ModelExchangeError as exc:   # a speed-driven scenario: nothing to integrate in ME
                    skipped[Path(path).stem] = str(exc)
                    print(f"SKIPPED {Path(path).stem}: {exc}")
            else:
                results.append(_run_one(args, path))
        except (ScenarioError, CosimulationError, FileNotFoundError) as exc:   # the next scenario still runs
            name = Path(path).stem if Path(path).stem not in errors else str(path)
            errors[name] = str(exc)
            print(f"ERROR {name}: {exc}")
    _plots_missing(args)
    _band_missing(results)
    _level_only(results)
    failed = [r for r in results if r.failed]
    unchecked = [r for r in results if not r.checked and not r.failed]
    loose = [r for r in results if not r.failed and r.strict_problems]
    if args.junit:   # what fails the command below fails its case: --strict's and an all-unchecked run's
        # a subfolder not searched is a skipped case: a dashboard counts what the gate did not check
        folders = {f"{sub} (folder not included)": f"not included: {sub} holds {count} scenario file"
                   f"{'s' if count > 1 else ''} this run did not check (a folder stands for its own *.toml); name it "
                   "on the command line to check it" for sub, count in left_out}
        report = write_junit(results, args.junit, errors, {**skipped, **folders}, kind,
                             unchecked_fail=bool(unchecked) and (args.strict or len(unchecked) == len(results)),
                             level_only_fail=args.strict)
        _say(args, f"JUnit report: {report}")
    strict_failed = loose if args.strict else []   # passed their bands, failed by --strict (JUnit cases too)
    strict_unchecked = unchecked if args.strict or len(unchecked) == len(results) else []   # failed cases too
    def first_problem(r):   # each failed scenario counted once, by the first of its --strict problems
        return ("level" if r.level_only_bands else "blind" if r.machines_unchecked else
                "part" if r.part_compared else "same")
    level, blind, part, same = ([r for r in strict_failed if first_problem(r) == kind]
                                for kind in ("level", "blind", "part", "same"))
    why = ([f"{len(level)} by bands that check the level only"] if level else []) + (
        [f"{len(blind)} by comparing no output of {'its' if len(blind) == 1 else 'their'} machines"]
        if blind else []) + (
        [f"{len(part)} by comparing only a part of {'its' if len(part) == 1 else 'their'} reference's run"]
        if part else []) + (
        [f"{len(same)} by a reference equal to the run to the last digit"] if same else []) + (
        [f"{len(strict_unchecked)} compare{'s' if len(strict_unchecked) == 1 else ''} nothing"]
        if strict_unchecked else [])
    print(f"{len(results) - len(failed) - len(unchecked) - len(strict_failed)} passed, "
          f"{len(failed) + len(strict_failed) + len(strict_unchecked)} failed"
          + (f" ({'--strict: ' if args.strict else ''}{', '.join(why)})" if why else "")
          + f", {len(unchecked) - len(strict_unchecked)} not checked"
          + (f", {len(errors)} could not run" if errors else "")
          + (f", {len(skipped)} skipped (no Model Exchange wiring: {', '.join(skipped)})" if skipped else ""))
    if unchecked:
        print(f"comparing nothing (no [reference] with tolerances): {', '.join(r.scenario.name for r in unchecked)}",
              file=sys.stderr)   # counted as failed above where that fails the gate, else as not checked
    strict_fail = False
    if unchecked and args.strict and len(unchecked) < len(results):
        print(f"ujfmu: error: --strict: {len(unchecked)} scenario(s) compare nothing: "
              f"{', '.join(r.scenario.name for r in unchecked)}", file=sys.stderr)
        strict_fail = True
    if blind:
        print(f"ujfmu: error: --strict: {len(blind)} scenario(s) compare no output of the machines they model, only "
              "their drive's and load's signals (an ideal source's own speed, a load's constant torque): "
              + "; ".join(f"{r.scenario.name}: {', '.join(r.machines_unchecked)}" for r in blind)
              + " (give a band to a signal of the machine under test: its output speed, torques, twist)",
              file=sys.stderr)
        strict_fail = True
    if level:
        print(f"ujfmu: error: --strict: {len(level)} scenario(s) compare through bands that check the level only, "
              "not the course: " + "; ".join(f"{r.scenario.name}: {', '.join(r.level_only_bands)}" for r in level)
              + " (a band of at least half the reference's range passes a flat line through its middle, one of at "
              "least half the steady peak-to-peak a signal without that vibration: tighten it below that, at the "
              "accuracy the study needs, or compare the vibration's orders, [reference.orders])", file=sys.stderr)
        strict_fail = True
    if part:
        print(f"ujfmu: error: --strict: {len(part)} scenario(s) compare only a part of the run their reference was "
              "made for: " + "; ".join(f"{r.scenario.name}: {r.part_compared}" for r in part)
              + " (run each to its reference's end, or make the reference for the span the gate runs: "
              "`ujfmu references`)", file=sys.stderr)
        strict_fail = True
    if same:
        print(f"ujfmu: error: --strict: {len(same)} scenario(s) equal their reference to the last digit in every "
              f"compared signal: {', '.join(r.scenario.name for r in same)} (a copy of a run's output compares "
              "nothing; compare a signal the reference computes on its own, a torque or a twist)", file=sys.stderr)
        strict_fail = True
    if errors:
        print(f"ujfmu: error: {len(errors)} scenario(s) could not run ({', '.join(errors)}): each ERROR line above "
              "says why", file=sys.stderr)
        return 2
    if not results:
        print("ujfmu: error: no scenario could run in Model Exchange (only torque-driven wirings can)",
              file=sys.stderr)
        return 1
    if len(unchecked) == len(results):
        print(f"ujfmu: error: nothing was checked: none of the {len(results)} scenario(s) compares a signal with a "
              "reference (add [reference] file and [reference.tolerance] to a scenario)", file=sys.stderr)
        return 1
    return 1 if failed or strict_fail else 0


def cmd_references(args):
    for module in ("scipy", "sympy"):
        require(module, "references", "ujfmu references")
    from .references import generate, method_of, provenance_of, scenario_of, write_reference
    from .references.common import (ReferenceCheckError, ReferenceStallError, WiringError, collect_checks,
                                    solve_progress)
    from .scenario import Scenario, ScenarioError
    wrote = 0
    for path in _scenarios(args.scenarios):
        scenario = Scenario(path)
        if scenario.reference_generator is None:
            why = "no [reference]" if scenario.reference_file is None else "its [reference] names no generator"
            print(f"{scenario.path}: skipped: {why}, so there is nothing to regenerate", file=sys.stderr)
            continue
        target = scenario.reference_output()   # inside the scenario's folder, checked before any work
        owner = scenario_of(provenance_of(target))
        foreign = scenario.foreign_reference(owner)
        if foreign:   # writing this scenario's reference there would replace that one's
            raise ScenarioError(f"{foreign}; or delete {target} if {owner} is gone")
        _say(args, f"{scenario.path}: solving the reference ({scenario.stop_time - scenario.start_time:g} s)")
        try:
            with _progress(args, f"{scenario.name}: reference solve (simulated time)", "ms") as progress, \
                    solve_progress(progress), collect_checks() as checks:
                table, provenance = generate(scenario)
        except (WiringError, ReferenceStallError) as exc:   # named once: a wiring error starts with the path
            text = str(exc)
            raise ScenarioError(text if text.startswith(f"{scenario.path}:") else f"{scenario.path}: {text}") from None
        except ReferenceCheckError as exc:
            raise ScenarioError(f"{exc}; the reference is not written. Each law is checked on the scenario's "
                                "output grid, so a step_size that does not resolve the fastest motion can fail it "
                                "where the solve itself is accurate: try the scenario at a smaller step_size; if it "
                                "fails there too, the generator is at fault (please report it)") from None
        write_reference(target, table, provenance)
        _say(args, f"wrote {scenario.reference_file}")
        print(f"  {scenario.name}: how the reference was made: {method_of(provenance) or provenance}; its "
              + (f"self-checks on the written grid, each deviation and its allowance as shares of the law's scale: "
                 + "; ".join(f"{what} {deviation:.2g} (allowed {allowed:.2g})" for what, deviation, allowed in checks)
                 if checks else "generator has no self-check of a conservation law for this wiring"))
        wrote += 1
    if not wrote:
        print("ujfmu: error: no reference was regenerated", file=sys.stderr)
        return 1
    return 0


def _with_coupling(scenario, coupling: str | None) -> None:
    """The scenario in the coupling scheme given instead of its [experiment] coupling (None: its own), named and
    titled so (its results beside those of the file's scheme, not over them)."""
    if coupling is not None and coupling != scenario.coupling:
        scenario.coupling = coupling
        scenario.title = f"{scenario.title} (coupling = {coupling})"
        scenario.name = f"{scenario.name}_{coupling}"


def cmd_sweep(args):
    if args.workers is None and not args.scheduler and not available("distributed"):
        args.workers = 0
        print("note: dask's distributed is not installed, so the points run one after another in this process "
              "(for worker processes, one per core: pip install 'ujfmu[sweep]'; in a clone: pip install -e "
              "'.[sweep]')", file=sys.stderr)
    if args.workers != 0 or args.scheduler:
        require("distributed", "sweep", "ujfmu sweep (--workers 0 runs in this process without it)")
    from .scenario import Scenario, ScenarioError
    from .scenario_run import load_order_holds
    from .steady import grows
    from .sweep import Sweep, SweepWarning, sweep_setup
    scenario = Scenario(args.scenario)
    fixed = _set_changes(scenario, args.set)
    if fixed:
        scenario = scenario.with_parameters(fixed)
    if args.step is not None:
        scenario.step_size = _step_size(args.step)
    _with_coupling(scenario, args.coupling)
    axes, settings = sweep_setup(scenario, args.param or scenario.sweep.get("params", []), outputs=args.output,
                                 running_speed=args.running_speed, settle_time=args.settle,
                                 revolutions=args.revolutions, orders=args.orders, steady_tol=args.steady_tol,
                                 max_settle_time=args.max_settle)
    clash = sorted(set(fixed) & {name for axis in axes for name in axis.names})
    if clash:   # the axis's values would replace the --set one at every point
        raise ScenarioError(f"{', '.join(clash)} both swept (--param) and fixed (--set): give it one of the two")
    sweep = Sweep(scenario, axes, settings, out_dir=args.out, name=args.name, fmu_dir=args.fmu_dir)
    grid = " x ".join(a.describe(scenario) for a in axes)
    revolutions = f"{settings.revolutions:g} revolution{'' if settings.revolutions == 1 else 's'}"
    print(f"{sweep.name}: {len(sweep.points)} point{'' if len(sweep.points) == 1 else 's'} ({grid}), "
          f"settle {settings.settle_time:g} s"
          + (f" or four windows of {revolutions} if longer, extended until steady (each point's settled_s is the time "
             "used)" if settings.steady_tol else " (no steady-state check)")
          + f", {revolutions} measured")
    holds = [hold for point in sweep.points for hold in load_order_holds(scenario.with_values(point))]
    if holds:   # a periodic load torque the step holds too coarsely at some point: said for the worst
        worst = max(holds, key=lambda hold: hold.lag)
        print(f"  warning {worst.text()} (the fastest of {len(holds)} such points: their order "
              "amplitudes carry it)", file=sys.stderr)
    smoothed = [(i, text) for i, point in enumerate(sweep.points)
                for text in scenario.with_values(point).smoothed_friction()]
    if smoothed:   # a friction smoothed at the speed of some points: said for the first such point
        points = len({i for i, _ in smoothed})
        print(f"  warning {smoothed[0][1]} (at {points} of {len(sweep.points)} points: their figures carry it)",
              file=sys.stderr)
    for name in filter(grows, settings.outputs):
        print(f"  note: {name} grows with time in any steady state (a running angle or an energy integral): its "
              "max, min, mean and order amplitudes over a window describe its ramp, not a vibration (the "
              "steady-state check leaves it out)")
    show = warnings.showwarning

    def said(message, category, filename, lineno, file=None, line=None):   # as it is said, in the command's words
        if issubclass(category, SweepWarning):
            print(f"  warning: {message}", file=sys.stderr)
        else:
            show(message, category, filename, lineno, file, line)

    try:
        with _progress(args, sweep.name, "point") as progress, warnings.catch_warnings():
            warnings.simplefilter("always", SweepWarning)
            warnings.showwarning = said
            sweep.run(workers=args.workers, scheduler=args.scheduler, progress=progress, extend=args.extend)
    except KeyboardInterrupt:
        kept = sum(r["status"] != "missing" for r in sweep.records())
        try:
            table = f" and in {sweep.write_csv()} (the others with status missing)"
        except OSError:   # interrupted before its folder was made
            table = ""
        print(f"\n{sweep.name}: {_stopped_text()}; {kept} of {len(sweep.points)} points are in {sweep.journal}"
              f"{table}: run the same command again to compute only the others", file=sys.stderr)
        return stopped_status()
    if sweep.reused:
        failed = (f", {sweep.reused_failures} of them failed (the same FMUs, code and settings fail the same way: "
                  "change one, or delete the journal, to run them again)") if sweep.reused_failures else ""
        print(f"  reused {sweep.reused} of {len(sweep.points)} points from {sweep.journal}{failed}")
    if sweep.superseded:
        print(f"  recomputed {sweep.superseded} points that {sweep.journal} holds from other settings, FMU builds "
              "or code (a journal's points serve only a rerun with the same)")
    if sweep.damaged:
        print(f"  skipped {sweep.damaged} line{'s' if sweep.damaged > 1 else ''} of {sweep.journal} that "
              f"{'are' if sweep.damaged > 1 else 'is'} no point record (cut by an interruption or a full disk, or "
              "written by something else); their points, if any, were run again", file=sys.stderr)
    _say(args, f"  table: {sweep.csv} (units: {sweep.csv.with_suffix('.columns.csv')})\n  journal: {sweep.journal}")
    if not args.no_plot and available("matplotlib"):
        for path in sweep.plot():
            _say(args, f"  plot:  {path}")
    else:
        stale = sorted(str(path) for path in sweep.out_dir.glob(f"{sweep.name}*.png"))
        if stale:
            print(f"  figures of an earlier run, not redrawn for this table: {', '.join(stale)}", file=sys.stderr)
    _plots_missing(args)
    failed = sweep.failed()
    for record in failed[:10]:
        where = ", ".join(f"{name} = {axis.value_text(scenario, value)}" for name, value in record["point"].items()
                          for axis in axes if name in axis.names)
        print(f"  point {where}: {record['status']}: {record['error']}", file=sys.stderr)
    unresolved = sweep.unresolved()
    if unresolved:
        print(f"  {len(unresolved)} point{'s have' if len(unresolved) > 1 else ' has'} order amplitudes that the "
              f"step does not resolve, NaN in the table; at the fastest: "
              f"{max(unresolved, key=lambda r: abs(r.get('speed_mean', 0.0)))['note'].split('; max, min and p2p')[0]}")
    coarse = sweep.coarse_peaks()
    if coarse:
        fastest = max(coarse, key=lambda r: abs(r.get("speed_mean", 0.0)))["note"]
        print(f"  the max, min and p2p of {len(coarse)} point{'s' if len(coarse) > 1 else ''} may fall short of the "
              f"peaks (read too few times a period); at the fastest: {fastest[fastest.index('max, min and p2p'):]}")
    crossings = {}
    for crossing in sweep.stepped_over_crossings():   # the outputs peaking next to one crossing in one line
        crossings.setdefault(crossing.key, []).append(crossing)
    for first, *peers in list(crossings.values())[:5]:
        print(f"  {first.text(scenario, peers)}")
    if len(crossings) > 5:
        print(f"  ... and {len(crossings) - 5} more crossings the grid steps over where an order peaks "
              "(Sweep.stepped_over_crossings)")
    warned = [r for r in sweep.table() if r.get("warnings")]
    if warned:
        print(f"  the FMUs warned at {len(warned)} point{'s' if len(warned) > 1 else ''} (the CSV's warnings column); "
              f"at the first: {warned[0]['warnings'][:400]}")
    step_ok = True
    if args.check_step:
        checks = sweep.step_checks()
        if not checks:
            print("  step check: no ok point to check", file=sys.stderr)
            step_ok = False
        else:
            print("\n".join(f"  {line}" for check in checks for line in check.lines(scenario)))
            step_ok = all(check.passed for check in checks)
    else:
        print("  the order amplitudes carry the run's error at this step and coupling: --check-step reruns each "
              "output's peak point at half the step to estimate it")
    print(_status_summary(sweep.status_counts(), len(sweep.points), steady_checked=bool(sweep.settings.steady_tol)),
          file=sys.stderr if failed else sys.stdout)
    return 1 if failed or not step_ok else 0


#: what each sweep point status means, for the summary line
STATUS_MEANING = {"ok": "steady at the operating point", "not_steady": "not steady by max_settle_time",
                  "off_target": "operating point not reached", "error": "failed (a rerun reuses it; one the machine caused runs again)",
                  "missing": "not run"}


def _status_summary(counts, total, steady_checked=True):
    """'N points: a ok (steady at the operating point), b not_steady (...), ...'; without the steady-state check
    (--steady-tol 0) an ok point is only at its operating point."""
    meaning = STATUS_MEANING if steady_checked else {
        **STATUS_MEANING, "ok": "at the operating point; steady state not checked (--steady-tol 0)"}
    parts = [f"{n} {status} ({meaning.get(status, status)})" for status, n in sorted(
        counts.items(), key=lambda item: list(STATUS_MEANING).index(item[0]) if item[0] in STATUS_MEANING else 99)]
    return f"{total} point{'' if total == 1 else 's'}: " + ", ".join(parts)


def _run_name(name: str) -> str:
    """--name NAME where it can name the files the run writes (``scenario.file_name_problem``), else UsageError."""
    from .scenario import file_name_problem
    if file_name_problem(name):
        raise UsageError(f"--name {file_name_problem(name)} (<name>.csv, <name>.columns.csv, <name>.png)")
    return name


def _with_set(scenario, texts):
    """The scenario with the --set values COMP.PAR=VALUE[rpm|deg] (``Scenario.with_parameters``: a copy named
    <scenario>_changed, without the reference), or itself without any."""
    changes = _set_changes(scenario, texts)
    return scenario.with_parameters(changes) if changes else scenario


def _set_changes(scenario, texts) -> dict:
    """{component.parameter: value} of the --set texts COMP.PAR=VALUE[rpm|deg] (``parse_axis``: one value each),
    each parameter once."""
    from .scenario import ScenarioError
    from .sweep import SweepSettingsError, parse_axis
    changes = {}
    for text in texts or []:
        try:
            axis = parse_axis(text, scenario, "--set")
        except SweepSettingsError as exc:   # one value of one parameter: its problems, not a sweep's
            raise ScenarioError("; ".join(exc.problems)) from None
        if len(axis.values) != 1:
            raise ScenarioError(f"--set {text!r}: one value (COMP.PAR=VALUE[rpm|deg]), not {len(axis.values)} "
                                "(`ujfmu sweep --param` takes ranges)")
        twice = [name for name in axis.names if name in changes]
        if twice:
            raise ScenarioError(f"--set {text!r}: {', '.join(twice)} is set by an earlier --set too: give each "
                                "parameter once")
        changes.update(axis.assignments(axis.values[0]))
    return changes


def cmd_variables(args):
    from .build import fmu_class
    from .fmu.base import HUMAN_UNITS
    if args.fmu not in FMUS:
        close = difflib.get_close_matches(args.fmu, FMUS, n=1)
        raise UsageError(f"no FMU named {args.fmu!r}" + (f" (did you mean {close[0]!r}?)" if close else "")
                         + f": the FMUs are {', '.join(FMUS)}")
    cls = fmu_class(args.fmu)
    kinds = [args.causality] if args.causality else ["parameter", "input", "output"]
    what = re.split(r"\.\s+(?=[A-Z])", " ".join(cls.__doc__.split()))[0].rstrip(".")   # its first sentence
    print(f"{args.fmu}: {what} (SI units; a scenario sets a parameter as "
          f"<component>.<name>, `--set` takes rpm or deg after the number)")
    for kind in kinds:
        print(f"\n{kind}s:")
        for v in (v for v in cls.VARIABLES if v.causality == kind):
            unit = "" if v.unit in (None, "1") or v.type is not float else f" {v.unit}"
            if kind == "output":
                print(f"  {v.name} [{unit.strip() or '-'}]: {v.description}")
                continue
            start = (str(v.start).lower() if v.type is bool else v.start) if v.type is not float else f"{v.start:g}"
            human = HUMAN_UNITS.get(v.unit) if v.type is float else None
            shown = f" ({v.start / human[1]:.6g} {human[0]})" if human and v.start else ""
            print(f"  {v.name} = {start}{unit}{shown}" + (f", range {v.range_text()}" if v.type is not bool else "")
                  + f": {v.description}")
    return 0


def cmd_modes(args):
    from .analysis import (NEAR_CRITICAL, PURE_MODE, drive_speeds, driven_components, excitations, held_input_modes,
                           load_orders, nearest_crossings, scenario_modes)
    from .scenario import Scenario
    from .steady import speed_text
    scenario = _with_set(Scenario(args.scenario), args.set)
    modes = scenario_modes(scenario)
    print(f"{scenario.name}: natural frequencies omega_n of its machine components, each linearised at rest (no "
          "load; the input shaft held where an ideal speed source drives it: the mean over the input angle, and the "
          "range it spans; free with the rotor inertia where a PI motor does, its speed loop left out: at input "
          "angle 0, which a joint's angle moves by a few percent), and the input speeds at which each order of the "
          "input speed that the component carries meets them (the crossings of a Campbell diagram: the k-th order at "
          "omega_n / k). Each mode is torsional (twist), lateral (bending) or lateral-torsional by where "
          f"{100 * PURE_MODE:g}% of its participation factors lie. An overdamped mode (damping ratio 1 or more) has "
          "no natural frequency and is not listed.")
    if not modes:
        print("  no component with modes of its own (rigid or kinematic models)")
        return 0
    loads = load_orders(scenario)

    def show(modes):
        for m in modes:
            spread = f", {m.low:.5g}-{m.high:.5g} over the input angle" if m.high > 1.005 * m.low else ""
            merged = f", {m.count} modes" if m.count > 1 else ""
            crossings = ("; ".join(f"{k:g}x{by} at {speed_text(m.critical_speed(k))}"
                                   for k, by in excitations(m, loads))
                         or "no order of the input speed excites it at these parameters")
            print(f"  {m.component}: {m.omega:.5g} rad/s ({m.omega / (2 * math.pi):.5g} Hz, {m.kind}{merged}"
                  f"{spread}, damping ratio {m.damping:.2g}): {crossings}")
    show(modes)
    held = held_input_modes(scenario)
    if held:
        print(f"  where a PI speed loop drives {', '.join(dict.fromkeys(m.component for m in held))}, the modes above "
              "have its input free (the speed loop left out); a loop much stiffer than a mode holds the input "
              "instead. A proportional loop puts each mode between the two; the integral action moves it too, "
              "outside them where it is strong (run or sweep the scenario for the closed loop's modes). With the "
              "input held:")
        show(held)
    speeds = drive_speeds(scenario)
    for name, nearest in nearest_crossings(scenario, modes, held).items():
        speed = speeds[name]
        if nearest is None:
            print(f"  {name} = {speed_text(speed)}: no order of the input speed excites a mode")
            continue
        margin, magnitude = nearest.margin, "'s magnitude" if speed < 0 else ""
        print(f"  {name} = {speed_text(speed)}: the nearest crossing is {nearest.text()}; the set speed{magnitude} "
              f"is {100 * abs(margin):.1f}% {'above' if margin > 0 else 'below'} it"
              + (f" (within {100 * NEAR_CRITICAL:g}%)" if nearest.near else ""))
        driven = driven_components(scenario, name.partition(".")[0])
        below = [(m, k) for m in modes if m.component in driven for k, _ in excitations(m, loads)
                 if m.critical_speed(k) < abs(speed)]
        if below:
            one = len(below) == 1
            print(f"    below it {'lies 1 crossing' if one else f'lie {len(below)} crossings'} (a run-up from rest "
                  f"passes {'it' if one else 'them'}): "
                  + ", ".join(f"{k:g}x with {m.omega:.5g} rad/s ({m.kind.partition(',')[0]}) at "
                              f"{m.critical_speed(k):.5g} rad/s"
                              for m, k in sorted(below, key=lambda mk: mk[0].critical_speed(mk[1]))))
    print("  A crossing resonates where the order's forcing acts on the mode's shape (an unbalance drives lateral "
          "modes at 1x; a Cardan joint's 2x drives twist and, through its secondary couple, lateral motion), and "
          "the damping sets how much: run the scenario, or sweep the speed (`ujfmu sweep`, whose order figure "
          "draws these natural frequencies as lines on a Campbell diagram and each order's response as markers at "
          "its frequency, sized by amplitude), to see the response.")
    return 0


def cmd_export_ssp(args):
    from .scenario import Scenario
    from .ssp import export_ssp
    for path in _scenarios(args.scenarios):
        scenario = Scenario(path)
        if args.step is not None:
            scenario.step_size = _step_size(args.step)
            scenario.check_experiment()
        print(f"wrote {export_ssp(scenario, args.out, args.fmu_dir)} (FMI {'3.0' if args.fmi == 3 else '2.0'} "
              "Co-Simulation FMUs)")
    return 0


def cmd_bench(args):
    for module, extra in (("scipy", "references"), ("sympy", "references"), ("distributed", "sweep")):
        require(module, extra, "ujfmu bench")
    from .bench import ENGINES, render, run_bench, write
    from .battery import paths as battery_paths
    cpus = None if args.engine_cpus is None else set() if args.engine_cpus == "all" else \
        {int(c) for c in args.engine_cpus.split(",")}
    fmu3_dir = None
    if not args.no_fmi3:
        fmu3_dir = Path(args.fmu_dir) / "fmi3"
        missing = [n for n in FMUS if not (fmu3_dir / f"{n}.fmu").exists()]
        if missing:
            raise UsageError(f"the FMI 3.0 cost figure needs the FMI 3.0 FMUs in {fmu3_dir} ({', '.join(missing)} "
                             "missing): run `ujfmu build --fmi 3` first, or skip the figure with --no-fmi3")
    result = run_bench(_scenarios(args.scenarios), fmu_dir=args.fmu_dir, sweep=not args.no_sweep,
                       progress=(lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr)),
                       battery=() if args.no_battery else battery_paths(),
                       engines=() if args.no_engines else ENGINES, cpus=cpus, fmu3_dir=fmu3_dir)
    print(render(result))
    print(f"\nwrote {write(result, args.out)}")
    return 0


def cmd_battery(args):
    from . import battery
    seed = battery.SEED if args.seed is None else args.seed
    where = args.dir or (battery.BATTERY_DIR if seed == battery.SEED else Path("results") / f"battery_seed{seed}")
    if args.regenerate:
        battery.regenerate(where, progress=print, seed=seed)
        return 0
    if seed != battery.SEED:   # a hold-out draw: its set-ups and references are made where missing
        battery.regenerate(where, progress=None if args.quiet else print, missing_only=True, seed=seed)
    runs = []
    print("| set-up | joint | " + " | ".join(f"{c}: worst error / range" for c in args.coupling) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in args.coupling) + " |")
    for path in battery.paths(where):
        row = [battery.run_one(path, c, args.fmu_dir) for c in args.coupling]
        runs += row
        kind = "double Cardan" if "driveline" in path.read_text() else "Cardan"
        cells = [r.error.split(":")[0][:60] + " (failed)" if r.error else
                 f"{100 * max(r.worst.values()):.2f}% {'ok' if r.passed else 'FAIL'}" for r in row]
        print(f"| {path.stem} | {kind} | " + " | ".join(cells) + " |", flush=True)
    for c in args.coupling:
        mine = [r for r in runs if r.coupling == c]
        print(f"{c}: {sum(r.passed for r in mine)} of {len(mine)} within {100 * battery.TOLERANCE:g}%, "
              f"{sum(bool(r.error) for r in mine)} stopped")
    return 0 if all(r.passed for r in runs) else 1


def cmd_report(args):
    for module in ("distributed", "scipy", "sympy", "matplotlib"):
        require(module, "report", "ujfmu report")
    from .report import write_report
    with _progress(args, "report sweep", "point") as progress:
        path = write_report(args.out, fmu_dir=args.fmu_dir, work_dir=args.work_dir, workers=args.workers,
                            progress=progress).path
    print(f"wrote {path} (figures in {path.parent / 'figures'})")
    return 0


def cmd_mutate(args):
    import json

    from .mutate import load_mutants, mutate, score
    mutants = load_mutants(args.list)
    if args.only:
        unknown = set(args.only) - {m.id for m in mutants}
        if unknown:
            raise FileNotFoundError(f"no mutant {', '.join(sorted(unknown))} in {args.list}")
        mutants = [m for m in mutants if m.id in args.only]
    journal = args.out / "mutate.jsonl"
    done = {}
    if args.resume and journal.is_file():
        latest = {r["id"]: r for r in map(json.loads, journal.read_text().splitlines())}
        done = {i: r for i, r in latest.items() if r["status"] in ("killed", "timeout", "equivalent")}
    elif journal.is_file():
        journal.unlink()
    todo = [m for m in mutants if m.id not in done]
    print(f"{len(mutants)} mutants ({len(done)} from {journal}), running {len(todo)}", flush=True)

    def report(outcome):
        print(f"{outcome.status:10s} {outcome.mutant.id:40s} {outcome.seconds:6.1f} s  "
              f"{outcome.detail.splitlines()[-1] if outcome.detail else ''}"[:200], flush=True)

    outcomes = mutate(todo, timeout=args.timeout, niceness=args.nice, progress=report, journal=journal)
    statuses = [r["status"] for r in done.values() if r["id"] in {m.id for m in mutants}]
    statuses += [o.status for o in outcomes]
    killed, judged, fraction = score(statuses)
    survivors = [m.id for m, o in zip(todo, outcomes) if o.status == "survived"]
    print(f"score: {killed} of {judged} non-equivalent mutants killed ({100 * fraction:.1f}%); "
          f"{statuses.count('equivalent')} equivalent, {statuses.count('error')} errors"
          + (f"; survivors: {', '.join(survivors)}" if survivors else ""))
    return 1 if survivors or "error" in statuses else 0


#: options every command accepts, before or after the command name
def _common(parser, suppress):
    default = (lambda value: argparse.SUPPRESS) if suppress else (lambda value: value)
    parser.add_argument("--fmu-dir", type=Path, default=default(DEFAULT_FMU_DIR),
                        help="where the FMUs are, or are built (default: fmus/ of the current directory)")
    parser.add_argument("--quiet", "-q", action="store_true", default=default(False),
                        help="no progress bars and no file listings (off a terminal there are no bars anyway; "
                             "sweeps then print a progress line at each tenth of their points)")


def _fmi(parser, helptext):
    parser.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                        help=f"FMI version (default 2: FMI 2.0 Co-Simulation); 3: {helptext}, in fmus/fmi3/ "
                             "unless --fmu-dir is given")


def _out(parser, default, helptext):
    parser.add_argument("--out", type=Path, default=argparse.SUPPRESS, help=f"{helptext} (default: {default})")
    parser.set_defaults(out_default=Path(default))


class _Parser(argparse.ArgumentParser):
    """An argument parser that keeps its last usage error's message (:func:`_usage_error_report`) and takes no
    abbreviated options (``sweep --set`` had been read as ``--settle``)."""

    refused = None

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        _Parser.refused = message
        super().error(message)


def _usage_error_report(argv: list, message: str) -> None:
    """A refused `ujfmu check` command line with --junit: the report at that path says so, an error case, so that
    a CI job's earlier report (passed, or the last run's) does not stand for a run that never started."""
    if "check" not in argv:
        return
    path, kind = None, ""
    for i, a in enumerate(argv):
        if a == "--junit" and i + 1 < len(argv):
            path = argv[i + 1]
        elif a.startswith("--junit="):
            path = a.split("=", 1)[1]
        elif a == "--model-exchange":
            kind = "model_exchange"
        elif (a == "--fmi" and argv[i + 1:i + 2] == ["3"] or a == "--fmi=3") and kind != "model_exchange":
            kind = "fmi3"
    if not path or Path(path).is_dir():
        return
    from .scenario_run import write_junit
    with contextlib.suppress(OSError):
        write_junit([], path, {"ujfmu check": f"the command line was refused: {message} (ujfmu check --help)"},
                    kind=kind)


def main(argv=None):
    raw = list(sys.argv[1:] if argv is None else argv)
    try:
        return _main(raw)
    except SystemExit as exc:
        if exc.code not in (0, None) and _Parser.refused is not None:
            _usage_error_report(raw, _Parser.refused)
        raise
    finally:
        _Parser.refused = None


def _main(raw: list):
    parser = _Parser(prog="ujfmu", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(parser, suppress=False)
    parser.add_argument("--out", type=Path, default=argparse.SUPPRESS,
                        help="output folder or file of the command (see the command's --help)")
    sub = parser.add_subparsers(dest="command", required=True)
    common = _Parser(add_help=False)
    _common(common, suppress=True)

    def command(name, func, helptext):
        p = sub.add_parser(name, help=helptext, parents=[common])
        p.set_defaults(func=func, out_default=None)
        return p

    p = command("build", cmd_build, "build all FMUs into fmus/ (or --fmu-dir)")
    p.add_argument("names", nargs="*", help=f"FMUs to build, of {', '.join(FMUS)} (default: all)")
    _fmi(p, "build FMI 3.0 FMUs (Co-Simulation, plus Model Exchange where the model offers it; pythonfmu3)")
    for name, func, helptext in (("run", cmd_run, "co-simulate one scenario, write CSV and PNG, compare"),
                                 ("check", cmd_check, "run every scenario against its reference")):
        p = command(name, func, helptext)
        if name == "run":
            p.add_argument("scenario", type=Path)
            p.add_argument("--step", metavar="SECONDS|auto",
                           help="communication step instead of the scenario's; auto: halve it until the coupling "
                                "error estimated by step halving is within the tolerances")
            p.add_argument("--check-step", action="store_true",
                           help="rerun at half the step and report the estimated coupling error per signal (and "
                                "per [reference.orders] amplitude) "
                                "(exit status 1 if above the tolerance); the default for a run that compares "
                                "nothing (no [reference], or a changed copy)")
            p.add_argument("--no-check-step", action="store_true",
                           help="a run that compares nothing skips the step-halving estimate it makes by default")
            p.add_argument("--set", action="append", metavar="COMP.PAR=VALUE[rpm|deg]",
                           help="a parameter instead of the scenario's (several --set for several), e.g. "
                                "driveline.yoke_phase=30deg: the run is <scenario>_changed, its title says what "
                                "changed, and it is not compared with the file's reference, made for the file's setup")
            p.add_argument("--coupling", choices=("implicit", "explicit"),
                           help="coupling scheme instead of the scenario's [experiment] coupling (compared with the "
                                "same reference, whose bands were chosen for the file's scheme; results as "
                                "<scenario>_<scheme>)")
            p.add_argument("--record", action="append", metavar="COMP.VAR",
                           help="record this signal too (several --record for several), e.g. "
                                "driveline.stored_energy: written and summarised, not compared (the run stays "
                                "checked against the file's reference)")
            p.add_argument("--name", metavar="NAME",
                           help="name of the run and of the files it writes (NAME.csv, NAME.columns.csv, NAME.png) "
                                "instead of <scenario>, <scenario>_changed (--set, --stop-time), _<scheme> or "
                                "_step<h>: variants run side by side keep their own files")
            p.add_argument("--stop-time", type=float, metavar="SECONDS",
                           help="run until this time instead of the scenario's stop_time (a whole number of steps "
                                "after its start): a changed copy, as --set makes, not compared with the file's "
                                "reference (its bands are shares of the range the file's whole run reaches)")
        else:
            p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
            p.add_argument("--junit", type=Path, help="write a JUnit XML report here")
            p.add_argument("--strict", action="store_true",
                           help="exit with status 1 when any scenario is not checked (no [reference] with "
                                "tolerances), not only when none is, passes through a band that checks the "
                                "level only (at least half its reference's range, or of the signal's steady "
                                "peak-to-peak), compares no output of its machines (only its drive's and load's), "
                                "compares only a part of its reference's run, or equals its reference to the last "
                                "digit in every compared signal")
        _out(p, "results/", "output folder; results/fmi3/ with --fmi 3, results/model_exchange/ with "
                             "--model-exchange, so that runs of different FMU kinds do not overwrite each other")
        p.add_argument("--no-plot", action="store_true", help="write no figures (about half the time)")
        _fmi(p, "run the FMI 3.0 Co-Simulation FMUs")
        p.add_argument("--model-exchange", action="store_true",
                       help="run the FMI 3.0 Model Exchange FMUs together under fmpy's CVode instead of "
                            "co-simulating (implies --fmi 3; torque-driven variants, MotorController, Load)")
        p.add_argument("--output-interval", type=_positive_int, metavar="N",
                       help="record every N-th communication step and the last (default: the scenario's "
                            "[experiment] output_interval, else 1)")
    p = command("references", cmd_references, "regenerate the reference CSV files of the scenarios")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p = command("sweep", cmd_sweep, "co-simulate a scenario over a parameter grid to steady state (dask)")
    p.add_argument("scenario", type=Path)
    p.add_argument("--param", action="append", metavar="COMP.PAR[,COMP.PAR]=START:STOP:STEP[rpm|deg]",
                   help="an axis (inclusive range, or V1,V2,... values; several --param make a grid; "
                        "default: the scenario's [sweep] params)")
    p.add_argument("--set", action="append", metavar="COMP.PAR=VALUE[rpm|deg]",
                   help="a parameter instead of the scenario's at every point (several --set for several), e.g. "
                        "driveline.k_theta=1e6: the sweep is <scenario>_changed_sweep")
    p.add_argument("--output", action="append", help="signal to reduce per point (default: [sweep] outputs)")
    p.add_argument("--running-speed", help="speed signal whose revolutions are measured [rad/s]")
    p.add_argument("--settle", type=float, help="settle time before measuring [s]")
    p.add_argument("--revolutions", type=float, help="measurement window in revolutions")
    p.add_argument("--steady-tol", type=float, help="steady-state tolerance: the figures over the last quarter of the "
                                                    "settle time agree within this relative change (default 1e-3; "
                                                    "0: no check)")
    p.add_argument("--max-settle", type=float, help="longest settle time before a point is 'not_steady' [s] "
                                                    "(default 8x --settle)")
    p.add_argument("--orders", type=lambda s: tuple(int(k) for k in s.split(",")), help="orders, e.g. 1,2,4")
    p.add_argument("--step", metavar="SECONDS", help="communication step instead of the scenario's (as for run; "
                                                     "points of the journal at another step are not reused)")
    p.add_argument("--check-step", action="store_true",
                   help="rerun each output's peak point at half the step and estimate the order amplitudes' error "
                        "(exit status 1 if above 2%%)")
    p.add_argument("--coupling", choices=("implicit", "explicit"),
                   help="coupling scheme instead of the scenario's [experiment] coupling, as for run (explicit: "
                        "up to 2.8x less time a point where the implicit scheme iterates, the coupling's error first "
                        "order in the step, which --check-step estimates; the sweep is <scenario>_<scheme>_sweep)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core, or this process "
                                               "alone where dask's distributed is not installed; 0: no dask)")
    p.add_argument("--extend", action="store_true",
                   help="take over the journal of another grid over the same parameters (a grid made finer or "
                        "wider): its points on this grid are reused, its CSV and plots become this grid's")
    p.add_argument("--scheduler", help="address of a running dask.distributed scheduler, e.g. tls://host:8786; "
                        "it must be a trusted cluster (it runs what its clients submit); TLS settings come from "
                        "the dask config (docs/security.md)")
    p.add_argument("--name", help="output name (default: <scenario>_sweep); a grid other than the one in the "
                                  "journal under this name is refused")
    _out(p, "results/", "output folder")
    p.add_argument("--no-plot", action="store_true", help="write no figures")
    p.add_argument("--no-progress", action="store_true", help="same as --quiet for the progress bar")
    p = command("modes", cmd_modes, "natural frequencies and critical speeds of a scenario's components")
    p.add_argument("scenario", type=Path)
    p.add_argument("--set", action="append", metavar="COMP.PAR=VALUE[rpm|deg]",
                   help="a parameter instead of the scenario's (several --set for several), e.g. rotor.beta=10deg")
    p = command("variables", cmd_variables, "an FMU's parameters, inputs and outputs: names, units, defaults, "
                                             "ranges, meanings")
    p.add_argument("fmu", metavar="FMU", help=f"one of {', '.join(FMUS)}")
    p.add_argument("--causality", choices=("parameter", "input", "output"), help="only these")
    p = command("export-ssp", cmd_export_ssp, "write scenarios as SSP packages (SystemStructure.ssd + FMUs)")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    _out(p, "results/", "writes <scenario>.ssp here (results/fmi3/ with --fmi 3)")
    p.add_argument("--step", metavar="SECONDS", help="communication step the package carries instead of the "
                                                     "scenario's (an importer that reads it runs at it)")
    _fmi(p, "package the FMI 3.0 FMUs")
    p = command("bench", cmd_bench, "speed figures as ratios in one run: FMI floor, monolithic solve, engines, "
                                    "sweeps")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p.add_argument("--no-sweep", action="store_true", help="skip the sweep figures (1 and 2 workers)")
    p.add_argument("--no-battery", action="store_true",
                   help="skip the coupling battery's cost per scheme (scenarios/battery, about 2 minutes)")
    p.add_argument("--no-fmi3", action="store_true",
                   help="skip the FMI 3.0 / FMI 2.0 cost per step (which needs `ujfmu build --fmi 3`)")
    p.add_argument("--no-engines", action="store_true",
                   help="skip our master, Ecos and libcosim side by side on the scenarios' SSP packages")
    p.add_argument("--engine-cpus", metavar="N[,N...]|all",
                   help="cores the engine runs are pinned to (default: the first core this process may use; "
                        "all: unpinned)")
    _out(p, "results/", "writes bench.md and bench.json here")
    p = command("battery", cmd_battery, "run the coupling battery (scenarios/battery) in each scheme against its "
                                        "monolithic references")
    p.add_argument("--coupling", action="append", choices=["explicit", "implicit"],
                   help="scheme(s) to run (default: both)")
    p.add_argument("--regenerate", action="store_true", help="redraw the set-ups and re-solve their references")
    p.add_argument("--seed", type=int, help="draw a hold-out battery from the same ranges with this seed (its "
                                            "set-ups and monolithic references are made where missing)")
    p.add_argument("--dir", type=Path, help="where a hold-out battery's scenario files and references are kept "
                                            "(default: results/battery_seed<SEED>)")
    p = command("report", cmd_report,
                "re-create the papers' published results with sweeps; write docs/validation.md (in a clone)")
    _out(p, "docs/validation.md", "markdown file to write")
    p.add_argument("--work-dir", type=Path, help="where the sweeps keep their points (default: results/report; "
                                                  "a rerun resumes from them)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core; 0: no dask)")
    p.add_argument("--no-progress", action="store_true", help="same as --quiet for the progress bar")
    p = command("mutate", cmd_mutate, "mutation run: the curated mutants (mutants.toml) against their tests")
    p.add_argument("--list", type=Path, default=REPO_DIR / "mutants.toml", help="mutant list (default: mutants.toml)")
    p.add_argument("--only", nargs="+", metavar="ID", help="run only these mutants")
    p.add_argument("--resume", action="store_true",
                   help="keep the killed mutants of results/mutate.jsonl, run the others (survivors, errors, new)")
    p.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant (default: 900)")
    p.add_argument("--nice", type=int, default=19, help="CPU niceness of the test runs (default: 19)")
    _out(p, "results/", "writes mutate.jsonl here")
    for p in sub.choices.values():   # --out after a command it does not apply to: said so below, not "unrecognized"
        if "--out" not in p._option_string_actions:
            p.add_argument("--out", type=Path, default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    args = parser.parse_args(_joined_values(raw, ("--step",)))
    if args.command == "battery" and not args.coupling:
        args.coupling = ["explicit", "implicit"]
    if getattr(args, "no_progress", False):
        args.quiet = True
    if args.out_default is None and "out" in args:
        parser.error(f"--out does not apply to `ujfmu {args.command}`" +
                     (" (FMUs go to --fmu-dir)" if args.command == "build" else ""))
    if "out" not in args:
        args.out = args.out_default
        if args.command in ("run", "check") and args.model_exchange:
            args.out = args.out / "model_exchange"
        elif args.command in ("run", "check", "export-ssp") and args.fmi == 3:
            args.out = args.out / "fmi3"
    if getattr(args, "model_exchange", False):
        args.fmi = 3
    if getattr(args, "fmi", 2) == 3 and args.fmu_dir == DEFAULT_FMU_DIR:   # --fmi 3: fmus/fmi3/ by default
        from .build3 import DEFAULT_FMU3_DIR
        args.fmu_dir = DEFAULT_FMU3_DIR
    other = other_checkout()
    if other is not None:
        print(f"ujfmu: warning: this directory holds another ujfmu checkout ({other.absolute()}) than the one this "
              f"command runs from ({PACKAGE_DIR}): FMUs are built, and scenarios run, from the latter's sources; "
              "install this one (`pip install -e .` in a venv of its own) to check its code", file=sys.stderr)
    try:
        from .master import FmuWarning
        with warnings.catch_warnings():   # the commands print what the FMUs warn of in their own terms
            warnings.simplefilter("ignore", FmuWarning)
            return args.func(args)
    except KeyboardInterrupt as exc:   # master.Interrupted says where, and the results it kept
        print(f"\nujfmu {args.command}: {_stopped_text()}" + (f": {exc}" if str(exc) else ""), file=sys.stderr)
        return stopped_status()
    except Exception as exc:  # a clear message, not a traceback, for user errors
        from .master import CosimulationError
        from .scenario import ScenarioError
        if isinstance(exc, (ScenarioError, CosimulationError, FileNotFoundError, UsageError, MissingExtraError)):
            print(f"ujfmu: error: {exc}", file=sys.stderr)
            return 2
        raise


def _joined_values(argv, options):
    """argv with `OPTION VALUE` written `OPTION=VALUE` where VALUE starts with '-' and reads as a number:
    argparse takes `--step -1e-3` for two options ("expected one argument"); joined, the value reaches the
    option's own check, which names what is wrong with it."""
    argv, out, i = list(argv), [], 0
    while i < len(argv):
        if argv[i] in options and i + 1 < len(argv) and argv[i + 1].startswith("-"):
            try:
                float(argv[i + 1])
            except ValueError:
                pass
            else:
                out.append(f"{argv[i]}={argv[i + 1]}")
                i += 2
                continue
        out.append(argv[i])
        i += 1
    return out


def entry() -> None:
    """The ``ujfmu`` command: :func:`main` through :func:`run_and_exit`, Ctrl-C handled by :func:`_interrupt`, the
    output to a reader that may stop reading (:class:`_ClosedPipeTolerant`)."""
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    sys.stdout = _ClosedPipeTolerant(sys.stdout)
    run_and_exit(main)


class _ClosedPipeTolerant:
    """sys.stdout that goes on when its reader has gone (``ujfmu build | head -1``): the command's work is done
    and its exit status kept, its further output discarded (a BrokenPipeError would stop a build part-way)."""

    def __init__(self, stream):
        self._stream = stream

    def _discard(self) -> None:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, self._stream.fileno())
        os.close(devnull)

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._discard()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._discard()

    def __getattr__(self, name):
        return getattr(self._stream, name)


#: the signal that stopped the command (SIGINT or SIGTERM), None while none has
STOPPED_BY = [None]


def _interrupt(signum, frame) -> None:
    """Ctrl-C (SIGINT) or a batch scheduler's or ``kill``'s SIGTERM: while a co-simulation is open, ask it to stop
    at its next communication step (``master.STOP``: an interrupt raised inside an FMU's code would be caught there
    as the FMU's fatal error); else, and at a second signal, KeyboardInterrupt at once. The commands report an
    interruption in a line and exit with 128 + the signal's number (``main``, :func:`stopped_status`)."""
    from . import master
    STOPPED_BY[0] = signum
    if master.OPEN[0] and not master.STOP[0]:
        master.STOP[0] = True
        what = "Ctrl-C" if signum == signal.SIGINT else "SIGTERM"
        print(f"\n{what}: stopping at the next communication step ({what} again to stop at once, or, inside an "
              "FMU's call, as it returns)", file=sys.stderr)
        return
    master.raise_at_once(frame)


def _stopped_text() -> str:
    """'interrupted' (Ctrl-C, or a KeyboardInterrupt of no signal) or 'terminated (SIGTERM)'."""
    return "terminated (SIGTERM)" if STOPPED_BY[0] == signal.SIGTERM else "interrupted"


def stopped_status() -> int:
    """The exit status of a command stopped by a signal: 128 + its number (130 for Ctrl-C, 143 for SIGTERM), as a
    shell reports a process the signal killed, so a batch script tells it from a failure."""
    return 128 + (STOPPED_BY[0] or signal.SIGINT)


#: the exit status of an unexpected exception (a bug), apart from 1 (a check failed) and 2 (could not run)
INTERNAL_ERROR = 3


def run_and_exit(function) -> None:
    """Run function() (a command's main: its exit status, or SystemExit), then, once Python's exit handlers have run
    and the output is flushed, end the process with that status without the shared libraries' destructors.
    pythonfmu 0.7.0's binary, in every FMU, reads at exit memory that its own static destructor has freed
    (valgrind: ``finalizePythonInterpreter``): ``ujfmu check`` aborted there ("corrupted double-linked list",
    status -6) after writing every result, in 2 of 3 test-suite runs on a busy machine."""
    try:
        code = function()
    except SystemExit as exc:
        code = exc.code
    except Exception:   # not a user error (those are messages, status 2): a bug, told apart from a FAIL
        traceback.print_exc()
        print(f"ujfmu: internal error (a bug: please report it with the traceback above); exit status "
              f"{INTERNAL_ERROR}", file=sys.stderr)
        code = INTERNAL_ERROR
    if code is None:
        code = 0
    elif not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)


if __name__ == "__main__":
    entry()
