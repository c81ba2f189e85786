"""Command line: ujfmu build | run SCENARIO | check | references | study omar."""

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
    from .scenario_run import run_scenario
    result = run_scenario(args.scenario, fmu_dir=args.fmu_dir, out_dir=args.out, plot=not args.no_plot)
    print(result.summary())
    print(f"  results: {result.csv}" + (f"\n  plot:    {result.plot}" if result.plot else ""))
    for extra in result.extra_plots:
        print(f"  plot:    {extra}")
    return 0 if result.passed else 1


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
        table, provenance = generate(scenario)
        write_reference(scenario.reference_file, table, provenance)
        print(f"wrote {scenario.reference_file}")
    return 0


def cmd_study(args):
    from .studies import omar
    path = omar.write_report(args.out, fmu_path=args.fmu_dir / "DoubleCardanDriveline.fmu")
    print(f"wrote {path}")
    return 0


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
        else:
            p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
            p.add_argument("--junit", type=Path, help="write a JUnit XML report here")
        p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
        p.add_argument("--no-plot", action="store_true")
        p.set_defaults(func=func)
    p = sub.add_parser("references", help="regenerate the reference CSV files of the scenarios")
    p.add_argument("scenarios", nargs="*", type=Path, help="default: scenarios/*.toml")
    p.set_defaults(func=cmd_references)
    p = sub.add_parser("study", help="re-run a paper's parameter studies on the FMUs and write the comparison")
    p.add_argument("paper", choices=["omar"], help="omar: Omar, Rahim, Rejab (DoubleCardanDriveline)")
    p.add_argument("--out", type=Path, default=REPO_DIR / "docs" / "omar_study.md", help="markdown file to write")
    p.set_defaults(func=cmd_study)
    args = parser.parse_args(argv)
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
