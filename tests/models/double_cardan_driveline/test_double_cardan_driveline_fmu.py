"""DoubleCardanDriveline.fmu through fmpy: continuity, power balance, errors. Every output of the flexible
driveline against the independent monolithic reference: scenarios/double_cardan_omar_*.toml."""

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

OUT = ("omega_out", "phi_out", "tau_in", "twist", "dynamic_misalignment", "omega_intermediate", "shaft_torque",
       "phi_in", "stored_energy")
DEG = math.pi / 180.0


def test_rigid_constant_velocity_layout_at_speed_keeps_angles_continuous(open_fmu, drive):
    """Z layout, yokes in phase, rigid, 200 rad/s for 1 s (~32 revolutions): output angle = input angle."""
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 200.0, 50.0, 1e-3, 1000, OUT,
              dict(rigid_intermediate_shaft=True, J_load=0.0))
    np.testing.assert_allclose(r.phi_out, r.phi_in, atol=1e-9)
    np.testing.assert_allclose(r.tau_in, 50.0, rtol=1e-12)
    assert np.all(np.diff(r.phi_out) > 0) and r.phi_out[-1] > 60 * math.pi
    assert np.ptp(r.omega_intermediate) > 5.0


def test_power_balance_through_the_fmu_outputs(open_fmu, drive):
    """Undamped, constant input speed and load: tau_in w1 - tau_load w4 = dE/dt (E the FMU's stored_energy)."""
    h = 2e-4
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 60.0, 5.0, h, 2500, OUT,
              dict(xi_theta=0.0, xi_phi=0.0, beta2=-15 * DEG))
    power = r.tau_in * r.omega_in - 5.0 * r.omega_out
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * h)])
    energy = r.stored_energy - r.stored_energy[0]
    assert np.ptp(energy) > 0.01
    assert np.max(np.abs(energy - work)) < 2e-3 * np.ptp(energy)   # trapezoidal rule, O(h^2)


@pytest.mark.parametrize("params,needle", [({"J_load": 0.0}, "J_load"),
                                           ({"I_cross_pin": 1e-3, "I_cross_normal": 3e-3}, "I_cross_normal")])
def test_inconsistent_parameters_are_errors_naming_them(open_fmu, params, needle):
    inst = open_fmu("DoubleCardanDriveline")
    with pytest.raises(FMICallException):
        inst.initialize(params)
    assert any(needle in m for m in inst._log), inst._log


@pytest.mark.parametrize("rigid", [True, False])
def test_fmu_estimates_the_input_acceleration_to_second_order(open_fmu, drive, rigid):
    """Fed a speed quadratic in time, alpha_in is its exact derivative at t_k from the third point on (BDF2; the
    backward difference would be off by b h, half a step late), in both modes; the first step has one difference
    only (backward)."""
    a, b, h = 30.0, 400.0, 1e-3
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 5.0 + a * t + b * t * t, 5.0, h, 40, ("alpha_in",),
              dict(rigid_intermediate_shaft=rigid))
    np.testing.assert_allclose(r.alpha_in[2:], a + 2.0 * b * r.time[2:], rtol=1e-9)
    np.testing.assert_allclose(r.alpha_in[1], a + b * h, rtol=1e-9)
