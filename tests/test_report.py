"""docs/validation.md regenerates from the FMUs, and the physics behind its Omar numbers holds: critical speeds
where twice the input speed meets each natural frequency, twist linear and dynamic misalignment quadratic in the
load (Table 2), critical speeds independent of beta0 (Figs. 5-7)."""

import math

import pytest

from ujfmu.build import REPO_DIR
from ujfmu.report import write_report

RPM = math.pi / 30.0


@pytest.fixture(scope="module")
def report(fmu_dir, tmp_path_factory):
    """The whole report, regenerated from scratch, its sweeps run in this process (on a local dask cluster of two
    workers, as `ujfmu report` runs them, it took a quarter more CPU: the suite's other worker shares the cores;
    test_the_reports_sweeps_run_on_one_dask_cluster_as_in_process covers that path)."""
    out = tmp_path_factory.mktemp("report")
    return write_report(out / "validation.md", fmu_dir=fmu_dir, work_dir=out / "work", workers=0, progress=False)


def test_the_reports_sweeps_run_on_one_dask_cluster_as_in_process(fmu_dir, tmp_path):
    """`ujfmu report`'s way: the sections' sweeps share one local dask cluster (two workers), made at the first
    sweep and closed at the end, and give the points the in-process run gives (Brutti's two speeds)."""
    from ujfmu.report import Report
    from ujfmu.sweep import Axis
    tables = {}
    for workers in (2, 0):
        rep = Report(fmu_dir, tmp_path / f"work{workers}", workers=workers, progress=False)
        try:
            for name in ("a", "b"):
                pts, sweep = rep.sweep("double_cardan_brutti_rigid", name,
                                       [Axis.of("motor.omega_set", [2000, 4000], "rpm")],
                                       outputs=["driveline.tau_in"], running_speed="motor.omega", settle_time=0.02,
                                       revolutions=2)
                if workers:
                    assert rep.client is not None and (name == "a" or rep.client is client)
                    client = rep.client
            tables[workers] = [(r["point"], r["driveline.tau_in.mean"]) for r in sweep.table()]
        finally:
            rep.close()
        assert rep.client is None
    assert tables[2] == tables[0] and len(tables[0]) == 2


def test_committed_report_regenerates(report):
    assert report.path.read_text() == (REPO_DIR / "docs" / "validation.md").read_text(), \
        "docs/validation.md is stale or hand-edited: run `ujfmu report`"
    for section in report.sections:
        for name, _ in section.figures:
            assert (report.path.parent / "figures" / name).is_file()
            assert (REPO_DIR / "docs" / "figures" / name).is_file()


def omar_rows(report, name, **fixed):
    return [r for r in report.sweeps[name].table()
            if all(math.isclose(r["point"][k], v) for k, v in fixed.items())]


def test_omar_critical_speeds_are_where_twice_the_speed_meets_each_natural_frequency(report):
    from ujfmu.report import peak
    rows = sorted(omar_rows(report, "omar_figs4_8", **{"driveline.beta1": math.radians(15)}),
                  key=lambda r: r["point"]["motor.omega_set"])
    rpm = [r["point"]["motor.omega_set"] / RPM for r in rows]
    t_rpm, _ = peak(rpm, [r["driveline.twist.h2"] for r in rows])
    l_rpm, l_peak = peak(rpm, [r["driveline.dynamic_misalignment.max"] for r in rows])
    assert t_rpm == pytest.approx(math.sqrt(92.2 / 0.0045) / 2 / RPM, rel=0.01)
    assert l_rpm == pytest.approx(math.sqrt(26331.0 / 4.09) / 2 / RPM, rel=0.01)
    median = sorted(r["driveline.dynamic_misalignment.max"] for r in rows)[len(rows) // 2]
    assert l_peak > 5 * median   # a resonance, not noise


def test_omar_twist_is_linear_and_misalignment_quadratic_in_the_load(report):
    rows = report.sweeps["omar_table2"].table()
    speeds = sorted({r["point"]["motor.omega_set"] for r in rows})
    lateral, torsional = speeds   # the lateral critical speed is the lower one
    def value(load, speed, key):
        return next(r[key] for r in rows if r["point"]["load.T0"] == load and r["point"]["motor.omega_set"] == speed)
    for load in (10.0, 15.0, 20.0, 25.0):
        k = load / 5.0
        assert value(load, torsional, "driveline.twist.max") / value(5.0, torsional, "driveline.twist.max") \
            == pytest.approx(k, rel=0.02)
        assert value(load, lateral, "driveline.dynamic_misalignment.max") \
            / value(5.0, lateral, "driveline.dynamic_misalignment.max") == pytest.approx(k * k, rel=0.05)


def test_every_verdict_is_backed_by_a_number_or_a_stated_reason(report):
    for section in report.sections:
        assert section.rows
        for quantity, paper, ours, unit, diff, verdict in section.rows:
            assert ours not in ("", "-") and verdict
            if verdict.startswith("not reproduced"):
                assert section.notes or "operating points" in verdict or "reason" in verdict, quantity
