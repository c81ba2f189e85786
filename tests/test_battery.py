"""Coupling battery: randomly drawn heavy and stiff drivelines against their monolithic references.

The default (implicit) scheme must run every set-up at 1 ms; within 2% of each signal's range everywhere except
the set-ups listed in FIRST_ORDER_LIMITED (CardanJoints carrying a heavy J2, whose inertia-torque ripple the
1 ms step samples coarsely), whose measured errors docs/cosimulation.md tabulates. The explicit scheme's
instability on heavy driven sides must be detected and named.
"""

import numpy as np
import pytest

from ujfmu import battery
from ujfmu.master import CouplingInstabilityError, cosimulate
from ujfmu.references import read_reference
from ujfmu.scenario import Scenario

PATHS = battery.paths()
#: set-ups whose first-order coupling error exceeds 2% at 1 ms in the implicit scheme (docs/cosimulation.md)
FIRST_ORDER_LIMITED = {"battery_00", "battery_04", "battery_06", "battery_10", "battery_14", "battery_15",
                       "battery_16", "battery_20", "battery_22", "battery_28", "battery_30", "battery_32",
                       "battery_34"}


def test_battery_is_drawn_as_committed():
    """The committed scenario files are what the fixed seed draws (regenerate: ujfmu battery --regenerate)."""
    setups = [s for s in battery.draw() if s["name"] not in battery.EXCLUDED]
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
def test_default_scheme_on_the_battery(path, fmu_dir):
    """Every set-up runs to the end in the default scheme; within 2% of each signal's range of the monolithic
    reference, except the FIRST_ORDER_LIMITED ones, which must stay between 2% and 10% (tabulated in
    docs/cosimulation.md: when one improves past 2%, move it out of the list and update the docs)."""
    run = battery.run_one(path, "implicit", fmu_dir)
    assert not run.error, run.error
    worst = max(run.worst.values())
    if path.stem in FIRST_ORDER_LIMITED:
        assert battery.TOLERANCE < worst < 0.10, {k: round(v, 4) for k, v in run.worst.items()}
    else:
        assert worst <= battery.TOLERANCE, {k: round(v, 4) for k, v in run.worst.items()}


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
    # the kept results end on the diverging torque, far outside anything the real system does
    np.testing.assert_array_equal(partial["time"], reference["time"][:len(partial)])
    assert abs(partial["joint.tau_in"][-1]) > 10 * np.ptp(reference["joint.tau_in"])
