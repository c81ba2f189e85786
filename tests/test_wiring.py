"""Wiring for explicit hosts: the speed-driven twin of each torque-driven scenario diverges where the
torque-driven wiring runs (tests/test_scenarios.py and tests/test_ssp.py run the latter in our master, libcosim
and SSP against the monolithic references), and it stays stable below the inertia ratio 1/2."""

import math
from pathlib import Path

from ujfmu.scenario import Scenario
from ujfmu.wiring import runs_stably, speed_driven_twin, with_changes

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_twin_is_the_speed_driven_wiring_of_the_same_system():
    scenario = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml")
    twin = speed_driven_twin(scenario)
    assert twin.components["motor"] == ("Motor", dict(scenario.components["motor"][1], J_rotor=0.01,
                                                      ideal_speed_source=False))
    assert twin.components["joint"] == ("CardanJoint", dict(bend_angle=math.radians(20), J2=0.2))
    links = {(c.source, c.target) for c in twin.connections}
    assert links == {("motor.omega", "joint.omega_in"), ("joint.tau_in", "motor.tau_load"),
                     ("joint.omega_out", "load.omega"), ("load.tau", "joint.tau_load")}
    assert "joint.tau_in" in twin.record and "joint.tau_input_shaft" not in twin.record


def test_heavy_cardan_speed_driven_diverges_in_our_master_and_runs_below_half_the_inertia_ratio(fmu_dir):
    """Speed-driven, J2 r^2 reflected to the input against J_rotor = 0.01: 20x (bundled) and 0.57x (J2 = 0.005)
    diverge at 1 ms, 0.40x (J2 = 0.0035) runs: the joint's second-order acceleration estimate puts the limit at
    1/2 (docs/cosimulation.md). The torque-driven wiring of the 20x case is the bundled scenario."""
    twin = speed_driven_twin(Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml"))
    assert not runs_stably(with_changes(twin, {}, stop_time=0.5), "master", fmu_dir)
    assert not runs_stably(with_changes(twin, {"joint.J2": 0.005}, stop_time=0.5), "master", fmu_dir)
    assert runs_stably(with_changes(twin, {"joint.J2": 0.0035}, stop_time=0.5), "master", fmu_dir)


def test_stiff_double_cardan_speed_driven_diverges_in_libcosim(fmu_dir):
    """The issue's set-up (k_theta 2e4, J_load 0.5, rotor 0.05, 1 ms): speed-driven it diverges in libcosim's
    Jacobi coupling within 0.2 s; torque-driven it is the bundled scenario."""
    twin = speed_driven_twin(Scenario(SCENARIOS / "double_cardan_stiff_torque_driven.toml"))
    assert not runs_stably(with_changes(twin, {}, stop_time=0.3), "libcosim", fmu_dir)


def test_a_diverging_speed_driven_run_names_the_torque_driven_wiring(fmu_dir, tmp_path):
    """The speed-driven twin of the heavy Cardan case run as a scenario (explicit, as written): its coupling error
    names the joint's tau_in connection, and the message goes on to the remedy beside a smaller step, the
    joint's torque-driven variant and the bundled scenario that wires it; a failure elsewhere, or with an ideal speed
    source, gets no such hint."""
    import pytest

    from ujfmu.master import CosimulationError
    from ujfmu.scenario_run import run_scenario, torque_driven_hint
    twin = with_changes(speed_driven_twin(Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml")), {},
                        stop_time=0.5)
    with pytest.raises(CosimulationError) as err:
        run_scenario(twin, fmu_dir=fmu_dir, out_dir=tmp_path, plot=False)
    message = str(err.value)
    assert "joint.tau_in -> motor.tau_load" in message.splitlines()[0]
    assert ("wire it torque-driven instead: CardanJointTorqueDriven driven by a MotorController" in message
            and "J_rotor = 0.01 kg.m2" in message and "scenarios/cardan_heavy_torque_driven.toml" in message)
    assert torque_driven_hint(twin, "component 'load' refused the step at t = 0.1") == ""
    # an ideal speed source ignores the torque: no heavier-side remedy applies to it
    ideal = with_changes(twin, {"motor.ideal_speed_source": True})
    assert torque_driven_hint(ideal, message.splitlines()[0]) == ""
