"""Every scenario against its reference; the fmpy/libcosim difference shrinks with the step (libcosim on every
scenario: tests/test_ssp.py); references regenerate; step-size convergence."""

import re
from pathlib import Path

import numpy as np
import pytest

from ujfmu.libcosim_run import cosimulate_libcosim
from ujfmu.references import generate, read_reference
from ujfmu.scenario import Scenario
from ujfmu.scenario_run import compare, run_scenario

SCENARIOS = sorted((Path(__file__).parents[1] / "scenarios").glob("*.toml"))


@pytest.fixture(scope="module")
def results(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    return {p.stem: run_scenario(p, fmu_dir=fmu_dir, out_dir=out, progress=False) for p in SCENARIOS}


def test_there_are_scenarios():
    assert {"cardan_startup", "cardan_constant_speed", "twin_jeffcott_steady", "twin_jeffcott_runup",
            "twin_jeffcott_aligned_vs_misaligned", "ring_coupling_fig3", "ring_coupling_speed_study",
            "ring_coupling_startup"} <= {p.stem for p in SCENARIOS}


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_scenario_passes_against_reference(results, path):
    result = results[path.stem]
    assert result.checks, "a scenario must compare at least one signal"
    assert result.passed, result.summary()
    assert result.fmpy_outlier_fraction == 0.0, result.summary()
    assert result.level_only_bands == [], result.summary()   # every band below its signal's steady vibration
    assert result.csv.is_file() and result.plot.is_file()
    assert len(result.extra_plots) == bool(result.scenario.orbits) + bool(result.scenario.spectra)
    assert all(p.is_file() for p in result.extra_plots)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_committed_reference_regenerates(path):
    """The reference file is what `ujfmu references` produces (same provenance, same numbers)."""
    scenario = Scenario(path)
    committed, provenance = read_reference(scenario.reference_file)
    fresh, fresh_provenance = generate(scenario)
    assert provenance == " ".join(fresh_provenance.split())
    assert committed.dtype.names == fresh.dtype.names
    for name in committed.dtype.names:
        deviation = np.max(np.abs(committed[name] - fresh[name]))
        assert deviation <= _regeneration_allowance(scenario, name, fresh[name]), (name, deviation)


def _regeneration_allowance(scenario, name, fresh):
    """How far a regenerated reference signal may differ from the committed one: 1e-9 of its range, never below the
    round-off of its values, and for a compared signal 1/100 of the tighter of its bands (comparison and
    step-halving). The adaptive solves follow the last bits of the elementary functions, which differ between
    CPUs (numpy's SIMD sin, cos, exp): two machines' references differ by up to about 1e-7 of a range, far below
    what any check can see, while a changed generator moves a signal by a good part of its band."""
    span = float(np.ptp(fresh))
    allowed = 1e-9 * span + 64.0 * np.finfo(float).eps * float(np.max(np.abs(fresh)))
    bands = [tol.rel_range * span + tol.abs for tol in (scenario.tolerances.get(name),
                                                         scenario.extrapolated_tolerances.get(name)) if tol]
    return max(allowed, 0.01 * min(bands)) if bands else allowed


#: steady_from windows must repeat to the sweeps' default steady-state tolerance (SweepSettings.steady_tol)
STEADY_TOL = 1e-3
STEADY_FROM = [p for p in SCENARIOS if "steady_from" in p.read_text()]


def test_the_steady_from_scenarios_are_the_twin_rotors():
    assert {p.stem for p in STEADY_FROM} == {"twin_jeffcott_steady", "twin_jeffcott_aligned_vs_misaligned"}


@pytest.mark.parametrize("path", STEADY_FROM, ids=lambda p: p.stem)
def test_a_steady_from_window_is_steady(path):
    """From steady_from to the end the response repeats: by ujfmu.steady.halves_change (the mean and the 1x, 2x,
    4x running-speed order amplitudes of the window's first and second halves, on the running angle) every
    recorded signal but the running angles and the energy integrals agrees within STEADY_TOL, in the committed
    reference (the co-simulation agrees with it within the scenario's tolerances). A window opened while the
    twin rotor's first torsional mode still rings (it decays as exp(-0.69 t); steady_from = 3 s left 230% in
    the order amplitudes of tau_in) fails."""
    from ujfmu.steady import grows, halves_change
    scenario = Scenario(path)
    reference, _ = read_reference(scenario.reference_file)
    window = reference[reference["time"] >= scenario.steady_from - 1e-9]
    assert window["time"][-1] - window["time"][0] >= 0.5, "a window too short to judge"
    speed = window[scenario.running_speed]
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(window["time"]))))
    signals = [n for n in scenario.record if not grows(n)]
    changes = {name: halves_change(angle, window, [name])[0] for name in signals}
    assert max(changes.values()) <= STEADY_TOL, {n: f"{c:.2g}" for n, c in changes.items() if c > STEADY_TOL}


