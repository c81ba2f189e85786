"""Sweeps: axis parsing, per-point figures against closed forms, resuming, failing points, dask (local cluster
and scheduler address), and the command line."""

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from ujfmu.cli import main
from ujfmu.references import read_reference
from ujfmu.scenario import Scenario, ScenarioError
from ujfmu import sweep as sweep_module
from ujfmu.sweep import Sweep, SweepSettings, SweepSettingsError, parse_axis

SCENARIOS = Path(__file__).parents[1] / "scenarios"
RPM = math.pi / 30.0


@pytest.fixture
def brutti():
    return Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")


def brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000:3000:1000rpm", name=None):
    """Rigid driveline on an ideal source: periodic from the start, so no steady-state check (steady_tol = 0)."""
    settings = SweepSettings.from_scenario(brutti, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=2, steady_tol=0.0)
    return Sweep(brutti, [parse_axis(spec, brutti)], settings, out_dir=tmp_path, name=name, fmu_dir=fmu_dir)


def without_timing(record):
    return {k: v for k, v in record.items() if k != "wall_s"}


def test_axis_ranges_are_inclusive_and_units_convert_to_si(brutti):
    axis = parse_axis("motor.omega_set=100:1500:10rpm", brutti)
    assert len(axis.values) == 141 and axis.values[0] == pytest.approx(100 * RPM)
    assert axis.values[-1] == pytest.approx(1500 * RPM) and axis.display(axis.values[-1]) == pytest.approx(1500)
    assert parse_axis("driveline.beta1=0.1,0.2rad", brutti).values == [0.1, 0.2]   # the SI units, named
    assert parse_axis("motor.omega_set=70rad/s", brutti).values == [70.0]
    with pytest.raises(ScenarioError, match=r"'rad' is rad, but the parameter's unit is N.m/rad"):
        parse_axis("driveline.k_theta=5rad", brutti)
    linked = parse_axis("driveline.beta1,driveline.beta2=5,10deg", brutti)
    assert linked.names == ("driveline.beta1", "driveline.beta2")
    assert linked.values == pytest.approx([math.radians(5), math.radians(10)])
    # in Python, one string joined by commas as on the command line, or a sequence
    from ujfmu.sweep import Axis
    assert Axis.of("driveline.beta1, driveline.beta2", [5], "deg").names == linked.names
    assert Axis.span(linked.names, 5, 10, 5, "deg").values == pytest.approx(linked.values)
    # a STOP the steps do not reach is said, not dropped in silence; a reached one is not mentioned
    short = parse_axis("driveline.beta1,driveline.beta2=0:10:3deg", brutti)
    assert short.display(short.values[-1]) == pytest.approx(9.0)
    assert "(ends at 9 deg: STOP 10 deg is not START plus a whole number of STEPs" in short.describe(brutti)
    assert "ends at" not in parse_axis("driveline.beta1=0:9:3deg", brutti).describe(brutti)


def test_a_negated_name_sets_minus_the_axis_value_and_a_boolean_axis_takes_true_false(tmp_path, fmu_dir):
    """`driveline.beta1,-driveline.beta2=10deg` (Omar's flexible driveline, whose suspended intermediate shaft
    tells the W layout beta2 = -beta1 from the Z layout beta2 = beta1) computes what two one-value axes beta1 = 10,
    beta2 = -10 deg compute, not the Z layout's figures; the CSV holds each parameter's own value. A Boolean axis
    (`rigid_intermediate_shaft=true,false`): the rigid shaft does not twist, the elastic one twists by the load
    torque over k_theta on average."""
    omar = Scenario(SCENARIOS / "double_cardan_omar_lateral.toml")
    settings = SweepSettings.from_scenario(omar, outputs=["driveline.dynamic_misalignment", "driveline.twist"],
                                           running_speed="motor.omega", settle_time=0.6, revolutions=2,
                                           steady_tol=0.0)

    def figures(name, *specs):
        sweep = Sweep(omar, [parse_axis(spec, omar) for spec in specs], settings, out_dir=tmp_path, name=name,
                      fmu_dir=fmu_dir)
        sweep.run(workers=0, progress=False)
        return sweep.table()

    (w,) = figures("w", "driveline.beta1,-driveline.beta2=10deg")
    (apart,) = figures("apart", "driveline.beta1=10deg", "driveline.beta2=-10deg")
    (z,) = figures("z", "driveline.beta1,driveline.beta2=10deg")
    assert w["driveline.beta1"] == -w["driveline.beta2"] == pytest.approx(math.radians(10))
    for column in ("driveline.dynamic_misalignment.p2p", "driveline.twist.h2", "driveline.twist.mean"):
        assert w[column] == apart[column], column
    assert abs(w["driveline.dynamic_misalignment.p2p"] - z["driveline.dynamic_misalignment.p2p"]) > 0.1 * abs(
        z["driveline.dynamic_misalignment.p2p"])
    with open(tmp_path / "w.csv") as f:
        row = next(csv.DictReader(f))
    assert float(row["driveline.beta2"]) == -float(row["driveline.beta1"])
    rigid, elastic = figures("rigid", "driveline.rigid_intermediate_shaft=true,false")
    assert rigid["driveline.rigid_intermediate_shaft"] == 1.0 and elastic["driveline.rigid_intermediate_shaft"] == 0.0
    assert rigid["driveline.twist.max"] == rigid["driveline.twist.min"] == 0.0
    # the intermediate shaft carries the 5 N.m load on average (Omar's k_theta = 92.2 N.m/rad, the default)
    assert elastic["driveline.twist.mean"] == pytest.approx(5.0 / 92.2, rel=0.03)


@pytest.mark.parametrize("spec, words", [
    ("nope.omega_set=1:2:1", "no component 'nope'"),
    ("motor.speed=1:2:1", "Motor has no parameter 'speed'"),
    ("motor.omega_set=1:x:1", "bad values"),
    ("motor.omega_set=10:1:1", "STOP >= START"),
    # beyond its allowed range, named in the unit it was given in (no "deg = rad?" slip hint: it was given in deg)
    ("driveline.beta1=0,95deg", "driveline.beta1 = 95 deg (1.65806 rad) is outside its allowed range [-89, 89] deg"),
    ("driveline.beta1=0,1.7", "driveline.beta1 = 1.7 is outside its allowed range"),
    ("motor.omega_set", "expected component.parameter"),
    # negated names, Boolean values, inputs read only with a parameter set, units and repeats within an axis
    ("-driveline.beta1,driveline.beta2=10deg", "the first name (-driveline.beta1) is the axis's own value"),
    ("driveline.beta1,-driveline.beta1=10deg", "driveline.beta1 named more than once in one axis"),
    ("driveline.beta1,-driveline.beta2=0,95deg", "driveline.beta2 = -95 deg (-1.65806 rad) is outside its allowed "
                                                  "range [-89, 89] deg"),
    ("driveline.rigid_intermediate_shaft=yes", "driveline.rigid_intermediate_shaft takes true or false (or 1, 0)"),
    ("driveline.rigid_intermediate_shaft=0:1:1", "write COMP.PAR=true,false (no range, no unit"),
    ("driveline.rigid_intermediate_shaft,driveline.beta1=1", "a Boolean parameter and a number cannot share"),
    ("load.T_h=0,2", "load.T_h != 0 reads load.phi, which"),   # its periodic torque needs the shaft's angle
    ("motor.omega_set,-load.T0=5", "their units differ (motor.omega_set [rad/s], load.T0 [N.m])"),
    ("driveline.rigid_intermediate_shaft=true,true", "a value repeats"),
    ("load.omega=3", "Load has no parameter 'omega' (it is an input: a connection feeds it"),
])
def test_bad_axes_are_rejected_before_anything_runs(brutti, spec, words):
    with pytest.raises(ScenarioError, match="--param") as err:
        parse_axis(spec, brutti)
    assert words in str(err.value)


@pytest.mark.parametrize("spec, words", [
    ("driveline.k_theta=1000:2000:500rpm", "driveline.k_theta: 'rpm' converts to rad/s, but the parameter's unit is "
                                           "N.m/rad; it takes SI values without a suffix"),
    ("driveline.beta1=10rpm", "driveline.beta1: 'rpm' converts to rad/s, but the parameter's unit is rad; it takes "
                              "a suffix deg or rad or none (SI)"),
    ("driveline.J_load=1deg", "driveline.J_load: 'deg' converts to rad, but the parameter's unit is kg.m2"),
    ("motor.omega_set=100deg", "motor.omega_set: 'deg' converts to rad, but the parameter's unit is rad/s; it takes "
                               "a suffix rpm or rad/s or none (SI)"),
    ("motor.omega_set=100Hz", "optionally followed by rpm or rad/s (rad/s parameters), deg or rad (rad parameters)"),
    # a unit of its own named whole, with the parameter's unit (a bench trial's message had cut it to '400N.m/')
    ("driveline.k_theta=400N.m/rad", "bad values '400N.m/rad' (not a number: a unit other than those below? give SI "
                                     "values without one, driveline.k_theta is in N.m/rad)"),
])
def test_a_unit_suffix_must_match_the_parameters_unit(brutti, spec, words):
    with pytest.raises(ScenarioError, match="--param") as err:
        parse_axis(spec, brutti)
    assert words in str(err.value)


def test_every_problem_of_a_sweeps_settings_is_reported_at_once(brutti, fmu_dir, tmp_path, capsys):
    """Six mistakes in one command line (an unknown component, a value outside its range, an unknown output, a
    negative settle time, no revolutions, a negative tolerance): one error lists all six, nothing runs."""
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--param", "nope.omega_set=1:2:1", "--param", "driveline.beta1=0,95,100deg", "--output", "driveline.tau",
            "--running-speed", "motor.omega", "--settle", "-1", "--revolutions", "0", "--steady-tol", "-1",
            "--workers", "0", "--out", str(tmp_path), "--no-progress", "--no-plot"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "6 problems with the sweep's axes and settings:" in err
    for words in ("no component 'nope'", "driveline.beta1 = 95 deg", "(and 1 more of its 3 values)",
                  "'driveline.tau'", "settle_time (--settle) = -1 must be >= 0", "revolutions (--revolutions) = 0 must be > 0",
                  "steady_tol (--steady-tol) = -1 must be >= 0"):
        assert words in err, words
    assert not list(tmp_path.iterdir())


def test_sweep_settings_from_python_list_every_problem(brutti):
    """The same from Python: SweepSettings.from_scenario and Sweep list every problem in one SweepSettingsError."""
    from ujfmu.sweep import Axis, Sweep, SweepSettingsError
    with pytest.raises(SweepSettingsError) as err:
        SweepSettings.from_scenario(brutti, outputs=["driveline.nope"], running_speed="motor.omega",
                                    settle_time=2.0, max_settle_time=1.0, orders=(0, 2))
    assert len(err.value.problems) == 3, err.value.problems
    assert "max_settle_time (--max-settle) = 1 must be >= settle_time (2 s)" in str(err.value) and "orders" in str(err.value)
    settings = SweepSettings.from_scenario(brutti, running_speed="motor.omega", settle_time=0.1)
    with pytest.raises(SweepSettingsError) as err:
        Sweep(brutti, [Axis.of("motor.omega_sett", [1.0]), Axis.of("load.c9", [1.0])], settings)
    assert len(err.value.problems) == 2 and "did you mean motor.omega_set?" in str(err.value)


def test_a_running_speed_that_is_not_a_speed_is_refused_naming_the_speeds(brutti):
    """Revolutions are counted from a shaft's speed: an angle (rad) or a torque given as the running speed is
    refused before any point runs, with the scenario's speed outputs (it had settled one point for minutes)."""
    from ujfmu.sweep import SweepSettingsError
    for name, unit in (("driveline.phi_out", "rad"), ("driveline.tau_in", "N.m")):
        with pytest.raises(SweepSettingsError) as err:
            SweepSettings.from_scenario(brutti, running_speed=name, settle_time=0.1)
        assert f"running_speed (--running-speed) = {name} is in {unit}, not rad/s" in str(err.value)
        assert "motor.omega" in str(err.value) and "driveline.omega_out" in str(err.value)
        assert len(err.value.problems) == 1   # once, though the torque is among the outputs swept too
    assert SweepSettings.from_scenario(brutti, running_speed="driveline.omega_out", settle_time=0.1)


def test_default_outputs_leave_out_the_signals_that_grow_in_any_steady_state():
    """A sweep of twin_jeffcott_steady without outputs reduces its compared signals but for the running angles
    and the energy integrals: input_work grows by the load's power (2 N.m x 100 rad/s), so with it no point could
    ever be steady (every point 'not_steady', the input_work mean changing by 26% between windows). Named, they
    are reduced; the steady-state check leaves them out either way."""
    from ujfmu.steady import grows
    path = SCENARIOS / "twin_jeffcott_steady.toml"
    without = Scenario(path)
    without.sweep.pop("outputs")   # the scenario's [sweep] names its own
    default = SweepSettings.from_scenario(without, settle_time=1.0).outputs
    growing = {"rotor.input_work", "rotor.dissipated_energy", "rotor.phi_out", "rotor.phi_in"}
    assert growing <= set(Scenario(path).tolerances) and not growing & set(default)
    assert {"rotor.X1", "rotor.Y2", "rotor.tau_in", "rotor.stored_energy", "motor.omega"} <= set(default)
    assert SweepSettings.from_scenario(path, settle_time=1.0, outputs=["rotor.input_work"]).outputs == [
        "rotor.input_work"]
    assert all(grows(n) for n in growing) and not any(grows(n) for n in default)


