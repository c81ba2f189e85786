"""Numbers the docs and the README quote from the code match the code, so the two cannot drift apart.

A constant is quoted as `module.NAME` = value (module relative to ujfmu), and every such quote is checked; a
substep rule must quote RATE_STEP that way rather than a bare number. Derived values (the twin rotor's default
rig, its natural frequencies and slowest decay) are recomputed and compared to the digits printed."""

import importlib
import math
import re
from pathlib import Path

import numpy as np
import pytest

from ujfmu.models.twin_jeffcott_rotor import model as tj
from ujfmu.models.twin_jeffcott_rotor.validation import twin_decay_rates

ROOT = Path(__file__).parents[1]
DOCS = (sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "ujfmu" / "models").glob("*/README.md"))
        + [ROOT / "README.md"])
QUOTE = re.compile(r"`((?:ujfmu\.)?[a-z_][a-z_0-9]*(?:\.[a-z_][a-z_0-9]*)*)\.([A-Z][A-Z_0-9]*)` = "
                   r"([-+]?\d[\d.]*(?:e[-+]?\d+)?)")


def quotes():
    for path in DOCS:
        for match in QUOTE.finditer(path.read_text()):
            yield (path.relative_to(ROOT).as_posix(), match.group(1).removeprefix("ujfmu."), match.group(2),
                   float(match.group(3)))


def test_every_quoted_constant_is_the_code_value():
    found = list(quotes())
    assert {(doc, name) for doc, _, name, _ in found} >= {
        (f"ujfmu/models/{stem}/README.md", "RATE_STEP")
        for stem in ("twin_jeffcott_rotor", "ring_coupling", "double_cardan_driveline")}
    for doc, module, name, value in found:
        assert getattr(importlib.import_module(f"ujfmu.{module}"), name) == value, f"{doc}: {module}.{name}"


def test_substep_rules_quote_the_constant_not_a_number():
    for path in DOCS:
        for line in path.read_text().splitlines():
            assert not re.search(r"at most \d[\d.]* /", line), f"{path.name}: {line.strip()}"


TWIN = "ujfmu/models/twin_jeffcott_rotor/README.md"
RING = "ujfmu/models/ring_coupling/README.md"


def printed(doc, pattern):
    """The numbers (as text) a regular expression captures in a doc (path relative to the repository)."""
    match = re.search(pattern, (ROOT / doc).read_text().replace("\n", " "))
    assert match, pattern
    return match.groups()


def agrees(value, text):
    """The code's value printed with the digits of the doc's text is that text (spaces as thousands separators)."""
    text = text.replace(" ", "")
    mantissa, _, exponent = text.partition("e")
    decimals = len(mantissa.partition(".")[2])
    scale = 10.0 ** int(exponent or 0)
    return f"{value / scale:.{decimals}f}" == mantissa


