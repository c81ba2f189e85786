"""``ujfmu bench``: speed figures as ratios measured in one run (these machines are noisy, ratios are not).

Per scenario, at a 1 ms communication step over the scenario's run:
- wall seconds per simulated second and microseconds per macro step of the stepping loop (set-up excluded, and
  reported apart), the fastest of three runs;
- the same master running pass-through twins of the FMUs (same variables, ports and FMI plumbing, no physics;
  ``ujfmu.fmu.passthrough``): the FMI call floor, and the ratio of the real run to it. The two run side by side in
  one process, in turns of 250 steps over the same simulated intervals, and the ratio is the median of the turns'
  ratios: a slow spell of a shared machine slows both alike (totals of separate runs scattered by 30% here);
- the monolithic scipy solve (DOP853, rtol 1e-8) of the same system by the scenario's reference generator, only
  the integration timed (the symbolic derivation is not), and the ratio; plus whether the co-simulation stays
  within the scenario's tolerance of that solve. Scenarios whose reference is a closed form have no solve.
For sweeps: Omar's Fig. 4 sweep (141 points) with 1 and 2 local dask workers (a new local cluster each run, its
start included), alternated, the fastest of three runs of each; points per minute and speed-up.
Engines (``ujfmu.engines``): each scenario's SSP package stepped by our master, Ecos and libcosim, each in its own
process pinned to one core, alternated, the fastest of three runs of each; microseconds per step and the ratios.
The figures above run the explicit scheme (inputs held over the step, as the C++ engines do); the coupling-scheme
table adds the implicit scheme's cost on the same scenarios.
"""

import json
import math
import os
import random
import tempfile
import time
from pathlib import Path

import numpy as np

from . import engines as engine_runs
from .build import DEFAULT_FMU_DIR, REPO_DIR, build_fmu
from .master import COUPLINGS, Component, Cosimulation, CosimulationError, FmuInstance, extracted
from .references import common, generate
from .scenario import Scenario
from .scenario_run import compare

STEP = 1e-3
REPEATS = 3        # co-simulation and floor runs per scenario, alternated; the fastest of each counts
#: the engine runs of a short scenario are repeated until each engine has stepped this many steps in all (at least
#: REPEATS runs): a 500-step scenario's stepping loop lasts about 40 ms, which one preemption on a shared machine
#: lengthens by 10% (cardan_constant_speed's ratio to Ecos, the fastest of 3 runs, scattered 0.63-1.37 between
#: bench runs; of 6, 0.84-1.06); the fastest of more runs is each engine at its best
ENGINE_MIN_STEPS = 3000
MONOLITHIC_RTOL, MONOLITHIC_ATOL = 1e-8, 1e-11
TARGETS = {"s_per_sim_s": 0.05, "floor_ratio": 2.0, "fig4_seconds": 120.0, "worker_speedup": 1.8,
           "engine_ratio": 1.1}
ENGINES = tuple(engine_runs.ENGINES)   # ours first: the others' ratios are to it


#: steps per timed chunk of the side-by-side run (``_side_by_side``)
CHUNK = 250


def _side_by_side(components, twins, scenario, n_steps, chunk=CHUNK):
    """(set-up seconds, the run's stepping seconds, the floor's, [run / floor of each chunk], the run's table): the
    co-simulation and its pass-through twins open together in this process and advanced in turn, ``chunk`` steps
    at a time over the same simulated intervals, each chunk timed; a slow spell of a shared machine then slows both
    alike, and each chunk's ratio compares the same part of the run (a run-up's cost changes along it)."""
    started = time.perf_counter()
    with Cosimulation(components, scenario.connections, STEP, scenario.record, scenario.start_time,
                      coupling="explicit") as cosim, \
            Cosimulation(twins, scenario.connections, STEP, scenario.record, scenario.start_time,
                         coupling="explicit") as floor_cosim:
        setup = time.perf_counter() - started
        wall = floor = 0.0
        ratios, tables = [], []
        for done in range(0, n_steps, chunk):
            steps = min(chunk, n_steps - done)
            t0 = time.perf_counter()
            tables.append(cosim.run(steps) if not tables else cosim.run(steps)[1:])
            t1 = time.perf_counter()
            floor_cosim.run(steps)
            t2 = time.perf_counter()
            wall, floor = wall + (t1 - t0), floor + (t2 - t1)
            ratios.append((t1 - t0) / (t2 - t1))
    return setup, wall, floor, ratios, np.concatenate(tables).view(np.recarray)