def test_unit_suffixes_are_case_insensitive(brutti):
    assert parse_axis("motor.omega_set=1000:2000:500RPM", brutti) == parse_axis("motor.omega_set=1000:2000:500rpm",
                                                                                  brutti)
    axis = parse_axis("driveline.beta1=10Deg", brutti)
    assert axis.unit == "deg" and axis.values == pytest.approx([math.radians(10)])


def test_points_reproduce_the_fan_load_and_the_inertia_torque_scaling(brutti, tmp_path, fmu_dir):
    """Rigid double Cardan, yokes in phase: mean input torque = c w^2 (output at constant speed, power balance);
    the crosses' inertia torque fluctuates at 2x and grows as w^2, and odd orders vanish by symmetry."""
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir)
    sweep.run(workers=0, progress=False)
    rows = sweep.table()
    assert [r["status"] for r in rows] == ["ok"] * 3
    for r in rows:
        w = r["point"]["motor.omega_set"]
        assert r["speed_mean"] == pytest.approx(w, rel=1e-12)
        # the mean of the fit over 2 revolutions (exact for a periodic signal) of a 0.7% 2x fluctuation
        assert r["driveline.tau_in.mean"] == pytest.approx(0.017 * w * w, rel=2e-5)
        assert r["driveline.tau_in.h1"] < 1e-6 * r["driveline.tau_in.h2"]
    # 2000 rpm is the scenario's own operating point: extremes and peak-to-peak of its closed-form reference
    # (steady from the start: ideal source, rigid shaft; sampling the extremes at 0.1 ms costs < 1e-3)
    reference, _ = read_reference(brutti.reference_file)
    tau = reference["driveline.tau_in"]
    for figure, expected in (("max", tau.max()), ("min", tau.min()), ("p2p", np.ptp(tau))):
        assert rows[1][f"driveline.tau_in.{figure}"] == pytest.approx(expected, rel=1e-3 if figure == "p2p" else 1e-6)
    fluct = [r["driveline.tau_in.p2p"] for r in rows]
    assert fluct[1] / fluct[0] == pytest.approx(4.0, rel=1e-3) and fluct[2] / fluct[0] == pytest.approx(9.0, rel=1e-3)
    with open(sweep.csv) as f:
        table = list(csv.DictReader(f))
    assert len(table) == 3 and table[0]["status"] == "ok"
    assert float(table[2]["driveline.tau_in.mean"]) == rows[2]["driveline.tau_in.mean"]


def test_an_order_the_step_cannot_resolve_is_nan_with_the_step_that_would(brutti, tmp_path, fmu_dir, capsys):
    """At 5000 rpm a 1 ms step samples a revolution 12.5 times: the fit reaches order 5 only, so the 4x amplitude
    would take the 6x-8x orders' aliases. It is NaN, the point says why and which step resolves it, and the
    resolved 2x equals the 0.1 ms run's; that run's 4x grows as w^2 from 2000 rpm (the crosses' inertia torque)."""
    rows = {}
    for h in (1e-3, 1e-4):
        brutti.step_size = h
        sweep = brutti_sweep(brutti, tmp_path, fmu_dir, "motor.omega_set=2000,5000rpm", name=f"step{h:g}")
        sweep.run(workers=0, progress=False)
        rows[h] = sweep.table()
    slow, fast = rows[1e-3]
    assert slow["status"] == fast["status"] == "ok" and "not resolved" not in slow["note"]   # its peaks': below
    assert math.isnan(fast["driveline.tau_in.h4"]) and not math.isnan(slow["driveline.tau_in.h4"])
    assert fast["driveline.tau_in.h2"] == pytest.approx(rows[1e-4][1]["driveline.tau_in.h2"], rel=1e-6)
    assert ("order 4x not resolved" in fast["note"] and "12.5 samples a revolution" in fast["note"]
            and "at most 0.000667 s" in fast["note"])   # 2 pi / (523.6 rad/s * 18)
    assert rows[1e-4][1]["driveline.tau_in.h4"] == pytest.approx(6.25 * rows[1e-4][0]["driveline.tau_in.h4"],
                                                                  rel=1e-3)
    assert all(r["note"] == "" for r in rows[1e-4])
    with open(tmp_path / "step0.001.csv") as f:
        table = list(csv.DictReader(f))
    assert table[1]["driveline.tau_in.h4"] == "nan" and table[1]["note"] == fast["note"]


def test_an_interrupted_sweep_resumes_without_recomputing(brutti, tmp_path, fmu_dir):
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir)
    sweep.run(workers=0, progress=False)
    first = sweep.table()
    lines = sweep.journal.read_text().splitlines()
    # interrupted while writing the third point: two whole lines and half a line on disk
    sweep.journal.write_text("\n".join(lines[:2]) + "\n" + lines[2][:40])
    again = brutti_sweep(brutti, tmp_path, fmu_dir)
    assert len(again.done()) == 2
    again.run(workers=0, progress=False)
    records = [json.loads(line) for line in again.journal.read_text().splitlines()[2:] if line.endswith("}")]
    assert [r["point"] for r in records] == [first[2]["point"]]   # only the missing point ran
    assert [without_timing(r) for r in again.table()] == [without_timing(r) for r in first]


def test_a_sweep_interrupted_from_python_writes_the_table_of_its_points(brutti, tmp_path, fmu_dir):
    """Ctrl-C in a script's Sweep.run (here: from its progress callback after the second point) leaves the table
    of the points done, the others with status missing, as the command line does; then KeyboardInterrupt."""
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir)

    def progress(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep.run(workers=0, progress=progress)
    with open(sweep.csv, newline="") as f:
        assert [row["status"] for row in csv.DictReader(f)] == ["ok", "ok", "missing"]


def test_changed_settings_do_not_reuse_old_points(brutti, tmp_path, fmu_dir):
    brutti_sweep(brutti, tmp_path, fmu_dir).run(workers=0, progress=False)
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.02, revolutions=2)
    other = Sweep(scenario, [parse_axis("motor.omega_set=1000:3000:1000rpm", scenario)], settings,
                  out_dir=tmp_path, fmu_dir=fmu_dir)
    assert other.done() == {}


def test_a_failing_point_is_recorded_and_the_sweep_goes_on(tmp_path, fmu_dir):
    """RingCoupling needs e < R: the point with e = R fails at initialization with the model's message. (The
    undamped ring never settles: measured without the steady-state check.)"""
    scenario = Scenario(SCENARIOS / "ring_coupling_fig3.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["coupling.x_e"], running_speed="motor.omega",
                                           settle_time=0.0, revolutions=1, steady_tol=0.0)
    sweep = Sweep(scenario, [parse_axis("coupling.e=0.001,0.1", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    ok, bad = sweep.table()
    assert ok["status"] == "ok" and ok["coupling.x_e.h2"] > 0
    assert bad["status"] == "error" and "e" in bad["error"] and "R" in bad["error"]
    assert sweep.failed() == [bad]


def test_a_failed_point_is_not_rerun_by_the_same_sweep_but_a_transient_failure_is(tmp_path, fmu_dir, capsys,
                                                                                     monkeypatch):
    """The ring coupling's e = R fails at initialization, and the same FMUs, code and settings fail it again: a rerun
    reuses the failure (it had run it again on every rerun) and says so; a failure the machine caused (a full disk
    extracting the FMUs) is run again. Through the command line: the reuse line counts the failures."""
    import errno

    import ujfmu.sweep as sweep_module
    from ujfmu.sweep import WorkerSetupError, repeatable
    assert repeatable(ValueError("e >= R")) and not repeatable(OSError(errno.ENOSPC, "No space left on device"))
    wrapped = RuntimeError("setup failed")
    wrapped.__cause__ = MemoryError()
    deeper = RuntimeError("fmi2DoStep failed")
    deeper.__context__ = wrapped   # the cause two levels down
    assert not repeatable(wrapped) and not repeatable(deeper) and not repeatable(WorkerSetupError("no FMUs"))
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "ring_coupling_fig3.toml"), "--param",
            "coupling.e=0.001,0.1", "--output", "coupling.x_e", "--running-speed", "motor.omega", "--settle", "0",
            "--revolutions", "1", "--steady-tol", "0", "--workers", "0", "--out", str(tmp_path), "--no-plot", "-q"]
    assert main(args) == 1
    ran = []
    real = sweep_module.run_point
    monkeypatch.setattr(sweep_module, "run_point", lambda job, point, blobs=None: ran.append(point) or real(
        job, point, blobs))
    assert main(args) == 1
    out = capsys.readouterr().out
    assert ran == [] and "reused 2 of 2 points" in out and "1 of them failed (the same FMUs" in out
    journal = tmp_path / "ring_coupling_fig3_sweep.jsonl"
    records = [json.loads(line) for line in journal.read_text().splitlines()]
    for record in records:   # as a full disk would have left the failed one
        if record["status"] == "error":
            record["repeatable"] = False
    journal.write_text("".join(json.dumps(r) + "\n" for r in records))
    assert main(args) == 1
    assert [p["coupling.e"] for p in ran] == [0.1]


def test_a_point_whose_coupling_diverges_names_the_torque_driven_wiring(tmp_path, fmu_dir):
    """A CardanJoint whose driven side is 20x the PI motor's rotor, coupled explicitly, diverges: the point's error
    gives the remedy `ujfmu run` gives, the torque-driven wiring (it had said only to reduce the step)."""
    from ujfmu import battery
    scenario = Scenario(battery.BATTERY_DIR / "battery_02.toml")
    scenario.coupling = "explicit"
    rotor = scenario.components["motor"][1]["J_rotor"]
    settings = SweepSettings.from_scenario(scenario, outputs=["joint.tau_in"], running_speed="motor.omega",
                                           settle_time=0.1, revolutions=1, steady_tol=0.0)
    sweep = Sweep(scenario, [parse_axis(f"joint.J2={0.01 * rotor},{20 * rotor}", scenario)], settings,
                  out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    light, heavy = sweep.table()
    assert "hint" not in light["error"] and heavy["status"] == "error"
    assert "coupling instability between 'joint' and 'motor'" in heavy["error"]
    assert ("hint: joint (CardanJoint) follows the speed motor sets" in heavy["error"]
            and "CardanJointTorqueDriven driven by a MotorController" in heavy["error"]), heavy["error"]


def test_a_scheduler_address_nobody_listens_on_is_a_plain_error(fmu_dir, tmp_path, capsys):
    """--scheduler at an address with no scheduler: after dask's connect timeout (1 s here), a usage error naming
    the address and the remedies, exit status 2, no traceback (it had been an internal error, status 3)."""
    import dask
    import distributed  # noqa: F401 (its config defaults loaded first: leaving the set below would drop them)
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--param", "motor.omega_set=1000,2000rpm", "--output", "driveline.tau_in", "--running-speed",
            "motor.omega", "--settle", "0.01", "--steady-tol", "0", "--scheduler", "tcp://127.0.0.1:1",
            "--out", str(tmp_path), "--no-progress", "--no-plot"]
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        assert main(args) == 2
    err = capsys.readouterr().err
    assert "--scheduler 'tcp://127.0.0.1:1': cannot reach a dask scheduler there" in err and "Traceback" not in err


def test_dask_local_cluster_and_scheduler_address_give_the_in_process_results(brutti, tmp_path, fmu_dir,
                                                                             monkeypatch):
    """The distributed path on a real LocalCluster with two worker processes, reached by its address as
    `--scheduler` does; each worker receives the FMUs (no shared folder needed) and runs points independently, and
    leaves no folder behind in its temporary directory when it exits."""
    from distributed import Client, LocalCluster
    workers_tmp = tmp_path / "workers_tmp"
    workers_tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(workers_tmp))   # read by each worker process as it starts
    serial = brutti_sweep(brutti, tmp_path / "serial", fmu_dir)
    serial.run(workers=0, progress=False)
    checked = []
    check = sweep_module.check_workers
    monkeypatch.setattr(sweep_module, "check_workers", lambda client: checked.append(check(client)) or checked[-1])
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        distributed = brutti_sweep(brutti, tmp_path / "dask", fmu_dir)
        distributed.run(scheduler=cluster.scheduler_address, progress=False)
        with Client(cluster) as client:
            ran_on = {w["id"] for w in client.scheduler_info()["workers"].values()}
            plugins = client.run_on_scheduler(lambda dask_scheduler: sorted(dask_scheduler.worker_plugins))
    assert len(ran_on) == 2
    assert checked == [[]]   # a cluster not started here: its workers checked, and fit
    # and left without the sweep's FMU plugin, which the scheduler would send to each worker that joins later
    assert not [name for name in plugins if name.startswith("ujfmu-fmus-")], plugins
    assert [without_timing(r) for r in distributed.table()] == [without_timing(r) for r in serial.table()]
    assert sorted(p.name for p in workers_tmp.iterdir()) == []


def _worker_settings(keys):
    import dask
    return {key: dask.config.get(key) for key in keys}


def test_local_cluster_workers_run_without_the_profiler_and_frequent_monitors():
    """The local cluster's workers start with sweep.LOCAL_WORKER_CONFIG (each periodic wake-up of their event
    loop takes the GIL from the point being computed), and the caller's dask config is left as it was. Another
    cluster on dask's default port (8787) draws no warning (dask had warned of it in every sweep's output)."""
    pytest.importorskip("distributed")   # its defaults in dask's config
    import socket
    import warnings

    import dask
    keys = sorted(sweep_module.LOCAL_WORKER_CONFIG)
    before = _worker_settings(keys)
    with socket.socket() as other, warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            other.bind(("", 8787))
            other.listen()
        except OSError:   # taken already: by another cluster, as in the case tested
            pass
        client = sweep_module.dask_client(workers=1)
        try:
            (settings,) = client.run(_worker_settings, keys).values()
        finally:
            sweep_module.close_client(client)
    assert not [w for w in said if "8787" in str(w.message)]
    assert settings == sweep_module.LOCAL_WORKER_CONFIG
    assert dask.config.get("distributed.worker.profile.enabled") is True and _worker_settings(keys) == before


