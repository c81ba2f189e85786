"""Command line: ujfmu build | run | check | references | sweep | report | bench | export-ssp."""

import argparse
import sys
from pathlib import Path

from .build import DEFAULT_FMU_DIR, FMUS, REPO_DIR

DEFAULT_SCENARIO_DIR = REPO_DIR / "scenarios"


def _scenarios(paths):
    if paths:
        return [Path(p) for p in paths]
    return sorted(DEFAULT_SCENARIO_DIR.glob("*.toml"))


def cmd_build(args):
    from .build import build_all
    from tqdm import tqdm
    unknown = [n for n in args.names if n not in FMUS]
    if unknown:
        print(f"ujfmu: error: unknown FMU {', '.join(unknown)}; known: {', '.join(FMUS)}", file=sys.stderr)
        return 2
    for name in tqdm(args.names or list(FMUS), desc="building FMUs", unit="fmu", disable=None):
        path = build_all(args.fmu_dir, [name])[0]
        tqdm.write(f"built {path}")
    return 0


def cmd_run(args):
    from . import stepsize
    from .scenario import Scenario
    from .scenario_run import run_scenario
    scenario = Scenario(args.scenario)
    if args.step == "auto":
        scenario.check_fmus(args.fmu_dir)
        scenario.step_size, _ = stepsize.choose(scenario, args.fmu_dir, progress=print)
        print(f"--step auto: step_size = {scenario.step_size:g} s")
    elif args.step is not None:
        scenario.step_size = float(args.step)
    result = run_scenario(scenario, fmu_dir=args.fmu_dir, out_dir=args.out, plot=not args.no_plot)
    print(result.summary())
    print(f"  results: {result.csv}" + (f"\n  plot:    {result.plot}" if result.plot else ""))
    for extra in result.extra_plots:
        print(f"  plot:    {extra}")
    step_ok = True
    if args.check_step:
        estimate = stepsize.estimate(scenario, fmu_dir=args.fmu_dir, coarse=result.table)
        print("\n".join(estimate.lines()))
        step_ok = estimate.passed
    return 0 if result.passed and step_ok else 1