def test_coupling_bound_scenarios_have_the_tight_extrapolated_comparison(results):
    """Every scenario driven by a PI motor (explicitly coupled, first-order error) checks the step-halving
    extrapolation of every recorded signal, 10-20x tighter than its own band."""
    pi_driven = {name for name, r in results.items()
                 if not r.scenario.parameters_with_defaults("motor").get("ideal_speed_source", False)}
    assert pi_driven == {n for n, r in results.items() if r.extrapolated_checks}
    for name in pi_driven:
        scenario = results[name].scenario
        assert [c.name for c in results[name].extrapolated_checks] == scenario.record
        assert all(c.passed for c in results[name].extrapolated_checks)


def test_reference_is_not_the_cosimulation(results):
    """Guard against a reference produced by the code it checks: in the coupled start-up the co-simulation
    must differ from the reference by a visible coupling error (O(h)), not agree to round-off."""
    result = results["cardan_startup"]
    assert all(c.max_error > 1e-6 for c in result.checks if c.name.startswith("joint.tau"))


def test_libcosim_difference_shrinks_with_step_size(fmu_dir):
    """The fmpy/libcosim difference in the coupled start-up is a coupling error of first order: halving h at least
    halves it (2.2-2.7x measured per halving from 4 to 0.5 ms, a second-order part on top)."""
    diffs = []
    for h in (2e-3, 1e-3):
        scenario = Scenario(SCENARIOS[0].parent / "cardan_startup.toml")
        scenario.step_size, scenario.stop_time = h, 2.0
        ours = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None, progress=False).table
        theirs = cosimulate_libcosim(scenario, fmu_dir)
        y = np.interp(theirs["time"], ours["time"], ours["joint.tau_in"])
        diffs.append(np.max(np.abs(theirs["joint.tau_in"] - y)))
    assert 1.8 < diffs[0] / diffs[1] < 3.2, diffs


def test_cosimulation_error_converges_at_second_order(fmu_dir):
    """Against the monolithic reference, the start-up's coupling error falls with the square of the step: the
    light joint leaves the implicit scheme's blend at 1/2, the trapezoidal mean of the torn torque, and the joint's
    acceleration estimate is second order (docs/cosimulation.md, "Accuracy"). joint.tau_in, which carries the
    iteration's tolerance besides, falls faster than first order."""
    errors = []
    for h in (2e-3, 1e-3, 5e-4):
        scenario = Scenario(SCENARIOS[0].parent / "cardan_startup.toml")
        scenario.step_size, scenario.stop_time = h, 1.0
        table = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None, progress=False).table
        reference, _ = generate(scenario)
        errors.append({c.name: c.max_error for c in compare(table, reference, scenario.tolerances)})
    for name, low in (("motor.omega", 3.4), ("motor.tau_motor", 3.4), ("joint.tau_in", 2.5)):
        ratios = [errors[i][name] / errors[i + 1][name] for i in range(2)]
        assert all(low < r < 4.6 for r in ratios), (name, ratios)