def test_cli_sweep_writes_table_and_plots_and_reports_bad_parameters(fmu_dir, tmp_path, capsys):
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--param", "motor.omega_set=1000,2000rpm", "--param", "driveline.beta1,driveline.beta2=5,10deg",
            "--output", "driveline.tau_in", "--running-speed", "motor.omega", "--settle", "0.01", "--revolutions", "1",
            "--steady-tol", "0", "--workers", "0", "--out", str(tmp_path), "--no-progress"]
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert "points done" not in err   # --no-progress: none
    # --steady-tol 0: no point is called steady (it had read "4 ok (steady at the operating point)")
    assert "4 ok (at the operating point; steady state not checked (--steady-tol 0))" in out, out
    assert "4 points (2 motor.omega_set 104.7..209.4 rad/s (given as 1000..2000 rpm) x " \
           "2 driveline.beta1,driveline.beta2 0.08727..0.1745 rad (given as 5..10 deg))" in out
    for name in ("double_cardan_brutti_rigid_sweep.csv", "double_cardan_brutti_rigid_sweep.png",
                 "double_cardan_brutti_rigid_sweep_orders.png"):
        assert (tmp_path / name).is_file()
    assert main(args[:4] + ["--param", "motor.nope=1:2:1"]) == 2
    assert "Motor has no parameter 'nope'" in capsys.readouterr().err
    # off a terminal (pytest's captured stderr, a CI log), progress comes as plain lines, the last at the end
    assert main([a for a in args if a != "--no-progress"] + ["--name", "again"]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if "points done" in line]
    assert lines and lines[-1].startswith("  again: 4 of 4 points done") and "\r" not in "".join(lines)


def test_cli_sweep_quiet_lists_no_files_and_step_sets_the_communication_step(fmu_dir, tmp_path, capsys):
    """-q prints the verdict, not the files (as run -q); --step reaches every point: points of the journal at
    another step are computed again, not reused, and the run says so; the step must be positive."""
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--param", "motor.omega_set=1000rpm", "--output", "driveline.tau_in", "--running-speed", "motor.omega",
            "--settle", "0.01", "--revolutions", "1", "--steady-tol", "0", "--workers", "0", "--out", str(tmp_path)]
    assert main(["-q"] + args) == 0
    out = capsys.readouterr().out
    assert "1 point: 1 ok" in out and "table:" not in out and "journal:" not in out and "plot:" not in out
    assert (tmp_path / "double_cardan_brutti_rigid_sweep.csv").is_file()
    assert main(["-q"] + args) == 0
    assert "reused 1 of 1 points" in capsys.readouterr().out
    assert main(["-q"] + args + ["--step", "5e-4"]) == 0
    out = capsys.readouterr().out
    assert "reused" not in out and "recomputed 1 points that" in out and "from other settings" in out
    assert main(["-q"] + args + ["--step", "5e-4"]) == 0
    out = capsys.readouterr().out
    assert "reused 1 of 1 points" in out and "recomputed" not in out
    assert main(["-q"] + args + ["--step", "0"]) == 2
    assert "--step 0: the communication step must be a number of seconds > 0" in capsys.readouterr().err


def test_cli_sweep_coupling_runs_every_point_in_that_scheme_beside_the_files_own(fmu_dir, tmp_path, capsys):
    """--coupling explicit runs the points in that scheme (the table's coupling column says it), as
    <scenario>_explicit_sweep beside the scenario's own (implicit) sweep, whose points it does not reuse; the two
    schemes agree on an ideal source's driveline to the implicit coupling's resolution."""
    import csv
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--param", "motor.omega_set=1000rpm", "--output", "driveline.tau_in", "--running-speed", "motor.omega",
            "--settle", "0.01", "--revolutions", "1", "--steady-tol", "0", "--workers", "0", "--out", str(tmp_path)]
    assert main(["-q"] + args) == 0
    assert main(["-q"] + args + ["--coupling", "explicit"]) == 0
    assert "reused" not in capsys.readouterr().out
    rows = {}
    for name in ("double_cardan_brutti_rigid_sweep", "double_cardan_brutti_rigid_explicit_sweep"):
        with open(tmp_path / f"{name}.csv", newline="") as f:
            rows[name] = [r for r in csv.DictReader(f) if not r[next(iter(r))].startswith("#")]
    own, explicit = rows["double_cardan_brutti_rigid_sweep"], rows["double_cardan_brutti_rigid_explicit_sweep"]
    assert [r["coupling"] for r in own] == ["implicit"] and [r["coupling"] for r in explicit] == ["explicit"]
    assert float(explicit[0]["driveline.tau_in.max"]) == pytest.approx(float(own[0]["driveline.tau_in.max"]),
                                                                        rel=1e-6)


def test_another_grid_under_the_same_name_is_refused_and_a_rerun_says_what_it_reused(fmu_dir, tmp_path, capsys):
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--output", "driveline.tau_in", "--running-speed", "motor.omega", "--settle", "0.01",
            "--revolutions", "1", "--workers", "0", "--out", str(tmp_path), "--no-plot"]
    assert main(args + ["--param", "motor.omega_set=1000,2000rpm"]) == 0
    csv_text = (tmp_path / "double_cardan_brutti_rigid_sweep.csv").read_text()
    capsys.readouterr()
    assert main(args + ["--param", "motor.omega_set=1000,2000rpm"]) == 0
    assert "reused 2 of 2 points" in capsys.readouterr().out
    # another grid: refused, the first grid's table untouched; under its own name it runs beside it
    assert main(args + ["--param", "motor.omega_set=1500rpm"]) == 2
    err = capsys.readouterr().err
    assert "over another grid" in err and "--name" in err
    assert (tmp_path / "double_cardan_brutti_rigid_sweep.csv").read_text() == csv_text
    assert main(args + ["--param", "motor.omega_set=1500rpm", "--name", "other"]) == 0
    assert (tmp_path / "double_cardan_brutti_rigid_sweep.csv").read_text() == csv_text
    with open(tmp_path / "other.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and float(rows[0]["motor.omega_set"]) == pytest.approx(1500 * RPM)


def test_a_grid_made_finer_takes_over_the_journal_with_extend_and_reuses_its_points(fmu_dir, tmp_path, capsys):
    """Small first, then bigger: a DOE engineer's second grid over the same parameter had been refused, and all its
    points computed again under another name. --extend takes the journal over: the points on the new grid are
    reused, the table and a plain rerun are the new grid's; a grid over other parameters is still refused."""
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--output", "driveline.tau_in", "--running-speed", "motor.omega", "--settle", "0.01",
            "--revolutions", "1", "--workers", "0", "--out", str(tmp_path), "--no-plot"]
    assert main(args + ["--param", "motor.omega_set=1000,2000rpm"]) == 0
    first = {r["motor.omega_set"]: r for r in csv.DictReader(open(tmp_path / "double_cardan_brutti_rigid_sweep.csv"))}
    capsys.readouterr()
    finer = ["--param", "motor.omega_set=1000,1500,2000rpm"]
    assert main(args + finer) == 2
    assert "--extend (Sweep.run(extend=True)) reuses its points on this one" in capsys.readouterr().err
    assert main(args + ["--param", "load.c2=0.02", "--extend"]) == 2
    assert "over other parameters (motor.omega_set): --extend takes over" in capsys.readouterr().err
    assert main(args + finer + ["--extend"]) == 0
    assert "reused 2 of 3 points" in capsys.readouterr().out
    rows = list(csv.DictReader(open(tmp_path / "double_cardan_brutti_rigid_sweep.csv")))
    assert [float(r["motor.omega_set"]) for r in rows] == pytest.approx([1000 * RPM, 1500 * RPM, 2000 * RPM])
    assert rows[0] == first[rows[0]["motor.omega_set"]] and rows[2] == first[rows[2]["motor.omega_set"]]
    assert main(args + finer) == 0   # the journal is the new grid's now
    assert "reused 3 of 3 points" in capsys.readouterr().out
    # a span made finer: its points meet the coarser span's, whatever the last bits of start + k step
    loads = args + ["--name", "loads"]
    assert main(loads + ["--param", "load.T0=0.1:0.7:0.3"]) == 0   # 0.1 + 2 x 0.3 = 0.7
    capsys.readouterr()
    assert main(loads + ["--param", "load.T0=0.1:0.7:0.1", "--extend"]) == 0   # 0.1 + 6 x 0.1 = 0.7000000000000001
    assert "reused 3 of 7 points" in capsys.readouterr().out
    # the step check's own journal (one point, the peak) follows a peak the wider grid moves
    checked = args + ["--name", "checked", "--check-step"]
    assert main(checked + ["--param", "motor.omega_set=1000,2000rpm"]) == 0
    assert main(checked + ["--param", "motor.omega_set=1000,2000,3000rpm", "--extend"]) == 0


