"""``ujfmu bench``: speed figures as ratios measured in one run (these machines are noisy, ratios are not).

Per scenario, at a 1 ms communication step over the scenario's run:
- wall seconds per simulated second and microseconds per macro step of the stepping loop (set-up excluded, and
  reported apart), the fastest of three runs alternated with the floor's;
- the same master running pass-through twins of the FMUs (same variables, ports and FMI plumbing, no physics;
  ``ujfmu.fmu.passthrough``): the FMI call floor, and the ratio of the real run to it;
- the monolithic scipy solve (DOP853, rtol 1e-8) of the same system by the scenario's reference generator, only
  the integration timed (the symbolic derivation is not), and the ratio; plus whether the co-simulation stays
  within the scenario's tolerance of that solve. Scenarios whose reference is a closed form have no solve.
For sweeps: Omar's Fig. 4 sweep (141 points) with 1 and 2 local dask workers, points per minute and speed-up.
"""

import json
import math
import tempfile
import time
from pathlib import Path


from .build import DEFAULT_FMU_DIR, REPO_DIR, build_fmu
from .master import COUPLINGS, Component, Cosimulation, CosimulationError
from .references import common, generate
from .scenario import Scenario
from .scenario_run import compare

STEP = 1e-3
REPEATS = 3        # co-simulation and floor runs per scenario, alternated; the fastest of each counts
MONOLITHIC_RTOL, MONOLITHIC_ATOL = 1e-8, 1e-11
TARGETS = {"s_per_sim_s": 0.05, "floor_ratio": 2.0, "fig4_seconds": 120.0, "worker_speedup": 1.8}


def _stepping_time(components, scenario, n_steps):
    """(set-up seconds, stepping seconds, table) of one co-simulation at STEP, recording the scenario's signals."""
    started = time.perf_counter()
    with Cosimulation(components, scenario.connections, STEP, scenario.record, scenario.start_time) as cosim:
        ready = time.perf_counter()
        table = cosim.run(n_steps)
        done = time.perf_counter()
    return ready - started, done - ready, table


def bench_scenario(path, fmu_dir, floor_dir, repeats=REPEATS):
    scenario = Scenario(path)
    duration = scenario.stop_time - scenario.start_time
    n_steps = int(round(duration / STEP))
    twins = [Component(c.name, Path(floor_dir) / f"{Path(c.fmu).stem}PassThrough.fmu", {})
             for c in scenario.master_components(fmu_dir)]
    wall = floor = setup = math.inf
    for _ in range(repeats):   # alternating, keeping the fastest of each: noise only ever adds time
        s, w, table = _stepping_time(scenario.master_components(fmu_dir), scenario, n_steps)
        setup, wall = min(setup, s), min(wall, w)
        floor = min(floor, _stepping_time(twins, scenario, n_steps)[1])
    row = dict(scenario=scenario.name, simulated_s=duration, steps=n_steps, setup_s=setup,
               s_per_sim_s=wall / duration, us_per_step=1e6 * wall / n_steps, floor_us_per_step=1e6 * floor / n_steps,
               floor_ratio=wall / floor, monolithic_s=None, monolithic_ratio=None, within_tolerance=None, note="")
    if scenario.reference_generator:
        grid = Scenario(path)
        grid.step_size = STEP
        with common.solver_override(MONOLITHIC_RTOL, MONOLITHIC_ATOL) as solver:
            reference, _ = generate(grid)
        if solver.solves:
            row.update(monolithic_s=solver.seconds, monolithic_ratio=wall / solver.seconds)
            checks = compare(table, reference, scenario.tolerances)
            row["within_tolerance"] = all(c.passed for c in checks)
            worst = max(checks, key=lambda c: c.max_error / c.allowed if c.allowed else 0.0)
            row["note"] = f"worst {worst.name}: {worst.max_error / worst.allowed:.2f} of its tolerance"
        else:
            row["note"] = "reference is a closed form: no ODE solve to compare"
    return row