def test_twin_jeffcott_runup_coupling_error_falls_at_second_order(fmu_dir):
    """The run-up's torque tolerance (3%) covers a coupling error, not a model error: up to the first torsional
    crossing (where it peaks) it falls 4-fold when the step halves (second-order implicit coupling)."""
    errors = []
    for h in (1e-3, 5e-4):
        scenario = Scenario(SCENARIOS[0].parent / "twin_jeffcott_runup.toml")
        scenario.step_size, scenario.stop_time = h, 3.0
        table = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None, progress=False).table
        reference, _ = generate(scenario)
        errors.append({c.name: c.max_error for c in compare(table, reference, scenario.tolerances)})
    for name in ("rotor.tau_in", "rotor.secondary_shaft_torque"):
        assert 3.4 < errors[0][name] / errors[1][name] < 5.5, (name, errors)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_committed_reference_names_its_generator_module_and_setup(path):
    """Without regenerating: the provenance line starts with the module of the scenario's generator, names the
    exact command that regenerates the file, and the reference was made for the scenario's present setup
    (read_reference refuses it otherwise)."""
    from ujfmu.references import GENERATORS, setup_of
    scenario = Scenario(path)
    _, provenance = read_reference(scenario.reference_file)
    assert provenance.split(":")[0] == GENERATORS[scenario.reference_generator][0]
    assert setup_of(provenance) == scenario.setup_digest()
    assert f". Regenerate: ujfmu references scenarios/{path.name} [scenario setup " in provenance   # the command
    scenario.read_reference()


def test_a_runs_steady_orders_are_data_and_a_hooke_joints_speed_has_its_closed_form_orders(fmu_dir):
    """The orders a run's summary prints over its steady window were text only: `steady_orders()` gives them as
    objects. An ideal Hooke joint at angle b driven at constant speed w turns its output at
    w cos b / (1 - sin^2 b cos^2 theta) = w (1 + 2 sum_n (-q)^n cos 2n theta), q = tan^2(b / 2): mean w, no 1x,
    2x amplitude 2 q w, 4x 2 q^2 w (zero-to-peak)."""
    import math
    copy = Scenario(Path(__file__).parents[1] / "scenarios" / "cardan_constant_speed.toml").with_parameters(
        {"joint.error_angle_beta": 0.0, "joint.error_angle_gamma": 0.0, "joint.bend_angle": math.radians(30.0)})
    with pytest.raises(ValueError, match="no steady window to fit orders over: set the scenario's steady_from"):
        run_scenario(copy, fmu_dir, out_dir=None, plot=False).steady_orders()
    copy.steady_from, copy.running_speed = 0.2, "motor.omega"
    orders = run_scenario(copy, fmu_dir, out_dir=None, plot=False).steady_orders()
    w, q = 20.0 * math.pi, math.tan(math.radians(15.0)) ** 2
    speed = orders["joint.omega_out"]
    assert speed.unit == "rad/s" and speed.mean == pytest.approx(w, rel=1e-6)
    assert speed.amplitudes[1] < 1e-6 * speed.amplitudes[2]   # the 6x, 8x ... the fit leaves out leak in: 2e-7
    assert speed.amplitudes[2] == pytest.approx(2.0 * q * w, rel=1e-6)
    assert speed.amplitudes[4] == pytest.approx(2.0 * q * q * w, rel=1e-5)
    assert "joint.phi_out" not in orders   # an angle grows: no orders


