"""Command line and Python entry points: run, check with JUnit, failing exit status."""

import math
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import ujfmu
from ujfmu.cli import main

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_run_scenario_from_python_returns_the_table(fmu_dir, tmp_path):
    result = ujfmu.run_scenario(SCENARIOS / "cardan_constant_speed.toml", fmu_dir=fmu_dir, out_dir=tmp_path,
                                progress=False)
    assert result.passed and "joint.M_z" in result.table.dtype.names
    assert (tmp_path / "cardan_constant_speed.csv").is_file() and (tmp_path / "cardan_constant_speed.png").is_file()


def test_a_scenario_with_changed_parameters_runs_unchecked_under_its_own_name(fmu_dir, tmp_path):
    """Scenario.with_parameters: the rigid double Cardan with its yokes 90 deg apart runs under its own name (the
    bundled run's files untouched), its title says what changed, nothing is compared against the reference made for
    the file's in-phase yokes, and the physics is the new one: the output speed's swing is twice a single joint's,
    2 (1/cos b - cos b) of the input speed (in phase: 0). An object changed by hand names the problem and the way."""
    import math

    from ujfmu.scenario import Scenario, ScenarioError
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    beta = scenario.parameters_with_defaults("driveline")["beta1"]
    phased = scenario.with_parameters({"driveline.yoke_phase": math.pi / 2})
    result = ujfmu.run_scenario(phased, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False)
    assert result.csv == tmp_path / "double_cardan_brutti_rigid_changed.csv" and result.verdict == "NOT CHECKED"
    assert phased.title == f"driveline.yoke_phase = 1.5708 rad (90 deg) (a changed copy of: {scenario.title})"
    # a copy of the copy says both changes, before the file's title (which describes another setup)
    assert phased.with_parameters({"driveline.beta1": 0.1}).title == (
        "driveline.yoke_phase = 1.5708 rad (90 deg), driveline.beta1 = 0.1 rad (5.72958 deg) (a changed copy of: "
        f"{scenario.title})")
    assert scenario.reference_file is not None
    phased.record.append("driveline.tau_out")   # the copy's lists are its own: the file's scenario records as before
    assert "driveline.tau_out" not in scenario.record and phased.connections is not scenario.connections
    omega_in, omega_out = result.table["motor.omega"], result.table["driveline.omega_out"]
    late = result.table["time"] > 0.5 * result.table["time"][-1]
    swing = np.ptp(omega_out[late] / omega_in[late])
    assert swing == pytest.approx(2.0 * (1.0 / math.cos(beta) - math.cos(beta)), rel=1e-3)
    with pytest.raises(ScenarioError, match="did you mean 'driveline'"):
        scenario.with_parameters({"drivline.yoke_phase": 1.0})
    scenario.components["driveline"][1]["yoke_phase"] = math.pi / 2
    with pytest.raises(ScenarioError, match=r"changed after it was read .*with_parameters"):
        ujfmu.run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None)


def test_run_scenario_types_and_documents_its_folders(fmu_dir, tmp_path, monkeypatch):
    """README gives run_scenario's signature with the fmu_dir and out_dir keywords, as the code declares them, and
    the defaults are those of the command line; str paths work and out_dir=None writes nothing."""
    import inspect

    from ujfmu.build import DEFAULT_FMU_DIR
    from ujfmu.cli import DEFAULT_OUT_DIR
    params = inspect.signature(ujfmu.run_scenario).parameters
    readme = (Path(__file__).parents[1] / "README.md").read_text()
    for name, default in (("fmu_dir", DEFAULT_FMU_DIR), ("out_dir", DEFAULT_OUT_DIR)):
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY and Path(params[name].default) == default
        assert f'{name}: {params[name].annotation} = "{params[name].default}"' in readme, name
    monkeypatch.chdir(tmp_path)
    result = ujfmu.run_scenario(str(SCENARIOS / "cardan_constant_speed.toml"), fmu_dir=str(fmu_dir), out_dir=None)
    assert result.passed and result.csv is None and list(tmp_path.iterdir()) == []


def test_check_writes_junit_and_fails_on_a_failing_scenario(fmu_dir, tmp_path, capsys):
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    strict = tmp_path / "too_strict.toml"
    # the same run with a 0.31 N.m load, compared with the 0.3 N.m reference: must fail (the reference copied
    # without its setup digest, as one made by hand, which is compared whatever the setup where the scenario names
    # no generator to make it)
    lines = (SCENARIOS / "references" / "cardan_constant_speed.csv").read_text().splitlines(keepends=True)
    (tmp_path / "references").mkdir()
    (tmp_path / "references" / "too_strict.csv").write_text("# the 0.3 N.m closed form\n" + "".join(lines[1:]))
    strict.write_text(text.replace("T0 = 0.3,", "T0 = 0.31,").replace(
        "references/cardan_constant_speed.csv", "references/too_strict.csv").replace('generator = "cardan_joint"', ""))
    junit = tmp_path / "report.xml"
    code = main(["--fmu-dir", str(fmu_dir), "check", str(SCENARIOS / "cardan_constant_speed.toml"), str(strict),
                 "--junit", str(junit), "--out", str(tmp_path / "out"), "--no-plot"])
    assert code == 1
    suite = ET.parse(junit).getroot()
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert set(cases) == {"cardan_constant_speed", "too_strict"}
    assert cases["too_strict"].find("failure") is not None and cases["cardan_constant_speed"].find("failure") is None
    # the failure names what is outside its band (the load torque, 0.31 against the reference's 0.3 N.m)
    assert "signal outside tolerance of the reference: " in cases["too_strict"].find("failure").get("message")
    assert "load.tau" in cases["too_strict"].find("failure").get("message").split(": ", 1)[1]
    out = capsys.readouterr().out
    assert "1 passed, 1 failed" in out
    assert f"ujfmu run {strict} --check-step --fmu-dir {fmu_dir} estimates it" in out   # runs as printed
    # a folder stands for its scenario files; `run` of a folder says what to name
    assert main(["--fmu-dir", str(fmu_dir), "check", str(tmp_path), "--junit", str(junit), "--out",
                 str(tmp_path / "out"), "--no-plot", "-q"]) == 1
    assert {c.get("name") for c in ET.parse(junit).getroot().iter("testcase")} == {"too_strict"}
    assert main(["run", str(tmp_path)]) == 2
    assert "is a folder: name one scenario file" in capsys.readouterr().err


def test_run_reports_a_bad_scenario_without_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[experiment]\nstop_time = 1\n")
    assert main(["run", str(bad)]) == 2
    assert "bad.toml" in capsys.readouterr().err


def _unchecked(tmp_path, name="unchecked"):
    """cardan_constant_speed without its [reference]: a scenario that runs but compares nothing."""
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    path = tmp_path / f"{name}.toml"
    path.write_text(text[:text.index("[reference]")])
    return path


def test_the_step_check_suggested_after_an_fmi3_run_runs_the_fmi3_fmus(fmu3_dir, tmp_path, capsys, monkeypatch):
    """After `run --fmi 3` the suggested step check carries --fmi 3 (so its results go to results/fmi3/, not over
    the FMI 2.0 ones), and --fmu-dir only for FMI 3.0 FMUs outside fmus/fmi3/."""
    unchecked = _unchecked(tmp_path)
    import shutil
    shutil.copytree(fmu3_dir, tmp_path / "fmus" / "fmi3")
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(unchecked), "--fmi", "3", "--no-plot", "--no-check-step"]) == 0
    assert f"ujfmu run {unchecked} --check-step --fmi 3 estimates the coupling error" in capsys.readouterr().out
    assert main(["run", str(unchecked), "--fmi", "3", "--fmu-dir", str(fmu3_dir), "--no-plot", "--no-check-step"]) == 0
    assert (f"ujfmu run {unchecked} --check-step --fmi 3 --fmu-dir {fmu3_dir} estimates the coupling error"
            in capsys.readouterr().out)


def test_a_scenario_without_reference_is_not_checked_never_passed(fmu_dir, tmp_path, capsys):
    unchecked = _unchecked(tmp_path)
    common = ["--fmu-dir", str(fmu_dir), "--out", str(tmp_path / "out"), "--no-plot"]
    # run --no-check-step: says NOT CHECKED (not PASS), exit 0 (nothing failed)
    assert main(["run", str(unchecked), "--no-check-step"] + common) == 0
    out = capsys.readouterr().out
    assert out.startswith("NOT CHECKED unchecked") and "PASS" not in out and "no [reference]" in out
    # how to learn more, with the FMU folder this run used (not fmus/ here): the command runs as printed
    assert f"ujfmu run {unchecked} --check-step --fmu-dir {fmu_dir} estimates the coupling error" in out
    # run, and run --check-step: the estimate follows the summary, which names it instead of suggesting the option
    # again (by default for a run that compares nothing, saying so)
    for given, said in (([], True), (["--check-step"], False)):
        assert main(["run", str(unchecked)] + given + common) == 0
        out = capsys.readouterr().out
        summary, estimate = out.split("estimated coupling error", 1)
        assert "--check-step" not in summary and "the step-halving estimate of the coupling error at this step " \
            "follows" in summary and "joint.tau_in" in estimate
        assert ("the run compares nothing, so its coupling error is estimated by a rerun at half the step "
                "(--no-check-step skips it)" in summary) is said
    assert main(["run", str(unchecked), "--check-step", "--no-check-step"] + common) == 2
    assert "--check-step and --no-check-step: give one" in capsys.readouterr().err
    # check of nothing but unchecked scenarios: exit 1, saying nothing was checked
    junit = tmp_path / "only.xml"
    assert main(["check", str(unchecked), "--junit", str(junit)] + common) == 1
    captured = capsys.readouterr()
    assert "0 passed, 1 failed (1 compares nothing), 0 not checked" in captured.out
    assert "nothing was checked" in captured.err
    assert "comparing nothing (no [reference] with tolerances): unchecked" in captured.err   # not "not checked"
    assert "not checked (" not in captured.err
    # and its JUnit case fails as the command does (a skipped case had shown a CI dashboard no failure)
    suite = ET.parse(junit).getroot()
    case = suite.find("testcase")
    assert case.find("skipped") is None and "not checked: the scenario has no [reference]" in case.find("failure").get(
        "message")
    assert suite.get("failures") == "1" and suite.get("skipped") == "0"
    # with a checked scenario beside it: exit 0, the unchecked one skipped in the JUnit report and listed
    assert main(["check", str(SCENARIOS / "cardan_constant_speed.toml"), str(unchecked), "--junit", str(junit)]
                + common) == 0
    captured = capsys.readouterr()
    assert "1 passed, 0 failed, 1 not checked" in captured.out and "unchecked" in captured.err
    suite = ET.parse(junit).getroot()
    assert suite.get("skipped") == "1" and suite.get("failures") == "0"
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases["unchecked"].find("skipped") is not None and cases["cardan_constant_speed"].find("skipped") is None
    # --strict: a gate that checks every scenario it is given fails on the unchecked one
    assert main(["check", str(SCENARIOS / "cardan_constant_speed.toml"), str(unchecked), "--strict", "--junit",
                 str(junit)] + common) == 1
    captured = capsys.readouterr()   # counted as failed, as its JUnit case and the exit status have it
    assert "--strict: 1 scenario(s) compare nothing: unchecked" in captured.err
    assert "1 passed, 1 failed (--strict: 1 compares nothing), 0 not checked" in captured.out
    suite = ET.parse(junit).getroot()   # its report fails that case too, and only that one
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert suite.get("failures") == "1" and suite.get("skipped") == "0"
    assert cases["unchecked"].find("failure") is not None and cases["cardan_constant_speed"].find("failure") is None


def test_a_changed_run_estimates_its_coupling_error_and_fails_where_it_is_high(fmu_dir, tmp_path, capsys):
    """A changed copy of cardan_startup at an 80 deg joint (a fresh-eyes trial's) had ended with status 0, 8% of a
    signal's range off its monolithic solution at 1 ms, its summary saying only that its accuracy was unknown: a
    run that compares nothing now estimates its coupling error by step halving, and one above the allowance ends
    with status 1 and a line saying so with the remedy; --no-check-step gives the old run."""
    args = ["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_startup.toml"), "--set",
            "joint.bend_angle=80deg", "--stop-time", "2", "--no-plot", "--out", str(tmp_path)]
    assert main(args) == 1
    captured = capsys.readouterr()
    assert "HIGH motor.tau_motor" in captured.out
    assert "ujfmu: the estimated coupling error at 0.001 s is above the allowance (HIGH above)" in captured.err
    assert "take a smaller step (--step, or --step auto to find one)" in captured.err
    assert main(args + ["--no-check-step"]) == 0
    assert "estimated coupling error" not in capsys.readouterr().out
    # a signal recorded with --record, which the run does not compare, is not judged either (it had failed the run)
    mild = [a.replace("80deg", "20deg") for a in args] + ["--record", "joint.alpha_in"]
    assert main(mild) == 0
    out = capsys.readouterr().out
    assert "estimated coupling error" in out and "joint.alpha_in " not in out.split("estimated coupling error")[1]
    # a run that compares something estimates nothing unless asked
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_constant_speed.toml"), "--no-plot",
                 "--out", str(tmp_path)]) == 0
    assert "estimated coupling error" not in capsys.readouterr().out


def test_a_step_check_that_could_not_run_says_so_not_that_its_error_is_high(fmu_dir, tmp_path, capsys, monkeypatch):
    """The step check's rerun at half the step stopped: there is no HIGH line, and the command said "above the
    allowance (HIGH above)"; it says the error is not known, and why."""
    from ujfmu import stepsize
    monkeypatch.setattr(stepsize, "estimate", lambda scenario, step=None, fmu_dir=None, coarse=None:
                        stepsize.StepEstimate(1e-3, {}, {}, "the co-simulation at half the step stopped: X"))
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_constant_speed.toml"), "--check-step",
                 "--no-plot", "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert "step 0.001 s: the co-simulation at half the step stopped: X" in captured.out
    assert "rerun at half the step stopped, so the coupling error at 0.001 s is not known" in captured.err
    assert "HIGH above" not in captured.err


