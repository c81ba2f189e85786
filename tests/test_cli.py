"""Command line and Python entry points: run, check with JUnit, failing exit status."""

import xml.etree.ElementTree as ET
from pathlib import Path

import ujfmu
from ujfmu.cli import main

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_run_scenario_from_python_returns_the_table(fmu_dir, tmp_path):
    result = ujfmu.run_scenario(SCENARIOS / "cardan_constant_speed.toml", fmu_dir=fmu_dir, out_dir=tmp_path,
                                progress=False)
    assert result.passed and "joint.M_z" in result.table.dtype.names
    assert (tmp_path / "cardan_constant_speed.csv").is_file() and (tmp_path / "cardan_constant_speed.png").is_file()


def test_check_writes_junit_and_fails_on_a_failing_scenario(fmu_dir, tmp_path, capsys):
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    strict = tmp_path / "too_strict.toml"
    # the same run with a 0.31 N.m load, compared with the 0.3 N.m reference: must fail
    strict.write_text(text.replace("T0 = 0.3,", "T0 = 0.31,").replace(
        'file = "references/', f'file = "{SCENARIOS}/references/'))
    junit = tmp_path / "report.xml"
    code = main(["--fmu-dir", str(fmu_dir), "check", str(SCENARIOS / "cardan_constant_speed.toml"), str(strict),
                 "--junit", str(junit), "--out", str(tmp_path / "out"), "--no-plot"])
    assert code == 1
    suite = ET.parse(junit).getroot()
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert set(cases) == {"cardan_constant_speed", "too_strict"}
    assert cases["too_strict"].find("failure") is not None and cases["cardan_constant_speed"].find("failure") is None
    assert "1 passed, 1 failed" in capsys.readouterr().out


def test_run_reports_a_bad_scenario_without_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[experiment]\nstop_time = 1\n")
    assert main(["run", str(bad)]) == 2
    assert "bad.toml" in capsys.readouterr().err