def test_the_recorded_signals_means_are_over_whole_revolutions(fmu_dir):
    """The summary's mean and RMS of each recorded signal were time averages over the steady window, 2.7 revolutions
    here, where a joint's 2x does not cancel: a trial's twin rotor tau_in read 6% off the fitted mean beside it. Over
    whole revolutions a Hooke joint's output speed averages to its input's and its input torque to the load's (power
    balance, no loss), to round-off."""
    import math
    import re
    copy = Scenario(Path(__file__).parents[1] / "scenarios" / "cardan_constant_speed.toml").with_parameters(
        {"joint.error_angle_beta": 0.0, "joint.error_angle_gamma": 0.0})
    copy.steady_from, copy.running_speed = 0.23, "motor.omega"
    text = run_scenario(copy, fmu_dir, out_dir=None, plot=False).summary()
    block = text[text.index("  recorded signals from t = 0.23 s"):]
    assert "mean, RMS over its first 2 whole revolutions of motor.omega, trapezoidal" in block.splitlines()[0]

    def mean(name):
        return float(re.search(rf"    {re.escape(name)} +\S+ \.\. \S+, mean (\S+),", block).group(1))
    assert mean("joint.omega_out") == pytest.approx(20.0 * math.pi, rel=1e-6)
    assert mean("joint.tau_in") == pytest.approx(0.3, rel=1e-6)


def test_a_run_that_would_compare_what_it_does_not_record_is_refused_before_it_starts(fmu_dir, tmp_path):
    """A caller who records fewer signals of a read scenario (`s.record = [...]`, a fresh-eyes trial's) ran the
    whole run, then lost it to a bare numpy error in the comparison: the run is refused before it starts, naming
    the compared signals it would lack and the remedies; unchecked, it runs and plots what it recorded. A record
    given as one string, an output_interval that is not a whole number, and changes that are not a dict are
    refused naming the field."""
    from ujfmu.scenario import ScenarioError
    path = Path(__file__).parents[1] / "scenarios" / "cardan_startup.toml"
    fewer = Scenario(path)
    fewer.record = ["joint.omega_out", "joint.tau_in"]
    with pytest.raises(ScenarioError, match=r"motor\.omega, .*load\.tau are compared with the reference but not "
                                            r"recorded: record them \(scenario\.record\)") as refused:
        run_scenario(fewer, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False)
    assert "joint.tau_in" not in str(refused.value).split(" are compared")[0]
    assert not list(tmp_path.iterdir())   # refused before anything ran
    fewer.reference_file = None
    result = run_scenario(fewer, fmu_dir=fmu_dir, out_dir=tmp_path, plot=True)
    assert result.table.dtype.names == ("time", "joint.omega_out", "joint.tau_in") and result.plot.is_file()
    for field, value, says in (("record", "joint.omega_out", "must be a list of signals, e.g. ['joint.omega_out']"),
                               ("output_interval", 2.5, "output_interval = 2.5 must be a whole number")):
        wrong = Scenario(path)
        setattr(wrong, field, value)
        with pytest.raises(ScenarioError, match=re.escape(says)):
            run_scenario(wrong, fmu_dir=fmu_dir, out_dir=None, plot=False)
    with pytest.raises(ScenarioError, match="with_parameters takes a dict"):
        Scenario(path).with_parameters(["motor.J_rotor", 1.0])


def _write_many(path, value, count, barrier):
    from ujfmu.scenario_run import write_table
    table = np.rec.fromarrays([np.arange(20000.0), np.full(20000, value)], names=["time", "x"])
    for _ in range(count):
        barrier.wait(60)   # both write at once, to the last
        write_table(path, table)


def test_runs_writing_one_name_at_once_leave_one_whole_table(tmp_path):
    """Two processes running changed copies of one name into one folder (a fresh-eyes trial's pool of variants)
    left a CSV of both interleaved, times running backwards: each writes its table whole, so the file is one of
    them, every row of one run."""
    import multiprocessing
    path = tmp_path / "same.csv"
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(2)
    writers = [context.Process(target=_write_many, args=(path, value, 20, barrier)) for value in (1.0, 2.0)]
    for writer in writers:
        writer.start()
    seen = []   # what a reader finds while they write: a whole table each time, never a part
    while any(writer.is_alive() for writer in writers):
        if path.exists():
            seen.append(path.read_text().count("\n"))
    for writer in writers:
        writer.join(120)
        assert writer.exitcode == 0
    assert seen and set(seen) == {20001}, sorted(set(seen))[:5]
    table = np.genfromtxt(path, delimiter=",", names=True)
    assert len(table) == 20000 and np.array_equal(table["time"], np.arange(20000.0))
    assert len(set(table["x"])) == 1 and table["x"][0] in (1.0, 2.0)
    assert [p.name for p in tmp_path.iterdir()] == ["same.csv"]   # no temporary file left