def bench_scenario(path, fmu_dir, floor_dir, repeats=REPEATS):
    """One row of the scenario table: the run's time per simulated second and per step, the fastest of ``repeats``
    side-by-side runs (``_side_by_side``), the floor's likewise, and their ratio as the median of the chunks'
    ratios over all repeats (a ratio of totals would carry whatever slow spells the two happened to meet)."""
    scenario = Scenario(path)
    duration = scenario.stop_time - scenario.start_time
    n_steps = int(round(duration / STEP))
    # the twins take the scenario's parameters (same variables): the same set-up, and an input the scenario holds
    # deliberately is held in the floor run too (no held-input warning)
    twins = [Component(c.name, Path(floor_dir) / f"{Path(c.fmu).stem}PassThrough.fmu", c.parameters)
             for c in scenario.master_components(fmu_dir)]
    wall = floor = setup = math.inf
    ratios = []
    for _ in range(repeats):   # keeping the fastest of each: noise only ever adds time
        s, w, f, chunk_ratios, table = _side_by_side(scenario.master_components(fmu_dir), twins, scenario, n_steps)
        setup, wall, floor = min(setup, s), min(wall, w), min(floor, f)
        ratios += chunk_ratios
    row = dict(scenario=scenario.name, simulated_s=duration, steps=n_steps, setup_s=setup,
               s_per_sim_s=wall / duration, us_per_step=1e6 * wall / n_steps, floor_us_per_step=1e6 * floor / n_steps,
               floor_ratio=float(np.median(ratios)), monolithic_s=None, monolithic_ratio=None, within_tolerance=None,
               note="")
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
        row = dict(scenario=scenario.name, simulated_s=duration, step_size=scenario.step_size)
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


def _floors(result):
    """{scenario: pass-through wall s per simulated s at STEP} of a bench result."""
    return {r["scenario"]: r["floor_us_per_step"] * 1e-6 / result["step_size"] for r in result["scenarios"]}


def render_schemes(title, figures, floors=None, targets=None):
    """Markdown table of ``bench_schemes``; with floors ({scenario: pass-through s per simulated s}) and targets,
    the implicit scheme's ratio to the floor and targets 1 / 2 met or not."""
    marks = floors is not None and targets is not None
    lines = [f"| {title} | sim. s | explicit wall s / sim. s | implicit wall s / sim. s | implicit / explicit |"
             + (" implicit x floor | implicit targets 1 / 2 |" if marks else ""),
             "| --- | --- | --- | --- | --- |" + (" --- | --- |" if marks else "")]
    for r in figures["rows"]:
        cells = [_f(r.get(c), ".3f") if r.get(c) is not None else "failed" for c in ("explicit", "implicit")]
        line = f"| {r['scenario']} | {r['simulated_s']:g} | {cells[0]} | {cells[1]} | {_f(r['ratio'], '.2f')} |"
        if marks:
            floor = floors.get(r["scenario"]) if r.get("step_size") == STEP else None   # the floor is at STEP
            cost = r.get("implicit")
            ratio = cost / floor if floor and cost else None
            line += (f" {_f(ratio, '.2f')} | " + ("-" if cost is None else "yes" if cost <= targets["s_per_sim_s"]
                                                  else "NO") + " / "
                     + ("-" if ratio is None else "yes" if ratio <= targets["floor_ratio"] else "NO") + " |")
        lines.append(line)
    t = figures["totals"]
    lines.append(f"| all that both complete | | {t['explicit']:.3f} | {t['implicit']:.3f} | "
                 f"{_f(figures['ratio'], '.2f')} |" + (" | |" if marks else ""))
    for c, names in figures["failed"].items():
        if names:
            lines.append(f"\n{c} failed on {len(names)}: {', '.join(names)}")
    return "\n".join(lines)


def default_cpus() -> set[int]:
    """The core the engines are pinned to: the first this process may run on (``taskset -c 0`` on a free machine)."""
    return {min(os.sched_getaffinity(0))}


def engine_runs_of(scenario: Scenario, repeats: int = REPEATS, min_steps: int = ENGINE_MIN_STEPS) -> int:
    """Runs of each engine on scenario: repeats, or as many as it takes to step min_steps in all."""
    steps = max(1, round((scenario.stop_time - scenario.start_time) / scenario.step_size))
    return max(repeats, math.ceil(min_steps / steps))


