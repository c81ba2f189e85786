"""ujfmu.scenario_run.compare and SignalCheck: the pass rule max |result - reference| <= rel_range * range + abs,
at its boundary, with the reference interpolated to the result's times."""

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from ujfmu.scenario import Tolerance
from ujfmu.scenario_run import SignalCheck, compare

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def table(time, **columns):
    names = ["time"] + [n.replace("__", ".") for n in columns]
    return np.rec.fromarrays([np.asarray(time, float)] + [np.asarray(c, float) for c in columns.values()],
                             names=names)


REFERENCE = table([0.0, 1.0, 2.0], a__y=[0.0, 4.0, 0.0])      # range 4
TOLERANCE = {"a.y": Tolerance(rel_range=0.5, abs=0.25)}        # allowed 0.5 * 4 + 0.25 = 2.25 (exact in binary)


JUST_OVER = 2.25 + 2.0 ** -48                                   # exact in binary, also as 4 + JUST_OVER


@pytest.mark.parametrize("offset, passed", [(0.0, True), (2.25, True), (-2.25, True), (JUST_OVER, False),
                                            (-JUST_OVER, False)])
def test_the_bound_is_inclusive(offset, passed):
    result = table([0.0, 0.5, 1.0, 1.5, 2.0], a__y=[0.0, 2.0, 4.0 + offset, 2.0, 0.0])
    (check,) = compare(result, REFERENCE, TOLERANCE)
    assert (check.name, check.allowed, check.reference_range) == ("a.y", 2.25, 4.0)
    assert check.max_error == abs(offset) and check.passed is passed


def test_the_reference_is_interpolated_to_the_result_times():
    """Between reference samples the reference is the straight line (2 at t = 0.5): a result of 2 + 1 there is
    off by exactly 1."""
    result = table([0.5, 1.5], a__y=[3.0, 2.0])
    (check,) = compare(result, REFERENCE, {"a.y": Tolerance(abs=1.0)})
    assert check.max_error == 1.0 and check.passed
    (check,) = compare(result, REFERENCE, {"a.y": Tolerance(abs=np.nextafter(1.0, 0.0))})
    assert not check.passed


def test_the_rms_error_is_over_the_compared_samples_and_printed_in_the_unit():
    """Errors 0, 1, 0, -3, 0 at the five shared instants: max 3, RMS sqrt(10 / 5); both in the signal's unit (a
    bench engineer comparing with noisy measurements had only the max, which the noise sets)."""
    result = table([0.0, 0.5, 1.0, 1.5, 2.0], a__y=[0.0, 3.0, 4.0, -1.0, 0.0])
    reference = table([0.0, 0.5, 1.0, 1.5, 2.0], a__y=[0.0, 2.0, 4.0, 2.0, 0.0])
    (check,) = compare(result, reference, {"a.y": Tolerance(abs=3.0)}, {"a.y": "N.m"})
    assert check.max_error == 3.0 and check.rms_error == pytest.approx(math.sqrt(2.0), rel=1e-15)
    assert "max|err| = 3.000e+00 N.m at t = 1.5 s  allowed 3.000e+00 N.m  (1 of allowed, RMS 1.414e+00 N.m" in \
        str(check)


def test_every_toleranced_signal_is_checked_and_must_be_in_the_reference():
    result = table([0.0, 1.0, 2.0], a__y=[0.0, 4.0, 0.0], b__z=[1.0, 1.0, 1.0])
    reference = table([0.0, 1.0, 2.0], a__y=[0.0, 4.0, 0.0], b__z=[1.0, 1.0, 2.0])
    checks = compare(result, reference, {"a.y": Tolerance(abs=0.0), "b.z": Tolerance(rel_range=0.999)})
    assert [(c.name, c.passed) for c in checks] == [("a.y", True), ("b.z", False)]
    with pytest.raises(KeyError, match="c.w"):
        compare(result, reference, {"c.w": Tolerance(abs=1.0)})


def test_signal_check_verdict_and_report():
    assert SignalCheck("x", 1.0, 1.0, 10.0).passed
    assert not SignalCheck("x", 1.0, np.nextafter(1.0, 0.0), 10.0).passed
    assert not SignalCheck("x", float("nan"), 1.0, 10.0).passed
    text = str(SignalCheck("x", 0.5, 1.0, 10.0))
    assert text.startswith("ok") and "(0.5 of allowed" in text
    assert str(SignalCheck("x", 2.0, 1.0, 10.0)).startswith("FAIL")


def test_fmpy_band_on_the_references_own_samples():
    """A decaying 117 rad/s oscillation over 17 s at 1 ms (a rotor's start transient): compared with itself it is
    inside fmpy's band when the band is built on the reference's 17001 samples, while fmpy's 1000 resampled
    points miss its first peak; a result 30% of the range off over a tenth of the run is still outside."""
    from fmpy.util import validate_result

    from ujfmu.scenario_run import fmpy_outlier_fraction
    t = np.arange(17001) * 1e-3
    reference = table(t, a__y=np.exp(-0.7 * t) * np.sin(117.0 * t))
    assert validate_result(reference, reference) > 0            # fmpy's own band misses the peaks
    assert fmpy_outlier_fraction(reference, reference) == 0.0
    shifted = table(t, a__y=reference["a.y"] + 0.6 * ((t > 8.0) & (t < 9.7)))   # range about 1.9
    assert fmpy_outlier_fraction(shifted, reference) == pytest.approx(0.1, abs=0.01)


def test_a_constant_reference_with_rel_range_alone_is_flagged():
    """A constant 20 N.m reference (its range 1e-10 from round-off) under rel_range = 1e-3 allows 1e-13: the line
    says why and what to give instead; with an abs tolerance, or a varying reference, there is no such note."""
    reference = table([0.0, 1.0, 2.0], a__y=[20.0, 20.0 + 1e-10, 20.0])
    result = table([0.0, 1.0, 2.0], a__y=[20.0, 20.0, 20.0])
    (check,) = compare(result, reference, {"a.y": Tolerance(rel_range=1e-3)})
    assert check.allowed == pytest.approx(1e-13) and "the reference is constant (20" in str(check)
    assert "give this signal an abs tolerance" in str(check)
    (check,) = compare(result, reference, {"a.y": Tolerance(rel_range=1e-3, abs=1e-6)})
    assert check.note == ""
    (check,) = compare(table([0.0, 1.0, 2.0], a__y=[0.0, 4.0, 0.0]), REFERENCE, {"a.y": Tolerance(rel_range=1e-3)})
    assert check.note == ""