def test_a_stopped_runs_columns_file_says_its_table_ends_early(fmu_dir, tmp_path):
    """A stopped run's CSV looked complete: its columns file's time row says where the results end, and why."""
    from ujfmu.master import RunStopped
    path = Path(__file__).parents[1] / "scenarios" / "cardan_startup.toml"
    with pytest.raises(RunStopped):
        run_scenario(path, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False,
                     progress=lambda done, total: False if done > 1000 else None)
    time_row = (tmp_path / "cardan_startup.columns.csv").read_text().splitlines()[1]
    assert "the run stopped early: results up to t = 1.0" in time_row and "of 6.0 s" in time_row
    assert "stopped by the progress callback" in time_row


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="os.fork: POSIX only")
def test_a_forked_child_that_exits_leaves_its_parents_fmu_folders(fmu_dir):
    """A process forked after running FMUs inherits the exit handler that removes the extracted FMU folders: the
    child's normal exit removed the parent's, whose next run then failed ("Cannot find shared library"). Only the
    folders a process made itself are removed at its exit."""
    import subprocess
    import sys
    script = f"""
import os, sys
from ujfmu.scenario_run import run_scenario
scenario = {str(Path(__file__).parents[1] / "scenarios" / "cardan_constant_speed.toml")!r}
run_scenario(scenario, fmu_dir={str(fmu_dir)!r}, out_dir=None, plot=False)
child = os.fork()
if child == 0:
    sys.exit(0)
os.waitpid(child, 0)
print(run_scenario(scenario, fmu_dir={str(fmu_dir)!r}, out_dir=None, plot=False).verdict, flush=True)
os._exit(0)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.stdout.strip() == "PASS", done.stderr[-2000:]


def test_a_runs_warnings_are_data_from_python(fmu_dir):
    """ScenarioResult.warnings was filled by the command line only: from Python it was always [] while the FMUs
    warned (a fresh-eyes trial's). A run holds the models' advice on their parameters (Feng's default error angles
    at a 0.03 rad bend) and the FMUs' warnings during the run (Omar's shaft twisted past LARGE_TWIST by 40 N.m on
    k_theta = 92.2 N.m/rad: 0.5 rad as it starts), each once, as 'component: text'; the FMU's warning is still
    warned too."""
    import warnings

    from ujfmu.master import FmuWarning
    scenarios = Path(__file__).parents[1] / "scenarios"
    bent = Scenario(scenarios / "cardan_startup.toml").with_parameters({"joint.bend_angle": 0.03})
    bent.stop_time = 0.2
    (advice,) = run_scenario(bent, fmu_dir=fmu_dir, out_dir=None, plot=False).warnings
    assert advice.startswith("joint: error_angle_beta = error_angle_gamma = 0.3 deg are the defaults")
    twisted = Scenario(scenarios / "double_cardan_omar_torsional.toml").with_parameters({"load.T0": 40.0})
    twisted.stop_time = 0.5
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FmuWarning)
        said = run_scenario(twisted, fmu_dir=fmu_dir, out_dir=None, plot=False).warnings
    twist = [line for line in said if line.startswith("driveline: at t = ") and "shaft is twisted 0.5" in line]
    assert len(twist) == 1, said
    assert any("the intermediate shaft is twisted" in str(w.message) for w in caught
               if issubclass(w.category, FmuWarning))