def test_a_high_step_estimate_suggests_the_torque_driven_wiring_only_where_a_joint_is_speed_driven(
        fmu_dir, tmp_path, capsys, monkeypatch):
    """A torque-driven scenario's HIGH estimate had advised "the torque-driven wiring where a speed-driven joint
    reflects a large inertia", the wiring it already had (a trial's): that remedy is said where a joint is
    speed-driven only."""
    from ujfmu import stepsize
    monkeypatch.setattr(stepsize, "estimate", lambda scenario, step=None, fmu_dir=None, coarse=None:
                        stepsize.StepEstimate(1e-3, {"joint.tau_in": 0.5}, {"joint.tau_in": 0.02}))
    for name, said in (("cardan_heavy_torque_driven", False), ("cardan_constant_speed", True)):
        assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / f"{name}.toml"), "--check-step",
                     "--no-plot", "--out", str(tmp_path)]) == 1
        err = capsys.readouterr().err
        assert "the estimated coupling error at 0.001 s is above the allowance" in err
        assert ("torque-driven wiring" in err) is said


def test_result_names_compared_and_uncompared_signals(fmu_dir, tmp_path):
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    assert '"joint.M_z" = { abs = 1e-09 }' in text
    partial = tmp_path / "partial.toml"   # M_z recorded but not compared
    partial.write_text(text.replace('"joint.M_z" = { abs = 1e-09 }', "").replace(
        "[reference]\n", '[reference]\nnot_compared = { "joint.M_z" = "left out by this test" }\n').replace(
        'file = "references/', f'file = "{SCENARIOS}/references/'))
    checked = ujfmu.run_scenario(partial, fmu_dir=fmu_dir, out_dir=None)
    assert checked.checked and checked.passed and checked.verdict == "PASS"
    assert checked.compared == list(checked.scenario.tolerances) and "joint.M_z" not in checked.compared
    assert checked.uncompared == ["joint.M_z"]
    unchecked = ujfmu.run_scenario(_unchecked(tmp_path), fmu_dir=fmu_dir, out_dir=None)
    assert not unchecked.checked and not unchecked.passed and not unchecked.failed
    assert unchecked.verdict == "NOT CHECKED" and unchecked.compared == []


def test_error_is_reported_against_the_allowed_error_not_a_constant_range():
    from ujfmu.scenario_run import SignalCheck
    constant = str(SignalCheck("joint.M_z", 8.5e-14, 1e-9, 5.7e-14))   # a constant reference: range ~ round-off
    assert "8.5e-05 of allowed" in constant and "range" not in constant
    failing = str(SignalCheck("joint.M_z", 0.01, 1e-9, 5.7e-14))
    assert failing.startswith("FAIL") and "1e+07 of allowed" in failing and "range" not in failing
    varying = str(SignalCheck("joint.tau_in", 1e-4, 1e-3, 0.1))
    assert "0.1 of allowed" in varying and "0.1% of the reference's range" in varying