def test_a_band_of_half_the_range_is_said_to_check_the_level_only():
    """A flat line through the middle of a reference ranging 0..4 is within 2 of it everywhere: a band of 2 (abs
    1000 N.m on a 4 N.m torque, a fresh-eyes trial's gate) passes it, and the line says the band checks the level
    only; a band just under half the range does not pass the flat line and has no such note."""
    from ujfmu.scenario_run import LEVEL_ONLY
    flat = table([0.0, 0.5, 1.0, 1.5, 2.0], a__y=[2.0] * 5)
    (check,) = compare(flat, REFERENCE, {"a.y": Tolerance(abs=2.0)})
    assert check.passed and check.level_only and LEVEL_ONLY in str(check)
    (check,) = compare(flat, REFERENCE, {"a.y": Tolerance(rel_range=0.25, abs=1.0)})
    assert check.passed and check.level_only
    (check,) = compare(flat, REFERENCE, {"a.y": Tolerance(abs=1.99)})
    assert not check.passed and not check.level_only and check.note == ""


def test_an_operating_point_missed_from_above_is_called_an_overshoot_not_unreached():
    """A drive 2.2% above its set point at the end is not short of it: the message says which side it missed."""
    from ujfmu.scenario_run import OperatingPointCheck
    above = OperatingPointCheck("motor.omega", "motor.omega_ref", 61.33, 60.0, 0.72)
    below = OperatingPointCheck("motor.omega", "motor.omega_ref", 58.0, 60.0, 0.72)
    assert not above.passed and not below.passed
    assert "above its set point" in str(above) and "not reached" not in str(above)
    assert "not reached" in str(below) and "above" not in str(below)


def test_a_drive_braking_to_rest_is_checked_against_its_top_speed(fmu_dir, tmp_path, capsys):
    """A drive braked to rest (set point 0) had crashed the summary (a division by the set point) and could pass only
    at exactly 0: its tolerance is 1% of the run's top set point, and the line says so. Through `ujfmu run`:
    Feng's joint braked from 50 rad/s to rest at 100 rad/s^2 (profile 3) stops within it."""
    from ujfmu.cli import main
    from ujfmu.scenario_run import OperatingPointCheck
    near = OperatingPointCheck("motor.omega", "motor.omega_ref", 0.3, 0.0, 1.0, top=50.0)
    far = OperatingPointCheck("motor.omega", "motor.omega_ref", 0.8, 0.0, 1.0, top=50.0)
    assert near.passed and not far.passed
    assert "(+0.6% of the run's top set point 50 rad/s (477.465 rpm), allowed 1%)" in str(near)
    scenario = Path(__file__).parent.parent / "scenarios" / "cardan_startup.toml"
    assert main(["--fmu-dir", str(fmu_dir), "run", str(scenario), "--no-plot", "--out", str(tmp_path), "--set",
                 "motor.profile=3", "--set", "motor.omega_initial=50", "--set", "motor.omega_set=0", "--set",
                 "motor.t_step=0.2", "--set", "motor.accel=100", "--stop-time", "1.5"]) == 0
    assert "ok   operating point motor.omega" in capsys.readouterr().out


def test_order_amplitudes_are_checked_against_the_reference_as_fractions_of_themselves(tmp_path):
    """[reference.orders]: over the steady window, each running-speed order the reference carries at 1% or more
    of its largest is fitted in the run and the reference, and must agree within rel of the reference's. Here a
    torque of mean 1000 N.m whose 2x is 19.19 N.m in the reference and 23.16 in the run (a truck driveline coupled
    explicitly: within 0.5% of the range, so the bands pass) fails on the 2x alone; the 1x (10% below) passes at
    rel = 0.15; the 4x, 0.5% of the 2x, is not compared; samples before steady_from do not count."""
    from types import SimpleNamespace

    from ujfmu.scenario_run import OrderCheck, check_orders
    t = np.arange(0.0, 2.0, 1e-3)
    omega = 100.0
    theta = omega * t

    def torque(h1, h2, h4):
        return 1000.0 + h1 * np.cos(theta + 0.3) + h2 * np.cos(2 * theta - 1.0) + h4 * np.cos(4 * theta)
    run = np.rec.fromarrays([t, np.full_like(t, omega), torque(3.6, 23.16, 0.1)], names=["time", "m.omega", "d.T"])
    early = t < 1.0
    run["d.T"][early] += 50.0 * np.sin(37.0 * t[early])   # a start-up transient before the window
    ref = np.rec.fromarrays([t, np.full_like(t, omega), torque(4.0, 19.19, 0.1)], names=["time", "m.omega", "d.T"])
    scenario = SimpleNamespace(order_tolerances={"d.T": 0.15}, steady_from=1.0, running_speed="m.omega")
    checks = check_orders(scenario, run, ref)
    assert [(c.order, c.passed) for c in checks] == [(1, True), (2, False)]
    assert checks[1].amplitude == pytest.approx(23.16, rel=1e-9)
    assert checks[1].reference_amplitude == pytest.approx(19.19, rel=1e-9)
    assert str(checks[1]) == ("FAIL d.T 2x order amplitude 23.16 against the reference's 19.19 (+20.7%, allowed 15%)")
    assert OrderCheck("x", 2, 10.5, 10.0, 0.05).passed and not OrderCheck("x", 2, 10.51, 10.0, 0.05).passed


