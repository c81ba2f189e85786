"""Master: feedthrough ordering, algebraic loops, clear errors."""

import numpy as np
import pytest

from ujfmu.master import Component, Connection, CosimulationError, cosimulate


def chain(fmu_dir):
    return [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=0, omega_set=50.0)),
            Component("joint", fmu_dir / "CardanJoint.fmu", {}),
            Component("load", fmu_dir / "Load.fmu", dict(T0=0.3))]


CONNECTIONS = [Connection("motor.omega", "joint.omega_in"), Connection("joint.tau_in", "motor.tau_load"),
               Connection("joint.omega_out", "load.omega"), Connection("load.tau", "joint.tau_load")]


def test_feedthrough_is_consistent_at_every_communication_point(fmu_dir):
    """Ordered transfers: load.tau = f(joint.omega_out) and joint.tau_in = r * load.tau at the same instant."""
    table = cosimulate(chain(fmu_dir), CONNECTIONS[::-1], 0.2, 1e-3,
                       ["joint.omega_out", "load.tau", "joint.tau_in", "joint.M_z", "motor.tau_motor"])
    w = table["joint.omega_out"]
    np.testing.assert_allclose(table["load.tau"], 0.3 * w / np.sqrt(w * w + 0.01), rtol=1e-14)
    np.testing.assert_allclose(table["joint.M_z"], table["load.tau"], rtol=1e-14)
    np.testing.assert_allclose(table["motor.tau_motor"], table["joint.tau_in"], rtol=1e-14)


def test_algebraic_loop_is_reported(fmu_dir):
    comps = [Component("a", fmu_dir / "Load.fmu", {}), Component("b", fmu_dir / "Load.fmu", {})]
    loop = [Connection("a.tau", "b.omega"), Connection("b.tau", "a.omega")]
    with pytest.raises(CosimulationError, match="algebraic loop"):
        cosimulate(comps, loop, 0.01, 1e-3, ["a.tau"])


def test_missing_fmu_and_bad_step_are_clear_errors(fmu_dir, tmp_path):
    with pytest.raises(CosimulationError, match="not found"):
        cosimulate([Component("m", tmp_path / "Nope.fmu", {})], [], 0.01, 1e-3, [])
    with pytest.raises(CosimulationError, match="whole number"):
        cosimulate(chain(fmu_dir), CONNECTIONS, 0.0105, 1e-3, [])


def test_invalid_parameter_surfaces_with_fmu_log(fmu_dir):
    comps = chain(fmu_dir)
    comps[1].parameters["J2"] = -1.0
    with pytest.raises(CosimulationError, match="J2"):
        cosimulate(comps, CONNECTIONS, 0.01, 1e-3, [])
