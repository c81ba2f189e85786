"""ujfmu bench produces its ratio figures (no timing is asserted: speed is measured by the benchmark itself)."""

from pathlib import Path

from ujfmu.bench import render, run_bench

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_bench_measures_floor_and_monolithic_ratios(fmu_dir):
    result = run_bench([SCENARIOS / "cardan_startup.toml", SCENARIOS / "cardan_constant_speed.toml"],
                       fmu_dir=fmu_dir, sweep=False, progress=lambda msg: None)
    startup, constant = result["scenarios"]
    assert startup["steps"] == 6000 and startup["floor_ratio"] > 0 and startup["monolithic_s"] > 0
    assert startup["within_tolerance"] is True   # the co-simulation agrees with the rtol 1e-8 monolithic solve
    assert constant["monolithic_s"] is None and "closed form" in constant["note"]
    table = render(result)
    assert "cardan_startup" in table and "x floor" in table
