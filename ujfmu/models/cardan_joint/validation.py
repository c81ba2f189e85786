"""The Feng, Wang, Zhu [Feng2012] section of docs/validation.md (``ujfmu report``): the moments of one universal
joint, against the published values in published.toml beside this module. Tooling (numpy, the sweeps): never
shipped in an FMU."""

import math

import numpy as np

from ...report import Report, Section, published, verdict
from ...sweep import Axis
from . import model as cardan
from .fmu import CardanJoint


def feng(rep: Report) -> Section:
    """Fig. 2 (the moments over a revolution) from the model's equations, Fig. 3 (start-up ramps) from sweeps."""
    joint = {v.name: v.start for v in CardanJoint.VARIABLES if v.causality == "parameter"}
    pub = published("cardan_joint")
    s = Section("Feng, Wang, Zhu: moments transmitted by one universal joint (CardanJoint)",
                "Laboratory model (T0 = 0.3 N.m, J1 = 2.0e-7 kg.m^2, alpha = 30 rad/s^2, phi = 30 deg, beta = "
                "gamma = 0.3 deg; the CardanJoint's defaults). Fig. 2 holds the *driving* torque at T0, whereas "
                "the FMU is driven by a speed and loaded by a torque, so Fig. 2 is evaluated with the FMU's own "
                "equations (`ujfmu.models.cardan_joint.model.transmitted_moment`, Eq. 10) over one revolution at "
                "net torque "
                "T0 - J1 alpha. Fig. 3 runs the FMU (scenario `cardan_constant_speed`, constant 0.3 N.m load) on "
                "start-up ramps of 10, 30 and 50 rad/s^2 from rest, measured over one revolution after 1 s: with "
                "the load torque fixed, the transmitted torque's fluctuation shows up in the driving torque "
                "tau_in. Derivations: [cardan_joint/README.md](../ujfmu/models/cardan_joint/README.md).")
    frame = cardan.joint_frame(joint["bend_angle"], joint["bend_plane_angle"], joint["error_angle_beta"],
                               joint["error_angle_gamma"])
    net = 0.3 - joint["J1"] * 30.0
    m = np.array([cardan.transmitted_moment(frame, t, net) for t in np.linspace(0, 2 * math.pi, 20001)])
    mx, my = np.abs(m[:, 0]).max(), np.abs(m[:, 1]).max()
    ideal = cardan.joint_frame(joint["bend_angle"], joint["bend_plane_angle"], 0.0, 0.0)
    m_ideal = np.array([cardan.transmitted_moment(ideal, t, net) for t in np.linspace(0, 2 * math.pi, 20001)])
    shaft = math.acos(math.cos(joint["error_angle_gamma"]) * math.cos(joint["bend_angle"] - joint["error_angle_beta"]))
    s.intro += (f" An ideal joint (error angles 0) gives M_z {m_ideal[:, 2].min():.4f} to {m_ideal[:, 2].max():.4f} "
                f"N.m, max |M_x| {np.abs(m_ideal[:, 0]).max():.4f} and max |M_y| {np.abs(m_ideal[:, 1]).max():.4f} "
                "N.m: the error angles move each Fig. 2 figure by less than 1%, within the rounding of the paper's "
                "two-digit values, so Fig. 2 cannot tell their effect. With bend_plane_angle = 0 they turn the "
                "driving shaft rigidly: the joint is an ideal one at the shaft angle acos(cos gamma cos(phi - beta)) "
                f"= {math.degrees(shaft):.4f} deg, whose M_z spans T cos(that angle) to T / cos(that angle) "
                f"({net * math.cos(shaft):.4f} to {net / math.cos(shaft):.4f} N.m). The published M_x and M_y ranges "
                "are read as magnitudes: our M_x changes sign over a revolution and our M_y is negative, as the "
                "paper's Eqs. 17-18 give (and the paper says M_y and M_z peak together: M_y's largest value, 0, "
                "falls where M_z's does).")
    for key, ours in (("fig2_mz_min", m[:, 2].min()), ("fig2_mz_max", m[:, 2].max()), ("fig2_mx", mx),
                      ("fig2_my", my)):
        v = pub[key]
        s.row(v.quantity, v.value, ours, v.unit, verdict(ours, v.value, v.band))
    pts, _ = rep.sweep("cardan_constant_speed", "feng_fig3", [Axis.of("motor.profile", [1]),
                                                              Axis.of("motor.omega_set", [150]),
                                                              Axis.of("motor.accel", [10, 30, 50])],
                       outputs=["joint.tau_in"], running_speed="motor.omega", settle_time=1.0, revolutions=1,
                       steady_tol=0.0)   # measured during the ramp, by design: no steady state to wait for
    rows = pts.sorted_by("motor.accel")
    p2p = [r["joint.tau_in.p2p"] for r in rows]
    periods = [math.pi / r["speed_mean"] for r in rows]
    spread = (max(p2p) - min(p2p)) / np.mean(p2p)
    s.row("Fig. 3: fluctuation (peak-to-peak) of the transmitted torque at alpha = 10, 30, 50 rad/s^2 "
          "\"does not change\" (measured in the driving torque tau_in, the load fixed)", None, None, "N.m",
          "consistent (at J2 = 0 and a fixed load the model's tau_in is J1 alpha + r(theta) T: its fluctuation "
          "cannot change with alpha, J1 alpha being constant over a ramp (the paper's J1 alpha / T0 is 2e-5); the "
          "spread is the sampling of the peaks at the 1 ms step)"
          if spread < 1e-3 else "not reproduced",
          paper_text="unchanged", ours_text=" / ".join(f"{v:.5f}" for v in p2p) + f" (spread {100 * spread:.3f}%)")
    s.row("Fig. 3: fluctuation period (2x) after 1 s \"decreases with the acceleration\" (pi / the mean speed "
          "reached)", None, None, "s",
          "consistent (arithmetic: the 2x period at a higher speed)" if periods[0] > periods[1] > periods[2]
          else "not reproduced", paper_text="decreases", ours_text=" / ".join(f"{v:.4f}" for v in periods))
    return s


SECTIONS = (feng,)