def bench_schemes(paths, fmu_dir=DEFAULT_FMU_DIR, repeats=1, progress=None) -> dict:
    """Cost of each coupling scheme on each scenario at its own step, taken in one run (schemes alternated, the
    fastest of ``repeats`` kept): wall seconds per simulated second, the implicit/explicit ratio, and the error
    that stopped a run. Totals over the scenarios both schemes complete."""
    rows = []
    for path in paths:
        scenario = Scenario(path)
        n_steps = int(round((scenario.stop_time - scenario.start_time) / scenario.step_size))
        duration = scenario.stop_time - scenario.start_time
        row = dict(scenario=scenario.name, simulated_s=duration)
        for _ in range(repeats):
            for coupling in COUPLINGS:
                try:
                    with Cosimulation(scenario.master_components(fmu_dir), scenario.connections, scenario.step_size,
                                      scenario.record, scenario.start_time, coupling) as cosim:
                        started = time.perf_counter()
                        cosim.run(n_steps)
                        seconds = time.perf_counter() - started
                    row[coupling] = min(row.get(coupling) or math.inf, seconds / duration)
                except CosimulationError as exc:
                    row[coupling], row[f"{coupling}_error"] = None, str(exc).splitlines()[0][:160]
        both = all(row.get(c) for c in COUPLINGS)
        row["ratio"] = row["implicit"] / row["explicit"] if both else None
        rows.append(row)
        if progress:
            progress(f"schemes {scenario.name}: " + ", ".join(f"{c} {_f(row.get(c), '.3f')} s/s" for c in COUPLINGS))
    done = [r for r in rows if r["ratio"] is not None]
    totals = {c: sum(r[c] * r["simulated_s"] for r in done) / max(1e-300, sum(r["simulated_s"] for r in done))
              for c in COUPLINGS}
    return dict(rows=rows, totals=totals,
                ratio=totals["implicit"] / totals["explicit"] if done else None,
                failed={c: [r["scenario"] for r in rows if r.get(c) is None] for c in COUPLINGS})


def render_schemes(title, figures):
    lines = [f"| {title} | sim. s | explicit wall s / sim. s | implicit wall s / sim. s | implicit / explicit |",
             "| --- | --- | --- | --- | --- |"]
    for r in figures["rows"]:
        cells = [_f(r.get(c), ".3f") if r.get(c) is not None else "failed" for c in ("explicit", "implicit")]
        lines.append(f"| {r['scenario']} | {r['simulated_s']:g} | {cells[0]} | {cells[1]} | {_f(r['ratio'], '.2f')} |")
    t = figures["totals"]
    lines.append(f"| all that both complete | | {t['explicit']:.3f} | {t['implicit']:.3f} | "
                 f"{_f(figures['ratio'], '.2f')} |")
    for c, names in figures["failed"].items():
        if names:
            lines.append(f"\n{c} failed on {len(names)}: {', '.join(names)}")
    return "\n".join(lines)


def bench_sweep(fmu_dir, workers):
    """Omar's Fig. 4 sweep (the scenario's [sweep] table) with this many local workers: (seconds, points)."""
    from .sweep import Sweep, SweepSettings, parse_axis
    scenario = Scenario(REPO_DIR / "scenarios" / "double_cardan_omar_torsional.toml")
    axes = [parse_axis(p, scenario) for p in scenario.sweep["params"]]
    with tempfile.TemporaryDirectory(prefix="ujfmu_bench_sweep_") as tmp:
        sweep = Sweep(scenario, axes, SweepSettings.from_scenario(scenario), out_dir=tmp, fmu_dir=fmu_dir)
        started = time.perf_counter()
        sweep.run(workers=workers, progress=False)
        seconds = time.perf_counter() - started
        failed = sweep.failed()
    if failed:
        raise RuntimeError(f"benchmark sweep: {len(failed)} points failed: {failed[0]['error']}")
    return seconds, len(sweep.points)


