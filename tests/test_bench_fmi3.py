"""The FMI 3.0 / FMI 2.0 cost-per-step figure: both versions run the scenario (no timing is asserted)."""

from ujfmu.bench_fmi3 import fmi3_step_cost_ratio


def test_fmi3_step_cost_ratio_times_both_versions(fmu_dir, fmu3_dir):
    row = fmi3_step_cost_ratio("scenarios/cardan_constant_speed.toml", fmu_dir, fmu3_dir, repeats=1)
    assert row["scenario"] == "cardan_constant_speed" and row["steps"] == 500
    assert row["fmi2_us_per_step"] > 0.0 and row["fmi3_us_per_step"] > 0.0
    assert row["fmi3_ratio"] == row["fmi3_us_per_step"] / row["fmi2_us_per_step"]


def test_bench_reports_the_fmi3_ratio_per_scenario(fmu_dir, fmu3_dir):
    from ujfmu.bench import render, run_bench
    result = run_bench(["scenarios/cardan_constant_speed.toml"], fmu_dir=fmu_dir, sweep=False,
                       progress=lambda msg: None, schemes=False, engines=(), fmu3_dir=fmu3_dir)
    (row,) = result["fmi3"]
    assert row["scenario"] == "cardan_constant_speed" and row["fmi3_ratio"] > 0.0
    table = render(result)
    assert "FMI 3.0 / FMI 2.0" in table and f"| cardan_constant_speed | {row['fmi2_us_per_step']:.1f} |" in table