def test_a_reference_sampled_more_coarsely_than_the_run_keeps_its_orders():
    """A run at 0.25 ms against a reference sampled every 1 ms (a trial's propshaft: its 4x at 180 rad/s, 8.7
    samples a period in the reference): the reference interpolated to the run's instants had lost 4% of its 4x and
    1% of its 2x, and a correct run failed a 5% band, more so at each smaller step. Fitted on its own samples,
    against the run's angle there, the same vibration in both agrees to round-off."""
    from types import SimpleNamespace

    from ujfmu.scenario_run import check_orders
    omega = 180.0

    def table(h):
        t = np.arange(0.0, 2.0 + h / 2, h)
        theta = omega * t
        torque = 550.0 + 12.5 * np.cos(2 * theta - 0.4) + 0.29 * np.cos(4 * theta + 1.1) + 0.2 * np.cos(theta)
        return np.rec.fromarrays([t, np.full_like(t, omega), torque], names=["time", "m.omega", "d.T"])
    scenario = SimpleNamespace(order_tolerances={"d.T": 0.01}, steady_from=1.0, running_speed="m.omega",
                               path=Path("s.toml"))
    checks = check_orders(scenario, table(2.5e-4), table(1e-3))
    assert [c.order for c in checks] == [1, 2, 4] and all(c.passed for c in checks)
    for c in checks:
        assert c.reference_amplitude == pytest.approx(c.amplitude, rel=1e-9)
    assert checks[2].reference_amplitude == pytest.approx(0.29, rel=1e-9)


def test_an_order_the_reference_file_does_not_resolve_fails_as_unchecked():
    """A reference sampled every 5 ms at 180 rad/s (3.5 samples a period of its 2x) against a run at 0.25 ms whose 2x
    is twice the reference's: fitted on its own samples the reference resolves only the 1x, and the 2x and 4x had
    passed as "not resolved at this step" (a review's case). An order the run carries and the reference file cannot
    resolve is a failure naming the file's sampling; the 1x is compared."""
    from types import SimpleNamespace

    from ujfmu.scenario_run import check_orders

    def table(h, h2):
        t = np.arange(0.0, 2.0 + h / 2, h)
        theta = 180.0 * t
        torque = 550.0 + 3.0 * np.cos(theta) + h2 * np.cos(2 * theta - 0.4) + 0.3 * np.cos(4 * theta + 1.1)
        return np.rec.fromarrays([t, np.full_like(t, 180.0), torque], names=["time", "m.omega", "d.T"])
    scenario = SimpleNamespace(order_tolerances={"d.T": 0.05}, steady_from=1.0, running_speed="m.omega",
                               path=Path("s.toml"))
    checks = check_orders(scenario, table(2.5e-4, 25.0), table(5e-3, 12.5))
    assert [(c.order, c.passed) for c in checks] == [(2, False), (4, False), (1, True)]
    assert str(checks[0]).startswith("FAIL d.T: its 2x order, which the run carries, is not resolved by the "
                                     "reference file's samples (every 0.005 s")


def test_an_order_the_run_has_and_the_reference_lacks_is_compared_and_round_off_is_not():
    """A spurious 1x in the run (3.8% of its 2x, none in the reference) had passed unseen: an order counts if it
    carries 1% of the largest in the run or the reference. A constant speed's orders at round-off (1e-14 of it) are
    not compared (they had failed at 7-23% 'of themselves'), and an order the step does not resolve is named, not
    dropped."""
    from types import SimpleNamespace

    from ujfmu.scenario_run import check_orders
    t = np.arange(0.0, 2.0, 1e-3)
    theta = 100.0 * t
    speed = np.full_like(t, 100.0)

    def table(tau, omega):
        return np.rec.fromarrays([t, speed, tau, omega], names=["time", "m.omega", "r.tau", "r.omega"])
    run = table(0.0256 * np.cos(theta) + 0.6717 * np.cos(2 * theta), 100.0 + 1e-14 * np.cos(2 * theta))
    ref = table(0.6717 * np.cos(2 * theta), 100.0 + 1.7e-14 * np.cos(2 * theta))
    scenario = SimpleNamespace(order_tolerances={"r.tau": 0.05, "r.omega": 0.05}, steady_from=1.0,
                               running_speed="m.omega", path=Path("s.toml"))
    checks = check_orders(scenario, run, ref)
    assert [(c.name, c.order, c.passed) for c in checks if not c.note] == [("r.tau", 1, False), ("r.tau", 2, True)]
    (flat,) = [c for c in checks if c.name == "r.omega"]
    assert flat.passed and str(flat).startswith("--   r.omega: no order above round-off")
    coarse = check_orders(scenario, run[::6], ref[::6])   # 6 ms: 10.5 samples a revolution, the 4x unresolved
    assert any(c.name == "r.tau" and c.order == 4 and "not resolved at this step" in c.note for c in coarse)
    assert "no order is resolved" in check_orders(scenario, run[::16], ref[::16])[0].note   # 3.9 a revolution


@pytest.mark.parametrize("edit, says", [
    (('steady_from = 16.0\n', ''), "so it needs output.steady_from after start_time (where the window starts"),
    (('"rotor.X2" = { rel = 0.02 }', '"rotor.input_work" = { rel = 0.02 }'), "grows along the run"),
    (('"rotor.X2" = { rel = 0.02 }', '"rotor.X2" = { rel = 1.5 }'), "reference.orders.rotor.X2.rel = 1.5 must lie in"),
    (('"rotor.X2" = { rel = 0.02 }', '"rotor.X2" = { rel_range = 0.02 }'), "must be { rel = ... }"),
    (('"rotor.X2" = { rel = 0.02 }', '"rotor.Z9" = { rel = 0.02 }'), "reference.orders.rotor.Z9: not a recorded"),
])
def test_an_order_check_without_its_window_or_with_a_bad_bound_is_refused(tmp_path, edit, says):
    from ujfmu.scenario import Scenario, ScenarioError
    text = (SCENARIOS / "twin_jeffcott_steady.toml").read_text().replace(
        "[reference.tolerance]", '[reference.orders]\n"rotor.X2" = { rel = 0.02 }\n\n[reference.tolerance]')
    (tmp_path / "references").mkdir()
    shutil.copy(SCENARIOS / "references" / "twin_jeffcott_steady.csv", tmp_path / "references")
    (tmp_path / "s.toml").write_text(text.replace(*edit))
    with pytest.raises(ScenarioError, match=re.escape(says)):
        Scenario(tmp_path / "s.toml")