def bench_engines(paths, fmu_dir=DEFAULT_FMU_DIR, repeats=REPEATS, cpus=None, engines=ENGINES,
                  progress=None, min_steps=ENGINE_MIN_STEPS) -> dict:
    """Our master, Ecos and libcosim on each scenario's SSP package (``ujfmu.engines``), each run a process pinned to
    cpus (None: the first core of ``default_cpus``; an empty set: unpinned), engines alternated, the fastest of
    repeats runs kept (of more where the scenario is shorter than min_steps / repeats steps: enough runs for
    min_steps in all): microseconds per step of the stepping loop with every recorded signal recorded (wall clock, and
    'cpu_<engine>' the process's CPU time), and the ratio of ours to each engine ('ratio_<engine>',
    'cpu_ratio_<engine>'). Engines not installed are listed in 'missing' with what to install."""
    from .ssp import export_ssp
    cpus = default_cpus() if cpus is None else cpus
    missing = {e: engine_runs.missing(e) for e in engines if engine_runs.missing(e)}
    running = [e for e in engines if e not in missing]
    rows = []
    with tempfile.TemporaryDirectory(prefix="ujfmu_engines_") as tmp:
        for path in paths:
            scenario = Scenario(path)
            ssp = export_ssp(scenario, tmp, fmu_dir)
            row = dict(scenario=scenario.name, steps=None, errors={}, rows={})
            best = {}
            row["runs"] = engine_runs_of(scenario, repeats, min_steps)
            for _ in range(row["runs"]):
                for engine in running:
                    if engine in row["errors"]:
                        continue
                    try:
                        result = engine_runs.run(engine, ssp, Path(path), cpus)
                    except RuntimeError as exc:
                        row["errors"][engine] = str(exc)
                        continue
                    row["steps"], row["rows"][engine] = result["steps"], result["rows"]
                    for key, figure in ((engine, "us_per_step"), (f"cpu_{engine}", "cpu_us_per_step")):
                        best[key] = min(best.get(key, math.inf), result[figure])
            for engine in engines:
                row[engine], row[f"cpu_{engine}"] = best.get(engine), best.get(f"cpu_{engine}")
            for engine in engines[1:]:
                for kind in ("", "cpu_"):
                    ours, theirs = row[kind + engines[0]], row[kind + engine]
                    row[f"{kind}ratio_{engine}"] = ours / theirs if ours and theirs else None
            rows.append(row)
            if progress:
                progress(f"engines {scenario.name}: " + ", ".join(f"{e} {_f(row[e], '.1f')} us/step" for e in engines))
    return dict(rows=rows, missing=missing, engines=list(engines), cpus=sorted(cpus))


def render_engines(figures, target=TARGETS["engine_ratio"]):
    """Markdown table of ``bench_engines``: us per step side by side, ours over each, target 5 (ours within target x
    the fastest C++ engine) met or not."""
    engines = figures["engines"]
    pinned = f"pinned to core {', '.join(map(str, figures['cpus']))}" if figures["cpus"] else "unpinned"
    others = engines[1:]
    lines = [f"Engines on the same SSP packages ({pinned}; stepping loop, every recorded signal recorded; the "
             f"fastest of alternated runs, at least {REPEATS} and {ENGINE_MIN_STEPS} steps in all):", "",
             "| scenario | " + " | ".join(f"{e} us / step" for e in engines) + " | "
             + " | ".join(f"{engines[0]} / {e}" for e in others) + " | "
             + " | ".join(f"{engines[0]} / {e}, CPU time" for e in others) + f" | within {target}x the fastest |",
             "| --- " * (len(engines) + 2 * len(others) + 2) + "|"]
    for r in figures["rows"]:
        fastest = min((r[e] for e in others if r.get(e)), default=None)
        mark = "-" if fastest is None or not r[engines[0]] else ("yes" if r[engines[0]] <= target * fastest else "NO")
        lines.append(f"| {r['scenario']} | " + " | ".join(_f(r.get(e), ".1f") for e in engines) + " | "
                     + " | ".join(_f(r.get(f"ratio_{e}"), ".2f") for e in others) + " | "
                     + " | ".join(_f(r.get(f"cpu_ratio_{e}"), ".2f") for e in others) + f" | {mark} |")
    for r in figures["rows"]:
        for engine, error in r["errors"].items():
            lines.append(f"\n{engine} failed on {r['scenario']}: {error}")
    for engine, reason in figures["missing"].items():
        lines.append(f"\nnot measured: {reason}")
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


#: a varying host's steps (bench_varying_steps): each length drawn anew, uniform in this range times STEP
VARYING_STEPS = (0.9, 1.1)