def test_the_same_grid_with_its_axes_in_another_order_reuses_its_points(fmu_dir, tmp_path, capsys):
    """A grid is its points: the same two axes given the other way round reuse every point (they were refused as
    another grid), and the table follows the order given (its first column, its rows)."""
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
            "--output", "driveline.tau_in", "--running-speed", "motor.omega", "--settle", "0.01",
            "--revolutions", "1", "--workers", "0", "--out", str(tmp_path), "--no-plot"]
    speeds, loads = ["--param", "motor.omega_set=1000,2000rpm"], ["--param", "load.c2=0.017,0.02"]
    assert main(args + speeds + loads) == 0
    capsys.readouterr()
    assert main(args + loads + speeds) == 0
    assert "reused 4 of 4 points" in capsys.readouterr().out
    with open(tmp_path / "double_cardan_brutti_rigid_sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[:2] == ["load.c2", "motor.omega_set"]
    assert [float(r["load.c2"]) for r in rows] == [0.017, 0.017, 0.02, 0.02]
    # fan torque c w^2 at each point, whichever order computed it
    assert all(float(r["driveline.tau_in.mean"]) == pytest.approx(float(r["load.c2"])
                                                                   * float(r["motor.omega_set"]) ** 2, rel=2e-5)
               for r in rows)


def test_table_is_flat_like_the_csv(brutti, tmp_path, fmu_dir):
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000rpm")
    sweep.run(workers=0)
    with open(sweep.csv) as f:
        header = next(csv.reader(f))
    row = sweep.table()[0]
    assert set(header) <= set(row) and row["motor.omega_set"] == pytest.approx(1000 * RPM)


def test_a_columns_file_gives_every_column_its_unit(brutti, tmp_path, fmu_dir):
    """Beside the CSV, ``<name>.columns.csv`` lists every column of the table with its unit and meaning: the swept
    speed in rad/s (given in rpm), the input torque's figures and orders in N.m, the settle time in s; every row
    says the communication step and coupling it was run with (a table merged from sweeps at other steps keeps
    them)."""
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000rpm")
    sweep.run(workers=0)
    with open(sweep.csv) as f:
        header = next(csv.reader(f))
    with open(tmp_path / "double_cardan_brutti_rigid_sweep.columns.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["column"] for r in rows] == header
    units = {r["column"]: r["unit"] for r in rows}
    assert units["motor.omega_set"] == "rad/s" and units["speed_mean"] == "rad/s" and units["settled_s"] == "s"
    assert {units[f"driveline.tau_in.{f}"] for f in ("max", "min", "p2p", "mean", "rms", "h1", "h2", "h4")} == {"N.m"}
    assert all(r["meaning"] for r in rows)
    assert units["step_size"] == "s"
    with open(sweep.csv) as f:
        row = next(csv.DictReader(f))
    assert float(row["step_size"]) == brutti.step_size and row["coupling"] == brutti.coupling
    assert sweep.table()[0]["step_size"] == brutti.step_size


def test_order_phases_refer_to_the_running_shafts_own_angle(tmp_path, fmu_dir):
    """An ideal 30 deg joint behind an ideal source: omega_out(phi) = omega cos b / (1 - sin^2 b cos^2 phi) is even
    in the joint's input angle phi with its largest value at phi = 0, so its 2x and 4x orders have phase 0 against
    phi. Started at phi_in_start = 0.3 rad, phi = motor.phi + 0.3, and against the motor's angle (the running
    angle of motor.omega) the phases are -2 (0.3) and -4 (0.3): a Bode or polar plot needs them referred to the
    shaft, not to where the window happened to start (an NVH trial had amplitudes only). In rad, in the columns
    file."""
    # at 50 rad/s the window starts at a motor angle no whole turn of any order (600 rpm's 4 pi had hidden a sign)
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml").with_parameters(
        {"joint.bend_angle": math.radians(30.0), "joint.error_angle_beta": 0.0, "joint.error_angle_gamma": 0.0,
         "motor.omega_set": 50.0})
    def swept(output, speed, starts, name):
        """The sweep of output over the joint's start angles, its orders against the angle of speed's shaft."""
        settings = SweepSettings.from_scenario(scenario, outputs=[output], running_speed=speed, settle_time=0.2)
        sweep = Sweep(scenario, [parse_axis(f"joint.phi_in_start={starts}", scenario)], settings, out_dir=tmp_path,
                      name=name, fmu_dir=fmu_dir)
        sweep.run(workers=0)
        return settings.running_angle, sweep.table()
    angle, rows = swept("joint.omega_out", "motor.omega", "0,0.3", "phases")
    assert angle == "motor.phi"
    for row in rows:
        start = row["point"]["joint.phi_in_start"]
        for k in (2, 4):
            assert row[f"joint.omega_out.ph{k}"] == pytest.approx(math.remainder(-k * start, 2 * math.pi), abs=1e-5)
    with open(tmp_path / "phases.columns.csv") as f:
        units = {r["column"]: r["unit"] for r in csv.DictReader(f)}
    assert units["joint.omega_out.ph2"] == "rad"
    assert all(math.isnan(row["joint.omega_out.ph1"]) for row in rows)   # a 1x of round-off: no phase
    # against the joint's own output angle (joint.omega_out's shaft), whose 2x ripple a plain mean of the angle's
    # offset had let into the phases (up to 0.03 rad, a reviewer's find): the input torque's 2x, even in that
    # angle, has phase 0 whatever the start
    angle, rows = swept("joint.tau_in", "joint.omega_out", "0,0.3,1,2", "output_phases")
    assert angle == "joint.phi_out"
    assert [row["joint.tau_in.ph2"] for row in rows] == pytest.approx([0.0] * 4, abs=1e-5)


def ring_sweep(tmp_path, fmu_dir, specs, name, **settings):
    scenario = Scenario(SCENARIOS / "ring_coupling_fig3.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["coupling.x_e"], running_speed="motor.omega",
                                           **{"revolutions": 2, **settings})
    return Sweep(scenario, [parse_axis(spec, scenario) for spec in specs], settings, out_dir=tmp_path, name=name,
                 fmu_dir=fmu_dir)


def test_the_settle_time_is_extended_until_the_point_is_steady(tmp_path, fmu_dir):
    """A damped ring (c_s = 20 N.m/rad, c_d = 0.5 N.m.s/rad on I2 = 0.05 kg.m^2: its free oscillation decays as
    exp(-5 t)) is far from steady after the 0.5 s asked for: the check extends the settle time until the figures
    at 3T/4 and T agree, and the figures are then those of a run settled 8 s (oracle), the mean included (a fit,
    not a sample mean, so it does not depend on where the window's ends fall)."""
    quick = ring_sweep(tmp_path, fmu_dir, ["coupling.c_s=20", "coupling.c_d=0.5"], "quick", settle_time=0.5)
    quick.run(workers=0, progress=False)
    long = ring_sweep(tmp_path, fmu_dir, ["coupling.c_s=20", "coupling.c_d=0.5"], "long", settle_time=8.0,
                      steady_tol=0.0)
    long.run(workers=0, progress=False)
    (q,), (r,) = quick.table(), long.table()
    assert q["status"] == "ok" and q["error"] == "" and q["steady_change"] <= 1e-3
    assert q["settled_s"] > 2.0 and math.isnan(r["steady_change"]) and r["settled_s"] == pytest.approx(8.0)
    assert q["coupling.x_e.h2"] == pytest.approx(r["coupling.x_e.h2"], rel=1e-6)
    assert q["coupling.x_e.mean"] == pytest.approx(r["coupling.x_e.mean"], abs=1e-5 * r["coupling.x_e.h2"])


def test_a_response_that_never_settles_is_not_steady_and_kept(tmp_path, fmu_dir):
    """The undamped pendulum ring has no steady state: its mean unevenness keeps drifting (about 1% of itself per
    second, its own slow libration, not locked to the running speed). The point is 'not_steady' at the cap (the
    settle time grows 1.5x to max_settle_time itself: it had stopped at 3.375 s of 4), with its figures and the
    reason, and a rerun does not recompute it (the result is final for these settings)."""
    sweep = ring_sweep(tmp_path, fmu_dir, ["coupling.e=0.001"], "pendulum", settle_time=1.0, max_settle_time=4.0,
                       revolutions=1)
    sweep.run(workers=0, progress=False)
    (r,) = sweep.table()
    assert r["status"] == "not_steady" and r["steady_change"] > 1e-3 and r["coupling.x_e.h2"] > 0
    assert "not steady after" in r["error"] and "max_settle_time" in r["error"]
    assert 4.0 - 1e-3 <= r["settled_s"] <= 4.0 + 2 * math.pi / 100.0   # the last window starts at the cap
    with open(sweep.csv) as f:
        (row,) = list(csv.DictReader(f))
    assert row["status"] == "not_steady" and float(row["coupling.x_e.h2"]) == r["coupling.x_e.h2"]
    lines = sweep.journal.read_text().splitlines()
    ring_sweep(tmp_path, fmu_dir, ["coupling.e=0.001"], "pendulum", settle_time=1.0, max_settle_time=4.0,
               revolutions=1).run(workers=0, progress=False)
    assert sweep.journal.read_text().splitlines() == lines


@pytest.mark.parametrize("cap", [0.2, 0.26, 0.4])
def test_a_not_steady_message_states_the_settle_time_used_and_why_it_passed_max_settle_time(tmp_path, fmu_dir, cap):
    """The criterion needs a settle time of at least four measurement windows (1 revolution at 100 rad/s: 63 steps
    of 1 ms) and lays whole windows back to back: with max_settle_time 0.2 s (under four windows) or 0.26 s (the
    last window starts past it, as with 0.4 s, which the settle time reaches in its last growth) the message gives
    the settle time actually used (settled_s) and says why it is past the maximum."""
    sweep = ring_sweep(tmp_path, fmu_dir, ["coupling.e=0.001"], f"cap{cap}", settle_time=0.1, max_settle_time=cap,
                       revolutions=1, steady_tol=1e-12)
    sweep.run(workers=0, progress=False)
    (r,) = sweep.table()
    window = 0.063
    assert r["status"] == "not_steady" and r["settled_s"] >= 4 * window - 1e-9
    assert r["error"].startswith(f"not steady after {r['settled_s']:.4g} s of settling")
    assert r["settled_s"] > cap
    if 4 * window > cap:
        assert f"past max_settle_time = {cap:g} s because the check needs a settle time of at least four " \
               f"measurement windows of 1 revolution of motor.omega ({window:.3g} s each)" in r["error"]
        assert f"above {4 * window:.3g} s" in r["error"] and cap == 0.2
    else:
        assert f"past max_settle_time = {cap:g} s by {r['settled_s'] - cap:.3g} s because the check lays whole " \
               "measurement windows" in r["error"] and cap in (0.26, 0.4)
        assert r["settled_s"] - cap < 2 * window


@pytest.mark.parametrize("revolutions", [2.0, 2.37])
def test_rms_is_the_mean_and_orders_by_parseval_wherever_the_window_ends(revolutions):
    """A signal 0.054 + 2e-4 cos(2 theta) + 1e-4 cos(4 theta): its RMS is sqrt(c0^2 + (a2^2 + a4^2) / 2) whether
    the window holds whole revolutions or not, and never below |mean| (the samples' own RMS over 2.37 revolutions
    with both ends is not: a sweep had shown rms < |mean|)."""
    from ujfmu.steady import Window, figures
    angle = np.linspace(0.0, revolutions * 2.0 * np.pi, 176)
    y = 0.054 + 2e-4 * np.cos(2.0 * angle) + 1e-4 * np.cos(4.0 * angle)
    table = np.rec.fromarrays([angle / 100.0, y], names="time,x")
    out = figures(Window(0.0, angle, table), ["x"], (2, 4))
    assert out["x.mean"] == pytest.approx(0.054, rel=1e-12) and out["x.h2"] == pytest.approx(2e-4, rel=1e-9)
    assert out["x.rms"] == pytest.approx(math.sqrt(0.054 ** 2 + (2e-4 ** 2 + 1e-4 ** 2) / 2.0), rel=1e-12)
    assert out["x.rms"] ** 2 - out["x.mean"] ** 2 == pytest.approx((2e-4 ** 2 + 1e-4 ** 2) / 2.0, rel=1e-6)


def test_rms_keeps_the_vibration_above_the_fitted_orders():
    """1 + 0.5 cos(2 theta) + 0.3 cos(12 theta) reduced with orders (1, 2): the 12x lies above the orders the fit
    takes, and the RMS still holds it, sqrt(1 + 0.5^2 / 2 + 0.3^2 / 2) (Parseval), through the mean square the fit
    leaves; without it the vibration's share, rms^2 - mean^2, reads 26% low."""
    from ujfmu.steady import Window, figures
    angle = np.linspace(0.0, 4 * 2.0 * np.pi, 800, endpoint=False)
    y = 1.0 + 0.5 * np.cos(2.0 * angle) + 0.3 * np.cos(12.0 * angle)
    out = figures(Window(0.0, angle, np.rec.fromarrays([angle / 100.0, y], names="time,x")), ["x"], (1, 2))
    assert out["x.h2"] == pytest.approx(0.5, rel=1e-9) and out["x.h1"] == pytest.approx(0.0, abs=1e-9)
    assert out["x.rms"] == pytest.approx(math.sqrt(1.0 + 0.125 + 0.045), rel=1e-9)


@pytest.mark.parametrize("spec, values", [("driveline.beta1=0:0.3:0.1", [0.0, 0.1, 0.2, 0.3]),
                                          ("driveline.beta1=0.1:0.7:0.2", [0.1, 0.3, 0.5, 0.7])])
def test_a_range_keeps_its_stop_through_the_steps_rounding(brutti, spec, values):
    """(0.3 - 0) / 0.1 is 2.9999999999999996 in floating point: the range still ends at its stop, 4 values, not 3
    with a refusal that the stop is not a whole number of steps from the start."""
    assert parse_axis(spec, brutti).values == pytest.approx(values, abs=1e-15)


def test_extremes_read_too_few_times_a_period_are_noted_with_the_step_that_reads_them(brutti, tmp_path, fmu_dir):
    """The rigid driveline's tau_in is shaped by its 2x order. At a 1 ms step it is read 10 times a period at 3000
    rpm, where a sampled extreme may miss the peak by 1 - cos(pi / 10) of the amplitude, 4.7%: the point's note
    says so with the step that reads it within 1%, and the p2p does fall short of twice the (exact) amplitude;
    at 500 rpm (60 reads a period, 0.14%) there is no note."""
    brutti.step_size = 1e-3
    settings = SweepSettings.from_scenario(brutti, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=2, steady_tol=0.0)
    sweep = Sweep(brutti, [parse_axis("motor.omega_set=500,3000rpm", brutti)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0)
    slow, fast = sweep.table()
    assert slow["note"] == "" and sweep.coarse_peaks() == [fast]
    reads = 2.0 * math.pi / (3000 * RPM * 1e-3) / 2.0
    assert (f"driveline.tau_in's 2x order is read {reads:.3g} times a period, so they may fall short of its peaks by "
            f"up to {100 * (1 - math.cos(math.pi / reads)):.2g}% of its amplitude") in fast["note"]
    step = 2.0 * math.pi / (3000 * RPM * 2) * math.acos(0.99) / math.pi
    assert f"a step of at most {step:.3g} s (--step)" in fast["note"]
    assert 0.01 < 1.0 - fast["driveline.tau_in.p2p"] / (2.0 * fast["driveline.tau_in.h2"]) < 0.047


def test_a_point_not_steady_for_its_aliases_names_the_step_as_the_remedy(tmp_path, fmu_dir):
    """Omar's driveline at 7000 rpm and 1 ms: 9 samples a revolution, the 2x and 4x orders unresolved, and the
    misalignment's 1x (8.7e-11 rad) takes their aliases, which differ between windows: not steady by its cap. The
    message says the step is the likelier remedy (it had said only to raise max_settle_time); at 0.2 ms the same
    point is steady."""
    scenario = Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")
    rows = {}
    for h in (1e-3, 2e-4):
        scenario.step_size = h
        settings = SweepSettings.from_scenario(scenario, settle_time=1.9)
        sweep = Sweep(scenario, [parse_axis("motor.omega_set=7000rpm", scenario)], settings, out_dir=tmp_path,
                      name=f"h{h:g}", fmu_dir=fmu_dir)
        sweep.run(workers=0, progress=False)
        (rows[h],) = sweep.table()
    assert rows[1e-3]["status"] == "not_steady" and rows[2e-4]["status"] == "ok"
    assert ("but at this step the fit reaches only order 3 (9.05 samples a revolution)" in rows[1e-3]["error"]
            and "a smaller step (--step: the note gives one) is the likelier remedy" in rows[1e-3]["error"])


def test_the_steady_state_change_names_the_order_and_what_it_is_relative_to():
    """Window figures [mean, 1x, 2x]: a 1x amplitude below 1% of the signal's size is judged against that 1%
    (FLOOR), and the verdict says so, with the order; a large figure is judged against itself."""
    from ujfmu.steady import FLOOR, Periodic, steady_change
    old = {"x": Periodic([2.0, 1e-8, 0.5], 2.0)}
    change, name, against = steady_change({"x": Periodic([2.0, 3e-8, 0.5], 2.0)}, old, (1, 2))
    assert change == pytest.approx(2e-8 / (FLOOR * 2.0)) and name == "x 1x order amplitude"
    assert against == (f"0.02, {FLOOR:g} of the signal's size 2 (its largest figure, or half its peak-to-peak), as "
                       "the figure itself is smaller (3e-08; the change 2e-08)")
    change, name, against = steady_change({"x": Periodic([2.0, 1e-8, 0.6], 2.0)}, old, (1, 2))
    assert change == pytest.approx(0.1 / 0.6)
    assert (name, against) == ("x 2x order amplitude", "itself (0.6; the change 0.1)")


def test_a_change_within_the_implicit_couplings_noise_is_no_change():
    """The implicit scheme stops iterating within COUPLING_RTOL (3e-4) of a torn input's value, so a window's figures
    move by a fraction of that (FIGURE_NOISE: a tenth) of their signal's size with no change of the motion: a truck
    driveline's 1x order of 0.0098 N.m (1e-5 of its 998 N.m torque, absent from the monolithic solve) wandered by
    0.019 N.m and failed steady points at any settle time. Within the noise it is no change; beyond it, and
    always for the explicit scheme (noise 0), it counts as before."""
    from ujfmu.master import COUPLING_RTOL
    from ujfmu.steady import FIGURE_NOISE, Periodic, coupling_noise, steady_change
    noise = coupling_noise(True)
    assert noise == FIGURE_NOISE * COUPLING_RTOL == pytest.approx(3e-5)
    assert coupling_noise(False) == 0.0
    old = {"torque": Periodic([998.0, 0.0098, 19.5], 998.0)}
    wandered = {"torque": Periodic([998.0, 0.0292, 19.5], 998.0)}
    assert steady_change(wandered, old, (1, 2), noise)[0] == 0.0
    assert steady_change(wandered, old, (1, 2))[0] == pytest.approx(0.0194 / 9.98)
    moved = {"torque": Periodic([998.0, 0.0098, 19.54], 998.0)}   # 0.04 N.m: past the noise, 2e-3 of itself
    assert steady_change(moved, old, (1, 2), noise)[0] == pytest.approx(0.04 / 19.54)


@pytest.mark.parametrize("drift", [0.0, 0.01])
def test_an_order_the_step_does_not_resolve_still_counts_toward_the_signals_size(drift):
    """A ring coupling's misalignment moment at 150 rad/s read every 5 ms: 8.4 samples a revolution, so its 2x
    (3.28 N.m, mean 0) is unresolved and left out of the figures; the 1x that remains is round-off, 1e-8, and
    differs by 30% between the record's halves. Judged against its own size it had failed the steady check (0.3
    of itself); the signal's size counts the 2x (half its peak-to-peak), so the noise is far within 1e-3 of it. A
    mean that drifts by 1% of the amplitude between the halves is still caught."""
    from ujfmu.steady import halves_change, unresolved_orders, Window
    t = np.arange(400) * 5e-3
    angle = 150.0 * t
    second = t >= t[200]
    y = 3.28 * np.cos(2 * angle + 0.3) + 1e-8 * np.where(second, 1.3, 1.0) * np.cos(angle) \
        + np.where(second, drift * 3.28, 0.0)
    table = np.rec.fromarrays([t, y], names="time,m")
    assert unresolved_orders(Window(0.0, angle, table), (1, 2, 4)) == (2, 4)
    change, name, _ = halves_change(angle, table, ["m"])
    if drift:
        assert change > 0.5 and name == "m mean"
    else:
        assert change < 1e-3, (change, name)


def test_a_drive_that_misses_its_set_speed_is_off_target(fmu_dir, tmp_path, capsys):
    """cardan_startup at a constant 150 rad/s set point: with its 5 N.m torque limit the PI motor holds it; limited
    to 0.25 N.m against the load 0.2 + 4e-6 w^2 N.m it settles where they balance, w = sqrt(0.05 / 4e-6) = 112 rad/s,
    and that point is 'off_target', naming the speed and its set point; the CLI summary counts both statuses and
    exits 1."""
    scenario = str(SCENARIOS / "cardan_startup.toml")
    args = ["--fmu-dir", str(fmu_dir), "sweep", scenario, "--param", "motor.profile=0", "--param",
            "motor.tau_max=0.25,5", "--output", "joint.tau_in", "--running-speed", "motor.omega", "--settle", "3",
            "--max-settle", "3", "--revolutions", "2", "--workers", "0", "--out", str(tmp_path), "--no-progress",
            "--no-plot"]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "2 points: 1 ok (steady at the operating point), 1 off_target (operating point not reached)" in err
    assert "point motor.profile = 0, motor.tau_max = 0.25 N.m: off_target:" in err   # the point with its units
    with open(tmp_path / "cardan_startup_sweep.csv") as f:
        low, high = list(csv.DictReader(f))
    assert high["status"] == "ok" and float(high["speed_mean"]) == pytest.approx(150.0, rel=1e-3)
    assert low["status"] == "off_target"
    assert float(low["speed_mean"]) == pytest.approx(math.sqrt(0.05 / 4e-6), rel=0.01)
    assert "motor.omega = 11" in low["error"] and "set point motor.omega_ref = 150 rad/s (1432.39 rpm)" in low["error"]
    reached = float(low["error"].split("motor.omega = ")[1].split()[0])   # in SI, then in rpm
    assert f"motor.omega = {reached:.6g} rad/s ({reached * 30 / math.pi:.6g} rpm) (mean)" in low["error"]


def test_points_are_reused_by_the_same_code_and_fmu_builds_only(brutti, tmp_path, fmu_dir, monkeypatch):
    """A journal's points are reused by a rerun of the same code on FMUs of the same build, also rebuilt (the FMU
    files differ in their time stamps only: built with another SOURCE_DATE_EPOCH); another version of the
    master-side code or another FMU build computes them again."""
    import shutil

    import ujfmu.sweep
    from ujfmu.build import build_fmu
    brutti_sweep(brutti, tmp_path, fmu_dir).run(workers=0, progress=False)
    rebuilt = tmp_path / "rebuilt"
    shutil.copytree(fmu_dir, rebuilt)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    build_fmu("Load", rebuilt)   # the same sources built again, dated otherwise: other bytes, the same build digest
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    assert (rebuilt / "Load.fmu").read_bytes() != (fmu_dir / "Load.fmu").read_bytes()
    assert len(brutti_sweep(brutti, tmp_path, rebuilt).done()) == 3
    # another build of the Load: its runtime package carries another source hash
    blob = (fmu_dir / "Load.fmu").read_bytes()
    digest = ujfmu.sweep.fmu_build_digest(blob)
    assert digest.startswith("ujfmu_load_")
    real = ujfmu.sweep.fmu_build_digest
    monkeypatch.setattr(ujfmu.sweep, "fmu_build_digest", lambda b: "other" if b == blob else real(b))
    assert brutti_sweep(brutti, tmp_path, fmu_dir).done() == {}
    monkeypatch.undo()
    # the master-side code changed (a new ujfmu version, or an edited master.py, steady.py, ...)
    monkeypatch.setattr(ujfmu.sweep, "code_digest", lambda: "0" * 16)
    assert brutti_sweep(brutti, tmp_path, fmu_dir).done() == {}


def test_the_code_digest_follows_the_sources_that_compute_a_point(tmp_path, monkeypatch):
    import shutil

    import ujfmu
    from ujfmu.sweep import POINT_CODE, code_digest
    package = Path(ujfmu.__file__).parent
    for name in POINT_CODE:
        shutil.copy(package / name, tmp_path / name)
    assert code_digest(tmp_path) == code_digest(package)
    with open(tmp_path / "steady.py", "a") as f:
        f.write("\nGROWTH = 2.0\n")
    assert code_digest(tmp_path) != code_digest(package)
    before = code_digest(package)
    monkeypatch.setattr(ujfmu, "__version__", "0.0.0")
    assert code_digest(package) != before


def test_a_motor_controller_is_checked_at_its_operating_point_by_default():
    """A torque-driven wiring's drive (MotorController) is held to its set point as a Motor is."""
    from ujfmu.scenario import Scenario
    from ujfmu.sweep import SweepSettings
    scenario = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["joint.tau_input_shaft"],
                                           running_speed="joint.omega_in", settle_time=1.0)
    assert settings.operating_point == (("motor.omega", "motor.omega_ref"),)


@pytest.mark.parametrize("signum, status, said", [(2, 130, "interrupted"), (15, 143, "terminated (SIGTERM)")])
def test_ctrl_c_or_sigterm_stops_an_in_process_sweep_with_its_points_kept(fmu_dir, tmp_path, signum, status, said):
    """Ctrl-C during `ujfmu sweep --workers 0`: the interrupt had been raised inside the FMU's Python code, which
    reported it as its fatal error, so the point was journalled as failed and the sweep went on to its end. Now it
    stops at the next communication step with one line naming the journal, exit status 130, and the journal holds
    only finished points (none failed). A batch scheduler's SIGTERM (a job over its time) had killed the process
    without the table; it now stops the same way, with exit status 143 (128 + 15, as a shell reports it)."""
    import subprocess
    out = tmp_path / "out"
    journal = out / "interrupted.jsonl"
    process = subprocess.Popen([sys.executable, "-m", "ujfmu", "--fmu-dir", str(fmu_dir), "sweep",
                                str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--param",
                                "motor.omega_set=600:1200:10rpm", "--workers", "0", "--out", str(out),
                                "--name", "interrupted", "--no-plot", "--quiet"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for _ in range(2400):   # until two points are journalled (or the sweep ended: then the asserts below say so)
        if journal.is_file() and journal.read_text().count("\n") >= 2:
            break
        try:
            process.wait(timeout=0.05)
            break
        except subprocess.TimeoutExpired:
            pass
    process.send_signal(signum)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == status, (stdout, stderr)
    records = [json.loads(line) for line in journal.read_text().splitlines()]
    assert 2 <= len(records) < 61 and all(r["status"] == "ok" for r in records), records
    assert f"{said}; {len(records)} of 61 points are in {journal} and in {out / 'interrupted.csv'}" in stderr
    assert "Traceback" not in stderr
    with open(out / "interrupted.csv") as f:   # the table so far, the points not run marked
        statuses = [row["status"] for row in csv.DictReader(f)]
    assert statuses.count("ok") == len(records) and statuses.count("missing") == 61 - len(records)


def test_a_misspelled_sweep_setting_from_python_is_refused_not_ignored():
    """SweepSettings.from_scenario(settle=..., revolutoins=...) had run with the scenario's settle time and 2
    revolutions: each unknown keyword is named with the setting it resembles."""
    path = Path(__file__).parent.parent / "scenarios" / "double_cardan_omar_torsional.toml"
    with pytest.raises(ScenarioError) as info:
        SweepSettings.from_scenario(path, settle=0.5, revolutoins=10)
    text = str(info.value)
    assert "no setting 'revolutoins' (did you mean 'revolutions'?)" in text
    assert "no setting 'settle' (did you mean 'settle_time'?)" in text
    settings = SweepSettings.from_scenario(path, settle_time=0.5, revolutions=10)
    assert (settings.settle_time, settings.revolutions) == (0.5, 10.0)


def test_a_points_fmu_warnings_are_kept_and_a_failed_point_has_every_column(tmp_path, fmu_dir):
    """Ring coupling at 100 rad/s over e = 3 mm (the paper's), 50 mm (half the ring radius: the FMU warns that the
    e^2 law is outside what the paper establishes) and 0.2 m (beyond R: the FMU refuses it). The warning is in
    the point's "warnings" (table and CSV), not lost; the failed point's figures are NaN in the table, so a loop
    over the rows does not stop at a KeyError."""
    ring = Scenario(SCENARIOS / "ring_coupling_fig3.toml")
    settings = SweepSettings.from_scenario(ring, outputs=["coupling.x_e"], running_speed="motor.omega",
                                           settle_time=0.02, revolutions=2, steady_tol=0.0)
    sweep = Sweep(ring, [parse_axis("coupling.e=0.003,0.05,0.2", ring)], settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    paper, half, beyond = sweep.table()
    assert paper["status"] == half["status"] == "ok" and beyond["status"] == "error"
    assert paper["warnings"] == "" and "e = 0.05 m is 0.5 of the ring radius R = 0.1 m" in half["warnings"]
    assert "must be smaller than the ring radius" in beyond["error"] and math.isnan(beyond["coupling.x_e.h2"])
    assert math.isnan(beyond["speed_mean"]) and half["coupling.x_e.h2"] > paper["coupling.x_e.h2"] > 0.0
    with open(sweep.csv) as f:
        rows = list(csv.DictReader(f))
    assert "e = 0.05 m is 0.5 of the ring radius" in rows[1]["warnings"] and rows[0]["warnings"] == ""


def test_a_sweep_on_workers_without_dask_installed_names_the_extra(brutti, fmu_dir, tmp_path, monkeypatch):
    """The README's Python recipe in a plain install (no `sweep` extra) had stopped on a bare ModuleNotFoundError
    from inside Sweep.run: it names the extra and the in-process way, before any point runs; workers=0 runs."""
    from ujfmu.extras import MissingExtraError
    monkeypatch.setitem(sys.modules, "distributed", None)   # import distributed -> ImportError
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, "motor.omega_set=100", "nodask")
    with pytest.raises(MissingExtraError, match=r"workers=0.*pip install 'ujfmu\[sweep\]'"):
        sweep.run()
    assert not sweep.journal.exists()
    sweep.run(workers=0)
    assert [row["status"] for row in sweep.table()] == ["ok"]


def test_orders_are_fitted_against_the_running_angle_without_the_speeds_own_ripple():
    """A PI motor's speed carries the joints' 2x (here 0.16 rad/s at 86 rad/s: its angle wobbles by 9.3e-4 rad at
    2x), and a signal with a pure 2x of 3.48 in time: against the instantaneous angle the fit had found a false 4x
    (0.035 where an FFT gives 0) and a shifted mean (a fresh-eyes NVH trial); against running_angle, the quadratic
    through it, the 2x is 3.48, the 4x 0 and the mean the time mean, to 1e-4. A constant run-up's angle is kept."""
    from ujfmu.steady import Window, periodic_figures, running_angle
    t = np.arange(0.0, 0.5, 1e-3)
    mean_speed, ripple = 86.0, 0.16
    speed = mean_speed + ripple * np.cos(2.0 * mean_speed * t)
    signal = 85.87 + 3.48 * np.cos(2.0 * mean_speed * t - 0.4)
    table = np.rec.fromarrays([t, speed, signal], names=["time", "m.omega", "d.w"])
    angle = running_angle(t, speed)
    assert angle == pytest.approx(mean_speed * t, abs=2e-3)
    figures = periodic_figures(Window(0.0, angle, table), ["d.w"], (1, 2, 4))["d.w"].figures
    assert figures == pytest.approx([85.87, 0.0, 3.48, 0.0], abs=1e-4)
    wobbling = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))))
    assert periodic_figures(Window(0.0, wobbling, table), ["d.w"], (1, 2, 4))["d.w"].figures[3] > 3e-3
    run_up = 10.0 + 40.0 * t
    assert running_angle(t, run_up) == pytest.approx(10.0 * t + 20.0 * t * t, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("span", [0.4, 0.437, 1.0])
def test_the_running_angle_keeps_its_slope_over_a_window_of_no_whole_number_of_ripples(span):
    """A stiff torque-driven driveline's input speed: 60 rad/s with a 3.4 rad/s 2x ripple, and a shaft torque whose
    2x is 75 N.m about 9.5 (a fresh-eyes trial's). A quadratic alone through the angle took 2.2e-3 rad/s of slope
    from the ripple over such windows, leaked the 2x into a 1x of 0.06 N.m (the true one 6e-5) and failed a steady
    run's check; fitted with the ripple's orders the slope is exact to 1e-6 and the 1x and 3x vanish."""
    from ujfmu.steady import Window, periodic_figures, running_angle
    t = np.arange(0.0, span, 1e-3)
    speed = 60.0 + 3.4 * np.cos(120.0 * t + 0.7)
    torque = 9.5 + 75.0 * np.cos(120.0 * t - 0.3)   # periodic in time, as every signal of a steady run
    angle = running_angle(t, speed)
    assert np.polyfit(t, angle, 1)[0] == pytest.approx(60.0, abs=1e-6)
    table = np.rec.fromarrays([t, speed, torque], names=["time", "d.omega_in", "d.T"])
    mean, h1, h2, h3 = periodic_figures(Window(0.0, angle, table), ["d.T"], (1, 2, 3))["d.T"].figures
    assert mean == pytest.approx(9.5, abs=1e-4) and h2 == pytest.approx(75.0, rel=1e-6) and h1 < 1e-4 and h3 < 1e-4


PI_DRIVELINE = """
title = "Double Cardan Z, b1 = 8 deg, b2 = 4 deg, PI motor of 0.01 kg.m2, no load (a fresh-eyes NVH trial's)"
[experiment]
stop_time = 4.0
step_size = 1e-3
[components.motor]
fmu = "Motor"
parameters = { profile = 0, omega_set = 85.0, ideal_speed_source = false, J_rotor = 0.01, tau_max = 100.0 }
[components.driveline]
fmu = "DoubleCardanDriveline"
parameters = { beta1 = 0.13962634015954636, beta2 = 0.06981317008077318, xi_theta = 0.0005 }
[components.load]
fmu = "Load"
parameters = { T0 = 0.0, c1 = 0.0, c2 = 0.0, omega_smooth = 1e-3 }
[[connections]]
from = "motor.omega"
to = "driveline.omega_in"
[[connections]]
from = "driveline.tau_in"
to = "motor.tau_load"
[[connections]]
from = "driveline.omega_out"
to = "load.omega"
[[connections]]
from = "load.tau"
to = "driveline.tau_load"
[output]
record = ["motor.omega", "driveline.omega_out", "driveline.shaft_torque"]
running_speed = "motor.omega"
[sweep]
outputs = ["driveline.omega_out", "driveline.shaft_torque"]
running_speed = "motor.omega"
settle_time = 2.0
revolutions = 8
"""


@pytest.mark.parametrize("step, passed", [(5e-3, False), (1e-3, True)])
def test_the_step_check_flags_order_amplitudes_that_depend_on_the_step(tmp_path, fmu_dir, step, passed):
    """Near its 2x resonance (820 rpm) the PI-driven driveline's 2x amplitudes at a 5 ms step are 3% off those at
    2.5 ms (a fresh-eyes trial: up to 21% against its own solve, every point ok, the summary calling them exact):
    the step check at the sweep's peak estimates 2 |a(h) - a(h/2)| above 2% and fails; at 1 ms it is 0.2-0.6%."""
    (tmp_path / "pi.toml").write_text(PI_DRIVELINE)
    scenario = Scenario(tmp_path / "pi.toml")
    scenario.step_size = step
    settings = SweepSettings.from_scenario(scenario)
    sweep = Sweep(scenario, [parse_axis("motor.omega_set=800,820rpm", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    check = sweep.step_check()
    assert check.point == {"motor.omega_set": pytest.approx(820 * math.pi / 30)}
    assert [f[0] for f in check.figures] == ["driveline.omega_out.h2", "driveline.shaft_torque.h2"]
    assert check.passed is passed
    report = "\n".join(check.lines())   # no scenario needed, as stepsize.estimate's lines()
    assert ("HIGH driveline.omega_out.h2" in report) is not passed
    assert "motor.omega_set = 85.8702 rad/s (820 rpm)" in report   # the point in its unit, and in the one given
    assert (tmp_path / "pi_sweep_step_check.jsonl").is_file()


def test_the_sweep_summary_says_where_the_fmus_warned(tmp_path, fmu_dir, capsys):
    """A point whose FMU warned (the ring at e = 50 mm, half its radius) is counted in the summary with the first
    warning, not left to the CSV's warnings column under an all-ok line; a sweep without warnings says nothing."""
    def sweep(values, name):
        code = main(["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "ring_coupling_fig3.toml"), "--param",
                     f"coupling.e={values}", "--output", "coupling.x_e", "--running-speed", "motor.omega",
                     "--settle", "0.02", "--revolutions", "2", "--steady-tol", "0", "--name", name, "--out",
                     str(tmp_path), "--workers", "0", "--no-plot", "--no-progress"])
        return code, capsys.readouterr().out
    code, out = sweep("0.003,0.05", "warned")
    assert code == 0 and "the FMUs warned at 1 point (the CSV's warnings column)" in out
    assert "e = 0.05 m is 0.5 of the ring radius" in out
    code, out = sweep("0.003", "quiet")
    assert code == 0 and "warned" not in out


def test_a_sweep_of_the_same_name_running_now_is_refused(brutti, tmp_path, fmu_dir):
    """Two sweeps of one name into one folder at once had both run: two grids mixed in one journal (every later run
    refused) or every point computed twice, and the CSV the last finisher's. While one holds the lock (here this
    test, as another process would), a second is refused with the remedy, before it writes anything; once the lock
    is free it runs, and removes its lock file when it ends (they had stayed beside every table)."""
    import fcntl

    from ujfmu.sweep import SweepBusy
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000rpm")
    with open(tmp_path / "double_cardan_brutti_rigid_sweep.lock", "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(SweepBusy, match=r"another process is running a sweep into .* now.*--name"):
            sweep.run(workers=0)
        assert not sweep.journal.exists() and not sweep.csv.exists()
        fcntl.flock(held, fcntl.LOCK_UN)
    sweep.run(workers=0)
    assert [row["status"] for row in sweep.table()] == ["ok"]
    assert not (tmp_path / "double_cardan_brutti_rigid_sweep.lock").exists()


def test_a_table_that_cannot_be_written_leaves_the_last_one_whole(brutti, tmp_path, fmu_dir, monkeypatch):
    """A full disk while the CSV is rewritten had left a truncated table whose last number still read (5.1e-0 for
    5.1e-06) and a traceback: the table is written beside it and moved over it, so the last whole table stays; the
    error names the file and the system's reason, and the journal keeps the points for a rerun."""
    import errno

    import ujfmu.sweep as sweep_module
    from ujfmu.sweep import SweepWriteError
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000:2000:1000rpm")
    sweep.run(workers=0)
    before = sweep.csv.read_bytes()
    real = csv.writer

    class Full:
        def __init__(self, f):
            self.inner, self.rows = real(f), 0

        def writerow(self, row):
            self.rows += 1
            if self.rows == 2:
                raise OSError(errno.ENOSPC, "No space left on device")
            self.inner.writerow(row)

        def writerows(self, rows):
            for row in rows:
                self.writerow(row)
    monkeypatch.setattr(sweep_module.csv, "writer", Full)
    with pytest.raises(SweepWriteError, match=r"cannot write the table .*_sweep.csv: No space left on device"):
        sweep.write_csv()
    assert sweep.csv.read_bytes() == before and not list(tmp_path.glob("*.partial"))


def test_a_dask_sweep_whose_workers_are_all_gone_stops_with_the_reason(brutti, tmp_path, fmu_dir, monkeypatch):
    """Workers killed faster than they came back (kill -9 in a loop, an out-of-memory killer) had left a sweep
    waiting all night with no worker and no word: after NO_WORKERS_TIMEOUT without any worker it stops, naming the
    points left and the rerun that reuses the finished ones; while workers are there it waits on. A cluster that
    never had a worker says so and how to start them (it had been told its workers died)."""
    import ujfmu.sweep as sweep_module
    from ujfmu.sweep import SweepWorkersLost
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000:2000:1000rpm")

    class Unfinished:   # a point's future that never finishes
        def add_done_callback(self, callback):
            pass

        def done(self):
            return False

    class Client:   # a client whose workers are gone after `workers_for` checks
        def __init__(self, workers_for):
            self.checks, self.workers_for = 0, workers_for

        def register_plugin(self, plugin):
            pass

        def unregister_worker_plugin(self, name):
            pass

        def submit(self, *args, **kwargs):
            return Unfinished()

        def cancel(self, futures):
            self.cancelled = len(futures)

        def run(self, function, workers=None):   # the workers' check, here: this environment's answer
            return {"w": function()} if self.workers_for else {}

        def scheduler_info(self):
            self.checks += 1
            if self.checks > 100:   # a sweep that waits on (the bug) fails here instead of hanging the test
                raise AssertionError("still waiting after 100 checks without workers")
            return {"workers": {"w": {"nthreads": 1}} if self.checks <= self.workers_for else {}}

    monkeypatch.setattr(sweep_module, "WORKER_CHECK", 1e-3)
    monkeypatch.setattr(sweep_module, "NO_WORKERS_TIMEOUT", 0.0)
    client = Client(workers_for=5)
    with pytest.raises(SweepWorkersLost, match=r"no dask worker has been left .* with 2 of 2 points to run"):
        sweep._run_dask(sweep.points, lambda record: None, 2, None, client)
    # two before the points (threads, any worker yet), three waiting with workers, then the first without, then
    # the one past the timeout
    assert client.checks == 7
    assert client.cancelled == 2   # the points left do not run on when workers come back
    never = Client(workers_for=0)
    with pytest.raises(SweepWorkersLost, match=r"has had no worker since the sweep started .* start its workers "
                                               r"\(`dask worker ADDRESS --nworkers N --nthreads 1`"):
        sweep._run_dask(sweep.points, lambda record: None, 2, None, never)


def test_workers_that_cannot_run_the_points_are_refused_before_any_is_sent():
    """A cluster's worker without ujfmu, of other ujfmu code or of another Python is named with its remedy before
    the FMUs or points are sent (a worker without ujfmu had ended the sweep in an internal error); workers of
    several threads are said to gain nothing."""
    from ujfmu.sweep import SweepWorkersUnfit, check_workers

    class Client:
        def __init__(self, answers, nthreads=1):
            self.answers, self.nthreads = answers, nthreads

        def run(self, function, workers=None):
            here = function()
            return {address: answer or here for address, answer in self.answers.items()}

        def scheduler_info(self):
            return {"workers": {address: {"nthreads": self.nthreads, "status": "running"}
                                for address in self.answers}}

    python = list(sys.version_info[:2])
    assert check_workers(Client({"tcp://a:1": None})) == []
    assert "several threads (e.g. tcp://a:1)" in check_workers(Client({"tcp://a:1": None}, nthreads=2))[0]
    with pytest.raises(SweepWorkersUnfit) as refused:
        check_workers(Client({"tcp://a:1": None, "tcp://b:2": ("", python, "ModuleNotFoundError: No module named "
                                                                "'ujfmu'"),
                              "tcp://c:3": ("0123", python, ""), "tcp://d:4": ("0123", [python[0], 99], "")}))
    text = str(refused.value)
    assert "tcp://a:1" not in text and "tcp://b:2 cannot import ujfmu (ModuleNotFoundError" in text
    assert "tcp://c:3 runs other ujfmu code" in text and "tcp://d:4 runs Python 3.99" in text


def test_a_worker_stuck_in_its_start_is_not_waited_on_for_ever(monkeypatch):
    """A worker that could not unpickle a plugin as it started stays listed as closing and answers nothing: it is
    left out of the check; workers that do not answer within WORKER_PROBE_TIMEOUT are named (it had hung), and a
    check broken off names the error, not an internal one."""
    import threading

    from ujfmu.sweep import SweepWorkersUnfit, check_workers
    monkeypatch.setattr(sweep_module, "WORKER_PROBE_TIMEOUT", 1.0)   # the probe hashes the sources: give it time
    released = threading.Event()

    class Client:
        def __init__(self, statuses):
            self.statuses, self.asked = statuses, None

        def run(self, function, workers=None):
            self.asked = workers
            if "tcp://stuck:1" in workers:
                released.wait()
            return {address: function() for address in workers}

        def scheduler_info(self):
            return {"workers": {a: {"nthreads": 1, "status": s} for a, s in self.statuses.items()}}

    fine = Client({"tcp://a:1": "running", "tcp://closing:2": "closing"})
    assert check_workers(fine) == [] and fine.asked == ["tcp://a:1"]
    with pytest.raises(SweepWorkersUnfit, match=r"\(tcp://a:1, tcp://stuck:1\) did not answer ujfmu's check in "
                                                r"1 s: see their logs"):
        check_workers(Client({"tcp://a:1": "running", "tcp://stuck:1": "running"}))
    released.set()

    class Broken(Client):
        def run(self, function, workers=None):
            raise OSError("CommClosedError: in <TCP (closed)>")

    with pytest.raises(SweepWorkersUnfit, match=r"\(tcp://a:1\) could not be checked \(OSError: CommClosedError"):
        check_workers(Broken({"tcp://a:1": "running"}))


def test_the_fmu_plugin_is_removed_after_a_sweep_and_a_cluster_that_cannot_take_it_is_named(brutti, tmp_path,
                                                                                              fmu_dir, monkeypatch):
    """A sweep on a cluster not started here removes its FMU plugin as it ends, even when interrupted, and only its
    own (another sweep's on the same cluster has another name): a worker without ujfmu that joined later had been
    sent it, could not unpickle it and stayed stuck closing, and the next sweep's registration then ended in an
    internal error. A registration that fails or gets no answer is SweepWorkersUnfit naming the workers not
    running; a removal that fails or gets no answer is a warning, one of a plugin the scheduler does not hold
    nothing."""
    import threading
    import warnings

    from ujfmu.sweep import SweepWarning, SweepWorkersUnfit
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000:2000:1000rpm")
    monkeypatch.setattr(sweep_module, "PLUGIN_REMOVAL_TIMEOUT", 0.5)   # the fakes answer at once, or after 3 s
    monkeypatch.setattr(sweep_module, "WORKER_PROBE_TIMEOUT", 0.5)
    hung = threading.Event()

    class Future:
        def __init__(self, point):
            self.point = point

        def add_done_callback(self, callback):
            callback(self)

        def done(self):
            return True

        def result(self):
            return {"point": self.point}

    class Client:
        def __init__(self, register=None, unregister=None):
            self.plugins, self.removed = [], []
            self.register, self.unregister = register, unregister

        def register_plugin(self, plugin):
            self.plugins.append(plugin.name)
            if self.register == "hang":
                hung.wait(3.0)   # bounded: a sweep that waits for it fails below, not hangs
            elif self.register:
                raise self.register

        def unregister_worker_plugin(self, name):
            if self.unregister == "hang":
                hung.wait(3.0)   # bounded: a sweep that waits for it fails below, not hangs
            elif self.unregister:
                raise self.unregister
            self.removed.append(name)

        def submit(self, function, job, point, pure):
            return Future(point)

        def run(self, function, workers=None):
            return {"tcp://a:1": function()}

        def scheduler_info(self):
            return {"workers": {"tcp://a:1": {"nthreads": 1, "status": "running"},
                                "tcp://stuck:2": {"nthreads": 1, "status": "closing"}}}

    def run(client, keep=lambda record: None):
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            sweep._run_dask(sweep.points, keep, None, None, client)
        return [str(w.message) for w in said if issubclass(w.category, SweepWarning)]

    first, second = Client(), Client()
    assert run(first) == [] and run(second) == []
    assert first.removed == first.plugins and len(first.plugins) == 1 and first.plugins[0].startswith("ujfmu-fmus-")
    assert second.plugins != first.plugins   # each sweep's own name

    def interrupt(record):
        raise KeyboardInterrupt
    interrupted = Client()
    with pytest.raises(KeyboardInterrupt):
        run(interrupted, interrupt)
    assert interrupted.removed == interrupted.plugins

    for cause, said in ((OSError("CommClosedError: Stream is closed"), r"\(OSError: CommClosedError: Stream is "
                                                                      r"closed\)"),
                        ("hang", r"\(NoAnswer: no answer in 0.5 s\)")):
        with pytest.raises(SweepWorkersUnfit, match=r"the cluster could not install the sweep's FMUs on its workers "
                                                    + said + r"; not running: tcp://stuck:2 .*restart the cluster's "
                                                    r"workers, each in an environment with ujfmu installed"):
            run(Client(register=cause))
    assert run(Client(unregister=ValueError("The worker plugin ujfmu-fmus-x does not exist"))) == []
    for cause, said in ((OSError("Stream is closed"), "failed (OSError: Stream is closed): if the scheduler still "
                                                       "holds the plugin"),
                        ("hang", "was not confirmed in 0.5 s: a worker that answers nothing holds the scheduler's "
                                 "broadcast")):
        (warning,) = run(Client(unregister=cause))
        assert "removing the sweep's FMU plugin ujfmu-fmus-" in warning and said in warning
    # dask's own timeout is the call's error, not "no answer in" our time
    with pytest.raises(SweepWorkersUnfit, match=r"\(TimeoutError: dask's own\)"):
        run(Client(register=TimeoutError("dask's own")))
    hung.set()


def test_a_dask_sweep_on_a_shared_client_cancels_what_an_interruption_leaves(brutti, tmp_path, fmu_dir):
    """A point whose worker died is an error record naming it; a sweep interrupted on a client it shares (Ctrl-C
    while a point is kept) cancels its points not yet finished, which that cluster would otherwise run on."""
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1000:4000:1000rpm")

    class Future:
        def __init__(self, finished, result):
            self.finished, self.outcome = finished, result

        def add_done_callback(self, callback):
            if self.finished:
                callback(self)

        def done(self):
            return self.finished

        def result(self):
            if isinstance(self.outcome, Exception):
                raise self.outcome
            return self.outcome

    class Client:
        def __init__(self):
            self.made, self.cancelled = [], []

        def register_plugin(self, plugin):
            pass

        def unregister_worker_plugin(self, name):
            pass

        def submit(self, function, job, point, pure):
            n = len(self.made)
            future = Future(n < 2, RuntimeError("KilledWorker: the worker died") if n == 0 else {"point": point})
            self.made.append(future)
            return future

        def cancel(self, futures):
            self.cancelled += futures

        def run(self, function, workers=None):
            return {"w": function()}

        def scheduler_info(self):
            return {"workers": {"w": {"nthreads": 1}}}

    kept = []

    def keep(record):
        kept.append(record)
        if len(kept) == 2:
            raise KeyboardInterrupt

    client = Client()
    with pytest.raises(KeyboardInterrupt):
        sweep._run_dask(sweep.points, keep, None, None, client)
    assert kept[0]["status"] == "error" and "worker failed: RuntimeError: KilledWorker" in kept[0]["error"]
    assert kept[0]["point"] == sweep.points[0]
    assert client.cancelled == client.made[2:] and len(client.made) == 4


def test_a_rerun_says_what_it_skipped_and_what_it_left(brutti, tmp_path, fmu_dir, capsys):
    """A journal line cut by a full disk is skipped and said (its point run again), and a rerun with --no-plot names
    the figures an earlier run left beside the new table (they had stood there unsaid)."""
    scenario = SCENARIOS / "double_cardan_brutti_rigid.toml"
    command = ["--fmu-dir", str(fmu_dir), "sweep", str(scenario), "--param", "motor.omega_set=1000:2000:1000rpm",
               "--running-speed", "motor.omega", "--settle", "0.01", "--steady-tol", "0", "--out", str(tmp_path),
               "--workers", "0", "--no-progress"]
    assert main(command) == 0
    figures = sorted(tmp_path.glob("*.png"))
    assert figures
    journal = tmp_path / "double_cardan_brutti_rigid_sweep.jsonl"
    journal.write_text(journal.read_text().splitlines()[0][:40] + "\n" + journal.read_text().splitlines()[1] + "\n")
    capsys.readouterr()
    assert main(command + ["--no-plot"]) == 0
    err = capsys.readouterr().err
    assert "skipped 1 line of" in err and "no point record" in err
    assert f"figures of an earlier run, not redrawn for this table: {figures[0]}" in err


def test_sweep_set_fixes_a_parameter_at_every_point(fmu_dir, tmp_path, capsys):
    """`ujfmu sweep --set driveline.k_theta=1000` (it had been read as an abbreviated --settle and refused): every
    point runs with the stiffer shaft, whose twist under the 5 N.m load is 5 / 1000 rad on average (92.2 N.m/rad
    in the file), in a sweep named <scenario>_changed_sweep. The CSV records the fixed value on every row, and its
    columns file says what it is, so the table says how it was made."""
    args = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--set",
            "driveline.k_theta=1000", "--param", "motor.omega_set=600,700rpm", "--output", "driveline.twist",
            "--settle", "0.5", "--steady-tol", "0", "--workers", "0", "--out", str(tmp_path), "--no-plot", "-q"]
    assert main(args) == 0, capsys.readouterr().err
    with open(tmp_path / "double_cardan_omar_torsional_changed_sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 and all(float(r["driveline.twist.mean"]) == pytest.approx(5.0 / 1000.0, rel=0.03)
                                  for r in rows)
    assert list(rows[0])[:3] == ["motor.omega_set", "driveline.k_theta", "status"]
    assert [r["driveline.k_theta"] for r in rows] == ["1000.0", "1000.0"]
    with open(tmp_path / "double_cardan_omar_torsional_changed_sweep.columns.csv") as f:
        columns = {r["column"]: r for r in csv.DictReader(f)}
    assert columns["driveline.k_theta"]["unit"] == "N.m/rad" and "fixed" in columns["driveline.k_theta"]["meaning"]


def test_sampled_rows_run_as_points_not_a_grid(brutti, tmp_path, fmu_dir):
    """A Monte Carlo sample of (beta1, beta2) as rows (Axis.rows: each row a point, a value per name; a tuple of
    values had been a TypeError): three rows run three points, each with its own pair, and the rigid driveline's
    output speed carries the 2x of the two joints' difference, 2 omega |q1 - q2|, q = tan^2(beta / 2) (to first
    order in q, README); with a grid axis of two speeds they make six points. Rows of the wrong length are
    refused."""
    from ujfmu.sweep import Axis
    rows = [(18.0, 22.0), (20.0, 20.0), (25.0, 15.0)]
    sample = Axis.rows("driveline.beta1,driveline.beta2", rows, "deg")
    assert sample.sampled and sample.describe(brutti) == "3 sampled points of (driveline.beta1,driveline.beta2)"
    settings = SweepSettings.from_scenario(brutti, outputs=["driveline.omega_out"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=2, steady_tol=0.0)
    sweep = Sweep(brutti, [sample], settings, out_dir=tmp_path, name="rows", fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    table = sweep.table()
    assert len(table) == 3 and all(r["status"] == "ok" for r in table)
    for row, (b1, b2) in zip(table, rows):
        assert (row["driveline.beta1"], row["driveline.beta2"]) == pytest.approx((math.radians(b1), math.radians(b2)))
        q1, q2 = math.tan(math.radians(b1) / 2) ** 2, math.tan(math.radians(b2) / 2) ** 2
        expected = 2.0 * row["speed_mean"] * abs(q1 - q2)
        assert row["driveline.omega_out.h2"] == pytest.approx(expected, rel=0.05, abs=1e-9 * row["speed_mean"])
    grid = Sweep(brutti, [sample, parse_axis("motor.omega_set=1000,2000rpm", brutti)], settings, out_dir=tmp_path,
                 name="rows_grid", fmu_dir=fmu_dir)
    assert len(grid.points) == 6
    with pytest.raises(ValueError, match="a value in every row"):
        Axis.rows("driveline.beta1,driveline.beta2", [(18.0,), (20.0, 20.0)], "deg")
    with pytest.raises(ValueError, match="give it with its sign in the rows"):   # not dropped in silence
        Axis.rows("driveline.beta1,-driveline.beta2", rows, "deg")
    # each name its own value: names of different units sample together (a grid axis of them is refused)
    mixed = Axis.rows("driveline.beta1,driveline.k_theta", [(0.3, 80.0), (0.35, 95.0)])
    assert mixed.problems(brutti) == []


def test_an_axis_is_the_same_grid_whatever_the_number_types_its_values_came_as(tmp_path, fmu_dir):
    """An Integer parameter's axis from the command line holds whole numbers, and one from Python numpy numbers:
    the grid's identity (what a journal is matched by) takes them as the floats they were, so an earlier journal
    of `motor.profile=0,1` is still this grid's; numpy Booleans are Booleans (a negated one the opposite)."""
    import numpy as np
    from ujfmu.sweep import Axis
    omar = Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")
    settings = SweepSettings.from_scenario(omar, outputs=["driveline.twist"], running_speed="motor.omega",
                                           settle_time=0.1)
    grids = {Sweep(omar, [axis], settings, out_dir=tmp_path, fmu_dir=fmu_dir).grid
             for axis in (parse_axis("motor.profile=0,1", omar), Axis.of("motor.profile", [0.0, 1.0]),
                          Axis.of("motor.profile", np.array([0, 1])))}
    # the identity an earlier release gave this axis (parse_axis then held floats): json of [names, values], sorted
    import hashlib
    earlier = hashlib.sha256(json.dumps(sorted([json.dumps([["motor.profile"], [0.0, 1.0]])])).encode())
    assert grids == {earlier.hexdigest()[:16]}
    flags = Axis.of("driveline.rigid_intermediate_shaft", np.array([True, False]))
    assert flags.values == [True, False] and all(type(v) is bool for v in flags.values)


def test_a_constant_signals_round_off_orders_are_neither_step_checked_nor_noted(tmp_path, fmu_dir):
    """An ideal speed source's speed among a sweep's outputs: its order amplitudes are round-off (1e-15 rad/s on
    63 rad/s), which the step check had compared (an error of 152%, exit status 1) and the peak note had named
    (its 8x read 12.5 times a period). Both leave it out; the twist's orders are still checked and pass. So they do
    a load torque whose orders are 1e-7 of its size (its smooth sign's slope, 1e-8 N.m.s/rad at 600 rpm, on the
    output speed's 2x: a trial's twin rotor tau_in without load or joint angle had failed the same way)."""
    omar = Scenario(SCENARIOS / "double_cardan_omar_torsional.toml").with_parameters({"load.omega_smooth": 0.1})
    settings = SweepSettings.from_scenario(omar, outputs=["motor.omega", "driveline.twist", "load.tau"],
                                           running_speed="motor.omega", settle_time=1.0, revolutions=2,
                                           steady_tol=0.0, orders=(1, 2, 4, 8))
    sweep = Sweep(omar, [parse_axis("motor.omega_set=600rpm", omar)], settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    (row,) = sweep.table()
    assert row["motor.omega.h1"] < 1e-12 * row["motor.omega.mean"] and "motor.omega" not in row["note"]
    assert 1e-9 < row["load.tau.h2"] / row["load.tau.mean"] < 1e-6 and "load.tau" not in row["note"]
    check = sweep.step_check()
    names = [name for name, _, _ in check.figures]
    assert names and all(name.startswith("driveline.twist.") for name in names) and check.passed


def test_a_parameter_swept_twice_or_swept_and_fixed_is_refused(fmu_dir, tmp_path, capsys):
    """`--param load.T0=4,5 --set load.T0=3` had run at 4 and 5 with the --set value dropped in silence, and two
    axes of one parameter had kept only the later one's values (the CSV's two columns alike): both are refused,
    naming the parameter. An axis's unit clash is listed beside its range problem, not after it is fixed."""
    base = ["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_omar_torsional.toml"), "--workers",
            "0", "--out", str(tmp_path), "-q"]
    assert main(base + ["--param", "load.T0=4,5", "--set", "load.T0=3"]) == 2
    assert "load.T0 both swept (--param) and fixed (--set)" in capsys.readouterr().err
    assert main(base + ["--param", "driveline.beta2=10,15deg", "--set", "driveline.beta1,driveline.beta2=20deg"]) == 2
    assert "driveline.beta2 both swept (--param) and fixed (--set)" in capsys.readouterr().err
    assert main(base + ["--param", "load.T0=4,5", "--param", "load.T0=6,7"]) == 2
    assert "load.T0 on more than one axis (--param)" in capsys.readouterr().err
    assert main(base + ["--param=driveline.beta1,driveline.k_theta=1:2:1"]) == 2
    err = capsys.readouterr().err
    assert "2 problems" in err and "outside its allowed range" in err and "their units differ" in err
    assert not list(tmp_path.glob("*.jsonl"))   # nothing ran


def test_a_periodic_load_torques_order_is_among_the_default_orders(brutti, tmp_path, fmu_dir):
    """A Load torque T_h cos(3 phi) on Brutti's constant-velocity pair (its output angle is its input's): the
    default orders take its 3x beside 1, 2 and 4 (it had been left out: a sweep reported no figure of the forcing),
    and the load torque's 3x is T_h. A given order list is kept as given; a fraction in it is refused, not cut to a
    whole number."""
    from ujfmu.master import Connection
    forced = brutti.with_values({"load.T_h": 2.0, "load.order_h": 3.0})
    forced.connections.append(Connection("driveline.phi_out", "load.phi"))
    settings = SweepSettings.from_scenario(forced, outputs=["load.tau"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=2, steady_tol=0.0)
    assert settings.orders == (1, 2, 3, 4)
    given = dict(running_speed="motor.omega", settle_time=0.01)
    assert SweepSettings.from_scenario(forced, orders=(2,), **given).orders == (2,)
    with pytest.raises(SweepSettingsError, match=r"orders \(--orders\) = \(1, 2.5\) must be positive whole"):
        SweepSettings.from_scenario(forced, orders=(1, 2.5), **given)
    sweep = Sweep(forced, [parse_axis("motor.omega_set=1000rpm", forced)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    (row,) = sweep.table()
    assert row["status"] == "ok" and row["load.tau.h3"] == pytest.approx(2.0, rel=1e-3)


def test_a_drive_set_to_rest_is_refused_before_any_point_runs(brutti, tmp_path, fmu_dir):
    """A point measures whole revolutions at its drive's set speed: a Motor at omega_set = 0 turns none and its
    operating point (within 1% of 0) cannot be met, so such a point is refused up front, on an axis or in the
    scenario, naming the parameter; a slow speed is not refused up front."""
    with pytest.raises(SweepSettingsError) as err:
        brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=0:2000:1000rpm")
    assert err.value.problems == [p for p in err.value.problems if p.startswith("motor.omega_set = 0 at 1 of the 3 "
                                                                             "points")] != []
    at_rest = brutti.with_parameters({"motor.omega_set": 0.0})
    with pytest.raises(SweepSettingsError, match=r"motor.omega_set = 0 for every point: .* give the drive a speed"):
        brutti_sweep(at_rest, tmp_path, fmu_dir, spec="load.T0=1,2")
    assert len(brutti_sweep(brutti, tmp_path, fmu_dir, spec="motor.omega_set=1,1000rpm").points) == 2


def test_a_window_longer_than_a_table_may_hold_is_refused_naming_its_length(brutti, tmp_path, fmu_dir):
    """Revolutions at a slow speed take a window of millions of steps, whose table would fill memory: the point
    fails at once with the window's length and what shortens it, before any step of the window runs."""
    from ujfmu.steady import MAX_WINDOW_STEPS
    speed = 2.0 * 2.0 * math.pi / (1.5 * MAX_WINDOW_STEPS * brutti.step_size)   # 2 revolutions: 1.5e6 steps
    sweep = brutti_sweep(brutti, tmp_path, fmu_dir, spec=f"motor.omega_set={speed!r}")
    sweep.run(workers=0)
    (row,) = sweep.table()
    assert brutti.step_size == 1e-4
    assert row["status"] == "error" and "2 revolutions take 150 s, 1.5e+06 steps of 0.0001 s" in row["error"]
    assert "--revolutions" in row["error"] and "--step" in row["error"]


def test_the_twin_rotors_sweep_table_runs_through_disc_2s_critical_speed(tmp_path, fmu_dir):
    """The twin rotor's [sweep] table, at two of its speeds: disc 2's 1x at its critical speed sqrt(K2X / (M2 +
    m_u2)) = 117 rad/s and at 100 rad/s is the Jeffcott unbalance response m_u e w^2 / |K - m w^2 + i C w| (within
    3%: the 5 deg joint and the 2 N.m load move it by 1.3% at the critical), a circle (X and Y alike), about nine
    times larger at the critical."""
    from ujfmu.models.twin_jeffcott_rotor.model import rig_parameters
    scenario = Scenario(SCENARIOS / "twin_jeffcott_steady.toml")
    settings = SweepSettings.from_scenario(scenario)
    assert scenario.sweep["params"] and "rotor.X2" in settings.outputs
    p = rig_parameters()
    m, k, c = p["M2"] + p["m_u2"], p["K2X"], p["C2X"]
    critical = math.sqrt(k / m)
    sweep = Sweep(scenario, [parse_axis(f"motor.omega_set=100,{critical!r}", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    rows = sweep.table()
    assert [r["status"] for r in rows] == ["ok", "ok"]
    for row in rows:
        w = row["motor.omega_set"]
        jeffcott = p["m_u2"] * p["e"] * w * w / math.hypot(k - m * w * w, c * w)
        assert row["rotor.X2.h1"] == pytest.approx(jeffcott, rel=0.03)
        assert row["rotor.Y2.h1"] == pytest.approx(row["rotor.X2.h1"], rel=0.01)
    assert rows[1]["rotor.X2.h1"] > 8.0 * rows[0]["rotor.X2.h1"]


def test_the_step_check_reruns_each_outputs_peak(tmp_path, fmu_dir):
    """A twin rotor swept through disc 2's lateral critical speed (117 rad/s) toward disc 1's (154 rad/s), its
    outputs X1 and X2: the step check had rerun only where the first output, X1, peaks (the grid's end), never at
    disc 2's resonance (a trial's). It reruns at each output's peak, each point once, naming the outputs peaking
    there."""
    twin = Scenario(SCENARIOS / "twin_jeffcott_steady.toml")
    settings = SweepSettings.from_scenario(twin, outputs=["rotor.X1", "rotor.X2"], running_speed="motor.omega",
                                           settle_time=1.0, revolutions=2, steady_tol=0.0)
    sweep = Sweep(twin, [parse_axis("motor.omega_set=117,150", twin)], settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    checks = sweep.step_checks()
    assert [(c.peaking, c.point["motor.omega_set"]) for c in checks] == [(["rotor.X1"], 150.0), (["rotor.X2"], 117.0)]
    assert all(c.passed for c in checks) and checks[1].lines(twin)[0].startswith(
        "step check at the peak of rotor.X2 (motor.omega_set = 117 rad/s (1117.27 rpm))")
    assert sweep.step_check().point == checks[0].point   # the first output's, as before


def test_a_grid_that_steps_over_a_mode_crossing_where_an_order_peaks_says_so_with_the_span_to_sweep(tmp_path,
                                                                                                 fmu_dir, capsys):
    """A speed sweep every 15 rad/s read a ring coupling's 2x torque peak 32% low (a fresh-eyes trial's) without a
    word: the ring's torsional mode (sqrt(c_s / I_eff), Turla and Iljin's omega_min = sqrt(c_s / (4 I2)) = 60.3
    rad/s its 2x crossing) lies between the points 55 and 70 rad/s, where the peak was read. The sweep names the
    crossing, the points around it and a span that resolves it; that span's sweep reads a peak at least 1.3x
    higher, and names no crossing (one of its points within 1% of it); nor does a grid with a point on it."""
    path = SCENARIOS / "ring_coupling_startup.toml"   # the ring at constant speeds against its load
    at_speed = {"motor.ideal_speed_source": True, "motor.profile": 0}
    ring = Scenario(path).with_parameters(at_speed)
    settings = SweepSettings.from_scenario(ring, outputs=["coupling.transmitted_torque", "coupling.x_e"],
                                           running_speed="motor.omega", settle_time=1.5, revolutions=4)

    def sweep(name, spec):
        swept = Sweep(ring, [parse_axis(spec, ring)], settings, out_dir=tmp_path, name=name, fmu_dir=fmu_dir)
        swept.run(workers=0, progress=False)
        return swept

    coarse = sweep("coarse", "motor.omega_set=10:100:15")
    found = coarse.stepped_over_crossings()
    assert [(c.output, c.order, c.low, c.high, c.at) for c in found] == [
        ("coupling.transmitted_torque", 2, 55.0, 70.0, 55.0), ("coupling.x_e", 2, 55.0, 70.0, 55.0)]
    crossing = math.sqrt(726.4294875418636 / (4 * 0.05))   # c_s = 87 EI/R at the defaults, I2
    assert found[0].speed == pytest.approx(crossing, rel=0.005) and found[0].component == "coupling"
    text = found[0].text(ring, found[1:])
    assert "the 2x order of coupling.transmitted_torque, coupling.x_e peaks next to the crossing of coupling's" in text
    assert text.endswith("--param motor.omega_set=55:70:0.75")
    fine = sweep("fine", "motor.omega_set=58:62:1")
    assert fine.stepped_over_crossings() == []
    read = max(r["coupling.transmitted_torque.h2"] for r in coarse.table())
    assert max(r["coupling.transmitted_torque.h2"] for r in fine.table()) > 1.3 * read
    assert sweep("on", "motor.omega_set=40,60.3,80").stepped_over_crossings() == []
    backwards = sweep("backwards", "motor.omega_set=-100:-10:15").stepped_over_crossings()   # the same ring reversed
    assert [(c.output, c.low, c.high, c.at) for c in backwards][:1] == [("coupling.transmitted_torque", -70.0, -55.0,
                                                                         -55.0)]
    # a PI motor's loop puts the mode between its free input's (the rotor J_rotor against I2) and its held input's:
    # both crossings are named where the grid steps over them next to the peak
    startup = Scenario(SCENARIOS / "ring_coupling_startup.toml")
    driven = Sweep(startup, [parse_axis("motor.omega_set=10:90:20", startup)],
                   SweepSettings.from_scenario(startup, outputs=["coupling.transmitted_torque"],
                                               running_speed="motor.omega", settle_time=1.5, revolutions=4),
                   out_dir=tmp_path, name="driven", fmu_dir=fmu_dir)
    driven.run(workers=0, progress=False)
    c_s, i2 = 726.4294875418636, 0.05
    j = startup.parameters_with_defaults("motor")["J_rotor"]
    named = sorted(c.speed for c in driven.stepped_over_crossings())
    assert named == pytest.approx([math.sqrt(c_s / i2) / 2, math.sqrt(c_s * (1 / i2 + 1 / j)) / 2], rel=2e-3)
    assert main(["sweep", str(path), *(f"--set={k}={v}" for k, v in at_speed.items()), "--param",
                 "motor.omega_set=10:100:15", "--name", "coarse", "--out", str(tmp_path), "--fmu-dir", str(fmu_dir),
                 "--workers", "0", "--no-plot", "--output", "coupling.transmitted_torque", "--output",
                 "coupling.x_e", "--settle", "1.5", "--revolutions", "4", "--running-speed", "motor.omega"]) == 0
    assert text in capsys.readouterr().out


def test_plot_before_run_makes_its_folder(brutti, tmp_path, fmu_dir):
    """A script's sweep.plot() before sweep.run() (a fresh-eyes trial's) had blamed a full disk for the folder the
    run would make: it makes the folder and draws what it has (the model's natural frequencies, no point)."""
    from ujfmu.sweep import Axis
    settings = SweepSettings.from_scenario(brutti, running_speed="motor.omega", settle_time=0.1)
    sweep = Sweep(brutti, [Axis.of("load.c1", [0.0, 0.001])], settings, out_dir=tmp_path / "fresh", fmu_dir=fmu_dir)
    paths = sweep.plot()
    assert paths and all(Path(p).is_file() and Path(p).parent == tmp_path / "fresh" for p in paths)
