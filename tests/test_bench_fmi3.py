"""The FMI 3.0 / FMI 2.0 cost-per-step figure: both versions run the scenario (no timing is asserted)."""

from ujfmu.bench_fmi3 import fmi3_step_cost_ratio


def test_fmi3_step_cost_ratio_times_both_versions(fmu_dir, fmu3_dir):
    row = fmi3_step_cost_ratio("scenarios/cardan_constant_speed.toml", fmu_dir, fmu3_dir, repeats=1)
    assert row["scenario"] == "cardan_constant_speed" and row["steps"] == 500
    assert row["fmi2_us_per_step"] > 0.0 and row["fmi3_us_per_step"] > 0.0
    assert row["fmi3_ratio"] == row["fmi3_us_per_step"] / row["fmi2_us_per_step"]