def test_twin_rotor_rig_table_and_modes_are_the_code_values():
    r = tj.rig_parameters()
    checks = {
        r"M1 = M2 = ([\d.]+) kg, J_M1 = J_M2 = ([\d.]+)e-3": (r["M1"], 1e3 * r["J_M1"]),
        r"K1X = K1Y = ([\d ]+) N/m, K2X = K2Y = ([\d ]+) N/m": (r["K1X"], r["K2X"]),
        r"C1 = ([\d.]+), C2 = ([\d.]+) N.s/m": (r["C1X"], r["C2X"]),
        r"K1T = ([\d.]+), K2T = ([\d.]+) N.m/rad": (r["K1T"], r["K2T"]),
        r"C1T = ([\d.]+), C2T = ([\d.]+) N.m.s/rad": (r["C1T"], r["C2T"]),
        r"J_gb = (\de-3) kg": (r["J_gb"],),
        r"joint angle \| beta = (\d+) deg": (math.degrees(r["beta"]),),
        r"lateral ([\d.]+) rad/s \(secondary, (\d+) rpm\) and ([\d.]+) rad/s \(primary, (\d+) rpm\)": (
            math.sqrt(r["K2X"] / (r["M2"] + r["m_u2"])), math.sqrt(r["K2X"] / (r["M2"] + r["m_u2"])) * 30 / math.pi,
            math.sqrt(r["K1X"] / (r["M1"] + r["m_u1"])), math.sqrt(r["K1X"] / (r["M1"] + r["m_u1"])) * 30 / math.pi),
    }
    for pattern, values in checks.items():
        for text, value in zip(printed(TWIN, pattern), values):
            assert agrees(value, text), (pattern, text, value)
    stiffness = np.array([[r["K1T"] + r["K2T"], -r["K2T"]], [-r["K2T"], r["K2T"]]])
    inertia = np.diag([r[f"J_M{i}"] + r[f"m_u{i}"] * r["e"] ** 2 for i in (1, 2)])   # with the unbalance mass
    torsion = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(inertia, stiffness)).real))
    for text, value in zip(printed(TWIN, r"torsional ([\d.]+) and ([\d.]+) rad/s"), torsion):
        assert agrees(value, text), (text, value)
    sigma = twin_decay_rates({**r, "phase_u1": 0.0, "phase_u2": 0.0, "beta": 0.0})[0]
    (text,) = printed(TWIN, r"decays at sigma = ([\d.]+) 1/s")
    assert agrees(sigma, text), (text, sigma)
    (text,) = printed(TWIN, r"only ([\d.]+)% of critical")
    assert agrees(100 * sigma / torsion[0], text), (text, sigma)


def _quoted_values():
    """(doc, pattern capturing one number, the code's value) for constants quoted in prose."""
    from ujfmu.fmu.base import SPEED_RANGE, TORQUE_RANGE
    from ujfmu.models.ring_coupling import model as rc
    from ujfmu.scenario import LOAD_CHATTER_ADVICE
    from ujfmu.steady import FLOOR, GROWTH
    from ujfmu.stepsize import DEFAULT_REL_RANGE
    from ujfmu.sweep import SweepSettings
    return [
        (RING, r"M_p = (\d+) \(EI/R\^3\)", rc.MP_COEFFICIENT),
        (RING, r"(\d+) EI/R \[N.m/rad\]", rc.CS_COEFFICIENT),
        (RING, r"= (\d+\.\d+) e\^2 EI/\(w\^2", rc.SMALL_PARAMETER_COEFFICIENT),
        ("README.md", r"M_p = (\d+) \(EI/R\^3\)", rc.MP_COEFFICIENT),
        ("README.md", r"c_s = (\d+) EI/R", rc.CS_COEFFICIENT),
        ("README.md", r"speeds within \+-(1e\d) rad/s", SPEED_RANGE["max"]),
        ("README.md", r"torques within \+-(1e\d) N.m", TORQUE_RANGE["max"]),
        ("docs/cosimulation.md", r"\+-(1e\d) rad/s", SPEED_RANGE["max"]),
        ("docs/cosimulation.md", r"\+-(1e\d) N.m", TORQUE_RANGE["max"]),
        ("README.md", r"`steady_tol` \(default (1e-\d) of", SweepSettings.steady_tol),
        ("README.md", r"or of (\d+)% of the output's size", 100 * FLOOR),
        ("README.md", r"T grows ([\d.]+)x", GROWTH),
        ("README.md", r"within (\d+)% of its set point", 100 * SweepSettings.operating_tol),
        ("README.md", r"against (\d+)% of the signal's range", 100 * DEFAULT_REL_RANGE),
        ("README.md", r"above (\d+) omega_smooth \(J the output inertia", LOAD_CHATTER_ADVICE),
    ]


@pytest.mark.parametrize("doc, pattern, value", _quoted_values(), ids=lambda x: str(x)[:30])
def test_constants_quoted_in_prose_are_the_code_values(doc, pattern, value):
    texts = [t for t in printed(doc, pattern) if t is not None]
    assert texts and all(agrees(value, t) for t in texts), (texts, value)