def test_a_run_checks_its_orders_and_a_reference_with_another_vibration_fails_it(tmp_path, fmu_dir):
    """twin_jeffcott_steady with [reference.orders] on the secondary shaft torque: its 1x and 2x agree with the
    monolithic reference to far within 1% and the run passes; against the same reference with that torque's
    oscillation about its window mean made 10% larger (its mean and every other signal as they were), every band
    still passes, the orders fail, and the JUnit failure says so."""
    import xml.etree.ElementTree as ET

    from ujfmu.references import read_reference, write_reference
    from ujfmu.scenario_run import run_scenario, write_junit
    text = (SCENARIOS / "twin_jeffcott_steady.toml").read_text().replace(
        "[reference.tolerance]", '[reference.orders]\n"rotor.secondary_shaft_torque" = { rel = 0.01 }\n\n'
                                 '[reference.tolerance]').replace(
        '"rotor.secondary_shaft_torque" = { rel_range = 7e-05 }',
        '"rotor.secondary_shaft_torque" = { rel_range = 0.01 }')
    (tmp_path / "references").mkdir()
    (tmp_path / "twin_jeffcott_steady.toml").write_text(text)
    reference, provenance = read_reference(SCENARIOS / "references" / "twin_jeffcott_steady.csv")
    write_reference(tmp_path / "references" / "twin_jeffcott_steady.csv", reference, provenance)
    good = run_scenario(tmp_path / "twin_jeffcott_steady.toml", fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert good.passed and [c.order for c in good.order_checks] == [1, 2]
    assert all(abs(c.amplitude / c.reference_amplitude - 1.0) < 1e-3 for c in good.order_checks)
    torque = reference["rotor.secondary_shaft_torque"]
    late = reference["time"] >= 16.0
    torque[late] = torque[late].mean() + 1.1 * (torque[late] - torque[late].mean())
    write_reference(tmp_path / "references" / "twin_jeffcott_steady.csv", reference, provenance)
    bad = run_scenario(tmp_path / "twin_jeffcott_steady.toml", fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert bad.failed and all(c.passed for c in bad.checks)
    assert [(c.order, c.passed) for c in bad.order_checks] == [(1, False), (2, False)]
    assert "2x order amplitude 0.1259 against the reference's 0.1385 (-9.09%, allowed 1%)" in bad.summary()
    case = ET.parse(write_junit([bad], tmp_path / "r.xml")).getroot().find("testcase")
    assert "running-speed order amplitude outside [reference.orders]" in case.find("failure").get("message")


@pytest.mark.parametrize("steady_from, speed, says", [(1.995, 100.0, "the window holds 5 samples"),
                                                      (1.0, 0.0, "span no revolution: the running speed is 0")])
def test_orders_that_cannot_be_fitted_name_the_window_not_a_traceback(steady_from, speed, says):
    """A steady window of a few samples, or a running speed of 0 (no revolutions), is a scenario error naming
    [reference.orders], the window and the remedy, not a numpy error out of the run."""
    from types import SimpleNamespace

    from ujfmu.scenario import ScenarioError
    from ujfmu.scenario_run import check_orders
    t = np.arange(0.0, 2.0, 1e-3)
    table = np.rec.fromarrays([t, np.full_like(t, speed), np.cos(2 * speed * t)], names=["time", "m.omega", "d.T"])
    scenario = SimpleNamespace(order_tolerances={"d.T": 0.05}, steady_from=steady_from, running_speed="m.omega",
                               path=Path("s.toml"))
    with pytest.raises(ScenarioError, match=rf"\[reference.orders\].*{re.escape(says)}.*move steady_from earlier"):
        check_orders(scenario, table, table)


def test_a_set_point_that_stops_moving_inside_the_check_window_is_said_with_when():
    """A ramp to 300 rpm ending at 30 s of a 32 s run (a marine run-up): the check window, the last 10%, starts at
    28.8 s inside the ramp, so nothing is checked, but the message had said the run ends before the profile does.
    It now says when the set point reaches its final value and the remedy; a ramp still moving at the end keeps
    its message."""
    from ujfmu.scenario_run import check_operating_points
    from ujfmu.scenario import Scenario
    scenario = Scenario(Path(__file__).parent.parent / "scenarios" / "cardan_startup.toml")
    t = np.linspace(0.0, 32.0, 3201)
    ramp = np.minimum(t, 30.0) * (31.4159 / 30.0)
    (check,) = check_operating_points(scenario, table(t, motor__omega=ramp, motor__omega_ref=ramp))
    assert not check.checked and check.passed and check.since == pytest.approx(28.8)
    assert check.holds_from == pytest.approx(30.0) and "reaches its final value only at t = 30 s" in str(check)
    assert "or set [output] steady_from (where the window starts) past t = 30 s" in str(check)
    (moving,) = check_operating_points(scenario, table(t, motor__omega=t, motor__omega_ref=t))
    assert "the run ends before the profile does)" in str(moving) and math.isnan(moving.holds_from)
    # a ramp that a run ends in (a set point the 30 rad/s^2 ramp reaches at 66.7 s, a fresh-eyes trial's 2000 rad/s
    # meant in rpm) says when it ends and the remedy
    far = scenario.with_parameters({"motor.omega_set": 2000.0})
    (moving,) = check_operating_points(far, table(t, motor__omega=t, motor__omega_ref=t))
    assert moving.reaches == (pytest.approx(2000.0 / 30.0), 2000.0)
    assert ("the run ends before the profile does: it reaches its final 2000 rad/s (19098.6 rpm) only at t = 66.67 s; "
            "lengthen stop_time past that") in str(moving)


def test_a_run_without_a_reference_gives_each_signals_figures(fmu_dir):
    """A run without a reference had printed no figure of its signals (a designer parsed the CSV for every answer):
    its summary lists each recorded signal's min, max, mean and RMS. Brutti's rigid driveline with its second yoke
    90 deg out of phase at 2000 rpm: the output speed swings between omega cos^2(beta) and omega / cos^2(beta)
    (read at the 1 ms instants, within 1% of them), the ideal source's speed is constant; the output angle, which
    grows, by its last value."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import run_scenario
    brutti = Scenario(Path(__file__).parent.parent / "scenarios" / "double_cardan_brutti_rigid.toml")
    changed = brutti.with_parameters({"driveline.yoke_phase": math.pi / 2})
    assert "driveline.phi_out" in changed.record
    text = run_scenario(changed, fmu_dir=fmu_dir, out_dir=None, plot=False).summary()
    assert "recorded signals over the run (min, max at the recorded instants; mean, RMS over time" in text
    line = next(line for line in text.splitlines() if line.strip().startswith("driveline.omega_out "))
    low, high = (float(x) for x in re.findall(r"(\S+) \.\. (\S+),", line)[0])
    omega, c2 = 2000.0 * math.pi / 30.0, math.cos(math.radians(10.0)) ** 2
    assert low == pytest.approx(omega * c2, rel=1e-2) and high == pytest.approx(omega / c2, rel=1e-2)
    speed = next(line for line in text.splitlines() if line.strip().startswith("motor.omega "))
    assert f"{omega:.6g} .. {omega:.6g}, mean {omega:.6g}" in speed
    assert re.search(r"driveline\.phi_out +last \S+ rad$", text, re.MULTILINE)


def test_a_runs_signal_means_are_time_averages(fmu_dir):
    """Feng's 30 deg joint at 600 rpm over 0.5 s, five whole revolutions, unchecked (a changed copy): over whole
    revolutions the output's mean speed is the input's and the input torque's mean is the 0.3 N.m load (lossless),
    which a plain average of the N + 1 samples (both ends counted) had missed by 0.03%; the summary's means are
    time averages (trapezoidal)."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import run_scenario
    feng = Scenario(Path(__file__).parent.parent / "scenarios" / "cardan_constant_speed.toml").with_parameters({})
    text = run_scenario(feng, fmu_dir=fmu_dir, out_dir=None, plot=False).summary()
    omega = 600.0 * math.pi / 30.0

    def mean(signal):
        line = next(line for line in text.splitlines() if line.strip().startswith(signal + " "))
        return float(re.search(r"mean (\S+),", line).group(1))
    assert mean("joint.omega_out") == pytest.approx(omega, rel=1e-6)
    assert mean("motor.tau_motor") == pytest.approx(0.3, rel=1e-5)


START_AT_SPEED = """
title = "A PI motor at 1500 rpm through a 20 deg joint, its load on from the start (a fresh-eyes trial's)"
[experiment]
stop_time = 0.3
step_size = 1e-3
[components.motor]
fmu = "Motor"
parameters = { J_rotor = 2e-3, Kp = 0.4, Ki = 20.0, tau_max = 20.0, profile = 0, omega_set = 157.07963267948966 }
[components.joint]
fmu = "CardanJoint"
parameters = { bend_angle = 0.3490658503988659, J2 = 5e-4, error_angle_beta = 0.0, error_angle_gamma = 0.0 }
[components.load]
fmu = "Load"
parameters = { T0 = 2.0, c1 = 0.0, c2 = 4e-5, omega_smooth = 1.0 }
""" + "".join(f'[[connections]]\nfrom = "{a}"\nto = "{b}"\n' for a, b in (
    ("motor.omega", "joint.omega_in"), ("joint.tau_in", "motor.tau_load"), ("joint.omega_out", "load.omega"),
    ("load.tau", "joint.tau_load"))) + """[output]
record = ["motor.omega", "joint.tau_in"]
[reference]
file = "start_at_speed.csv"
generator = "cardan_joint"
[reference.tolerance]
"motor.omega" = { rel_range = 0.05 }
"joint.tau_in" = { rel_range = 0.05 }
"""


def test_an_error_only_in_the_first_steps_of_a_speed_driven_run_is_named_as_the_start(fmu_dir, tmp_path):
    """A PI motor at speed with no torque yet decelerates under its load from the first step; the speed-driven
    joint, without a speed history, leaves that acceleration's inertia torque out of tau_in at t = 0 (25% of its
    range there, under 1% after). The line gives the time of the largest error, and the hint says it is the start,
    which no step removes, instead of suggesting a smaller step or a wrong model."""
    from ujfmu.references import generate, write_reference
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import run_scenario
    path = tmp_path / "start_at_speed.toml"
    path.write_text(START_AT_SPEED)
    write_reference(tmp_path / "start_at_speed.csv", *generate(Scenario(path)))
    result = run_scenario(Scenario(path), fmu_dir=fmu_dir, out_dir=None, plot=False, progress=False)
    (torque,) = [c for c in result.checks if c.name == "joint.tau_in"]
    assert not torque.passed and torque.at == 0.0 and "at t = 0 s" in str(torque)
    from_rest = torque.max_error
    text = result.summary()
    assert "joint.tau_in: the largest error is in the first 3 steps, and after them joint.tau_in 0." in text
    assert "if the error shrinks with the step" not in text
    # an error that merely peaks at the start, less than START_DOMINANCE times the largest after it, is the step's:
    # with a band of 0.4 N.m and 0.33 N.m more error after the first steps (passing there), the general hint
    from ujfmu.scenario import Tolerance
    from ujfmu.scenario_run import START_DOMINANCE
    scenario = result.scenario
    scenario.tolerances["joint.tau_in"] = Tolerance(abs=0.4)
    table = result.table.copy()
    table["joint.tau_in"][table["time"] > 0.0025] += 0.33
    result.table, result.checks = table, compare(table, scenario.read_reference(), scenario.tolerances)
    (torque,) = [c for c in result.checks if c.name == "joint.tau_in"]
    assert not torque.passed and torque.at == 0.0 and torque.max_error < START_DOMINANCE * 0.3
    assert result._start_failures() == ([], "")
    assert "the largest error is in the first 3 steps" not in result.summary()
    assert "if the error shrinks with the step" in result.summary()
    # a run of two steps has nothing after its start to compare: the summary says the general hint, not a crash
    short = Scenario(path)
    short.stop_time = 0.002
    assert "if the error shrinks with the step" in run_scenario(short, fmu_dir=fmu_dir, out_dir=None, plot=False,
                                                                progress=False).summary()
    # started in equilibrium (tau_initial about the load's 2 + 4e-5 * 157^2 N.m), the motor does not decelerate
    # first: the co-simulation and the reference, both started so, agree at t = 0 within the joint's own swing
    path.write_text(START_AT_SPEED.replace("profile = 0,", "profile = 0, tau_initial = 3.0,"))
    write_reference(tmp_path / "start_at_speed.csv", *generate(Scenario(path)))
    result = run_scenario(Scenario(path), fmu_dir=fmu_dir, out_dir=None, plot=False, progress=False)
    assert result.passed, result.summary()
    (torque,) = [c for c in result.checks if c.name == "joint.tau_in"]
    assert torque.max_error < 0.15 * from_rest


def test_the_operating_point_is_the_angles_advance_not_a_mean_of_aliased_samples():
    """A record of every 20th step meets a 50 Hz ripple of the drive's speed at one phase (a fresh-eyes trial's
    joint at 1500 rpm): the samples' mean sits on the ripple's crest, 1% over the set point, and had failed the
    drive. Its angle's advance over the window is the mean speed whatever the samples."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import check_operating_points
    scenario = Scenario(Path(__file__).parent.parent / "scenarios" / "cardan_startup.toml")
    omega, ripple, w = 150.0, 3.0, 2.0 * math.pi * 50.0
    t = np.arange(0.0, 6.0 + 1e-9, 0.02) + 0.005   # a quarter period of the ripple in: its crest
    speeds = omega + ripple * np.sin(w * t)
    angle = omega * t - ripple / w * np.cos(w * t)
    record = table(t, motor__omega=speeds, motor__omega_ref=np.full_like(t, omega), motor__phi=angle)
    (check,) = check_operating_points(scenario, record)
    assert float(np.mean(speeds[t >= check.since])) == pytest.approx(omega + ripple)
    assert check.value == pytest.approx(omega, rel=1e-12) and check.passed
    (plain,) = check_operating_points(scenario, record[["time", "motor.omega", "motor.omega_ref"]])
    assert plain.value == pytest.approx(omega + ripple) and not plain.passed


def test_a_steady_run_states_its_orders_over_the_steady_window(fmu_dir):
    """The twin rotor at 100 rad/s (beta 5 deg, 2 N.m), steady from 16 s: the summary gives each recorded signal's
    mean and orders over that window; disc 2's 1x is the Jeffcott unbalance response m_u e w^2 / |K - m w^2 + i C w|
    (within 1%: the joint adds 0.4%), X and Y alike (a circle), and the misaligned joint's 2x is there."""
    from ujfmu.models.twin_jeffcott_rotor.model import rig_parameters
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import run_scenario
    scenario = Scenario(Path(__file__).parent.parent / "scenarios" / "twin_jeffcott_steady.toml")
    text = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None, plot=False, progress=False).summary()
    assert "orders over the steady window from t = 16 s, against the angle of motor.omega" in text
    figures = {}
    for axis in ("X2", "Y2"):
        line = next(x for x in text.splitlines() if x.strip().startswith(f"rotor.{axis} "))
        figures[axis] = [float(x.split()[-1]) for x in line.replace(" m", "").split(",")[1:]]
    p, w = rig_parameters(), 100.0
    m, k, c = p["M2"] + p["m_u2"], p["K2X"], p["C2X"]
    jeffcott = p["m_u2"] * p["e"] * w * w / math.hypot(k - m * w * w, c * w)
    assert figures["X2"][0] == pytest.approx(jeffcott, rel=0.01)
    assert figures["Y2"][0] == pytest.approx(figures["X2"][0], rel=0.01)
    assert figures["X2"][1] > 0.01 * figures["X2"][0]
    # the window is the steady one: a least-squares fit of orders 0..8 of the ideal source's angle 100 t over
    # t >= 16 s, made here, gives the same 1x (over the whole run, start-up included, it is 0.04% off)
    table = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=None, plot=False, progress=False).table
    steady = table[table["time"] >= 16.0 - 1e-9]
    angle = w * steady["time"]
    basis = np.column_stack([np.ones_like(angle)] + [f(j * angle) for j in range(1, 9) for f in (np.cos, np.sin)])
    coef = np.linalg.lstsq(basis, steady["rotor.X2"], rcond=None)[0]
    assert figures["X2"][0] == pytest.approx(math.hypot(coef[1], coef[2]), rel=2e-4)


