"""DoubleCardanDriveline.fmu through fmpy: physics agreement, continuity, power balance, errors."""

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from ujfmu.physics import double_cardan as dc

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


def test_flexible_outputs_follow_the_physics_module(open_fmu, drive):
    h, w, n = 1e-3, 71.6, 300
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: w, 5.0, h, n, OUT)
    p = dc.Driveline(15 * DEG, 15 * DEG, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0045, 92.2, 0.002, 4.09, 26331.0, 0.002,
                     0.325)
    phi1, state = 0.0, (0.0, w, 0.0, 0.0)
    substeps = dc.flexible_substeps(dc.natural_rate_bound(p), h, w)
    for k in range(n):
        out = dc.flexible_outputs(p, phi1, w, 0.0, state)
        assert (r.phi_out[k], r.omega_out[k], r.dynamic_misalignment[k]) == pytest.approx(state[:3], abs=1e-12)
        assert (r.twist[k], r.tau_in[k]) == pytest.approx((out["twist"], out["tau_in"]), abs=1e-12)
        state = dc.flexible_step(p, h, phi1, w, 0.0, state, 5.0, substeps)
        phi1 += w * h
    assert np.max(r.twist) > 4.0 / 92.2          # the load twists the shaft (static twist 5/92.2 rad)


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
