"""`--fmi 3` on the command line: build, check and export-ssp with the FMI 3.0 FMUs."""

import zipfile
from pathlib import Path

from fmpy import read_model_description

from ujfmu.cli import main
from ujfmu.scenario import Scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_build_fmi3_writes_an_fmi3_fmu(tmp_path):
    assert main(["build", "--fmi", "3", "Load", "--fmu-dir", str(tmp_path), "-q"]) == 0
    assert read_model_description(str(tmp_path / "Load.fmu")).fmiVersion == "3.0"


def test_check_runs_a_scenario_with_the_fmi3_fmus(fmu3_dir, tmp_path, capsys):
    assert main(["check", "--fmi", "3", "--fmu-dir", str(fmu3_dir), "scenarios/cardan_constant_speed.toml",
                 "--out", str(tmp_path), "--no-plot", "-q"]) == 0
    assert "1 passed, 0 failed" in capsys.readouterr().out


def test_missing_fmi3_fmus_name_the_build_command(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios").mkdir()
    assert main(["check", "--fmi", "3", "--no-plot", "-q",
                 str(Path(__file__).parents[2] / "scenarios" / "cardan_constant_speed.toml")]) == 2
    assert "ujfmu build --fmi 3" in capsys.readouterr().err


def test_export_ssp_packages_the_fmi3_fmus(fmu3_dir, tmp_path):
    path = "scenarios/cardan_heavy_torque_driven.toml"
    assert main(["export-ssp", "--fmi", "3", "--fmu-dir", str(fmu3_dir), path, "--out", str(tmp_path)]) == 0
    ssp = tmp_path / "cardan_heavy_torque_driven.ssp"
    with zipfile.ZipFile(ssp) as zf:
        names = zf.namelist()
        for fmu in {fmu for fmu, _ in Scenario(path).components.values()}:
            assert f"resources/{fmu}.fmu" in names
            (tmp_path / f"{fmu}.fmu").write_bytes(zf.read(f"resources/{fmu}.fmu"))
            assert read_model_description(str(tmp_path / f"{fmu}.fmu")).fmiVersion == "3.0"
        assert b'startConnector="tau_motor"' in zf.read("SystemStructure.ssd")


def test_run_model_exchange_checks_the_scenario_against_its_reference(fmu3_dir, tmp_path, capsys):
    """`ujfmu run --model-exchange`: the torque-driven driveline under CVode, within the scenario's tolerances and
    its tight step-halving bands (no step error to remove)."""
    assert main(["run", "--model-exchange", "--fmu-dir", str(fmu3_dir), "scenarios/cardan_heavy_torque_driven.toml",
                 "--out", str(tmp_path), "--no-plot", "-q"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("PASS cardan_heavy_torque_driven") and "step-halving" not in out   # no step to halve
    assert "Model Exchange run (no communication step) against the [reference.extrapolated] bands" in out
    # each band's line under that header (a failing one had been counted in the verdict but never shown)
    banded = out.split("[reference.extrapolated] bands:\n", 1)[1].splitlines()
    bands = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml").extrapolated_tolerances
    assert len(bands) >= 3 and [line.split()[1] for line in banded[:len(bands)]] == list(bands)
    assert all(line.split()[0] == "ok" for line in banded[:len(bands)])
    assert (tmp_path / "cardan_heavy_torque_driven.csv").is_file()


def test_run_model_exchange_refuses_a_speed_driven_scenario_and_step_checks(fmu3_dir, tmp_path, capsys):
    assert main(["run", "--model-exchange", "--fmu-dir", str(fmu3_dir), "scenarios/cardan_startup.toml",
                 "--out", str(tmp_path), "--no-plot", "-q"]) == 2
    assert "has no Model Exchange interface" in capsys.readouterr().err
    assert main(["run", "--model-exchange", "--check-step", "--fmu-dir", str(fmu3_dir),
                 "scenarios/cardan_heavy_torque_driven.toml", "--no-plot", "-q"]) == 2
    assert "has none" in capsys.readouterr().err
    # nor does a Model Exchange run that compares nothing estimate one by default, as a co-simulation's does
    assert main(["run", "--model-exchange", "--fmu-dir", str(fmu3_dir), "scenarios/cardan_heavy_torque_driven.toml",
                 "--stop-time", "0.2", "--out", str(tmp_path), "--no-plot", "-q"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("NOT CHECKED") and "estimated coupling error" not in out


def test_model_exchange_run_checks_the_operating_point(fmu3_dir, tmp_path, capsys):
    """A MotorController limited to 0.5 N.m against the load's 5 N.m cannot run the heavy torque-driven driveline
    up to its 60 rad/s: the Model Exchange run says the operating point is not reached and exits 1, as the
    co-simulation does."""
    text = (SCENARIOS / "cardan_heavy_torque_driven.toml").read_text()
    assert "tau_max = 100.0" in text
    weak = tmp_path / "weak.toml"
    weak.write_text(text.replace("tau_max = 100.0", "tau_max = 0.5").split("[reference]")[0])
    assert main(["run", "--model-exchange", "--fmu-dir", str(fmu3_dir), str(weak), "--out", str(tmp_path),
                 "--no-plot", "-q"]) == 1
    out = capsys.readouterr().out
    assert out.startswith("FAIL weak") and "motor.omega" in out and "not reached" in out


def test_fmi3_runs_refuse_fmi2_fmus_and_check_skips_speed_driven_scenarios(fmu_dir, fmu3_dir, tmp_path, capsys):
    """--fmi 3 on a folder of FMI 2.0 FMUs is refused with the build command (not run as FMI 2.0); `check
    --model-exchange` checks the torque-driven scenarios and lists the speed-driven ones it cannot run."""
    scenario = str(SCENARIOS / "cardan_heavy_torque_driven.toml")
    for flag in ("--fmi=3", "--model-exchange"):
        assert main(["run", flag, "--fmu-dir", str(fmu_dir), scenario, "--out", str(tmp_path), "--no-plot"]) == 2
        err = capsys.readouterr().err
        # the FMI 3.0 FMUs' own folder, never this one, whose FMI 2.0 FMUs a build there would replace
        assert "is an FMI 2.0 FMU" in err and f"ujfmu build --fmi 3 --fmu-dir {fmu_dir / 'fmi3'}`" in err
        assert f"--fmu-dir {fmu_dir}`" not in err
    assert main(["run", "--fmi=3", "--fmu-dir", str(tmp_path), scenario, "--no-plot"]) == 2
    assert f"ujfmu build --fmi 3 --fmu-dir {tmp_path}" in capsys.readouterr().err
    junit = tmp_path / "me.xml"
    assert main(["check", "--model-exchange", "--fmu-dir", str(fmu3_dir), str(SCENARIOS / "cardan_startup.toml"),
                 scenario, "--out", str(tmp_path), "--no-plot", "-q", "--junit", str(junit)]) == 0
    out = capsys.readouterr().out
    assert "SKIPPED cardan_startup" in out and "1 passed, 0 failed, 0 not checked, 1 skipped" in out
    import xml.etree.ElementTree as ET
    suite = ET.parse(junit).getroot()   # the skipped one counted, the run's kind in the names
    assert (suite.get("tests"), suite.get("skipped"), suite.get("name")) == ("2", "1", "ujfmu scenarios (model_exchange)")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases["cardan_startup"].find("skipped") is not None
    assert {c.get("classname") for c in cases.values()} == {"ujfmu.scenarios.model_exchange"}