def test_a_unit_slip_is_named_by_the_signals_unit_and_not_for_a_wave_out_of_phase():
    """unit_slip names a measured column that is the run's signal times a unit's factor: rpm only for a speed, the
    other sign only where the signal has a clear mean (a zero-mean wave half a period late is its own negative too),
    nothing for a reference that does not vary (any two constants have some ratio)."""
    from ujfmu.scenario_run import unit_slip
    t = np.linspace(0.0, 1.0, 1001)
    wave = np.sin(2.0 * np.pi * 5.0 * t)
    speed = 100.0 + 5.0 * wave
    assert "rpm where rad/s is meant" in unit_slip(speed, speed * 30.0 / np.pi, "rad/s")
    assert unit_slip(speed, speed * 30.0 / np.pi, "N.m") == ""
    assert "degrees where rad is meant" in unit_slip(wave, np.degrees(wave), "rad")
    torque = 0.3 + 0.05 * wave
    assert "the opposite sign convention" in unit_slip(torque, -torque, "N.m")
    assert unit_slip(wave, -wave, "N.m") == ""   # half a period late
    assert unit_slip(np.full(11, 300.0), np.full(11, 0.3), "N.m") == ""


def test_a_band_as_wide_as_the_steady_vibration_is_said_to_check_the_level_only(tmp_path, fmu_dir):
    """A gate passed a measured reference with a driveline's 2x vibration removed through bands of 17-20% of the
    range (a fresh-eyes trial's): twin_jeffcott_steady against its reference with the secondary shaft torque made
    flat from the steady window on (its 2x, 0.126 N.m, gone) passes a band of 5% of the range (0.19 N.m), and the
    line says that the band checks the level only over the steady window, naming the run's 2x: a gate under
    --strict fails it. A band below the vibration fails the flat reference unmarked; with the torque's orders
    compared ([reference.orders]) the band is not marked and the orders fail. (The bundled runs, whose bands are far
    below their signals' vibration, mark none: tests/test_scenarios.py.)"""
    from ujfmu.references import read_reference, write_reference
    from ujfmu.scenario_run import LEVEL_ONLY, run_scenario
    base = (SCENARIOS / "twin_jeffcott_steady.toml").read_text()
    (tmp_path / "references").mkdir()
    reference, provenance = read_reference(SCENARIOS / "references" / "twin_jeffcott_steady.csv")
    torque = reference["rotor.secondary_shaft_torque"]
    late = reference["time"] >= 16.0
    torque[late] = torque[late].mean()
    write_reference(tmp_path / "references" / "twin_jeffcott_steady.csv", reference, provenance)

    def run(band, orders=""):
        text = base.replace('"rotor.secondary_shaft_torque" = { rel_range = 7e-05 }',
                            f'"rotor.secondary_shaft_torque" = {{ rel_range = {band} }}')
        if orders:
            text = text.replace("[reference.tolerance]", f"{orders}\n\n[reference.tolerance]")
        (tmp_path / "twin_jeffcott_steady.toml").write_text(text)
        result = run_scenario(tmp_path / "twin_jeffcott_steady.toml", fmu_dir=fmu_dir, out_dir=None, plot=False)
        return result, next(c for c in result.checks if c.name == "rotor.secondary_shaft_torque")

    result, check = run(0.05)
    assert result.passed and check.passed and check.level_only
    assert result.level_only_bands == ["rotor.secondary_shaft_torque"]
    assert f"{LEVEL_ONLY} over the steady window from t = 16 s" in str(check)
    assert "the run's largest order there 2x, 0.126 N.m" in str(check)
    result, check = run(0.02)   # 0.076 N.m, below the 0.13 N.m the flat file misses by
    assert not check.passed and not check.level_only
    result, check = run(0.05, '[reference.orders]\n"rotor.secondary_shaft_torque" = { rel = 0.05 }')
    assert check.passed and not check.level_only and result.failed
    assert any(c.order == 2 and not c.passed for c in result.order_checks)
    # a signal that grows (the input work, an angle) has no steady vibration for a band to miss
    grows = base.replace('"rotor.input_work" = { rel_range = 1e-06 }', '"rotor.input_work" = { rel_range = 0.05 }')
    assert grows != base
    (tmp_path / "twin_jeffcott_steady.toml").write_text(grows)
    (tmp_path / "references" / "twin_jeffcott_steady.csv").write_bytes(
        (SCENARIOS / "references" / "twin_jeffcott_steady.csv").read_bytes())
    assert run_scenario(tmp_path / "twin_jeffcott_steady.toml", fmu_dir=fmu_dir, out_dir=None,
                        plot=False).level_only_bands == []


