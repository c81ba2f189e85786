"""ujfmu bench produces its ratio figures (no timing is asserted: speed is measured by the benchmark itself)."""

from pathlib import Path

import importlib.util
import math
import warnings

import pytest

from ujfmu import engines
from ujfmu.bench import bench_engines, bench_scenario, bench_schemes, render, render_engines, render_schemes, run_bench
from ujfmu.build import build_fmu
from ujfmu.master import HeldInputWarning

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_bench_measures_floor_and_monolithic_ratios(fmu_dir):
    result = run_bench([SCENARIOS / "cardan_startup.toml", SCENARIOS / "cardan_constant_speed.toml"],
                       fmu_dir=fmu_dir, sweep=False, progress=lambda msg: None, schemes=False, engines=())
    startup, constant = result["scenarios"]
    assert startup["steps"] == 6000 and startup["floor_ratio"] > 0 and startup["monolithic_s"] > 0
    assert startup["within_tolerance"] is True   # the co-simulation agrees with the rtol 1e-8 monolithic solve
    assert constant["monolithic_s"] is None and "closed form" in constant["note"]
    table = render(result)
    assert "cardan_startup" in table and "x floor" in table
    # when and where it ran, the machine's pace and the scheme, before the table
    facts = result["machine"]
    assert facts["pace_us"] > 0 and facts["cores"] >= 1 and facts["utc"].endswith("UTC")
    assert table.startswith(f"Run of {facts['utc']}: Python ") and "coupled explicitly" in table.split("|")[0]
    # each FMU of the scenarios costed at a fixed and at a varying step, in the same run
    varying = {r["fmu"]: r for r in result["varying_steps"]}
    assert set(varying) == {"Motor", "CardanJoint", "Load"}
    for r in varying.values():
        assert r["fixed_us_per_step"] > 0 and r["varying_ratio"] == pytest.approx(r["varying_us_per_step"]
                                                                                / r["fixed_us_per_step"])
    assert "| Motor |" in table and "varying / fixed" in table


def test_floor_run_holds_the_inputs_the_scenario_holds_without_a_warning(fmu_dir, tmp_path):
    """ring_coupling_fig3 holds the coupling's tau_load at a value it states: its pass-through twins take the same
    parameters, so the floor run holds it deliberately too (a held-input warning there would be noise)."""
    for name in ("Motor", "RingCoupling", "Load"):
        build_fmu(name, tmp_path, pass_through=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HeldInputWarning)
        row = bench_scenario(SCENARIOS / "ring_coupling_fig3.toml", fmu_dir, tmp_path, repeats=1)
    assert row["floor_us_per_step"] > 0 and row["floor_ratio"] > 0


def test_bench_costs_each_coupling_scheme_in_one_run(fmu_dir):
    """Per scheme: wall s per simulated s and the implicit/explicit ratio where both run; a scheme that cannot run
    a set-up (explicit, heavy driven side) is listed as failed, not timed."""
    battery = SCENARIOS / "battery"
    figures = bench_schemes([battery / "battery_02.toml", battery / "battery_04.toml"], fmu_dir)
    light, heavy = figures["rows"]
    assert light["explicit"] > 0 and light["implicit"] > 0 and light["ratio"] > 1.0   # iterating costs more
    assert heavy["explicit"] is None and "coupling instability" in heavy["explicit_error"]
    assert figures["failed"] == {"explicit": ["battery_04"], "implicit": []}
    assert figures["ratio"] == light["ratio"]
    table = render_schemes("set-up", figures)
    assert "failed" in table and "battery_04" in table