def cmd_check(args):
    from .scenario_run import run_scenario, write_junit
    results = []
    for path in _scenarios(args.scenarios):
        result = run_scenario(path, fmu_dir=args.fmu_dir, out_dir=args.out, plot=not args.no_plot)
        print(result.summary())
        results.append(result)
    if args.junit:
        print(f"JUnit report: {write_junit(results, args.junit)}")
    failed = [r.scenario.name for r in results if not r.passed]
    print(f"{len(results) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


def cmd_references(args):
    from .references import generate, write_reference
    from .scenario import Scenario
    for path in _scenarios(args.scenarios):
        scenario = Scenario(path)
        if scenario.reference_generator is None:
            continue
        target = scenario.reference_output()   # inside the scenario's folder, checked before any work
        table, provenance = generate(scenario)
        write_reference(target, table, provenance)
        print(f"wrote {scenario.reference_file}")
    return 0


def cmd_sweep(args):
    from .scenario import Scenario, ScenarioError
    from .sweep import Sweep, SweepSettings, parse_axis
    scenario = Scenario(args.scenario)
    specs = args.param or scenario.sweep.get("params", [])
    if not specs:
        raise ScenarioError(f"{scenario.path}: nothing to sweep: give --param comp.par=START:STOP:STEP "
                            "or [sweep] params in the scenario")
    axes = [parse_axis(spec, scenario) for spec in specs]
    settings = SweepSettings.from_scenario(scenario, outputs=args.output, running_speed=args.running_speed,
                                           settle_time=args.settle, revolutions=args.revolutions,
                                           orders=args.orders, steady_tol=args.steady_tol,
                                           max_settle_time=args.max_settle)
    sweep = Sweep(scenario, axes, settings, out_dir=args.out, name=args.name, fmu_dir=args.fmu_dir)
    print(f"{sweep.name}: {len(sweep.points)} points ({' x '.join(str(len(a.values)) for a in axes)}), "
          f"settle {settings.settle_time:g} s, {settings.revolutions:g} revolutions measured")
    sweep.run(workers=args.workers, scheduler=args.scheduler, progress=not args.no_progress)
    print(f"  table: {sweep.csv}\n  journal: {sweep.journal}")
    if not args.no_plot:
        for path in sweep.plot():
            print(f"  plot:  {path}")
    failed = sweep.failed()
    for record in failed[:10]:
        print(f"  point {record['point']} {record['status']}: {record['error']}", file=sys.stderr)
    print(_status_summary(sweep.status_counts(), len(sweep.points)), file=sys.stderr if failed else sys.stdout)
    return 1 if failed else 0


#: what each sweep point status means, for the summary line
STATUS_MEANING = {"ok": "steady at the operating point", "not_steady": "not steady by max_settle_time",
                  "off_target": "operating point not reached", "error": "failed (rerun to retry)",
                  "missing": "not run"}


def _status_summary(counts, total):
    """'N points: a ok (steady at the operating point), b not_steady (...), ...'."""
    parts = [f"{n} {status} ({STATUS_MEANING.get(status, status)})" for status, n in sorted(
        counts.items(), key=lambda item: list(STATUS_MEANING).index(item[0]) if item[0] in STATUS_MEANING else 99)]
    return f"{total} points: " + ", ".join(parts)


def cmd_export_ssp(args):
    from .scenario import Scenario
    from .ssp import export_ssp
    for path in _scenarios(args.scenarios):
        print(f"wrote {export_ssp(Scenario(path), args.out, args.fmu_dir)}")
    return 0


def cmd_bench(args):
    from .bench import render, run_bench, write
    from .battery import paths as battery_paths
    result = run_bench(_scenarios(args.scenarios), fmu_dir=args.fmu_dir, sweep=not args.no_sweep,
                       progress=lambda msg: print(msg, file=sys.stderr),
                       battery=() if args.no_battery else battery_paths())
    print(render(result))
    print(f"\nwrote {write(result, args.out)}")
    return 0


def cmd_battery(args):
    from . import battery
    if args.regenerate:
        battery.regenerate(progress=print)
        return 0
    runs = []
    print("| set-up | joint | " + " | ".join(f"{c}: worst error / range" for c in args.coupling) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in args.coupling) + " |")
    for path in battery.paths():
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
    from .report import write_report
    path = write_report(args.out, fmu_dir=args.fmu_dir, work_dir=args.work_dir, workers=args.workers,
                        progress=not args.no_progress).path
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