@pytest.mark.parametrize("bend_deg, marked", [(8.0, True), (3.0, True), (1.5, False)])
def test_a_band_wider_than_a_propshaft_joints_steady_swing_is_marked(bend_deg, marked):
    """A run-up from rest to 2000 rpm through a Cardan joint: the output speed's steady 2x swing, half of
    (1/cos(b) - cos(b)) times the speed, is 0.97% of the run's range at 8 deg and 0.14% at 3 deg (a propshaft's
    angles). A run without the joint's swing (a straight shaft, a fresh-eyes trial's) passed a 5% band unmarked at
    8 deg; now a band as wide as the swing is marked as checking the level only from 3 deg up; at 1.5 deg (0.03%) the
    swing is below what is taken for a feature of the signal, and nothing is marked."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import mark_vibration_blind
    scenario = Scenario(SCENARIOS / "cardan_startup.toml")   # no steady window: its run's last quarter is looked at
    t = np.linspace(0.0, scenario.stop_time, round(scenario.stop_time / 1e-3) + 1)
    speed = np.minimum(100.0 * t, 2000.0 * math.pi / 30.0)
    angle = np.cumsum(speed) * 1e-3
    b = math.radians(bend_deg)
    joint = speed * math.cos(b) / (1.0 - math.sin(b) ** 2 * np.sin(angle) ** 2)   # the Cardan joint's speed ratio
    names = ["time", "motor.omega", "joint.omega_out"]
    reference = np.rec.fromarrays([t, speed, joint], names=names)
    run = np.rec.fromarrays([t, speed, speed * float(np.mean(joint[t > 5.0]) / np.mean(speed[t > 5.0]))],
                            names=names)   # the straight shaft: the level, not the swing
    checks = compare(run, reference, {"joint.omega_out": Tolerance(rel_range=0.05)}, {"joint.omega_out": "rad/s"})
    swing = 0.5 * float(np.ptp(joint[t >= 4.5]))
    assert swing / float(np.ptp(joint)) == pytest.approx(0.5 * (1 / math.cos(b) - math.cos(b)), rel=0.05)
    assert checks[0].passed and checks[0].allowed > swing
    mark_vibration_blind(scenario, run, reference, checks)
    assert checks[0].level_only is marked, checks[0]


def test_orders_at_a_step_that_hides_the_vibration_fail_naming_the_step_not_a_spurious_order():
    """A Cardan joint's output speed at 209.4 rad/s, its 2x swing 2.05 rad/s, recorded every 4 ms (3.7 samples a
    period of the 2x, a fresh-eyes trial's coarse step): the 2x is not resolved, and the run's spurious 1x of 8.5e-5
    rad/s (4e-5 of the swing) against the reference's 2.4e-9 had been the FAIL's stated cause (+3.6e6%). Now the 1x
    is not compared (below 1% of the vibration, half the peak-to-peak), and the 2x, which the joint carries (its 4x
    it does not: a note), fails naming the step (the record's interval where a 1 ms run records every fourth step,
    a CI trial's case: the step was fine); at 8 ms, where no order is resolved, the same. At 1 ms the 2x is
    resolved and compared, and the 1x is still no order to compare. A run equal to its reference with a 3x and a
    drift beside the resolved 2x passes (a review's case: only an order a machine carries fails unresolved)."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import check_orders
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml")   # a 30 deg joint: it carries the 2x
    scenario.order_tolerances, scenario.steady_from, scenario.running_speed = {"joint.omega_out": 0.02}, 1.0, \
        "motor.omega"

    def table(h, spurious, more=0.0):
        t = np.arange(0.0, 2.0 + h / 2, h)
        theta = 209.44 * t
        speed = (209.44 * (1.0 + 0.0098 * np.cos(2 * theta)) + spurious * np.cos(theta + 0.3)
                 + more * (np.cos(3 * theta + 0.4) + t))
        return np.rec.fromarrays([t, np.full_like(t, 209.44), speed], names=["time", "motor.omega", "joint.omega_out"])
    coarse = check_orders(scenario, table(4e-3, 8.5e-5), table(4e-3, 2.4e-9))
    assert [(c.order, c.passed) for c in coarse] == [(2, False), (4, True)], [str(c) for c in coarse]
    assert str(coarse[0]).startswith("FAIL joint.omega_out: its 2x order is not resolved at this step")
    assert "its machine carries it (its share of the signal's vibration, 2.04 half its peak-to-peak about its " \
        "trend" in str(coarse[0]) and "take a smaller step" in str(coarse[0])
    (none,) = check_orders(scenario, table(8e-3, 8.5e-5), table(8e-3, 2.4e-9))
    assert not none.passed and "no order is resolved at this step" in none.note and "the 2x its machine carries" in none.note
    scenario.output_interval = 4   # a 1 ms step recorded every 4 ms: the record's interval named, not the step
    sparse = check_orders(scenario, table(4e-3, 8.5e-5), table(4e-3, 2.4e-9))
    assert str(sparse[0]).startswith("FAIL joint.omega_out: its 2x order is not resolved at this record's interval")
    assert ("cannot be checked): record more often (output_interval = 4 steps now), and take a smaller step where one "
            "step is too long already") in str(sparse[0])
    scenario.output_interval = None
    fine = check_orders(scenario, table(1e-3, 8.5e-5), table(1e-3, 2.4e-9))
    assert [(c.order, c.passed) for c in fine] == [(2, True)], [str(c) for c in fine]
    same = check_orders(scenario, table(2.5e-3, 0.0, 1.5), table(2.5e-3, 0.0, 1.5))   # 2x resolved, 4x not
    assert all(c.passed for c in same) and any(c.order == 4 and c.note for c in same), [str(c) for c in same]


def test_a_wrong_stop_time_is_the_one_problem_of_a_scenario_with_orders(tmp_path):
    """A stop time that is not whole steps leaves the steady window unread: it had added a false second problem,
    that [reference.orders] needs steady_from after start_time (set to 16 s in the file)."""
    from ujfmu.scenario import Scenario, ScenarioError
    text = (SCENARIOS / "twin_jeffcott_steady.toml").read_text().replace(
        "[reference.tolerance]", '[reference.orders]\n"rotor.X2" = { rel = 0.02 }\n\n[reference.tolerance]')
    (tmp_path / "references").mkdir()
    shutil.copy(SCENARIOS / "references" / "twin_jeffcott_steady.csv", tmp_path / "references")
    (tmp_path / "s.toml").write_text(text.replace("stop_time = 17.0", "stop_time = 17.0005"))
    with pytest.raises(ScenarioError) as info:
        Scenario(tmp_path / "s.toml")
    assert "must be a whole number (at least 1) of communication steps" in str(info.value)
    assert "problems" not in str(info.value) and "steady_from" not in str(info.value)


def test_a_signal_still_settling_in_its_last_quarter_is_no_vibration():
    """Without a steady window the run's last quarter is looked at where its drive holds within 1%: a speed still
    settling there (an exponential approach, no vibration at all, the run equal to its reference) had been marked
    as checking the level only (a review's case: its trend taken for a swing); the swing is taken about the window's
    quadratic trend, so a settle is none, and a 2x on top of it still is."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import mark_vibration_blind
    scenario = Scenario(SCENARIOS / "cardan_startup.toml")
    t = np.linspace(0.0, scenario.stop_time, round(scenario.stop_time / 1e-3) + 1)
    speed = 209.44 * (1.0 - 0.02 * np.exp(-t / 1.5))

    def marked(signal):
        table = np.rec.fromarrays([t, speed, signal], names=["time", "motor.omega", "joint.omega_out"])
        checks = compare(table, table, {"joint.omega_out": Tolerance(rel_range=0.1)}, {"joint.omega_out": "rad/s"})
        mark_vibration_blind(scenario, table, table, checks)
        return checks[0].level_only
    assert not marked(speed)
    assert marked(speed * (1.0 + 0.002 * np.cos(2 * np.cumsum(speed) * 1e-3)))
    # a signal that grows (a running angle, an energy integral) is left out by name, whatever its window holds
    angle = np.cumsum(speed) * 1e-3
    table = np.rec.fromarrays([t, speed, angle + 50.0 * np.cos(2 * angle)], names=["time", "motor.omega",
                                                                                   "joint.phi_out"])
    checks = compare(table, table, {"joint.phi_out": Tolerance(rel_range=0.1)}, {"joint.phi_out": "rad"})
    mark_vibration_blind(scenario, table, table, checks)
    assert not checks[0].level_only


def test_an_unresolved_order_fails_only_the_signals_of_a_machine_that_carries_it():
    """Two twin rotors on one drive at 70 rad/s, sampled every 15 ms (the 1x resolved, the 2x at 3 samples a period
    not): the misaligned rotor carries the joint's 2x and its unresolved 2x fails; the aligned one carries only
    the unbalance's 1x, so its unresolved 2x is a note (each signal judged by its own machine's orders)."""
    from ujfmu.scenario import Scenario
    from ujfmu.scenario_run import check_orders, machine_orders
    scenario = Scenario(SCENARIOS / "twin_jeffcott_aligned_vs_misaligned.toml")
    assert machine_orders(scenario) == {"aligned": {1}, "misaligned": {1, 2}}
    scenario.order_tolerances = {"aligned.omega_out": 0.02, "misaligned.omega_out": 0.02}
    scenario.steady_from = 1.0
    t = np.arange(0.0, 3.0 + 7.5e-3, 15e-3)
    theta = 70.0 * t
    table = np.rec.fromarrays([t, np.full_like(t, 70.0), 70.0 + 0.5 * np.cos(theta),
                               70.0 + 0.5 * np.cos(theta) + 0.3 * np.cos(2 * theta)],
                              names=["time", "motor.omega", "aligned.omega_out", "misaligned.omega_out"])
    checks = check_orders(scenario, table, table)
    failed = {(c.name, c.order) for c in checks if not c.passed}
    assert failed == {("misaligned.omega_out", 2)}, [str(c) for c in checks]
    assert any(c.name == "aligned.omega_out" and c.order == 2 and c.note for c in checks)
