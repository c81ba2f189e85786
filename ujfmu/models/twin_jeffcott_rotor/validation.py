"""The Tchomeni, Alugongo, Masu [Tchomeni2019] section of docs/validation.md (``ujfmu report``): two unbalanced
Jeffcott rotors through a Hooke joint; the paper publishes no numbers (published.toml beside this module is
empty), so its qualitative claims are checked. Tooling (numpy, the sweeps): never shipped in an FMU."""

import dataclasses
import math
import shutil
from pathlib import Path

import numpy as np

from ...analysis import decay_rates
from ...report import SCENARIOS, Report, Section, below, settled_text
from ...scenario import Scenario
from ...scenario_run import run_scenario
from ...sweep import Axis, SweepSettings
from . import model as tj


#: the 2x / 1x amplitude ratio at which a whirl orbit starts to cross itself (loops): 1/2
LOOP_RATIO = 0.5


def twin_decay_rates(parameters: dict) -> np.ndarray:
    """Decay rates [1/s] of the TwinJeffcottRotor's free modes, slowest first: eigenvalues of its equations
    linearised at rest with the input held (an ideal speed source), no load (``analysis.decay_rates``)."""
    fields = [f.name for f in dataclasses.fields(tj.Parameters) if f.init and f.name in parameters]
    p = tj.Parameters(**{n: parameters[n] for n in fields})
    return decay_rates(lambda y: tj.rates(p, 0.0, 0.0, 0.0, list(y) + [0.0, 0.0], 0.0)[:12], np.zeros(12))