def test_common_options_go_before_or_after_the_command_and_hints_name_the_folder(tmp_path, capsys):
    scenario = SCENARIOS / "cardan_constant_speed.toml"
    custom = tmp_path / "my_fmus"
    for argv in (["--fmu-dir", str(custom), "run", str(scenario)], ["run", str(scenario), "--fmu-dir", str(custom)],
                 ["run", "--quiet", str(scenario), "--fmu-dir", str(custom), "--out", str(tmp_path)],
                 ["-q", "--out", str(tmp_path), "run", str(scenario), "--fmu-dir", str(custom)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert str(custom) in err and f"ujfmu build --fmu-dir {custom}" in err, err
    assert main(["build", "NoSuchFMU", "--fmu-dir", str(custom), "-q"]) == 2
    assert "unknown FMU NoSuchFMU" in capsys.readouterr().err
    # --out means nothing to build: refused, not ignored, and said so before or after the command (after it, it
    # had read "unrecognized arguments: --out", as for battery and modes, though the README says either works)
    for argv in (["build", "--out", str(tmp_path)], ["--out", str(tmp_path), "build"]):
        with pytest.raises(SystemExit):
            main(argv)
        assert "--out does not apply to `ujfmu build` (FMUs go to --fmu-dir)" in capsys.readouterr().err
    for command in (["battery"], ["modes", str(scenario)]):
        with pytest.raises(SystemExit):
            main(command + ["--out", str(tmp_path)])
        assert f"--out does not apply to `ujfmu {command[0]}`" in capsys.readouterr().err


def test_default_folders_are_the_current_directorys(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["check"]) == 2   # no scenarios/ here: an error, not "0 passed"
    assert f"no scenario files (*.toml) in {tmp_path / 'scenarios'}" in capsys.readouterr().err
    (tmp_path / "scenarios").mkdir()
    _unchecked(tmp_path / "scenarios", "mine")
    assert main(["check"]) == 2   # finds ./scenarios/mine.toml, looks for ./fmus
    err = "".join(capsys.readouterr())
    assert "mine.toml" in err and str(tmp_path / "fmus" / "Motor.fmu") in err and "run `ujfmu build` first" in err
    assert "or give --fmu-dir DIR (from Python: fmu_dir=DIR) where they were built" in err


def test_progress_is_a_callback_and_the_cli_draws_no_bar_off_a_terminal(fmu_dir, tmp_path, capsys, monkeypatch):
    calls = []
    ujfmu.run_scenario(SCENARIOS / "cardan_constant_speed.toml", fmu_dir=fmu_dir, out_dir=None,
                       progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (500, 500) and all(b >= a for (a, _), (b, _) in zip(calls, calls[1:]))
    # pytest's captured stderr is not a terminal: no progress bar (no carriage returns), in spite of no --quiet
    assert main(["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out",
                 str(tmp_path), "--no-plot"]) == 0
    captured = capsys.readouterr()
    assert "\r" not in captured.err + captured.out and "PASS cardan_constant_speed" in captured.out
    # the verdict says what it compared against: the file, as a path from the current directory (the clone here;
    # not from the scenario's folder: "references/..." did not exist from where it was run), and how it was made
    # (its provenance line)
    monkeypatch.chdir(SCENARIOS.parent)
    assert main(["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out",
                 str(tmp_path), "--no-plot"]) == 0
    captured = capsys.readouterr()
    assert ("  against scenarios/references/cardan_constant_speed.csv: closed form (ideal speed source)"
            in captured.out)
    assert main(["-q", "run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out",
                 str(tmp_path), "--no-plot"]) == 0
    assert "results:" not in capsys.readouterr().out   # --quiet: the verdict only


def test_run_prints_what_an_fmu_warns_of_while_it_steps(fmu_dir, tmp_path, capsys):
    """A truck engineer left k_theta out of a scenario: Omar's 92.2 N.m/rad shaft twisted past 0.5 rad under the
    load and the FMU said so, but ``ujfmu run`` printed nothing (the command ignores FmuWarning and says only its
    own advice, which comes before the run): the warning is printed once, in the command's own form."""
    assert main(["run", str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--set", "load.T0=60", "--set",
                 "driveline.k_phi=1e8", "--stop-time", "0.3", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path),
                 "--no-plot", "--no-check-step"]) == 0
    err = capsys.readouterr().err
    twisted = [line for line in err.splitlines() if "intermediate shaft is twisted" in line]
    assert len(twisted) == 1 and twisted[0].startswith("  warning driveline: at t = ")
    assert "Said once" not in twisted[0] and "DoubleCardanDriveline 'driveline'" not in twisted[0]


def test_run_without_plots_names_an_earlier_runs_figures_beside_the_new_table(fmu_dir, tmp_path, capsys):
    """--no-plot had left an earlier run's figure of another setup beside the fresh CSV, unsaid."""
    (tmp_path / "cardan_constant_speed.png").write_bytes(b"an earlier figure")
    assert main(["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out",
                 str(tmp_path), "--no-plot"]) == 0
    assert (f"figures of an earlier run, not redrawn for this one: {tmp_path / 'cardan_constant_speed.png'}"
            in capsys.readouterr().err)


def test_the_fmus_warnings_of_a_run_are_said_once_per_component_and_kind():
    """Two rigs named driveline1 and driveline2 each warned of their twist; the dedup had masked the digits of their
    names and printed one. Said once per component and kind of warning (the step-halving rerun's, at another time,
    left out); what the command said before the run is not said again."""
    from ujfmu.scenario_run import fmu_warning_lines

    def fmu(name, text):
        return f"[warning] {name}: DoubleCardanDriveline '{name}': {text}"
    caught = [fmu("driveline1", "at t = 0.014 s the shaft is twisted 0.528 rad"),
              fmu("driveline2", "at t = 0.016 s the shaft is twisted 0.531 rad"),
              fmu("driveline1", "at t = 0.0145 s the shaft is twisted 0.529 rad"),   # the rerun at h/2
              fmu("driveline2", "T0 = 3 N.m is the paper's")]
    assert fmu_warning_lines(caught, ["driveline2: T0 = 3 N.m is the paper's"]) == [
        "driveline1: at t = 0.014 s the shaft is twisted 0.528 rad",
        "driveline2: at t = 0.016 s the shaft is twisted 0.531 rad"]


@pytest.mark.parametrize("reused, workers, seconds, said, pace, startup", [
    (0, 0, 10.0, "about 16 min to go", "10 s each", 0.0), (20, 0, 10.0, "about 13 min to go", "10 s each", 0.0),
    (0, 0, 0.1, None, None, 0.0),
    (0, 4, 10.0, "about 3.7 min to go", "2.5 s each", 0.0),   # four at a time: each round of 10 s ends four points
    (0, 0, 10.0, "about 16 min to go", "10 s each", 120.0),   # the workers' start is not a point's pace
    (0, 4, 10.0, "about 3.7 min to go", "2.5 s each", 120.0)])
def test_a_sweep_off_a_terminal_says_its_time_to_go_once_from_its_first_computed_points(capsys, reused, workers,
                                                                                      seconds, said, pace, startup):
    """A DOE engineer's long sweep in a CI log had said nothing about its length: after its first computed points
    (four, or three rounds of the workers: points finish together on parallel workers; the ones reused from a
    journal are done at once and do not count) it says the time to go at their pace, once, where that is a minute
    or more. The pace is taken after the first round, which also pays the workers' start (a trial's estimate of 2.3
    min for a sweep of 34 s, the validation report's 9.6 min for 95 s)."""
    import argparse

    from ujfmu import cli
    clock = [0.0]   # a clock of its own, advanced by hand
    with cli._progress(argparse.Namespace(quiet=False, workers=workers), "grid", "point", lambda: clock[0]) as say:
        say(reused, 100)
        clock[0] += startup
        for done in range(reused + 1, reused + 13):
            if (done - reused - 1) % max(workers, 1) == 0:
                clock[0] += seconds
            say(done, 100)
    lines = [line for line in capsys.readouterr().err.splitlines() if "to go" in line]
    if said is None:
        assert not lines
    else:
        assert len(lines) == 1 and said in lines[0] and f"({pace}, wall" in lines[0], lines


def test_the_progress_counts_the_step_halving_rerun(fmu_dir):
    """cardan_startup's [reference.extrapolated] bands rerun it at half the step after its 6000 steps: the progress
    had stood at 6000 of 6000 through that rerun, the longer part (12000 steps). Its total counts both from the
    start, 18000, and the count goes on through the rerun to it; a run without a rerun counts its own steps."""
    calls = []
    ujfmu.run_scenario(SCENARIOS / "cardan_startup.toml", fmu_dir=fmu_dir, out_dir=None, plot=False,
                       progress=lambda done, total: calls.append((done, total)))
    assert {total for _, total in calls} == {18000}
    done = [d for d, _ in calls]
    assert done == sorted(done) and done[-1] == 18000 and any(6000 < d < 18000 for d in done)
    calls.clear()
    from ujfmu.scenario import Scenario
    plain = Scenario(SCENARIOS / "cardan_startup.toml").with_parameters({})   # a changed copy: no reference
    ujfmu.run_scenario(plain, fmu_dir=fmu_dir, out_dir=None, plot=False,
                       progress=lambda done, total: calls.append((done, total)))
    assert {total for _, total in calls} == {6000} and calls[-1][0] == 6000


@pytest.mark.parametrize("scenario", ["cardan_constant_speed", "cardan_startup"])   # explicit, implicit steps
def test_a_progress_callback_that_returns_false_stops_the_run_and_keeps_its_results(fmu_dir, tmp_path, scenario):
    """As fmpy's step_finished: returning False stops the run at that report (a caller's time budget had to raise
    an exception and lost the results); RunStopped carries the rows up to there, also written to the CSV, and
    no hint about the drive (a run-up stopped early is not a stalled drive)."""
    from ujfmu.master import RunStopped
    from ujfmu.scenario import Scenario
    path = SCENARIOS / f"{scenario}.toml"
    s = Scenario(path)
    n = int(round((s.stop_time - s.start_time) / s.step_size))
    with pytest.raises(RunStopped) as info:
        ujfmu.run_scenario(path, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False,
                           progress=lambda done, total: done < n // 2)
    partial = info.value.partial
    assert n // 2 <= len(partial) - 1 <= n // 2 + n // 200 + 1 and "hint" not in str(info.value)
    assert f"stopped by the progress callback after {len(partial) - 1} of {n} steps" in str(info.value)
    written = np.genfromtxt(tmp_path / f"{scenario}.csv", delimiter=",", names=True)
    assert len(written) == len(partial) and written["time"][-1] == pytest.approx(partial["time"][-1])


def test_a_ctrl_c_keeps_a_runs_results_up_to_the_step_it_stopped_at(fmu_dir, tmp_path):
    """A Ctrl-C (or the command's SIGTERM: a batch job over its time) had stopped a run with nothing written: the
    KeyboardInterrupt now carries the rows up to the communication step it stopped at, written to the CSV as a
    failed run's, and is still a KeyboardInterrupt (a caller's ``except CosimulationError`` does not take it)."""
    import signal

    from ujfmu.master import Interrupted
    path = SCENARIOS / "cardan_startup.toml"

    def progress(done, total):
        if done >= total // 3:
            signal.raise_signal(signal.SIGINT)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        try:
            ujfmu.run_scenario(path, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False, progress=progress)
        except Interrupted as exc:
            stopped = exc
        except KeyboardInterrupt:
            pytest.fail("a KeyboardInterrupt without the results")
        else:
            pytest.fail("the run was not stopped")
    finally:
        signal.signal(signal.SIGINT, previous)
    partial, text = stopped.partial, str(stopped)
    assert f"after {len(partial) - 1} steps" in text and f"results up to t = {float(partial['time'][-1])!r}" in text
    written = np.genfromtxt(tmp_path / "cardan_startup.csv", delimiter=",", names=True)
    assert len(written) == len(partial) > 2 and len(written.dtype.names) == len(partial.dtype.names)
    assert np.allclose(written["time"], partial["time"])


def test_a_long_run_says_its_pace_and_what_sets_it_once_unless_quiet(fmu_dir, tmp_path, capsys, monkeypatch):
    """With the thresholds at zero every run counts as long: one note (not one per report) on stderr, in seconds
    per simulated second and minutes to go, naming what sets the substeps and where the rule is; --quiet: none."""
    from ujfmu import cli
    monkeypatch.setattr(cli, "PACE_AFTER", 0.0)
    monkeypatch.setattr(cli, "PACE_LONG", 0.0)
    args = ["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path),
            "--no-plot"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert err.count("note: this run steps at") == 1 and "s per simulated second (0.001 s steps)" in err
    assert "min to go" in err and "k_theta" in err and "What a communication step costs" in err
    assert main(["-q"] + args) == 0
    assert "note:" not in capsys.readouterr().err
    monkeypatch.setattr(cli, "PACE_LONG", 1e9)   # a run that ends well within it: no note
    assert main(args) == 0
    assert "note:" not in capsys.readouterr().err


def test_missing_reference_file_names_the_scenario_and_field(fmu_dir, tmp_path, capsys):
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    path = tmp_path / "lost_reference.toml"
    path.write_text(text)   # its reference path is relative to the scenario: not there
    assert main(["run", str(path), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert (f"{path}: [reference] file = 'references/cardan_constant_speed.csv'" in err and "not found" in err
            and "Errno" not in err)
    # the two ways on: regenerate it (with the extra that can), or run the copy unchecked
    assert f"ujfmu references {path}" in err and "ujfmu[references]" in err and "remove the [reference]" in err


def test_references_says_when_a_scenario_has_nothing_to_regenerate(tmp_path, capsys):
    assert main(["references", str(_unchecked(tmp_path))]) == 1
    captured = capsys.readouterr()
    assert "unchecked.toml: skipped: no [reference]" in captured.err and "no reference was regenerated" in captured.err


def test_references_says_how_each_reference_was_made_and_how_well_it_keeps_its_laws(tmp_path, capsys):
    """`ujfmu references` had said only "wrote": a CI trial could not tell how good its reference was. It gives the
    method (the provenance line's) and each self-check the generator passed on the written grid, its deviation
    within its allowance, as shares of the law's scale: for Omar's driveline, the energy balance."""
    (tmp_path / "references").mkdir()
    mine = tmp_path / "my_torsional.toml"
    mine.write_text((SCENARIOS / "double_cardan_omar_torsional.toml").read_text().replace(
        "references/double_cardan_omar_torsional.csv", "references/my_torsional.csv").replace(
        "stop_time = 3.0", "stop_time = 0.5"))
    assert main(["references", str(mine), "-q"]) == 0
    line = capsys.readouterr().out.rstrip().splitlines()[-1]
    assert line.startswith("  my_torsional: how the reference was made: monolithic ODE of ideal speed source + "
                           "driveline + load") and "scipy DOP853 rtol=1e-10" in line, line
    laws = re.findall(r"(stored energy against the work of [^;]*?) (\S+) \(allowed (\S+)\)", line)
    # a solve sampled on a grid keeps no law to the last digit: a deviation of 0 would not be the one measured
    assert laws and all(0.0 < float(d) <= float(a) < 1e-5 for _, d, a in laws), line


def test_references_refuses_to_overwrite_another_scenarios_reference(fmu_dir, tmp_path, capsys):
    """A copy of a scenario that still names its original's reference file: `ujfmu references` on the copy refuses
    before any work, names the owner (from the file's provenance line) and the fix, and leaves the file as it
    was; the original itself still regenerates there (its own file)."""
    (tmp_path / "references").mkdir()
    target = tmp_path / "references" / "cardan_startup.csv"
    target.write_text((SCENARIOS / "references" / "cardan_startup.csv").read_text())
    copy = tmp_path / "my_cardan45.toml"
    copy.write_text((SCENARIOS / "cardan_startup.toml").read_text())
    before = target.stat().st_mtime_ns, target.read_text()
    assert main(["references", str(copy)]) == 2
    err = capsys.readouterr().err
    assert "is the reference of scenarios/cardan_startup.toml" in err and 'file = "references/my_cardan45.csv"' in err
    assert (target.stat().st_mtime_ns, target.read_text()) == before
    # run first, with a parameter edited: the same advice (not "regenerate it", which the command above refuses)
    copy.write_text(copy.read_text().replace("parameters = { J2 = 1e-5 }", "parameters = { J2 = 2e-5 }"))
    assert copy.read_text() != (SCENARIOS / "cardan_startup.toml").read_text()
    assert main(["run", str(copy), "--fmu-dir", str(fmu_dir), "--no-plot", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is the reference of scenarios/cardan_startup.toml" in err and 'file = "references/my_cardan45.csv"' in err
    assert f"ujfmu references {copy}" in err and "regenerate it" not in err


def test_check_runs_every_scenario_and_reports_one_that_cannot_run(fmu_dir, tmp_path, capsys):
    """A copy of a scenario with its original's reference copied under the copy's own name, then a parameter
    edited: `check` of the copy and a good scenario runs both, reports the copy as an ERROR with the fix (make its
    own reference; the file is already named after it), writes the JUnit report with the passing case and an error
    case, and exits 2. `ujfmu references` then replaces the copied file (it is the copy's own), and the copy
    passes."""
    (tmp_path / "references").mkdir()
    copied = tmp_path / "references" / "my_copy.csv"
    copied.write_text((SCENARIOS / "references" / "cardan_constant_speed.csv").read_text())
    copy = tmp_path / "my_copy.toml"
    copy.write_text((SCENARIOS / "cardan_constant_speed.toml").read_text().replace(
        "references/cardan_constant_speed.csv", "references/my_copy.csv").replace("T0 = 0.3,", "T0 = 0.31,"))
    junit = tmp_path / "report.xml"
    common = ["--out", str(tmp_path / "out"), "--no-plot", "-q"]
    code = main(["--fmu-dir", str(fmu_dir), "check", str(copy), str(SCENARIOS / "cardan_constant_speed.toml"),
                 "--junit", str(junit)] + common)
    out, err = capsys.readouterr()
    assert code == 2
    assert "ERROR my_copy" in out and "holds the reference of scenarios/cardan_constant_speed.toml" in out
    assert f"`ujfmu references {copy}`" in out and "give this scenario its own file" not in out
    assert "PASS cardan_constant_speed" in out and "1 passed, 0 failed, 0 not checked, 1 could not run" in out
    assert "could not run (my_copy)" in err
    suite = ET.parse(junit).getroot()
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("2", "0", "1")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases["my_copy"].find("error") is not None
    assert cases["cardan_constant_speed"].find("error") is None and cases["cardan_constant_speed"].find("failure") is None
    assert main(["references", str(copy), "-q"]) == 0
    assert "my_copy.toml" in copied.read_text().splitlines()[0]
    assert main(["--fmu-dir", str(fmu_dir), "check", str(copy)] + common) == 0


def test_output_interval_thins_the_written_rows_and_keeps_the_verdict(fmu_dir, tmp_path, capsys):
    """--output-interval 10 on a 500-step run: rows at 0, 10, ..., 500 s/1000 in the CSV, still compared (PASS).
    --output-interval 50 records every 0.05 s, one period of the joint's 2x order at 600 rpm: every row at one joint
    angle, which the reference at the same instants matches, so the sampling check fails it. A value below 1 is
    refused by the argument parser."""
    path = SCENARIOS / "cardan_constant_speed.toml"
    assert main(["run", str(path), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path), "--no-plot",
                 "--output-interval", "10"]) == 0
    out = capsys.readouterr().out
    assert "PASS cardan_constant_speed" in out
    # each error in its signal's unit: the speeds in rad/s, the torques in N.m
    assert re.search(r"joint\.omega_out +max\|err\| = \S+ rad/s at t = \S+ s  allowed \S+ rad/s  ", out), out
    assert re.search(r"joint\.tau_in +max\|err\| = \S+ N\.m at t = \S+ s  allowed \S+ N\.m  ", out), out
    rows = (tmp_path / "cardan_constant_speed.csv").read_text().splitlines()[1:]
    assert [float(r.split(",")[0]) for r in rows] == pytest.approx([0.01 * k for k in range(51)], abs=1e-12)
    assert main(["run", str(path), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path), "--no-plot",
                 "--output-interval", "50"]) == 1
    out = capsys.readouterr().out
    assert out.startswith("FAIL cardan_constant_speed") and "FAIL sampling joint" in out
    assert all(line.startswith("  ok") for line in out.splitlines() if "max|err|" in line)
    with pytest.raises(SystemExit):
        main(["run", str(path), "--output-interval", "0"])


def test_a_failed_signal_names_the_step_check_as_a_remedy():
    """A FAIL on a signal says how to tell a coarse step from a wrong model (--check-step, --step auto); a PASS
    does not; the missing scipy band is not repeated per scenario."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import ScenarioResult, SignalCheck
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml")
    failing = ScenarioResult(scenario, None, checks=[SignalCheck("joint.tau_in", 0.05, 1e-3, 0.1)]).summary()
    assert failing.startswith("FAIL") and f"ujfmu run {scenario.path} --check-step" in failing
    assert "--step auto" in failing and "validate_result" not in failing
    assert "[reference.tolerance] holds figures chosen for the scenario's own parameters" in failing   # a copy's
    after_estimate = ScenarioResult(scenario, None, checks=[SignalCheck("joint.tau_in", 0.05, 1e-3, 0.1)]).summary(
        step_check_follows=True)   # ujfmu run --check-step prints the estimate next
    assert "--check-step" not in after_estimate and "the step-halving estimate below gives it per signal" \
        in after_estimate
    result = ScenarioResult(scenario, None, checks=[SignalCheck("joint.tau_in", 1e-5, 1e-3, 0.1)])
    passing = result.summary()
    assert passing.startswith("PASS") and "--check-step" not in passing
    # a compared run has no reason for not being compared, and its repr is a line, not its table
    assert result.not_checked_reason() == ""
    assert repr(result) == "<ScenarioResult cardan_constant_speed: PASS, 0 rows, csv=None>"


def test_record_adds_a_signal_and_keeps_the_run_checked(fmu_dir, tmp_path, capsys):
    """--record driveline.tau_out: the CSV gains the column (an energy auditor had to edit the file for a signal),
    it is listed as not compared, and the run is still compared with the file's reference (PASS); a misspelt name
    is an error naming the close one."""
    path = SCENARIOS / "double_cardan_omar_torsional.toml"
    argv = ["run", str(path), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path), "--no-plot"]
    assert main(argv + ["--record", "driveline.tau_out"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("PASS double_cardan_omar_torsional:")
    assert "not compared: driveline.tau_out: recorded with --record" in out
    header = (tmp_path / "double_cardan_omar_torsional.csv").read_text().splitlines()[0]
    assert '"driveline.tau_out"' in header
    assert main(argv + ["--record", "driveline.stored_enrgy"]) == 2
    assert "did you mean driveline.stored_energy?" in capsys.readouterr().err


def test_a_stop_in_the_step_halving_rerun_keeps_the_whole_run(fmu_dir, tmp_path):
    """cardan_startup's [reference.extrapolated] bands rerun it at h/2 after the run itself: that rerun asks the
    callback too (its steps counted on from the run's; it had asked nothing, 70% of the call unseen), a False
    stops it, and the complete run at the scenario's step is written, not lost (a notebook user's interrupt there
    had kept only the rerun's rows)."""
    from ujfmu.master import RunStopped
    from ujfmu.scenario_run import run_scenario
    reports, steps = [], 6000

    def progress(done, total):
        reports.append((done, total))
        return done <= steps   # the rerun's first report stops it
    with pytest.raises(RunStopped) as info:
        run_scenario(SCENARIOS / "cardan_startup.toml", fmu_dir=fmu_dir, out_dir=tmp_path, plot=False,
                     progress=progress)
    assert {t for _, t in reports} == {3 * steps} and reports[-1][0] > steps
    assert "stopped in the step-halving rerun" in str(info.value) and "complete and kept" in str(info.value)
    rows = (tmp_path / "cardan_startup.csv").read_text().splitlines()
    assert len(rows) - 1 == steps + 1 == len(info.value.partial)


def test_an_unchecked_model_exchange_run_is_not_sent_to_the_step_check():
    """A Model Exchange run without a reference has no communication step: its summary does not suggest
    --check-step (which refuses such a run; a motorsport trial was sent there), and says what would check it."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import ScenarioResult
    scenario = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml")
    scenario.reference_file = None
    summary = ScenarioResult(scenario, None, model_exchange=True).summary()
    assert "--check-step" not in summary and "a Model Exchange run has no communication step" in summary
    assert "--check-step" in ScenarioResult(scenario, None).summary()


def test_the_reference_method_is_read_from_the_provenance_line(tmp_path):
    """The method between the generator's name and 'Regenerate:' (or the setup tag, or the line's end); None for a
    file without a provenance line, or none at all."""
    from ujfmu.references import method_of, provenance_of

    def reference_method(path):
        return method_of(provenance_of(path))
    cases = {"# ujfmu.models.x.reference: closed form: a pendulum. Regenerate: ujfmu references s.toml [scenario "
             "setup 0123]\n": "closed form: a pendulum",
             "# mine.gen: monolithic ODE, rtol=1e-10 [scenario setup 0123]\n": "monolithic ODE, rtol=1e-10",
             "# by hand: measured on the rig\n": "by hand: measured on the rig",
             '"time","x"\n': None}
    for k, (line, method) in enumerate(cases.items()):
        path = tmp_path / f"r{k}.csv"
        path.write_text(line + "0,1\n")
        assert reference_method(path) == method, line
    assert reference_method(tmp_path / "missing.csv") is None


def test_the_regenerate_command_runs_from_where_the_reference_was_made(monkeypatch, tmp_path):
    """A project folder inside the clone: the provenance line's command is relative to the current directory (it
    had been relative to the clone, "myproject/scenarios/...", a path that does not exist from the project); the
    bundled scenarios keep scenarios/<name>.toml from anywhere in the clone."""
    import ujfmu.references as references
    from types import SimpleNamespace
    monkeypatch.setattr(references, "_REPO_DIR", tmp_path)
    project = tmp_path / "myproject"
    (project / "scenarios").mkdir(parents=True)
    monkeypatch.chdir(project)
    mine = SimpleNamespace(path=Path("scenarios") / "mine.toml")
    assert references.regenerate_text(mine) == "Regenerate: ujfmu references scenarios/mine.toml"
    bundled = SimpleNamespace(path=tmp_path / "scenarios" / "cardan_startup.toml")
    assert references.regenerate_text(bundled) == "Regenerate: ujfmu references scenarios/cardan_startup.toml"


def test_runs_of_different_fmu_kinds_write_to_different_folders(monkeypatch, tmp_path):
    """FMI 2.0, FMI 3.0 and Model Exchange runs of one scenario do not overwrite each other's results by default;
    an explicit --out is taken as given."""
    import ujfmu.cli as cli
    seen = []
    monkeypatch.setattr(cli, "cmd_run", lambda args: seen.append(args.out) or 0)
    monkeypatch.setattr(cli, "cmd_check", lambda args: seen.append(args.out) or 0)
    scenario = str(SCENARIOS / "cardan_constant_speed.toml")
    for argv in (["run", scenario], ["run", scenario, "--fmi", "3"], ["run", scenario, "--model-exchange"],
                 ["check", "--fmi", "3"], ["run", scenario, "--fmi", "3", "--out", str(tmp_path)]):
        assert cli.main(argv) == 0
    assert seen == [Path("results"), Path("results/fmi3"), Path("results/model_exchange"), Path("results/fmi3"),
                    tmp_path]


def test_a_finer_step_is_compared_where_the_reference_has_samples():
    """A reference sampled at 1 ms holding a fast ripple, a result at 0.5 ms equal to the exact signal: compared
    at the shared instants the error is nil; interpolating the reference to the half steps would have charged the
    result with the reference's own sampling error (about w^2 h^2 / 8 of the amplitude)."""
    from ujfmu.scenario import Tolerance
    from ujfmu.scenario_run import compare
    exact = lambda t: 40.0 * np.sin(600.0 * t)   # noqa: E731  2x-per-revolution ripple at 300 rad/s
    t_ref, t_run = np.linspace(0.0, 1.0, 1001), np.linspace(0.0, 1.0, 2001)
    reference = np.rec.fromarrays([t_ref, exact(t_ref)], names=["time", "x"])
    result = np.rec.fromarrays([t_run, exact(t_run)], names=["time", "x"])
    (check,) = compare(result, reference, {"x": Tolerance(rel_range=1e-6, abs=0.0)})
    assert check.passed and check.max_error < 1e-9
    interpolated = np.max(np.abs(exact(t_run) - np.interp(t_run, t_ref, exact(t_ref))))
    assert interpolated > 1.0   # what the old comparison charged: far outside the band
    # a short run on a grid sharing almost no instants with the reference (0.7 ms) falls back to interpolation
    t_odd = np.arange(0.0, 0.01, 7e-4)
    odd = np.rec.fromarrays([t_odd, exact(t_odd)], names=["time", "x"])
    (check,) = compare(odd, reference, {"x": Tolerance(rel_range=1e-6, abs=0.0)})
    assert check.max_error > 0.1


def test_extrapolated_bands_are_left_out_at_a_coarser_step_and_said_so(fmu_dir, tmp_path, capsys):
    """The [reference.extrapolated] bands hold at the scenario's own step; a coarser --step checks the direct
    tolerances and names the bands it left out."""
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_startup.toml"), "--step", "0.002",
                 "--no-plot", "-q", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("PASS") and "[reference.extrapolated] bands not checked" in out and "0.002 s" in out


def test_a_large_error_on_a_varying_signal_keeps_its_share_of_the_range():
    """16% of a varying reference's range is said as such, however far outside the band it is."""
    from ujfmu.scenario_run import SignalCheck
    text = str(SignalCheck("motor.tau_motor", 0.061, 7.6e-4, 0.38))
    assert text.startswith("FAIL") and "16.1% of the reference's range" in text


def test_the_command_runs_exit_handlers_flushes_and_keeps_the_exit_status(tmp_path):
    """``ujfmu`` (``cli.entry``) ends the process without the shared libraries' destructors (pythonfmu's aborts
    at exit), but only after Python's exit handlers have run and its output is flushed, with main()'s status: 0
    for --help, 2 for a scenario file that is not there."""
    import subprocess
    import sys
    script = ("import atexit, sys\nfrom ujfmu.cli import entry\natexit.register(lambda: print('exit handler ran'))\n"
              "sys.argv = ['ujfmu'] + sys.argv[1:]\nprint('before', end='')\nentry()\nprint('never')\n")
    for args, status, words in ((["--help"], 0, "usage: ujfmu"), (["references", str(tmp_path / "no.toml")], 2,
                                                                  "scenario file not found")):
        done = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=120)
        assert done.returncode == status, done.stderr
        assert done.stdout.startswith("before") and "exit handler ran" in done.stdout and "never" not in done.stdout
        assert words in done.stdout + done.stderr


def test_a_reader_that_stops_reading_does_not_stop_the_build(tmp_path):
    """``ujfmu build | head -1``: the reader closes the pipe after the first line; the build goes on to build every
    FMU asked for and exits 0, where the next line's BrokenPipeError had stopped it after the second FMU."""
    import subprocess
    import sys
    names = ["Motor", "Load", "CardanJoint"]
    script = "import sys\nfrom ujfmu.cli import entry\nsys.argv = ['ujfmu'] + sys.argv[1:]\nentry()\n"
    with subprocess.Popen([sys.executable, "-c", script, "build", "--fmu-dir", str(tmp_path), *names],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as process:
        assert process.stdout.readline().startswith("built ")
        process.stdout.close()
        assert process.wait(timeout=120) == 0, process.stderr.read()
        assert "Traceback" not in process.stderr.read()
    assert sorted(p.name for p in tmp_path.glob("*.fmu")) == sorted(f"{n}.fmu" for n in names)


def test_a_negative_step_is_refused_by_its_own_check_not_argparse(tmp_path, capsys):
    """`--step -1e-3` reads as an option to argparse ("expected one argument"); the value reaches the step check,
    which says what a step must be. An option after --step stays an option."""
    scenario = str(SCENARIOS / "cardan_constant_speed.toml")
    for value in ("-1e-3", "-0.001", "-inf"):
        assert main(["run", scenario, "--step", value, "--out", str(tmp_path), "--no-plot"]) == 2
        assert f"--step {value}: the communication step must be a number of seconds > 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", scenario, "--step", "--no-plot"])
    assert "expected one argument" in capsys.readouterr().err


def test_an_fmu_file_holding_another_model_is_named_before_anything_runs(fmu_dir, tmp_path, capsys):
    """DoubleCardanDrivelineTorqueDriven.fmu copied over DoubleCardanDriveline.fmu: the run had failed on a missing
    output with a hint to rewire the (ideal) motor torque-driven; the file's own modelDescription says which model
    it holds."""
    import shutil
    fmus = tmp_path / "fmus"
    shutil.copytree(fmu_dir, fmus)
    shutil.copy(fmus / "DoubleCardanDrivelineTorqueDriven.fmu", fmus / "DoubleCardanDriveline.fmu")
    assert main(["--fmu-dir", str(fmus), "check", str(SCENARIOS / "double_cardan_omar_torsional.toml"),
                 "--out", str(tmp_path / "out"), "--no-plot", "-q"]) == 2
    out = capsys.readouterr().out
    assert "holds the model 'DoubleCardanDrivelineTorqueDriven'" in out and "rebuild it" in out
    assert "torque-driven instead" not in out


def test_an_unreadable_reference_says_what_the_file_is(fmu_dir, tmp_path, capsys):
    """A reference checked out as a Git LFS pointer, or cut short, is named as such with the remedy, not only by
    numpy's parse error; a measured one (no generator named) is not told to regenerate itself."""
    import shutil
    for name, text, words in (("lfs", "version https://git-lfs.github.com/spec/v1\noid sha256:abc\nsize 12\n",
                               "Git LFS pointer"),
                              ("cut", None, "truncated or hand-edited file? `ujfmu references"),
                              ("measured", None, "hand-edited file? the scenario names no generator")):
        scenario = tmp_path / f"{name}.toml"
        scenario.write_text((SCENARIOS / "cardan_constant_speed.toml").read_text().replace(
            "references/cardan_constant_speed.csv", f"{name}.csv").replace(
            'generator = "cardan_joint"\n', "" if name == "measured" else 'generator = "cardan_joint"\n'))
        reference = tmp_path / f"{name}.csv"
        if text is None:
            shutil.copy(SCENARIOS / "references" / "cardan_constant_speed.csv", reference)
            lines = reference.read_text().splitlines()
            reference.write_text("\n".join(lines[:60] + [lines[60][:15]] + lines[61:]) + "\n")
        else:
            reference.write_text(text)
        assert main(["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert words in err and (name != "measured" or "ujfmu references" not in err), err


def test_a_run_at_a_critical_speed_says_so_before_it_runs(fmu_dir, tmp_path, capsys):
    """`ujfmu run` of the twin rotor with its drive set to disc 2's Jeffcott speed sqrt(K2X / (M2 + m_u2)) = 117.02
    rad/s (a trial's changed copy had run there, its title saying "below its first critical speed", without a
    word) notes the 1x crossing of that lateral mode before the run; at 90 rad/s, more than 10% from every crossing
    (the 1x with the 110 rad/s torsional mode, the 2x with disc 1's 154 rad/s lateral one), it notes none; `check`
    (a gate's output) never does."""
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    rig = tj.rig_parameters()
    jeffcott = math.sqrt(rig["K2X"] / (rig["M2"] + rig["m_u2"]))
    steady = str(SCENARIOS / "twin_jeffcott_steady.toml")
    common = ["--stop-time", "0.05", "--no-plot", "--no-check-step", "--out", str(tmp_path)]
    assert main(["--fmu-dir", str(fmu_dir), "run", steady, "--set", f"motor.omega_set={jeffcott:.6f}"] + common) == 0
    out = capsys.readouterr().err   # beside the warnings: the output starts with the verdict
    said = re.search(r"note: motor\.omega_set = (\S+) rad/s is 0\.0% (above|below) the speed (\S+) rad/s at "
                     r"which the 1x order meets rotor's (\S+) rad/s lateral mode: resonant where that order acts on "
                     r"the mode's shape", out)
    assert said, out
    assert [float(said[i]) for i in (1, 3, 4)] == pytest.approx([jeffcott] * 3, rel=5e-4)
    assert main(["--fmu-dir", str(fmu_dir), "run", steady, "--set", "motor.omega_set=90"] + common) == 0
    assert "note: motor.omega_set" not in capsys.readouterr().err
    torsional = str(SCENARIOS / "double_cardan_omar_torsional.toml")   # at its 2x crossing by design
    main(["--fmu-dir", str(fmu_dir), "run", torsional] + common)
    assert ("note: motor.omega_set = 71.6283 rad/s is 0.1% above the speed 71.57 rad/s at which the 2x order meets "
            "driveline's 143.14 rad/s torsional mode") in capsys.readouterr().err
    main(["--fmu-dir", str(fmu_dir), "run", torsional, "--set", "motor.omega_set=-71.6283"] + common)
    assert "note: motor.omega_set = -71.6283 rad/s is in magnitude 0.1% above" in capsys.readouterr().err
    main(["--fmu-dir", str(fmu_dir), "check", torsional, "--out", str(tmp_path), "--no-plot"])
    assert "note: motor.omega_set" not in capsys.readouterr().err


def test_modes_names_the_nearest_order_crossing_of_the_set_speed(capsys):
    """`ujfmu modes`: Omar's double Cardan at 684 rpm runs at the 2x crossing of its torsional mode (the paper's
    critical speed: sqrt(k/J) = 143.1 rad/s mean over the input angle, crossed by the 2x at 683.4 rpm), reported
    as the nearest crossing within 10%; --set moves the speed (in rpm) and the margin follows; a --set of a range
    or an unknown parameter is an error naming the option."""
    scenarios = Path(__file__).parent.parent / "scenarios"
    assert main(["modes", str(scenarios / "double_cardan_omar_torsional.toml")]) == 0
    out = capsys.readouterr().out
    assert "143.14 rad/s (22.781 Hz, torsional, 138.26-148.19 over the input angle, damping ratio" in out   # / 2 pi
    assert "2x at 71.5697 rad/s (683.44 rpm)" in out
    assert "nearest crossing is the 2x order's with driveline's 143.14 rad/s torsional mode, at 71.57 rad/s; the set " \
           "speed is " \
           "0.1% above it " \
           "(within 10%)" in out
    assert main(["modes", str(scenarios / "double_cardan_omar_torsional.toml"), "--set",
                 "motor.omega_set=500rpm"]) == 0
    out = capsys.readouterr().out
    # 500 rpm against the 2x crossings at 383.10 and 683.44 rpm: 30.5% above the first, 26.8% below the second
    assert "2x order's with driveline's 143.14 rad/s torsional mode, at 71.57 rad/s; the set speed is 26.8% below " \
           "it\n" in out
    assert "below it lies 1 crossing (a run-up from rest passes it): 2x with 80.237 rad/s (lateral) at 40.118 rad/s" \
        in out
    # a reverse set speed keeps its sign (a steering trial's -2000 rad/s had read 2000), its margin by magnitude
    assert main(["modes", str(scenarios / "double_cardan_omar_torsional.toml"), "--set",
                 "motor.omega_set=-500rpm"]) == 0
    assert "motor.omega_set = -52.3599 rad/s (-500 rpm): the nearest crossing is the 2x order's with driveline's " \
           "143.14 rad/s torsional mode, at 71.57 rad/s; the set speed's magnitude is 26.8% below it\n" \
           in capsys.readouterr().out
    assert main(["modes", str(scenarios / "double_cardan_omar_torsional.toml"), "--set",
                 "motor.omega_set=1:2:1"]) == 2
    assert "--set 'motor.omega_set=1:2:1': one value" in capsys.readouterr().err
    assert main(["modes", str(scenarios / "double_cardan_omar_torsional.toml"), "--set", "driveline.nope=1"]) == 2
    assert "--set 'driveline.nope=1'" in capsys.readouterr().err


def test_junit_says_which_comparison_a_signal_failed(tmp_path):
    """A signal within its reference band but outside its [reference.extrapolated] band (the step-halving
    estimate) had been listed as "outside tolerance of the reference": the failure names each comparison
    with its own signals."""
    from types import SimpleNamespace

    from ujfmu.scenario_run import write_junit

    def check(name, passed):
        return SimpleNamespace(name=name, passed=passed)
    result = SimpleNamespace(
        scenario=SimpleNamespace(name="heavy"), failed=True, checked=True, total_time=1.0, warnings=[],
        checks=[check("joint.tau_in", True), check("load.tau", False)],
        extrapolated_checks=[check("joint.tau_in", False), check("load.tau", True)],
        operating_checks=[], sampling_checks=[], steady_checks=[], order_checks=[], summary=lambda: "FAIL heavy")
    path = write_junit([result], tmp_path / "report.xml")
    message = ET.parse(path).getroot().find("testcase").find("failure").get("message")
    assert message == ("signal outside tolerance of the reference: load.tau; step-halving error estimate outside "
                       "[reference.extrapolated]: joint.tau_in")


def test_fmus_built_from_other_sources_are_refused_before_anything_runs(fmu_dir, tmp_path, capsys):
    """An FMU built before the model was edited (or by another checkout) had passed `ujfmu check`, which then
    checked old code: its build hash (in its runtime package's name) is compared with the one these sources give,
    and a mismatch is an error naming the FMU and the rebuild, for run, check and sweeps alike."""
    import shutil
    import zipfile

    from ujfmu.scenario import Scenario, ScenarioError
    from ujfmu.sweep import Sweep, SweepSettings, parse_axis
    stale = tmp_path / "fmus"
    shutil.copytree(fmu_dir, stale)
    with zipfile.ZipFile(fmu_dir / "Load.fmu") as old, zipfile.ZipFile(stale / "Load.fmu", "w") as new:
        for item in old.infolist():
            name = re.sub(r"(ujfmu_load_)[0-9a-f]{10}(_entry\.py)$", r"\g<1>0123456789\2", item.filename)
            new.writestr(name, old.read(item.filename))
    scenario = Scenario(SCENARIOS / "cardan_startup.toml")
    with pytest.raises(ScenarioError, match=r"Load.fmu was built from other sources than this ujfmu's .*its build "
                                            r"hash 0123456789"):
        scenario.check_fmus(stale)
    assert main(["--fmu-dir", str(stale), "check", str(SCENARIOS / "cardan_startup.toml"), "--no-plot",
                 "--out", str(tmp_path / "out")]) == 2
    assert "rebuild it" in capsys.readouterr().out
    with pytest.raises(ScenarioError, match="was built from other sources"):
        Sweep(scenario, [parse_axis("motor.omega_set=100,150", scenario)],
              SweepSettings.from_scenario(scenario, settle_time=0.1, running_speed="motor.omega"), out_dir=tmp_path,
              fmu_dir=stale)
    scenario.check_fmus(fmu_dir)   # the session's own build: accepted


def test_an_fmu_edited_after_its_build_is_refused(fmu_dir, tmp_path, capsys):
    """An FMU whose shipped code was edited by hand kept the name whose build hash the check compares, and passed
    `ujfmu check`: each copied source, its runtime package's docstring module, its entry point and the module
    pythonfmu loads, the pythonfmu files it ships and any added Python file are compared with what a build ships,
    and a difference is an error naming the member and the rebuild; line endings are no difference."""
    import zipfile

    from ujfmu.scenario import Scenario, ScenarioError
    scenario = Scenario(SCENARIOS / "cardan_startup.toml")
    with zipfile.ZipFile(fmu_dir / "Load.fmu") as archive:
        names = archive.namelist()
    model = next(n for n in names if n.endswith("/models/load/model.py"))
    entry = next(n for n in names if n.endswith("_entry.py"))
    package = entry.removesuffix("_entry.py") + "/__init__.py"
    added = "resources/other_entry.py"
    for member, edit, named in ((model, lambda b: b.replace(b"return", b"return 0.0 *", 1), model),
                                (entry, lambda b: b + b"import os\n", entry),
                                (package, lambda b: b + b"import os\n", package),
                                ("resources/pythonfmu/fmi2slave.py", lambda b: b + b"\n# edited\n",
                                 "resources/pythonfmu/fmi2slave.py"),
                                ("resources/slavemodule.txt", lambda b: b"other_entry", "resources/slavemodule.txt"),
                                (entry, lambda b: b.replace(b"\n", b"\r\n"), None),   # a Windows build's
                                ("modelDescription.xml", lambda b: b, added)):   # only a Python file added
        edited = tmp_path / f"{member.replace('/', '_')}_{named is None}" / "fmus"
        shutil.copytree(fmu_dir, edited)
        with zipfile.ZipFile(fmu_dir / "Load.fmu") as old, zipfile.ZipFile(edited / "Load.fmu", "w") as new:
            for item in old.infolist():
                data = old.read(item.filename)
                new.writestr(item, edit(data) if item.filename == member else data)
            if member in ("resources/slavemodule.txt", "modelDescription.xml"):
                new.writestr(added, "import os\n")
        if named is None:
            scenario.check_fmus(edited)   # line endings are no edit
            continue
        with pytest.raises(ScenarioError, match=f"Load.fmu was changed after its build: {re.escape(named)}"):
            scenario.check_fmus(edited)
        assert main(["--fmu-dir", str(edited), "check", str(SCENARIOS / "cardan_startup.toml"), "--no-plot",
                     "--out", str(tmp_path / "out")]) == 2
        assert "rebuild it" in capsys.readouterr().out
    scenario.check_fmus(fmu_dir)   # the build itself: accepted


def test_another_pythonfmu_makes_the_fmus_stale(monkeypatch):
    """An FMU carries pythonfmu's files: one built with another pythonfmu had been reported as edited by hand; its
    build hash covers pythonfmu's version, so it is stale, with the rebuild as remedy."""
    import pythonfmu

    from ujfmu import build
    before = build.source_hash("load")
    monkeypatch.setattr(pythonfmu, "__version__", pythonfmu.__version__ + ".post1")
    assert build.source_hash("load") != before


def test_an_edit_of_the_module_that_writes_the_model_description_makes_the_fmus_stale(tmp_path, monkeypatch):
    """The build hash covers the module that writes the modelDescription, not only the runtime sources: an FMU
    built before an edit of it (units, model structure) had been taken as fresh."""
    from ujfmu import build
    before = build.source_hash("load")
    edited = tmp_path / "build.py"
    edited.write_bytes(build.WRITERS[0].read_bytes() + b"\n# edited\n")
    monkeypatch.setattr(build, "WRITERS", (edited,))
    assert build.source_hash("load") != before


def test_a_command_run_in_another_checkout_says_whose_sources_it_uses(tmp_path, capsys, monkeypatch):
    """A CI job whose cached venv holds another checkout's editable install had built and checked that checkout's
    code, not the one in its directory, without a word: the command warns, naming both."""
    from ujfmu.build import PACKAGE_DIR
    from ujfmu.cli import other_checkout
    (tmp_path / "ujfmu").mkdir()
    (tmp_path / "ujfmu" / "__init__.py").write_text("")
    assert other_checkout(tmp_path) == tmp_path / "ujfmu" and other_checkout(PACKAGE_DIR.parent) is None
    monkeypatch.chdir(tmp_path)
    main(["modes", str(SCENARIOS / "twin_jeffcott_steady.toml")])
    err = capsys.readouterr().err
    assert f"this directory holds another ujfmu checkout ({tmp_path / 'ujfmu'})" in err and str(PACKAGE_DIR) in err


def test_the_gate_does_not_pass_on_what_it_did_not_check(fmu_dir, tmp_path, capsys):
    """Ways a CI gate had shown green: an all-pass JUnit report of an earlier run left in place by a run that never
    got to write its own (an empty folder, an interruption, a kill); two scenarios of one name sharing a case and a
    CSV; a reference that is the co-simulation's own output. Each now fails, naming why."""
    junit = tmp_path / "report.xml"
    junit.write_text('<testsuite tests="16" failures="0" errors="0"/>')
    (tmp_path / "empty").mkdir()
    assert main(["--fmu-dir", str(fmu_dir), "check", str(tmp_path / "empty"), "--junit", str(junit)]) == 2
    suite = ET.parse(junit).getroot()
    assert suite.get("errors") == "1"
    assert "refused: " in suite.find("testcase").find("error").get("message")
    assert "is a folder without scenario files" in suite.find("testcase").find("error").get("message")
    assert main(["--fmu-dir", str(fmu_dir), "check", str(SCENARIOS / "cardan_constant_speed.toml"), "--junit",
                 str(tmp_path)]) == 2
    assert f"--junit {tmp_path} is a folder" in capsys.readouterr().err
    (tmp_path / "other").mkdir()
    twin = tmp_path / "other" / "cardan_constant_speed.toml"
    twin.write_text((SCENARIOS / "cardan_constant_speed.toml").read_text())
    assert main(["--fmu-dir", str(fmu_dir), "check", str(SCENARIOS / "cardan_constant_speed.toml"), str(twin)]) == 2
    assert "scenarios of the same name would share their results and JUnit case" in capsys.readouterr().err
    # a run's own CSV, copied in as the reference of a scenario that names no generator (made by hand)
    out = tmp_path / "out"
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_constant_speed.toml"), "--no-plot",
                 "--out", str(out)]) == 0
    (tmp_path / "references").mkdir()
    (tmp_path / "references" / "selfref.csv").write_text((out / "cardan_constant_speed.csv").read_text())
    selfref = tmp_path / "selfref.toml"
    selfref.write_text((SCENARIOS / "cardan_constant_speed.toml").read_text().replace(
        "references/cardan_constant_speed.csv", "references/selfref.csv").replace('generator = "cardan_joint"', ""))
    capsys.readouterr()
    assert main(["--fmu-dir", str(fmu_dir), "check", str(selfref), "--no-plot", "--out", str(out)]) == 2
    assert "equals this run to the last digit in every compared signal" in capsys.readouterr().out
    # the same copy under the committed reference's provenance line (the setup it names is this one's): a trial's
    # gate had passed it, every signal at 0.000 of its band; no closed form or solve repeats a joint's outputs so
    provenance = (SCENARIOS / "references" / "cardan_constant_speed.csv").read_text().splitlines()[0]
    (tmp_path / "references" / "selfprov.csv").write_text(
        provenance + "\n" + (out / "cardan_constant_speed.csv").read_text())
    selfprov = tmp_path / "selfprov.toml"
    selfprov.write_text((SCENARIOS / "cardan_constant_speed.toml").read_text().replace(
        "references/cardan_constant_speed.csv", "references/selfprov.csv"))
    assert main(["--fmu-dir", str(fmu_dir), "check", str(selfprov), "--no-plot", "--out", str(out)]) == 0
    said = capsys.readouterr().out   # a closed form can repeat some signals exactly: said, and --strict fails it
    assert "(check --strict fails it: every compared signal equals the reference to the last digit" in said
    junit = tmp_path / "strict.xml"
    assert main(["--fmu-dir", str(fmu_dir), "check", str(selfprov), "--no-plot", "--out", str(out), "--strict",
                 "--junit", str(junit)]) == 1
    said = capsys.readouterr()
    assert "0 passed, 1 failed (--strict: 1 by a reference equal to the run to the last digit)" in said.out
    assert "--strict: 1 scenario(s) equal their reference to the last digit in every compared signal" in said.err
    assert ET.parse(junit).getroot().find("testcase").find("failure").get("message").startswith(
        "every compared signal equals the reference to the last digit")


def test_a_closed_form_that_repeats_the_run_exactly_is_said_not_refused(fmu_dir, tmp_path, capsys):
    """A closed form can repeat a run to the last digit: the input angle of an ideal speed source at 100 rad/s and a
    binary-exact step (2^-10 s) is omega t in both. A reference `ujfmu references` has just made for it is run
    (a review found it refused as a copy): its verdict line says that nothing independent was compared, and
    --strict fails it."""
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    start = text.index("record = [")
    end = text.index("\n", text.index("]", start))
    text = (text[:start] + 'record = ["motor.omega", "joint.phi_in"]' + text[end:]).replace(
        "step_size = 1e-3", "step_size = 0.0009765625").replace("omega_set = 62.83185307179586", "omega_set = 100.0")
    text = text.replace("references/cardan_constant_speed.csv", "references/exact.csv")
    kept = ('"motor.omega"', '"joint.phi_in"')
    text = "\n".join(line for line in text.splitlines()
                     if not (line.startswith('"') and "=" in line and not line.startswith(kept))) + "\n"
    (tmp_path / "references").mkdir()
    path = tmp_path / "exact.toml"
    path.write_text(text)
    assert main(["references", str(path), "-q"]) == 0
    common = ["--fmu-dir", str(fmu_dir), "check", str(path), "--no-plot", "--out", str(tmp_path / "out")]
    assert main(common) == 0
    assert "(check --strict fails it: every compared signal equals the reference to the last digit" in \
        capsys.readouterr().out
    assert main(common + ["--strict"]) == 1


def test_a_check_refused_after_its_command_line_says_why_in_its_report(fmu_dir, tmp_path):
    """Refusals after the command line was read (two scenarios of one name, FMUs not built) had left the JUnit
    placeholder 'did not finish', not the reason: the report quotes the refusal."""
    junit = tmp_path / "report.xml"
    twice = str(SCENARIOS / "cardan_constant_speed.toml")
    assert main(["--fmu-dir", str(fmu_dir), "check", twice, twice, "--junit", str(junit)]) == 2
    message = ET.parse(junit).getroot().find("testcase").find("error").get("message")
    assert message.startswith("refused: scenarios of the same name would share")
    assert main(["--fmu-dir", str(tmp_path / "none"), "check", twice, "--junit", str(junit), "--no-plot",
                 "--out", str(tmp_path / "out")]) == 2
    assert "not found" in ET.parse(junit).getroot().find("testcase").find("error").get("message")


@pytest.mark.parametrize("argv, kind", [
    (["check", "--junit", "{junit}", "--bogus"], ""),
    (["check", "--fmi", "3", "--junit={junit}", "--output-interval", "0"], ".fmi3"),
    (["check", "--model-exchange", "--junit", "{junit}", "--fmi", "3", "--fmi", "4"], ".model_exchange"),
])
def test_a_refused_command_line_leaves_no_earlier_report_standing(tmp_path, capsys, argv, kind):
    """An argparse usage error (status 2) had left the JUnit report of an earlier run in place, all passed: the
    report now holds one error case that quotes the refusal, in the suite of the run's kind."""
    junit = tmp_path / "report.xml"
    junit.write_text('<testsuite tests="16" failures="0" errors="0"/>')
    with pytest.raises(SystemExit) as exc:
        main([a.replace("{junit}", str(junit)) for a in argv])
    assert exc.value.code == 2
    refusal = capsys.readouterr().err.strip().splitlines()[-1].split("error: ", 1)[1]
    suite = ET.parse(junit).getroot()
    (case,) = suite.findall("testcase")
    assert suite.get("errors") == "1" and case.get("classname") == "ujfmu.scenarios" + kind
    assert case.find("error").get("message").startswith(f"the command line was refused: {refusal}")


@pytest.mark.parametrize("edit, message", [
    (lambda rows: rows[:2] + [rows[2].replace(rows[2].split(",")[1], "inf", 1)] + rows[3:], "has inf in column"),
    (lambda rows: rows[:2] + [rows[3], rows[2]] + rows[4:], "has times that do not increase (data row 2"),
    (lambda rows: rows[:2], "a header but no data rows"),
    (lambda rows: [r for r in rows if not r.startswith("#")], "has no provenance line"),
])
def test_a_reference_that_checks_nothing_is_refused(tmp_path, edit, message):
    """A reference with an infinite value (its band became infinite: any error passed), with times out of order
    (fmpy's validate_result never returned), without data, or without the provenance line of the generator its
    scenario names (a file made otherwise): refused before anything runs, naming the file and the row."""
    from ujfmu.scenario import Scenario, ScenarioError
    rows = (SCENARIOS / "references" / "cardan_constant_speed.csv").read_text().splitlines()
    (tmp_path / "references").mkdir()
    (tmp_path / "references" / "cardan_constant_speed.csv").write_text("\n".join(edit(rows)) + "\n")
    (tmp_path / "cardan_constant_speed.toml").write_text((SCENARIOS / "cardan_constant_speed.toml").read_text())
    with pytest.raises(ScenarioError, match=re.escape(message)):
        Scenario(tmp_path / "cardan_constant_speed.toml").reference()


def test_a_band_of_half_the_range_or_more_is_refused(tmp_path):
    """rel_range = 1e9 had passed a model 238x outside its real band, and 0.99 passed a fresh-eyes trial's gate: a
    band of half the signal's range or more passes a flat line through its middle and checks nothing of its course,
    and the scenario file is refused, naming the signal; just under half is taken."""
    from ujfmu.scenario import Scenario, ScenarioError
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    wide = tmp_path / "wide.toml"
    for band, refused in (("1e9", r"1e\+09"), ("0.99", "0.99"), ("0.5", "0.5")):
        wide.write_text(re.sub(r'("joint\.tau_in" = )\{[^}]*\}', rf'\1{{ rel_range = {band} }}', text))
        assert wide.read_text() != text
        with pytest.raises(ScenarioError, match=rf"reference.tolerance.joint.tau_in: rel_range = {refused} allows "
                                                "an error of .* a flat line through the middle"):
            Scenario(wide)
    wide.write_text(re.sub(r'("joint\.tau_in" = )\{[^}]*\}', r'\1{ rel_range = 0.49 }', text))
    assert Scenario(wide).tolerances["joint.tau_in"].rel_range == 0.49


def test_check_names_the_bands_that_check_the_level_only(fmu_dir, tmp_path, capsys):
    """An abs band 250x a torque's range (a fresh-eyes trial's) passed `ujfmu check --strict` without a word: the
    signal's line and the command's summary say that the band checks its level only."""
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    loose = tmp_path / "cardan_constant_speed.toml"
    loose.write_text(re.sub(r'("joint\.tau_in" = )\{[^}]*\}', r'\1{ abs = 1000.0 }', text))
    (tmp_path / "references").mkdir()
    shutil.copy(SCENARIOS / "references" / "cardan_constant_speed.csv", tmp_path / "references")
    assert main(["check", str(loose), "--no-plot", "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)]) == 0
    out, err = capsys.readouterr()
    assert "joint.tau_in" in out and "checks the level only: the band, 1e+03 N.m, is at least half" in out
    assert "1 band(s) check the level only, not the course (at least half the reference's range" in err
    assert "cardan_constant_speed: joint.tau_in" in err
    # a gate under --strict fails it, and so does its JUnit case, naming the band (it had passed with status 0)
    junit = tmp_path / "strict.xml"
    assert main(["check", str(loose), "--strict", "--junit", str(junit), "--no-plot", "--out", str(tmp_path / "out"),
                 "--fmu-dir", str(fmu_dir)]) == 1
    out, err = capsys.readouterr()
    assert ("--strict: 1 scenario(s) compare through bands that check the level only, not the course: "
            "cardan_constant_speed: joint.tau_in (") in err
    assert "0 passed, 1 failed (--strict: 1 by bands that check the level only), 0 not checked" in out
    suite = ET.parse(junit).getroot()
    assert suite.get("failures") == "1"
    assert suite.find("testcase").find("failure").get("message").endswith("(--strict): joint.tau_in")
    # the bundled band of the same scenario passes --strict
    assert main(["check", str(SCENARIOS / "cardan_constant_speed.toml"), "--strict", "--junit", str(junit),
                 "--no-plot", "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)]) == 0
    assert ET.parse(junit).getroot().get("failures") == "0"


def test_a_band_wider_than_the_ripple_is_level_only_without_a_steady_window(fmu_dir, tmp_path, capsys):
    """double_cardan_omar_torsional (no steady_from) with its shaft torque's band at 20% of the range, against a
    reference whose torque holds its mean from 1 s on, the 2x ripple gone (a CI trial's): it had passed --strict.
    Without a steady window the run's last quarter is looked at: a flat line there passes the band, so the band
    checks the level only and --strict fails it; the file's own bands pass."""
    from ujfmu.references import read_reference, write_reference
    text = (SCENARIOS / "double_cardan_omar_torsional.toml").read_text()
    assert "steady_from" not in text
    path = tmp_path / "double_cardan_omar_torsional.toml"
    path.write_text(re.sub(r'("driveline\.shaft_torque" = )\{[^}]*\}', r'\1{ rel_range = 0.2 }', text))
    (tmp_path / "references").mkdir()
    reference, provenance = read_reference(SCENARIOS / "references" / "double_cardan_omar_torsional.csv")
    late = reference["time"] >= 1.0
    reference["driveline.shaft_torque"][late] = reference["driveline.shaft_torque"][late].mean()
    write_reference(tmp_path / "references" / "double_cardan_omar_torsional.csv", reference, provenance)
    assert main(["check", str(path), "--strict", "--no-plot", "--out", str(tmp_path / "out"), "--fmu-dir",
                 str(fmu_dir)]) == 1
    out, err = capsys.readouterr()
    assert "checks the level only over the run's last 25% from t = 2.25 s" in out
    assert "double_cardan_omar_torsional: driveline.shaft_torque" in err
    assert main(["check", str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--strict", "--no-plot", "--out",
                 str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)]) == 0
    # a run still settling from its run-up in its last quarter (its motor 2% off its set speed there) is not looked
    # at: its trend is no vibration (a 2% band on the motor's speed had been marked)
    assert main(["check", str(SCENARIOS / "battery" / "battery_06.toml"), "--strict", "--no-plot", "--out",
                 str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)]) == 0


def test_a_gate_that_compares_only_the_drive_and_the_load_fails_strict(fmu_dir, tmp_path, capsys):
    """cardan_constant_speed comparing only motor.omega (its ideal source's own set speed) and load.tau (a
    constant), the joint's signals moved to not_compared (a CI trial's): it had passed `check --strict`, no
    output of the joint compared. Its verdict line says --strict fails it, and --strict does, naming the joint."""
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text()
    blind = re.sub(r'(?m)^"(joint\.\w+|motor\.tau_motor)" = \{[^}]*\}$', "", text).replace(
        "[reference.tolerance]", '[reference.not_compared]\n' + "".join(
            f'"{n}" = "covered elsewhere"\n' for n in ("joint.omega_out", "joint.phi_out", "joint.phi_in",
                                                        "joint.tau_in", "joint.M_x", "joint.M_y", "joint.M_z",
                                                        "motor.tau_motor")) + '\n[reference.tolerance]')
    path = tmp_path / "cardan_constant_speed.toml"
    path.write_text(blind)
    (tmp_path / "references").mkdir()
    shutil.copy(SCENARIOS / "references" / "cardan_constant_speed.csv", tmp_path / "references")
    assert main(["check", str(path), "--no-plot", "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)]) == 0
    out, err = capsys.readouterr()
    assert ("PASS cardan_constant_speed" in out and "(check --strict fails it: no output of its machines (joint) "
            "compared, only its drive's and load's)" in out)
    assert "it needs scipy" not in err   # scipy is here: fmpy's band was left out for want of a varying signal
    junit = tmp_path / "strict.xml"
    assert main(["check", str(path), "--strict", "--junit", str(junit), "--no-plot", "--out", str(tmp_path / "out"),
                 "--fmu-dir", str(fmu_dir)]) == 1
    out, err = capsys.readouterr()
    assert "0 passed, 1 failed (--strict: 1 by comparing no output of its machines), 0 not checked" in out
    assert "--strict: 1 scenario(s) compare no output of the machines they model" in err
    assert "cardan_constant_speed: joint (give a band" in err
    case = ET.parse(junit).getroot().find("testcase")
    assert case.find("failure").get("message") == ("compares no output of its machines, joint, only its drive's and "
                                                    "load's (--strict)")


def test_a_reference_sampled_below_the_joints_order_is_named_not_blamed_on_the_model(fmu_dir, tmp_path, capsys):
    """Bench data logged at 20 Hz against a joint whose 2x order is at 20 Hz (600 rpm) was interpolated between its
    samples and failed as "the model or its parameters likely differ": the reference's own sampling is checked
    against the order, as the record's is, and fails naming the file's step and the rate that resolves it; the same
    data every 5 ms passes it, and so does a file compared at the instants it shares with the run."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import run_scenario
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text().replace('generator = "cardan_joint"\n', "")
    lines = (SCENARIOS / "references" / "cardan_constant_speed.csv").read_text().splitlines()
    (tmp_path / "references").mkdir()
    for every, passes, late in ((50, False, 0.0), (5, True, 5e-4), (5, None, 0.0)):
        name = f"bench_{every}ms_{late}"   # a logger's file (no provenance line), its clock late by `late`
        rows = [line.split(",", 1) for line in lines[2::every]]
        (tmp_path / "references" / f"{name}.csv").write_text(
            "\n".join([lines[1]] + [f"{float(t) + late!r},{rest}" for t, rest in rows]) + "\n")
        path = tmp_path / f"{name}.toml"
        path.write_text(text.replace("references/cardan_constant_speed.csv", f"references/{name}.csv")
                        .replace("stop_time = 0.5", "stop_time = 0.49"))
        result = run_scenario(Scenario(path), fmu_dir, out_dir=None, plot=False)
        if passes is None:   # 99 instants shared with the run: compared there, not interpolated
            assert not [c for c in result.sampling_checks if "reference file" in str(c)]
            continue
        if every == 50:   # a file of signals flat within their bands (a load's constant torque) is not judged
            flat = Scenario(path)
            flat.tolerances = {name: flat.tolerances[name] for name in ("joint.M_z", "load.tau")}
            assert not [c for c in run_scenario(flat, fmu_dir, out_dir=None, plot=False).sampling_checks
                        if "reference file" in str(c)]
        [check] = [c for c in result.sampling_checks if "reference file" in str(c)]
        assert check.passed is passes and check.interval == pytest.approx(every * 1e-3)
        if not passes:
            assert str(check).startswith("FAIL sampling of the reference file against joint's 2x order (up to 20 Hz")
            assert "give a reference sampled at least every 0.005 s (a logger at 200 Hz or more)" in str(check)
            assert result.failed


def test_bench_data_in_rpm_or_milliseconds_is_named_as_such(fmu_dir, tmp_path):
    """Bench data with speeds in rpm failed at 1e3 of allowed, blamed on the model or the noise, and a file with
    times in milliseconds on its span only: the failing line says the file is 9.55 times the run (rpm where rad/s is
    meant), the span error that its times look like milliseconds; a torque of the other sign is named too."""
    import math

    from ujfmu.scenario import Scenario, ScenarioError
    from ujfmu.scenario_run import run_scenario
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text().replace('generator = "cardan_joint"\n', "")
    lines = (SCENARIOS / "references" / "cardan_constant_speed.csv").read_text().splitlines()
    head = lines[1].split(",")
    speed, torque = head.index('"joint.omega_out"'), head.index('"joint.tau_in"')
    rows = [[float(v) for v in line.split(",")] for line in lines[2:]]
    (tmp_path / "references").mkdir()

    def bench(name, edit):
        (tmp_path / "references" / f"{name}.csv").write_text(
            "\n".join([lines[1]] + [",".join(repr(v) for v in edit(list(row))) for row in rows]) + "\n")
        path = tmp_path / f"{name}.toml"
        path.write_text(text.replace("references/cardan_constant_speed.csv", f"references/{name}.csv"))
        return Scenario(path)

    def in_rpm(row):
        row[speed] *= 30.0 / math.pi
        row[torque] = -row[torque]
        return row
    checks = {c.name: c for c in run_scenario(bench("rpm", in_rpm), fmu_dir, out_dir=None, plot=False).checks}
    assert not checks["joint.omega_out"].passed and "as if the file held rpm where rad/s is meant" in str(
        checks["joint.omega_out"]) and "the reference is 9.549 times the run here" in str(checks["joint.omega_out"])
    assert "as if the file held the opposite sign convention" in str(checks["joint.tau_in"])
    assert checks["joint.M_x"].passed and not checks["joint.M_x"].note
    # a zero-mean 2x logged a quarter revolution late reads as the run's negative: no sign convention is blamed
    moment = head.index('"joint.M_x"')
    late = [row[moment] for row in rows[-25:] + rows[:-25]]

    def quarter_late(row, values=iter(late)):
        row[moment] = next(values)
        return row
    checks = {c.name: c for c in run_scenario(bench("late", quarter_late), fmu_dir, out_dir=None, plot=False).checks}
    assert not checks["joint.M_x"].passed and "sign convention" not in str(checks["joint.M_x"])

    def in_ms(row):
        row[0] *= 1000.0
        return row
    checks = run_scenario(bench("ms", in_ms), fmu_dir, out_dir=None, plot=False).checks
    assert all(c.passed or "the reference file's times look like milliseconds (in seconds they would run from 0 to "
               "0.5 s)" in str(c) for c in checks) and not all(c.passed for c in checks)

    def late_in_ms(row):   # a logger that starts 0.3 ms late: short of the experiment's start
        row[0] = 1000.0 * row[0] + 0.3
        return row
    with pytest.raises(ScenarioError, match=r"covers t = 0.3 to 500.3 s, .*its times look like milliseconds \(in "
                                            r"seconds they would run from 0.0003 to 0.5003 s\)"):
        run_scenario(bench("late_ms", late_in_ms), fmu_dir, out_dir=None, plot=False)


def test_checks_warnings_name_their_scenario_and_reach_its_junit_case(fmu_dir, tmp_path, capsys):
    """A parameter in degrees that is valid in radians (a trial's) was said only on stderr, without the scenario's
    name, and not at all in the JUnit report a CI dashboard shows: `check` names the scenario on each warning line,
    and the case's system-out carries the warnings after the summary."""
    text = (SCENARIOS / "cardan_constant_speed.toml").read_text().split("[reference]")[0]   # unchecked
    steep = tmp_path / "steep.toml"
    steep.write_text(text.replace('[components.joint]\nfmu = "CardanJoint"\nparameters = {}',
                                  '[components.joint]\nfmu = "CardanJoint"\nparameters = { bend_angle = 1.0 }'))
    junit = tmp_path / "report.xml"
    main(["check", str(steep), "--junit", str(junit), "--no-plot", "--out", str(tmp_path / "out"), "--fmu-dir",
          str(fmu_dir)])
    err = capsys.readouterr().err
    assert "  warning steep: joint: bend_angle = 1 rad is 57.3 deg" in err
    said = ET.parse(junit).getroot().find("testcase").find("system-out").text
    assert "\n  warning joint: bend_angle = 1 rad is 57.3 deg" in said


def test_a_truncated_fmu_and_a_subfolder_left_out_are_named(fmu_dir, tmp_path, capsys):
    """A truncated or damaged FMU had failed with "File is not a zip file" or "Bad CRC-32 for file ...", naming
    neither file nor remedy; scenarios in a
    subfolder of a folder given to `check` are left out (a folder stands for its own *.toml), which a note says."""
    import shutil

    from ujfmu.scenario import Scenario, ScenarioError
    cut = tmp_path / "fmus"
    shutil.copytree(fmu_dir, cut)
    (cut / "Load.fmu").write_bytes((fmu_dir / "Load.fmu").read_bytes()[:1000])
    with pytest.raises(ScenarioError, match=r"Load.fmu is not an FMU \(not a zip archive: truncated"):
        Scenario(SCENARIOS / "cardan_startup.toml").check_fmus(cut)
    # a damaged one, its directory whole (a byte changed in a member: a bad CRC, or a deflate stream that breaks),
    # is named with the remedy too (it had read "Bad CRC-32 for file 'binaries/win64/Load.dll'", no path, no remedy)
    data = (fmu_dir / "Load.fmu").read_bytes()
    for offset in (len(data) // 2, 5000):
        damaged = bytearray(data)
        damaged[offset] ^= 0xFF
        (cut / "Load.fmu").write_bytes(bytes(damaged))
        assert main(["--fmu-dir", str(cut), "check", str(SCENARIOS / "cardan_startup.toml"), "--no-plot", "--out",
                     str(tmp_path / "o")]) == 2
        out = capsys.readouterr().out   # its ERROR line
        assert f"{(cut / 'Load.fmu').resolve()} is damaged (" in out and f"rebuild it (run `ujfmu build --fmu-dir " \
            f"{cut.resolve()}` first)" in out, out
    (tmp_path / "gate" / "team").mkdir(parents=True)
    shutil.copy(SCENARIOS / "cardan_constant_speed.toml", tmp_path / "gate" / "team" / "mine.toml")
    (tmp_path / "gate" / "mine.toml").write_text("not toml [")
    junit = tmp_path / "gate.xml"
    main(["--fmu-dir", str(fmu_dir), "check", str(tmp_path / "gate"), "--no-plot", "--out", str(tmp_path / "o"),
          "--junit", str(junit)])
    assert f"not included, a folder standing for its own *.toml only: {tmp_path / 'gate' / 'team'} (1 scenario " \
           "file)" in capsys.readouterr().err
    # and in the report, a skipped case (a CI trial's forgotten folder had left no trace there)
    (case,) = [c for c in ET.parse(junit).getroot().iter("testcase") if "folder not included" in c.get("name")]
    assert case.find("skipped").get("message").startswith(f"skipped: not included: {tmp_path / 'gate' / 'team'} "
                                                          "holds 1 scenario file this run did not check")


def test_an_unexpected_exception_exits_3_not_as_a_failed_check(capsys):
    """A bug's exception had ended the command with Python's status 1, a FAIL's: it prints its traceback and
    exits with 3."""
    from ujfmu.cli import INTERNAL_ERROR, run_and_exit

    def broken():
        raise RuntimeError("a bug")
    with pytest.raises(SystemExit) as info, pytest.MonkeyPatch.context() as mp:
        mp.setattr("os._exit", lambda code: (_ for _ in ()).throw(SystemExit(code)))
        mp.setattr("atexit._run_exitfuncs", lambda: None)   # this process's exit handlers stay for its exit
        run_and_exit(broken)
    assert info.value.code == INTERNAL_ERROR == 3
    err = capsys.readouterr().err
    assert "RuntimeError: a bug" in err and "internal error" in err


def test_fmus_not_found_from_another_directory_names_the_checkouts_own(tmp_path, capsys, monkeypatch):
    """Run from a folder without fmus/, the error names the checkout's own FMUs and the --fmu-dir that reaches them
    (following "run `ujfmu build` first" there had built a second set in the wrong folder: a first-day trial)."""
    from ujfmu import build
    checkout = tmp_path / "checkout"
    (checkout / "fmus").mkdir(parents=True)
    (checkout / "fmus" / "Motor.fmu").write_bytes(b"")
    monkeypatch.setattr(build, "REPO_DIR", checkout)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert main(["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert "fmus/Motor.fmu not found" in err and f"this checkout's are in {checkout / 'fmus'}: --fmu-dir " in err


def test_a_gate_in_a_checkout_whose_code_differs_from_the_installed_one_refuses(tmp_path, capsys):
    """A CI job whose ujfmu was installed from other sources than the checkout its scenarios are in (a cached venv,
    a wheel built before the change) had built and checked the installed code and passed, even with the checkout's
    model edited: `check` and `run` refuse (status 2), naming the checkout and how to install it; a checkout with
    the same sources (a non-editable install of it) is fine."""
    import shutil

    from ujfmu.build import PACKAGE_DIR
    from ujfmu.cli import foreign_checkout
    checkout = tmp_path / "checkout"
    shutil.copytree(PACKAGE_DIR, checkout / "ujfmu", ignore=shutil.ignore_patterns("__pycache__"))
    (checkout / "pyproject.toml").write_text("[project]\nname = 'ujfmu'\n")
    (checkout / "scenarios").mkdir()
    scenario = checkout / "scenarios" / "cardan_constant_speed.toml"
    shutil.copy(SCENARIOS / "cardan_constant_speed.toml", scenario)
    assert foreign_checkout([scenario]) is None                    # the same sources
    model = checkout / "ujfmu" / "models" / "cardan_joint" / "model.py"
    model.write_text(model.read_text() + "\n# edited\n")
    assert foreign_checkout([scenario]) == checkout / "ujfmu"
    junit = tmp_path / "report.xml"
    for command in (["check", str(scenario), "--junit", str(junit)], ["run", str(scenario)]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert f"{checkout} is a ujfmu checkout whose sources differ" in err and f"pip install -e {checkout}" in err
        assert "move them out of it" in err
    assert "refused: " in junit.read_text() and "sources differ" in junit.read_text()


def test_run_set_changes_a_parameter_for_that_run_only(fmu_dir, tmp_path, capsys):
    """`ujfmu run --set` (as `modes --set`): Brutti's rigid driveline, whose in-phase equal joints keep the output
    speed constant, with its second yoke 90 deg out of phase swings at 2x, in a run named <scenario>_changed whose
    title says what changed, written beside the original's CSV, not compared with the file's reference; a range is
    refused."""
    scenario = Path(__file__).parent.parent / "scenarios" / "double_cardan_brutti_rigid.toml"
    code = main(["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--out", str(tmp_path), "--set",
                 "driveline.yoke_phase=90deg", "--no-check-step"])
    out = capsys.readouterr().out
    assert code == 0 and out.startswith("NOT CHECKED double_cardan_brutti_rigid_changed")
    assert "changed: driveline.yoke_phase = 1.5708 rad (90 deg)" in out and "--check-step on the same command" in out
    changed = np.genfromtxt(tmp_path / "double_cardan_brutti_rigid_changed.csv", delimiter=",", names=True)
    assert main(["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    original = np.genfromtxt(tmp_path / "double_cardan_brutti_rigid.csv", delimiter=",", names=True)
    w_in = original["motoromega"][-1]
    assert np.ptp(original["drivelineomega_out"][100:]) < 1e-9 * w_in < np.ptp(changed["drivelineomega_out"][100:])
    assert main(["--fmu-dir", str(fmu_dir), "run", str(scenario), "--set", "motor.omega_set=1:2:1"]) == 2
    assert "--set 'motor.omega_set=1:2:1': one value" in capsys.readouterr().err
    # a Boolean parameter takes true or false (it had taken only numbers, which a Boolean refuses)
    from ujfmu.cli import _with_set
    from ujfmu.scenario import Scenario, ScenarioError
    for text, value in (("true", True), ("False", False), ("1", True)):
        changed = _with_set(Scenario(scenario), [f"driveline.rigid_intermediate_shaft={text}"])
        assert changed.start_values("driveline")["rigid_intermediate_shaft"] is value
    # one parameter's problems as themselves (not "problems with the sweep's axes"); a parameter set twice refused
    for texts, words in ((["motor.omega_set=1e9"], "--set 'motor.omega_set=1e9': motor.omega_set = 1000000000.0 is outside"),
                         (["motor.omega_set=x"], "expected a number, optionally followed by rpm"),
                         (["load.T0=1", "load.T0=2"], "load.T0 is set by an earlier --set too")):
        with pytest.raises(ScenarioError) as info:
            _with_set(Scenario(scenario), texts)
        assert words in str(info.value) and "sweep's axes" not in str(info.value), str(info.value)
    # a whole number written as a float, as an optimizer hands it over, for an Integer parameter
    assert Scenario(scenario).with_parameters({"motor.profile": 0.0}).start_values("motor")["profile"] == 0


def test_run_name_keeps_variants_apart_and_their_columns_say_the_values_set(fmu_dir, tmp_path, capsys):
    """`ujfmu run --set ... --name`: two joint angles run side by side keep their own files (without --name both
    were <scenario>_changed, the second over the first), each table's columns file names the scenario file and the
    values set, and each table holds its own angle's physics: the output-to-input speed ratio swings between
    cos b and 1 / cos b (an ideal joint). A name that is a path is refused."""
    scenario = SCENARIOS / "cardan_constant_speed.toml"
    base = ["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--no-check-step", "--out", str(tmp_path),
            "--set", "joint.error_angle_beta=0", "--set", "joint.error_angle_gamma=0"]
    for deg in (10, 30):
        assert main(base + ["--set", f"joint.bend_angle={deg}deg", "--name", f"bend{deg}"]) == 0
    capsys.readouterr()
    for deg in (10, 30):
        table = np.genfromtxt(tmp_path / f"bend{deg}.csv", delimiter=",", names=True)
        ratio = table["jointomega_out"][50:] / table["motoromega"][50:]
        b = math.radians(deg)
        assert (ratio.min(), ratio.max()) == pytest.approx((math.cos(b), 1.0 / math.cos(b)), rel=1e-4)
        with open(tmp_path / f"bend{deg}.columns.csv") as f:
            time_row = next(line for line in f if line.startswith("time,"))
        assert "scenario file cardan_constant_speed.toml" in time_row and f"joint.bend_angle = " in time_row
        assert f"({deg} deg)" in time_row and "joint.error_angle_beta = 0 rad" in time_row, time_row
    assert not (tmp_path / "cardan_constant_speed_changed.csv").exists()
    for name in ("../elsewhere", "a:b", "x.", " "):   # a path, or a name some systems cannot store
        assert main(base + ["--name", name]) == 2
        assert f"--name {name!r} must be a plain file name" in capsys.readouterr().err


def test_run_stop_time_runs_a_changed_copy_and_says_why_it_is_not_compared(fmu_dir, tmp_path, capsys):
    """`ujfmu run --stop-time 0.5` runs the scenario to 0.5 s as a changed copy (it had taken Python or a copied
    file): its results end there, its title says so, and the summary says the file's reference, made for the file's
    span, is left out (it had said the scenario had none). A time that is not a whole number of steps is refused."""
    scenario = SCENARIOS / "twin_jeffcott_runup.toml"
    base = ["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--out", str(tmp_path)]
    assert main(base + ["--stop-time", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "(stop_time = 0.5 s)" in out and "not compared with the scenario file's [reference]" in out
    with open(tmp_path / "twin_jeffcott_runup_changed.csv") as f:
        times = [float(line.split(",")[0]) for line in f if line[0].isdigit()]
    assert times[-1] == pytest.approx(0.5) and len(times) == 501
    assert main(base + ["--stop-time", "0.5005"]) == 2
    assert "whole number (at least 1) of communication steps" in capsys.readouterr().err
    # a time of whole steps of the --step given, not of the file's (a review's 0.5005 s at 0.5 ms had been refused)
    assert main(base + ["--stop-time", "0.5005", "--step", "5e-4", "--no-check-step"]) == 0
    assert (tmp_path / "twin_jeffcott_runup_changed_step0.0005.csv").is_file()
    steady = ["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "twin_jeffcott_steady.toml"), "--no-plot", "--out",
              str(tmp_path), "--stop-time", "0.5"]   # its steady window starts at 16 s: left out, and said
    assert main(steady) == 0 and "(no steady window: the file's steady_from = 16 s is after it)" in \
        capsys.readouterr().out
    from ujfmu.scenario import Scenario, ScenarioError
    short = Scenario(SCENARIOS / "twin_jeffcott_steady.toml")
    short.stop_time = 0.5   # from Python: an error naming both times (it had been an internal error)
    with pytest.raises(ScenarioError, match=r"steady_from = 16.0 s is not before stop_time = 0.5 s.*with_stop_time"):
        short.check_experiment()
    changed = Scenario(SCENARIOS / "twin_jeffcott_steady.toml").with_parameters({"motor.omega_set": 50.0})
    with pytest.raises(ScenarioError, match="whole number"):   # a copy of a copy: the copy itself left as it was
        changed.with_stop_time(0.5004)
    assert (changed.stop_time, changed.name) == (17.0, "twin_jeffcott_steady_changed") and "0.5004" not in changed.title
    assert changed.with_stop_time(0.5).name == "twin_jeffcott_steady_changed" and changed.stop_time == 17.0
    for before in (0.0, -1.0):   # the option named, not the file's experiment
        with pytest.raises(ScenarioError, match=r"with_stop_time\(-?[01].0\) \(ujfmu run --stop-time\): experiment "
                                                r"step_size = 0.001 s must be > 0 and stop_time = -?[01].0 s after "
                                                r"start_time = 0.0 s"):
            changed.with_stop_time(before)
    with pytest.raises(ScenarioError, match=r"with_stop_time\(0.5004\) \(ujfmu run --stop-time\): \[experiment\]"):
        changed.with_stop_time(0.5004)
    copy = Scenario(SCENARIOS / "twin_jeffcott_steady.toml").with_stop_time(0.5)   # as --stop-time, from Python
    assert (copy.stop_time, copy.steady_from, copy.name, copy.reference_file) == (0.5, 0.0,
                                                                                   "twin_jeffcott_steady_changed", None)
    assert copy.title.endswith("(no steady window: the file's steady_from = 16 s is after it)")


def test_a_parameter_named_in_the_wrong_case_is_suggested(capsys):
    """`--set rotor.k2x=5e4`: the parameter is K2X, which the error suggests (it had listed every name)."""
    assert main(["modes", str(SCENARIOS / "twin_jeffcott_steady.toml"), "--set", "rotor.k2x=5e4"]) == 2
    assert "(did you mean rotor.K2X?)" in capsys.readouterr().err


def test_run_coupling_and_step_say_the_bands_are_the_files(fmu_dir, tmp_path, capsys):
    """`--coupling explicit` runs the scenario with the other scheme against the same reference, its results beside
    the file's scheme's (the explicit scheme is first order: its result differs from the implicit one's); a run at another step or scheme that fails a band
    says the bands were chosen for the file's step and scheme (Omar's driveline at 5 ms fails one at 1.2x its band,
    0.0001% of the range)."""
    import numpy as np
    base = ["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_startup.toml"), "--no-plot", "-q"]
    assert main(base + ["--out", str(tmp_path / "implicit")]) == 0
    assert main(base + ["--coupling", "explicit", "--out", str(tmp_path / "explicit")]) == 0
    assert "(coupling = explicit)" in capsys.readouterr().out   # the run says it is not the file's scheme
    implicit, explicit = (np.genfromtxt(tmp_path / kind / name, delimiter=",", names=True, comments="#")
                          for kind, name in (("implicit", "cardan_startup.csv"),
                                             ("explicit", "cardan_startup_explicit.csv")))
    assert np.max(np.abs(implicit["motoromega"] - explicit["motoromega"])) > 1e-4
    capsys.readouterr()
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--step",
                 "5e-3", "--no-plot", "--out", str(tmp_path)]) == 1
    assert ("and for its own step and coupling (0.001 s, implicit): at 0.005 s, implicit, a FAIL holds this run to "
            "the file's accuracy") in capsys.readouterr().out


def test_a_runs_table_has_its_units_beside_it(fmu_dir, tmp_path):
    """`ujfmu run` writes `<scenario>.columns.csv` beside its CSV: every column of the table with its declared unit
    and its FMU's description, the time with the communication step and coupling it ran with (a student's table had
    carried neither)."""
    import csv as csv_module
    assert main(["--fmu-dir", str(fmu_dir), "run", str(SCENARIOS / "cardan_constant_speed.toml"), "--no-plot", "-q",
                 "--step", "5e-4", "--out", str(tmp_path)]) in (0, 1)
    assert not (tmp_path / "cardan_constant_speed.csv").exists()   # a trial's FAIL at --step had replaced a PASS's
    with open(tmp_path / "cardan_constant_speed_step0.0005.csv") as f:   # beside the file's step's results
        header = next(line for line in f if not line.startswith("#")).strip().replace('"', "").split(",")
    with open(tmp_path / "cardan_constant_speed_step0.0005.columns.csv") as f:
        rows = {r["column"]: r for r in csv_module.DictReader(f)}
    assert list(rows) == header
    assert rows["joint.tau_in"]["unit"] == "N.m" and rows["joint.omega_out"]["unit"] == "rad/s"
    assert "communication step 0.0005 s, implicit coupling" in rows["time"]["meaning"]
    assert "(joint, CardanJoint)" in rows["joint.tau_in"]["meaning"]


def test_a_missing_fmu_folders_hint_fits_what_was_given(tmp_path):
    """The remedy for FMUs not found follows the folder given (a scripting trial's): a folder named fmi3 is built by
    `ujfmu build --fmi 3` (the plain build's hint would put FMI 2.0 FMUs there), and an FMU file given as the folder
    is told to be one FMU, with its folder."""
    from ujfmu.build import build_hint
    assert build_hint(tmp_path / "fmus" / "fmi3").startswith(
        f"a folder named as the FMI 3.0 FMUs' is: `ujfmu build --fmi 3 --fmu-dir {tmp_path / 'fmus' / 'fmi3'}`")
    assert build_hint(tmp_path / "Motor.fmu") == (f"{tmp_path / 'Motor.fmu'} names one FMU: give the folder that "
                                                 f"holds them all, e.g. --fmu-dir {tmp_path} (from Python: "
                                                 "fmu_dir=...)")
    assert build_hint(tmp_path / "mine") == f"run `ujfmu build --fmu-dir {tmp_path / 'mine'}` first"


def test_an_out_dir_that_is_a_file_is_refused_before_the_run(fmu_dir, tmp_path):
    """out_dir pointing at a file had ended the run in a bare FileExistsError: a ScenarioError says so first."""
    from ujfmu.scenario import ScenarioError
    taken = tmp_path / "results"
    taken.write_text("not a folder")
    for out in (taken, taken / "sub"):   # a folder under a file too (a review's: an internal error after the run)
        with pytest.raises(ScenarioError, match=r"out_dir .*: .*results is a file: give a folder for the results"):
            ujfmu.run_scenario(SCENARIOS / "cardan_constant_speed.toml", fmu_dir=fmu_dir, out_dir=out, plot=False)


def test_a_reference_solves_progress_is_said_off_a_terminal_once_it_takes_a_while(capsys):
    """Off a terminal (a CI log), a reference's solve says how far it has come at each tenth once it has run 10 s
    (most take a few, and say nothing more), in ms of simulated time; a second solve (a second rotor's) counts anew."""
    from types import SimpleNamespace

    from ujfmu.cli import PLAIN_PROGRESS_AFTER, _progress
    now = [0.0]
    with _progress(SimpleNamespace(quiet=False), "s: reference solve (simulated time)", "ms",
                   clock=lambda: now[0]) as say:
        for at, done in ((1.0, 1000), (PLAIN_PROGRESS_AFTER - 1.0, 2000), (PLAIN_PROGRESS_AFTER + 2.0, 3000),
                         (PLAIN_PROGRESS_AFTER + 3.0, 3100), (PLAIN_PROGRESS_AFTER + 4.0, 7900),
                         (PLAIN_PROGRESS_AFTER + 5.0, 300), (PLAIN_PROGRESS_AFTER + 6.0, 1200)):
            now[0] = at   # the last two: a second solve (a second rotor's), counted from 0 again
            say(done, 8000)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": ")[-1] for line in lines] == [
        f"{done} of 8000 ms done ({PLAIN_PROGRESS_AFTER + at:.0f} s)" for at, done in ((2, 3000), (4, 7900), (6, 1200))]


def test_run_names_its_files_by_absolute_paths(fmu_dir, tmp_path, capsys, monkeypatch):
    """`ujfmu run --out out` names the files it wrote by their absolute paths (a relative one, as given, is read
    against whatever directory the log's reader is in)."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(SCENARIOS / "cardan_constant_speed.toml"), "--fmu-dir", str(fmu_dir), "--out", "out",
                 "--no-plot"]) == 0
    assert f"  results: {tmp_path / 'out' / 'cardan_constant_speed.csv'}\n" in capsys.readouterr().out


def test_variables_lists_an_fmus_declared_variables_with_units_defaults_and_ranges(capsys):
    """`ujfmu variables FMU`: every parameter, input and output of the declaration (the twin rotor's names had been
    only in each FMU's documentation/index.html), a parameter with its default, unit, range and meaning (an angle's
    default in degrees too), an output with its unit; --causality keeps one kind; an unknown FMU exit status 2."""
    from ujfmu.build import fmu_class
    assert main(["variables", "TwinJeffcottRotor"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for v in fmu_class("TwinJeffcottRotor").VARIABLES:
        line = next(x for x in lines if x.startswith(f"  {v.name} "))
        if v.causality == "output":
            assert line == f"  {v.name} [{v.unit}]: {v.description}"
        else:
            assert line.startswith(f"  {v.name} = {v.start:g} {v.unit}") and f"range {v.range_text()}: " in line
    assert any(x.startswith("  beta = 0.0872665 rad (5 deg), range [-1.553343034, 1.553343034] rad: ") for x in lines)
    assert main(["variables", "Motor", "--causality", "parameter"]) == 0   # a Boolean as a scenario writes it
    assert "  ideal_speed_source = false: " in capsys.readouterr().out
    assert main(["variables", "Load", "--causality", "input"]) == 0
    out = capsys.readouterr().out
    assert "inputs:" in out and "parameters:" not in out and "outputs:" not in out and "  omega = 0 rad/s" in out
    assert main(["variables", "Cardan"]) == 2
    assert "no FMU named 'Cardan'" in capsys.readouterr().err
    assert main(["variables", "TwinJeffcottRotor", "--causality", "output"]) == 0   # its docstring's first sentence
    assert capsys.readouterr().out.startswith("TwinJeffcottRotor: Two unbalanced Jeffcott rotors coupled through a "
                                              "Hooke joint, Tchomeni, Alugongo, Masu Eqs. (1)-(11) (SI units;")
