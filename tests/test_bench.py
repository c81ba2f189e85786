"""ujfmu bench produces its ratio figures (no timing is asserted: speed is measured by the benchmark itself)."""

from pathlib import Path

from ujfmu.bench import bench_schemes, render, render_schemes, run_bench

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_bench_measures_floor_and_monolithic_ratios(fmu_dir):
    result = run_bench([SCENARIOS / "cardan_startup.toml", SCENARIOS / "cardan_constant_speed.toml"],
                       fmu_dir=fmu_dir, sweep=False, progress=lambda msg: None, schemes=False)
    startup, constant = result["scenarios"]
    assert startup["steps"] == 6000 and startup["floor_ratio"] > 0 and startup["monolithic_s"] > 0
    assert startup["within_tolerance"] is True   # the co-simulation agrees with the rtol 1e-8 monolithic solve
    assert constant["monolithic_s"] is None and "closed form" in constant["note"]
    table = render(result)
    assert "cardan_startup" in table and "x floor" in table


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
