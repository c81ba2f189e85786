"""The report engine without running it: published values as per-model data, points found by axis values, axes
as objects equal to the command line's."""

import math

import pytest

from ujfmu.bibliography import BY_KEY
from ujfmu.build import REPO_DIR
from ujfmu.report import VALIDATED, Points, published, section_functions
from ujfmu.scenario import Scenario
from ujfmu.sweep import Axis, parse_axis


def test_published_values_are_data_that_the_committed_report_shows():
    """Every published value is read from its model's published.toml, cites a known paper, and appears as the
    paper column of its row in docs/validation.md."""
    report = (REPO_DIR / "docs" / "validation.md").read_text()
    count = 0
    for stem in VALIDATED:
        for v in published(stem).values():
            count += 1
            assert v.paper in BY_KEY and v.value > 0 and (v.band is None or 0 < v.band < 1)
            assert f"| {v.quantity} | {v.value:.4g} |" in report, v.id
    assert count == 29


def test_sections_come_from_the_model_folders_in_report_order():
    assert [s.__name__ for s in section_functions()] == ["feng", "brutti", "omar", "tchomeni", "turla"]
    assert all(s.__module__.startswith("ujfmu.models.") for s in section_functions())


def test_points_are_found_by_axis_values_in_any_unit():
    rows = [{"point": {"motor.omega_set": w * math.pi / 30.0, "load.T0": t}, "value": (w, t)}
            for w in (100.0, 110.0) for t in (5.0, 10.0)]
    points = Points(rows)
    rpm = (110.0 / 30.0) * math.pi   # the same speed computed another way: not the same float
    assert rpm != 110.0 * math.pi / 30.0
    assert points.at({"motor.omega_set": rpm, "load.T0": 10})["value"] == (110.0, 10.0)
    assert [r["value"] for r in points.where({"load.T0": 5.0})] == [(100.0, 5.0), (110.0, 5.0)]
    with pytest.raises(KeyError, match="0 sweep points"):
        points.at({"load.T0": 7.0})
    with pytest.raises(KeyError, match="2 sweep points"):
        points.at({"load.T0": 5.0})


def test_axis_objects_are_what_the_command_line_parses():
    scenario = Scenario(REPO_DIR / "scenarios" / "double_cardan_omar_torsional.toml")
    assert Axis.span("motor.omega_set", 100, 1500, 10, "rpm") == parse_axis("motor.omega_set=100:1500:10rpm",
                                                                            scenario)
    linked = Axis.of(("driveline.beta1", "driveline.beta2"), [15, 30], "deg")
    assert linked == parse_axis("driveline.beta1,driveline.beta2=15,30deg", scenario)
    with pytest.raises(Exception, match="outside its allowed range"):
        Axis.of("driveline.beta1", [95], "deg").check(scenario)


def test_an_axis_says_its_si_unit_and_flags_a_speed_given_without_one():
    """A plain number on a speed axis is rad/s: the sweep's header says so and how to give rpm."""
    scenario = Scenario(REPO_DIR / "scenarios" / "double_cardan_omar_torsional.toml")
    plain = parse_axis("motor.omega_set=100:300:100", scenario).describe(scenario)
    assert plain.startswith("3 motor.omega_set 100..300 rad/s") and "taken as rad/s" in plain and "rpm" in plain
    rpm = parse_axis("motor.omega_set=955:2865:955rpm", scenario).describe(scenario)
    assert "rad/s" in rpm and "given as 955..2865 rpm" in rpm and "taken as" not in rpm
    angle = parse_axis("driveline.beta1=5,10deg", scenario).describe(scenario)
    assert "rad" in angle and "given as 5..10 deg" in angle


def test_a_trend_is_a_verdict_only_where_it_holds():
    """A value outside its band is "reproduced in trend" only where the caller checked the effect the paper shows
    (a direction, a sign) and it holds; a trend that does not hold is "not reproduced", naming it. Any text had
    passed before, unchecked."""
    from ujfmu.report import verdict
    assert verdict(1.02, 1.0, 0.03) == "reproduced (within 3%)"
    assert verdict(1.66, 2.0, 0.1, trend=("rises with beta0", True)) == "reproduced in trend: rises with beta0"
    assert verdict(0.9, 2.0, 0.1, trend=("rises with beta0", False)) == "not reproduced: rises with beta0"
    assert verdict(0.9, 2.0, 0.1) == "not reproduced"