def main(argv=None):
    parser = argparse.ArgumentParser(prog="ujfmu", description=__doc__)
    parser.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR, help="where the FMUs are (default: fmus/)")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("build", help="build all FMUs into fmus/")
    p.add_argument("names", nargs="*", help=f"FMUs to build, of {', '.join(FMUS)} (default: all)")
    p.set_defaults(func=cmd_build)
    for name, func, helptext in (("run", cmd_run, "co-simulate one scenario, write CSV and PNG, compare"),
                                 ("check", cmd_check, "run every scenario against its reference")):
        p = sub.add_parser(name, help=helptext)
        if name == "run":
            p.add_argument("scenario", type=Path)
            p.add_argument("--step", metavar="SECONDS|auto",
                           help="communication step instead of the scenario's; auto: halve it until the coupling "
                                "error estimated by step halving is within the tolerances")
            p.add_argument("--check-step", action="store_true",
                           help="rerun at half the step and report the estimated coupling error per signal "
                                "(exit status 1 if above the tolerance)")
        else:
            p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
            p.add_argument("--junit", type=Path, help="write a JUnit XML report here")
        p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
        p.add_argument("--no-plot", action="store_true")
        p.set_defaults(func=func)
    p = sub.add_parser("references", help="regenerate the reference CSV files of the scenarios")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p.set_defaults(func=cmd_references)
    p = sub.add_parser("sweep", help="co-simulate a scenario over a parameter grid to steady state (dask)")
    p.add_argument("scenario", type=Path)
    p.add_argument("--param", action="append", metavar="COMP.PAR[,COMP.PAR]=START:STOP:STEP[rpm|deg]",
                   help="an axis (inclusive range, or V1,V2,... values; several --param make a grid; "
                        "default: the scenario's [sweep] params)")
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
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core; 0: no dask)")
    p.add_argument("--scheduler", help="address of a running dask.distributed scheduler, e.g. tls://host:8786; "
                        "it must be a trusted cluster (it runs what its clients submit); TLS settings come from "
                        "the dask config (docs/security.md)")
    p.add_argument("--name", help="output name (default: <scenario>_sweep)")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
    p.add_argument("--no-plot", action="store_true")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_sweep)
    p = sub.add_parser("export-ssp", help="write scenarios as SSP packages (SystemStructure.ssd + FMUs)")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p.add_argument("--out", type=Path, default=Path("results"), help="writes <scenario>.ssp here")
    p.set_defaults(func=cmd_export_ssp)
    p = sub.add_parser("bench", help="speed figures as ratios in one run: FMI floor, monolithic solve, sweeps")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p.add_argument("--no-sweep", action="store_true", help="skip the sweep figures (1 and 2 workers)")
    p.add_argument("--no-battery", action="store_true",
                   help="skip the coupling battery's cost per scheme (scenarios/battery, about 2 minutes)")
    p.add_argument("--out", type=Path, default=Path("results"), help="writes bench.md and bench.json here")
    p.set_defaults(func=cmd_bench)
    p = sub.add_parser("battery", help="run the coupling battery (scenarios/battery) in each scheme against its "
                                       "monolithic references")
    p.add_argument("--coupling", action="append", choices=["explicit", "implicit"],
                   help="scheme(s) to run (default: both)")
    p.add_argument("--regenerate", action="store_true", help="redraw the set-ups and re-solve their references")
    p.set_defaults(func=cmd_battery)
    p = sub.add_parser("report", help="re-create the papers' published results with sweeps; write docs/validation.md")
    p.add_argument("--out", type=Path, default=REPO_DIR / "docs" / "validation.md", help="markdown file to write")
    p.add_argument("--work-dir", type=Path, help="where the sweeps keep their points (default: results/report; "
                                                  "a rerun resumes from them)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core; 0: no dask)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_report)
    p = sub.add_parser("mutate", help="mutation run: the curated mutants (mutants.toml) against their tests")
    p.add_argument("--list", type=Path, default=REPO_DIR / "mutants.toml", help="mutant list (default: mutants.toml)")
    p.add_argument("--only", nargs="+", metavar="ID", help="run only these mutants")
    p.add_argument("--resume", action="store_true",
                   help="keep the killed mutants of results/mutate.jsonl, run the others (survivors, errors, new)")
    p.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant (default: 900)")
    p.add_argument("--nice", type=int, default=19, help="CPU niceness of the test runs (default: 19)")
    p.add_argument("--out", type=Path, default=Path("results"), help="writes mutate.jsonl here")
    p.set_defaults(func=cmd_mutate)
    args = parser.parse_args(argv)
    if args.command == "battery" and not args.coupling:
        args.coupling = ["explicit", "implicit"]
    try:
        return args.func(args)
    except Exception as exc:  # a clear message, not a traceback, for user errors
        from .master import CosimulationError
        from .scenario import ScenarioError
        if isinstance(exc, (ScenarioError, CosimulationError, FileNotFoundError)):
            print(f"ujfmu: error: {exc}", file=sys.stderr)
            return 2
        raise


if __name__ == "__main__":
    sys.exit(main())