def test_engines_run_the_same_ssp_side_by_side_and_a_missing_one_is_named(fmu_dir, monkeypatch):
    """Our master and libcosim step the scenario's SSP package in pinned child processes, every step recorded (ours
    a row per point with the start, libcosim's observer a sample per step); the ratio is ours over theirs. An engine
    whose package is not installed is named with the pip extra that brings it, not timed."""
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "ecospy" else real_find_spec(name, *a))
    assert "pip install 'ujfmu[bench]'" in engines.missing("ecos") and engines.missing("libcosim") is None
    figures = bench_engines([SCENARIOS / "cardan_constant_speed.toml"], fmu_dir, repeats=1, min_steps=0)
    (row,) = figures["rows"]
    assert row["errors"] == {} and row["steps"] == 500 and row["rows"] == {"ujfmu": 501, "libcosim": 500}
    assert row["runs"] == 1
    assert row["ecos"] is None and row["ratio_ecos"] is None and list(figures["missing"]) == ["ecos"]
    assert row["ratio_libcosim"] == row["ujfmu"] / row["libcosim"] and len(figures["cpus"]) == 1
    assert row["cpu_ratio_libcosim"] == row["cpu_ujfmu"] / row["cpu_libcosim"]
    table = render_engines(figures)
    assert "| cardan_constant_speed |" in table and "ujfmu / libcosim" in table
    assert "not measured: ecos is not installed" in table


def test_ecos_runs_without_ecos_name_the_extra(monkeypatch, tmp_path):
    """ujfmu.engines.cosimulate_ecos where Ecos is missing: an error naming the extra to install, not a bare
    ModuleNotFoundError."""
    from ujfmu import engines
    from ujfmu.extras import MissingExtraError
    monkeypatch.setattr(engines.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(MissingExtraError, match=r"pip install 'ujfmu\[bench\]'"):
        engines.cosimulate_ecos(tmp_path / "x.ssp", None, tmp_path)


def test_side_by_side_turns_record_the_run_a_single_run_records(fmu_dir, tmp_path):
    """The scenario run timed in turns with its pass-through twins records the same table, row for row, as one
    uninterrupted run (the turns' joins neither repeat nor drop a point; the times agree to round-off, the values
    bit for bit), so its tolerance check is the run's."""
    from ujfmu.bench import _side_by_side
    from ujfmu.master import Component, Cosimulation
    from ujfmu.scenario import Scenario
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml")
    for c in scenario.master_components(fmu_dir):
        build_fmu(Path(c.fmu).stem, tmp_path, pass_through=True)
    twins = [Component(c.name, tmp_path / f"{Path(c.fmu).stem}PassThrough.fmu", c.parameters)
             for c in scenario.master_components(fmu_dir)]
    _, wall, floor, ratios, table = _side_by_side(scenario.master_components(fmu_dir), twins, scenario, 500, chunk=120)
    with Cosimulation(scenario.master_components(fmu_dir), scenario.connections, 1e-3, scenario.record,
                      scenario.start_time, coupling="explicit") as cosim:
        whole = cosim.run(500)
    assert len(ratios) == 5 and wall > 0 and floor > 0
    assert table.dtype.names == whole.dtype.names and len(table) == len(whole) == 501
    assert table["time"] == pytest.approx(whole["time"], rel=1e-14, abs=1e-15)   # t0 + k h summed per turn
    for name in whole.dtype.names[1:]:
        assert (table[name] == whole[name]).all(), name


def test_a_short_scenario_gets_enough_engine_runs_for_the_minimum_steps():
    """The engines run a scenario at least REPEATS times, and a short one as often as it takes to step
    ENGINE_MIN_STEPS in all (cardan_constant_speed: 500 steps, double_cardan_brutti_rigid: 2000 of 0.1 ms)."""
    from ujfmu.bench import ENGINE_MIN_STEPS, REPEATS, engine_runs_of
    from ujfmu.scenario import Scenario
    short, shorter, long = (Scenario(SCENARIOS / f"{name}.toml") for name in
                            ("cardan_constant_speed", "double_cardan_brutti_rigid", "twin_jeffcott_steady"))
    assert engine_runs_of(long) == REPEATS and engine_runs_of(long, repeats=1) == 1
    assert engine_runs_of(short) == math.ceil(ENGINE_MIN_STEPS / 500) > REPEATS
    assert engine_runs_of(shorter, repeats=1, min_steps=5000) == 3
    assert engine_runs_of(short, repeats=1, min_steps=0) == 1
