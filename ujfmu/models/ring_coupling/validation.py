"""The Turla, Iljin [Turla2002] section of docs/validation.md (``ujfmu report``): the elastic centrifugal ring
coupling; the paper prints no values (published.toml beside this module is empty), so the FMU is compared with
the paper's Eq. (20) and the trends of its figures. Tooling (numpy, the sweeps): never shipped in an FMU."""

import numpy as np

from ...report import SCENARIOS, Report, Section
from ...scenario import Scenario
from ...sweep import Axis
from . import model as rc


def turla(rep: Report) -> Section:
    """Fig. 3 (the pendulum's 2x amplitude) and Fig. 4 (Eq. 20's validity) from sweeps against Eq. (20)."""
    sc = Scenario(SCENARIOS / "ring_coupling_fig3.toml")
    p = sc.parameters_with_defaults("coupling")
    s = Section("Turla, Iljin: elastic centrifugal ring coupling between misaligned shafts (RingCoupling)",
                "Fig. 3 ring (scenario `ring_coupling_fig3`, pendulum case c_s = c_d = 0: undamped, so its "
                "oscillation from the start is the result and is measured over the first 4 revolutions, without a "
                "steady-state check) swept over the running speed; Fig. 4's limits from the three rings of "
                "scenario `ring_coupling_speed_study` (c_s = 87 "
                "EI/R, 10% damping) swept at constant speeds. Eq. (20): amplitude 39.25 e^2 EI/(w^2 I2 R^3). "
                "Derivation: [ring_coupling/README.md](../ujfmu/models/ring_coupling/README.md).")

    def eq20(q, w):
        return rc.small_parameter_amplitude(q["E"], q["d"], q["R"], q["e"], q["I2"], w)

    pts, _ = rep.sweep("ring_coupling_fig3", "turla_fig3", [Axis.of("motor.omega_set", [50, 100, 200, 400])],
                       outputs=["coupling.x_e"], running_speed="motor.omega", settle_time=0.0, revolutions=4,
                       steady_tol=0.0)   # undamped pendulum: its oscillation never settles, it is the result
    r100 = pts.at({"motor.omega_set": 100.0})
    a100 = eq20(p, 100.0)
    solves = ("consistent (the pendulum case solves the paper's Eq. 9, of which Eq. 20 is the paper's approximate "
              "solution: it checks the integration and our reading of the equations, not the physics)")
    s.row("Fig. 3: 2x amplitude of x_e at 100 rad/s (Eq. 20 vs FMU)", a100, r100["coupling.x_e.h2"], "rad",
          solves if abs(r100["coupling.x_e.h2"] / a100 - 1.0) <= 0.02 else "not reproduced",
          paper_text=f"{a100:.4g} (Eq. 20; no value printed)")
    w2a = [w * w * pts.at({"motor.omega_set": w})["coupling.x_e.h2"] for w in (50.0, 100.0, 200.0, 400.0)]
    spread = (max(w2a) - min(w2a)) / np.mean(w2a)
    s.row("Fig. 3: amplitude falls as 1/w^2 (w^2 x amplitude at 50, 100, 200, 400 rad/s)", None, None, "rad/s^2",
          solves if spread < 0.02 else "not reproduced", paper_text="1/w^2",
          ours_text=" / ".join(f"{v:.4g}" for v in w2a) + f" (spread {100 * spread:.2f}%)")

    rings = {"ring_r10": 0.1, "ring_r20": 0.2, "ring_r30": 0.3}
    study = Scenario(SCENARIOS / "ring_coupling_speed_study.toml")
    limits = {}
    for comp, radius in rings.items():
        q = study.parameters_with_defaults(comp)
        limits[comp] = rc.validity_speed(q["E"], q["d"], q["R"], q["I2"])
    factors = (1.2, 2.0, 4.0, 8.0)
    speeds = sorted({round(f * w, 6) for w in limits.values() for f in factors})
    pts, _ = rep.sweep("ring_coupling_speed_study", "turla_fig4",
                       [Axis.of("motor.profile", [0]), Axis.of("motor.omega_set", speeds)],
                       outputs=[f"{c}.x_e" for c in rings], running_speed="motor.omega", settle_time=2.0,
                       revolutions=4)
    for comp, radius in rings.items():
        q = study.parameters_with_defaults(comp)
        errors = []
        for f in factors:
            w = round(f * limits[comp], 6)
            amp = pts.at({"motor.profile": 0.0, "motor.omega_set": w})[f"{comp}.x_e.h2"]
            errors.append(abs(eq20(q, w) - amp) / amp)
        monotone = all(a > b for a, b in zip(errors, errors[1:]))
        s.row(f"Fig. 4: lower speed limit of Eq. (20), R = {radius} m", None, None, "rad/s",
              "no published value: derived from Eqs. (20), (22); the FMU's error against Eq. (20) falls with "
              "the speed" if monotone else "not reproduced: the FMU's error against Eq. (20) does not fall with "
              "the speed",
              paper_text="stroked zone, no number",
              ours_text=f"{limits[comp]:.1f}; error of Eq. (20) at " + ", ".join(
                  f"{f:g}" for f in factors) + " w_min: " + " / ".join(f"{100 * e:.0f}%" for e in errors))
    return s


SECTIONS = (turla,)