def _step_cost(fmu_path: Path, name: str, lengths: list) -> float:
    """Seconds per fmi2DoStep of one fresh instance of the FMU (parameters and inputs at their start values) stepping
    through the given step lengths."""
    unzip_dir, description = extracted(fmu_path)
    fmu = FmuInstance(Component(name, fmu_path), unzip_dir, description, [])
    try:
        fmu.initialize()
        t, started = 0.0, time.perf_counter()
        for h in lengths:
            fmu.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
        return (time.perf_counter() - started) / len(lengths)
    finally:
        fmu.free()


def bench_varying_steps(names, fmu_dir=DEFAULT_FMU_DIR, steps: int = 300, repeats: int = REPEATS) -> list:
    """Per FMU: its cost per fmi2DoStep at a fixed STEP and with every step's length drawn anew from
    VARYING_STEPS (a host that varies its step), each the fastest of ``repeats`` alternated runs of ``steps`` steps
    of a fresh instance (parameters and inputs at their start values), and their ratio: the price of a new step
    length (an FMU that builds operators per length pays it at every step)."""
    rng = random.Random(0)
    lengths = [STEP * rng.uniform(*VARYING_STEPS) for _ in range(steps)]
    rows = []
    for name in names:
        path = Path(fmu_dir) / f"{name}.fmu"
        fixed = varying = math.inf
        for _ in range(repeats):
            fixed = min(fixed, _step_cost(path, name, [STEP] * steps))
            varying = min(varying, _step_cost(path, name, lengths))
        rows.append(dict(fmu=name, fixed_us_per_step=1e6 * fixed, varying_us_per_step=1e6 * varying,
                         varying_ratio=varying / fixed))
    return rows


def machine_facts() -> dict:
    """When and where a bench runs: the UTC time, Python, platform, cores, the load average at the start, and the
    machine's pace in pure Python (``pace_us``: the fastest of five timings of ``sum(range(1000))`` [us]). Absolute
    times scale with the pace; ratios within one run hardly do."""
    import platform
    import timeit
    pace = min(timeit.repeat("sum(range(1000))", number=2000, repeat=5)) / 2000 * 1e6
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    return dict(utc=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), python=platform.python_version(),
                platform=platform.platform(terse=True), cores=os.cpu_count(), load_average=load, pace_us=pace)


def run_bench(scenarios, fmu_dir=DEFAULT_FMU_DIR, sweep=True, progress=print, battery=(), schemes=True,
              engines=ENGINES, cpus=None, fmu3_dir=None):
    """All figures of one run: {'scenarios': [rows], 'engines': {...}, 'schemes': {...}, 'battery': {...},
    'sweep': {...}}; battery: the coupling battery's scenario files (ujfmu.battery.paths()) to cost in each scheme;
    schemes: cost each scheme on the scenarios too; engines: those to run side by side on the scenarios' SSP
    packages (() for none), pinned to cpus (see ``bench_engines``); fmu3_dir: the FMI 3.0 FMUs (``ujfmu build
    --fmi 3``), whose cost per step is compared with the FMI 2.0 FMUs' on each scenario (None: not measured)."""
    facts = machine_facts()
    with tempfile.TemporaryDirectory(prefix="ujfmu_floor_") as floor_dir:
        names = sorted({fmu for p in scenarios for fmu, _ in Scenario(p).components.values()})
        for name in names:
            build_fmu(name, floor_dir, pass_through=True)
        rows = []
        for path in scenarios:
            progress(f"bench {Path(path).stem}")
            rows.append(bench_scenario(path, fmu_dir, floor_dir))
    result = {"step_size": STEP, "scenarios": rows, "targets": TARGETS, "machine": facts}
    progress("bench varying steps")
    result["varying_steps"] = bench_varying_steps(names, fmu_dir)
    if engines:
        result["engines"] = bench_engines(scenarios, fmu_dir, REPEATS, cpus, engines, progress)
    if schemes:
        result["schemes"] = bench_schemes(scenarios, fmu_dir, REPEATS, progress)
    if fmu3_dir is not None:
        from .bench_fmi3 import fmi3_step_cost_ratio
        result["fmi3"] = []
        for path in scenarios:
            progress(f"bench FMI 3.0 / FMI 2.0 {Path(path).stem}")
            result["fmi3"].append(fmi3_step_cost_ratio(path, fmu_dir, fmu3_dir))
    if battery:
        result["battery"] = bench_schemes(battery, fmu_dir, 1, progress)
    if sweep:
        figures = {}
        for turn in range(REPEATS):   # alternated, the fastest of each: a slow spell does not pick one count
            for workers in (1, 2):
                progress(f"bench Omar Fig. 4 sweep, {workers} worker(s), run {turn + 1} of {REPEATS}")
                seconds, points = bench_sweep(fmu_dir, workers)
                if workers not in figures or seconds < figures[workers]["seconds"]:
                    figures[workers] = dict(seconds=seconds, points=points, points_per_minute=60.0 * points / seconds)
        result["sweep"] = dict(workers=figures, speedup=figures[1]["seconds"] / figures[2]["seconds"])
    return result