def run_bench(scenarios, fmu_dir=DEFAULT_FMU_DIR, sweep=True, progress=print, battery=(), schemes=True):
    """All figures of one run: {'scenarios': [rows], 'schemes': {...}, 'battery': {...}, 'sweep': {...}};
    battery: the coupling battery's scenario files (ujfmu.battery.paths()) to cost in each scheme; schemes: cost
    each scheme on the scenarios too."""
    with tempfile.TemporaryDirectory(prefix="ujfmu_floor_") as floor_dir:
        names = sorted({fmu for p in scenarios for fmu, _ in Scenario(p).components.values()})
        for name in names:
            build_fmu(name, floor_dir, pass_through=True)
        rows = []
        for path in scenarios:
            progress(f"bench {Path(path).stem}")
            rows.append(bench_scenario(path, fmu_dir, floor_dir))
    result = {"step_size": STEP, "scenarios": rows, "targets": TARGETS}
    if schemes:
        result["schemes"] = bench_schemes(scenarios, fmu_dir, REPEATS, progress)
    if battery:
        result["battery"] = bench_schemes(battery, fmu_dir, 1, progress)
    if sweep:
        figures = {}
        for workers in (1, 2):
            progress(f"bench Omar Fig. 4 sweep, {workers} worker(s)")
            seconds, points = bench_sweep(fmu_dir, workers)
            figures[workers] = dict(seconds=seconds, points=points, points_per_minute=60.0 * points / seconds)
        result["sweep"] = dict(workers=figures, speedup=figures[1]["seconds"] / figures[2]["seconds"])
    return result


def _f(value, fmt):
    return "-" if value is None else format(value, fmt)


def render(result):
    """Markdown tables of a bench result, with each target met or not."""
    t = result["targets"]
    lines = ["| scenario | sim. s | wall s / sim. s | us / step | floor us / step | x floor | "
             "monolithic s | co-sim / monolithic | within tolerance | targets 1 / 2 / 3 |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in result["scenarios"]:
        marks = ["yes" if r["s_per_sim_s"] <= t["s_per_sim_s"] else "NO",
                 "yes" if r["floor_ratio"] <= t["floor_ratio"] else "NO",
                 "-" if r["monolithic_ratio"] is None else
                 ("yes" if r["monolithic_ratio"] < 1.0 and r["within_tolerance"] else "NO")]
        lines.append(f"| {r['scenario']} | {r['simulated_s']:g} | {r['s_per_sim_s']:.4f} | {r['us_per_step']:.1f} | "
                     f"{r['floor_us_per_step']:.1f} | {r['floor_ratio']:.2f} | {_f(r['monolithic_s'], '.2f')} | "
                     f"{_f(r['monolithic_ratio'], '.3f')} | "
                     f"{'-' if r['within_tolerance'] is None else ('yes' if r['within_tolerance'] else 'NO')} | "
                     f"{' / '.join(marks)} |")
    if "schemes" in result:
        lines += ["", "Coupling schemes, each scenario at its own step (docs/cosimulation.md):", "",
                  render_schemes("scenario", result["schemes"])]
    if "battery" in result:
        lines += ["", "Coupling battery (ujfmu.battery), 1 ms:", "", render_schemes("set-up", result["battery"])]
    if "sweep" in result:
        s = result["sweep"]
        one, two = s["workers"][1], s["workers"][2]
        lines += ["", "| Omar Fig. 4 sweep (141 points, 100-1500 rpm) | wall s | points / min |", "| --- | --- | --- |",
                  f"| 1 worker | {one['seconds']:.1f} | {one['points_per_minute']:.0f} |",
                  f"| 2 workers | {two['seconds']:.1f} | {two['points_per_minute']:.0f} |", "",
                  f"Speed-up with 2 workers: {s['speedup']:.2f}x (target >= {t['worker_speedup']}x: "
                  f"{'met' if s['speedup'] >= t['worker_speedup'] else 'NOT met'}); Fig. 4 sweep on 2 workers "
                  f"{two['seconds']:.0f} s (target < {t['fig4_seconds']:.0f} s: "
                  f"{'met' if two['seconds'] < t['fig4_seconds'] else 'NOT met'})."]
    lines += ["", f"Targets: 1. <= {t['s_per_sim_s']} wall s per simulated s; 2. <= {t['floor_ratio']}x the "
              "pass-through run; 3. faster than the DOP853 rtol 1e-8 solve and within the scenario's tolerance of it."]
    return "\n".join(lines)


def write(result, out_dir):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "bench.json").write_text(json.dumps(result, indent=1, default=lambda x: None if x != x else x))
    (out_dir / "bench.md").write_text(render(result) + "\n")
    return out_dir / "bench.md"

