"""Coupling battery: randomly drawn heavy and stiff drivelines against their monolithic references.

The default (implicit) scheme must run every set-up at 1 ms; within 2% of each signal's range everywhere except
the set-ups listed in FIRST_ORDER_LIMITED, whose measured errors docs/cosimulation.md tabulates (strict xfail: if
one starts passing, the list and the docs must be updated). The explicit scheme's instability on heavy driven
sides must be detected and named.
"""

import numpy as np
import pytest

from ujfmu import battery
from ujfmu.master import CouplingInstabilityError, cosimulate
from ujfmu.references import read_reference
from ujfmu.scenario import Scenario

PATHS = battery.paths()
#: set-ups whose first-order coupling error exceeds 2% at 1 ms in the implicit scheme (docs/cosimulation.md)
FIRST_ORDER_LIMITED = {"battery_00", "battery_04", "battery_05", "battery_06", "battery_07"}


def test_battery_is_drawn_as_committed():
    """The committed scenario files are what the fixed seed draws (regenerate: ujfmu battery --regenerate)."""
    setups = battery.draw()
    assert len(setups) >= 30 and [p.stem for p in PATHS] == [s["name"] for s in setups]
    assert {s["kind"] for s in setups} == {"CardanJoint", "DoubleCardanDriveline"}
    for setup, path in zip(setups, PATHS):
        assert path.read_text() == battery.scenario_text(setup), path.name
        assert Scenario(path).reference_file.is_file(), path.name


def test_battery_spans_the_heavy_driven_side():
    """The battery must contain set-ups that the explicit inertia coupling cannot run: driven inertia above the
    motor's (J2 for the CardanJoint, J_load for the DoubleCardanDriveline)."""
    ratios = [(s["joint"].get("J2") or s["joint"]["J_load"]) / s["motor"]["J_rotor"] for s in battery.draw()]
    assert sum(r > 1.0 for r in ratios) >= 5 and sum(r < 1.0 for r in ratios) >= 5


@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.stem)
def test_default_scheme_within_two_percent(path, fmu_dir, request):
    if path.stem in FIRST_ORDER_LIMITED:
        request.applymarker(pytest.mark.xfail(strict=True, reason="first-order coupling error above 2% at 1 ms "
                                                                 "(docs/cosimulation.md)"))
    run = battery.run_one(path, "implicit", fmu_dir)
    assert not run.error, run.error
    assert run.passed, {k: round(v, 4) for k, v in run.worst.items()}


@pytest.mark.parametrize("name", sorted(FIRST_ORDER_LIMITED))
def test_default_scheme_stays_stable_where_it_is_inaccurate(name, fmu_dir):
    """Where 2% is not reached at 1 ms, the implicit run still completes and stays within 60% of each signal's
    range of the reference (no divergence: the explicit scheme overflows the ports on some of these)."""
    run = battery.run_one(battery.BATTERY_DIR / f"{name}.toml", "implicit", fmu_dir)
    assert not run.error and max(run.worst.values()) < 0.6, (run.error, run.worst)


def test_explicit_instability_is_detected_and_named(fmu_dir):
    """A driven inertia 30x the motor's: the explicit loop's torque alternates and grows at every step; the error
    names both components, the connection, the growth and the remedy, and keeps the results so far."""
    scenario = Scenario(battery.BATTERY_DIR / "battery_00.toml")
    with pytest.raises(CouplingInstabilityError) as info:
        cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time,
                   scenario.step_size, scenario.record, coupling="explicit")
    message = str(info.value)
    for words in ("'joint' and 'motor'", "joint.tau_in -> motor.tau_load", "growing x", "h = 0.001",
                  'coupling = "implicit"'):
        assert words in message
    partial = info.value.partial
    assert partial is not None and 2 <= len(partial) < 50 and partial["time"][0] == 0.0
    reference, _ = read_reference(scenario.reference_file)
    # the first steps, before the divergence took hold, follow the reference
    np.testing.assert_allclose(partial["motor.omega"][:2], reference["motor.omega"][:2], atol=0.05)