def _f(value, fmt):
    return "-" if value is None else format(value, fmt)


def render(result):
    """Markdown tables of a bench result, with each target met or not."""
    t = result["targets"]
    lines = []
    m = result.get("machine")
    if m:
        load = "" if m["load_average"] is None else f", load average {m['load_average']:.2f} at the start"
        lines += [f"Run of {m['utc']}: Python {m['python']}, {m['platform']}, {m['cores']} cores{load}; pace "
                  f"{m['pace_us']:.1f} us for sum(range(1000)) in pure Python (absolute times scale with it, the "
                  "ratios within one run hardly). The scenarios coupled explicitly, 1 ms (the implicit scheme: "
                  "the coupling schemes' table):", ""]
    lines += ["| scenario | sim. s | wall s / sim. s | us / step | floor us / step | x floor | "
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
    if "engines" in result:
        lines += ["", render_engines(result["engines"], t["engine_ratio"])]
    if "schemes" in result:
        lines += ["", "Coupling schemes, each scenario at its own step (docs/cosimulation.md); targets 1 / 2 for the "
                  "implicit scheme against the same pass-through floor:", "",
                  render_schemes("scenario", result["schemes"], _floors(result), t)]
    if "fmi3" in result:
        lines += ["", "FMI 3.0 against FMI 2.0 Co-Simulation FMUs, same master and scheme, 1 ms:", "",
                  "| scenario | FMI 2.0 us / step | FMI 3.0 us / step | FMI 3.0 / FMI 2.0 |", "| --- | --- | --- | --- |"]
        lines += [f"| {r['scenario']} | {r['fmi2_us_per_step']:.1f} | {r['fmi3_us_per_step']:.1f} | "
                  f"{r['fmi3_ratio']:.2f} |" for r in result["fmi3"]]
    if "varying_steps" in result:
        lo, hi = VARYING_STEPS
        lines += ["", f"A host that varies its step: each FMU alone (fmi2DoStep of a fresh instance, parameters and "
                  f"inputs at their start values), every step's length drawn anew from {lo * STEP * 1e3:g}-"
                  f"{hi * STEP * 1e3:g} ms, against {STEP * 1e3:g} ms at every step:", "",
                  "| FMU | us / step, fixed | us / step, varying | varying / fixed |", "| --- | --- | --- | --- |"]
        lines += [f"| {r['fmu']} | {r['fixed_us_per_step']:.1f} | {r['varying_us_per_step']:.1f} | "
                  f"{r['varying_ratio']:.2f} |" for r in result["varying_steps"]]
    if "battery" in result:
        lines += ["", "Coupling battery (ujfmu.battery), 1 ms:", "", render_schemes("set-up", result["battery"])]
    if "sweep" in result:
        s = result["sweep"]
        one, two = s["workers"][1], s["workers"][2]
        lines += ["", "| Omar Fig. 4 sweep (141 points, 100-1500 rpm; fastest of 3) | wall s | points / min |",
                  "| --- | --- | --- |",
                  f"| 1 worker | {one['seconds']:.1f} | {one['points_per_minute']:.0f} |",
                  f"| 2 workers | {two['seconds']:.1f} | {two['points_per_minute']:.0f} |", "",
                  f"Speed-up with 2 workers: {s['speedup']:.2f}x (target >= {t['worker_speedup']}x: "
                  f"{'met' if s['speedup'] >= t['worker_speedup'] else 'NOT met'}); Fig. 4 sweep on 2 workers "
                  f"{two['seconds']:.0f} s (target < {t['fig4_seconds']:.0f} s: "
                  f"{'met' if two['seconds'] < t['fig4_seconds'] else 'NOT met'})."]
    lines += ["", f"Targets: 1. <= {t['s_per_sim_s']} wall s per simulated s; 2. <= {t['floor_ratio']}x the "
              "pass-through run; 3. faster than the DOP853 rtol 1e-8 solve and within the scenario's tolerance of it; "
              f"5. our master's stepping loop within {t['engine_ratio']}x the fastest C++ engine's time per step."]
    return "\n".join(lines)


def write(result, out_dir):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "bench.json").write_text(json.dumps(result, indent=1, default=lambda x: None if x != x else x))
    (out_dir / "bench.md").write_text(render(result) + "\n")
    return out_dir / "bench.md"