def tchomeni(rep: Report) -> Section:
    """The paper's qualitative claims (2x with misalignment, orbits) from sweeps over the joint angle."""
    sc = Scenario(SCENARIOS / "twin_jeffcott_steady.toml")
    betas = (0, 5, 10, 15)
    sigma = min(twin_decay_rates({**sc.parameters_with_defaults("rotor"), "beta": math.radians(b)})[0]
                for b in betas)
    tol = SweepSettings.steady_tol
    settle = 4.0 / 3.0 * math.log(1.0 / tol) / sigma
    outputs = ["rotor.X2", "rotor.Y2", "rotor.X1", "rotor.Y1", "rotor.tau_in", "rotor.omega_out"]
    pts, sw = rep.sweep("twin_jeffcott_steady", "tchomeni_beta", [Axis.of("rotor.beta", betas, "deg")],
                        outputs=outputs, running_speed="motor.omega", settle_time=settle, revolutions=8)
    s = Section("Tchomeni, Alugongo, Masu: two unbalanced Jeffcott rotors through a Hooke joint (TwinJeffcottRotor)",
                "The paper publishes no parameter table and no numbers; its claims are qualitative. Default rig "
                "(ujfmu/models/twin_jeffcott_rotor/README.md) in scenario `twin_jeffcott_steady` at 100 rad/s with 2 N.m, swept over "
                f"the joint angle. The slowest free mode of the linearised rotor (its first torsional mode) decays "
                f"at sigma = {sigma:.3f} 1/s, so each point settles at least T = (4/3) ln(1/steady_tol) / sigma = "
                f"{settle:.1f} s (a start transient of relative size 1 then changes by less than steady_tol = "
                f"{tol:g} between 3T/4 and T), is checked for steady state and settled in {settled_text(sw)}; then "
                "8 revolutions are measured. Derivation: [twin_jeffcott_rotor/README.md](../ujfmu/models/twin_jeffcott_rotor/README.md).")
    rows = [pts.at({"rotor.beta": math.radians(b)}) for b in betas]
    ratios = [r["rotor.X2.h2"] / r["rotor.X2.h1"] for r in rows]
    s.row("2x running-speed component of disc 2 appears with misalignment (2x / 1x of X2 at beta = 0, 5, 10, "
          "15 deg)", None, None, "1",
          "reproduced in trend" if ratios[0] < 1e-4 and all(a < b for a, b in zip(ratios, ratios[1:]))
          else "not reproduced", paper_text="2x present when misaligned",
          ours_text=" / ".join([below(ratios[0])] + [f"{v:.3g}" for v in ratios[1:]]))
    s.row("1x (unbalance) amplitude of disc 2 barely depends on beta (X2 1x at 0 and 15 deg)", None, None, "m",
          "no published value", paper_text="-",
          ours_text=f"{rows[0]['rotor.X2.h1']:.4g} / {rows[3]['rotor.X2.h1']:.4g}")
    aligned = rows[0]
    circular = max(abs(aligned[f"rotor.X{i}.h1"] - aligned[f"rotor.Y{i}.h1"]) / aligned[f"rotor.X{i}.h1"]
                   for i in (1, 2))
    s.row("aligned rotor under load: circular orbits (X, Y 1x equal) and no 2x in tau_in and omega_out "
          "(beta = 0)", None, None, "1, N.m, rad/s",
          "consistent (axisymmetric)" if circular < 10 * tol else "not axisymmetric", paper_text="-",
          ours_text=f"max \\|X 1x - Y 1x\\| / X 1x {below(circular)}; 2x of tau_in "
                    f"{below(aligned['rotor.tau_in.h2'])}, of omega_out {below(aligned['rotor.omega_out.h2'])}")
    for b, r in zip(betas, rows):
        s.row(f"disc 2 at beta = {b} deg: X2 and Y2 1x / 2x / 4x / mean", None, None, "um", "no published value",
              paper_text="-", ours_text="; ".join(
                  " / ".join(f"{1e6 * r[f'rotor.{c}.{f}']:.2f}" for f in ("h1", "h2", "h4", "mean"))
                  for c in ("X2", "Y2")))
    result = run_scenario(SCENARIOS / "twin_jeffcott_aligned_vs_misaligned.toml", fmu_dir=rep.fmu_dir,
                          out_dir=rep.work_dir, progress=False)
    for extra in result.extra_plots:
        shutil.copy(extra, rep.figure_dir / f"tchomeni_{Path(extra).name}")
    # a 1x circle of radius A with a 2x part B crosses itself only where the 2x's speed 2B passes the 1x's A
    distortion = [max(r["rotor.X2.h2"] / r["rotor.X2.h1"], r["rotor.Y2.h2"] / r["rotor.Y2.h1"]) for r in rows]
    primary = [max(r["rotor.X1.h2"] / r["rotor.X1.h1"], r["rotor.Y1.h2"] / r["rotor.Y1.h1"]) for r in rows]
    looping = [b for b, v in zip(betas, primary) if v >= LOOP_RATIO]
    if not result.passed:
        loops = "not reproduced: the orbit scenario failed its reference check"
    elif max(distortion) >= LOOP_RATIO:
        loops = "reproduced qualitatively"
    elif distortion[0] < 1e-4 and all(a < b for a, b in zip(distortion, distortion[1:])):
        loops = (f"reproduced in trend: the 2x distorts the orbit more as beta grows; loops, which need 2x / 1x >= "
                 f"{LOOP_RATIO:g}, are not reached on the output shaft at the operating points run"
                 + (f"; disc 1's orbit, on the primary shaft (the paper's Fig. 8 spectrum), loops from beta = "
                    f"{looping[0]} deg" if looping else ""))
    else:
        loops = "not reproduced"
    s.row("unbalanced, misaligned output shaft: irregular orbit loops (Fig. 7; Fig. 5 balanced)", None, None, "1",
          loops, paper_text="irregular loops",
          ours_text="2x / 1x of disc 2 at beta = 0, 5, 10, 15 deg: " + " / ".join(
              [below(distortion[0])] + [f"{v:.3g}" for v in distortion[1:]])
          + "; of disc 1: " + " / ".join([below(primary[0])] + [f"{v:.3g}" for v in primary[1:]])
          + "; orbit figure: beta = 0 vs 10 deg at 70 rad/s")
    s.row("unstable operation / divergent equilibrium (Fig. 7)", None, None, "-",
          "not reproduced at the operating points run", paper_text="unstable", ours_text="bounded, steady orbits")
    s.figures += [(f"tchomeni_{Path(p).name}", cap) for p, cap in
                  zip(result.extra_plots, ("orbits, beta = 0 vs 10 deg", "spectra in running-speed orders"))]
    s.notes = ("The aligned orbits are circles to the accuracy of the steady-state check, and exactly so in the "
               "model (an axisymmetric rotor: the bent shaft ends turn about the normals of their bending planes; "
               "tests/models/twin_jeffcott_rotor/test_twin_jeffcott_rotor_model.py shows it to round-off).")
    return s


SECTIONS = (tchomeni,)
