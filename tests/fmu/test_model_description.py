"""Every FMU: fmpy validate and fmutool -check clean, units and descriptions, documentation, std-lib only."""

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from ujfmu.build import FMUS, fmu_class

NAMES = list(FMUS)


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_validate_reports_no_problem(fmu_dir, name):
    assert validate_fmu(str(fmu_dir / f"{name}.fmu")) == []


@pytest.mark.parametrize("name", NAMES)
def test_fmutool_check_reports_no_error(fmu_dir, name):
    fmutool = Path(sys.executable).parent / "fmutool"
    out = subprocess.run([str(fmutool), "-input", str(fmu_dir / f"{name}.fmu"), "-check"],
                         capture_output=True, text=True, timeout=120)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text
    assert "No semantic error" in text and "compliant with FMI-2.0" in text, text
    assert "ERROR" not in text.upper().replace("NO SEMANTIC ERROR", ""), text


@pytest.mark.parametrize("name", NAMES)
def test_every_variable_has_description_and_real_has_unit(fmu_dir, name):
    """FMI 2.0 allows a unit on Real variables only; Integer/Boolean say their meaning in the description."""
    md = read_model_description(str(fmu_dir / f"{name}.fmu"))
    units = {u.name for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description, v.name
        if v.type == "Real":
            assert v.unit in units, v.name


@pytest.mark.parametrize("name", NAMES)
def test_model_description_follows_declaration(fmu_dir, name):
    """One source of truth: causality, variability, unit, range, start, feedthrough all from VARIABLES."""
    md = read_model_description(str(fmu_dir / f"{name}.fmu"))
    declared = {v.name: v for v in fmu_class(name).VARIABLES}
    assert [v.name for v in md.modelVariables] == list(declared)
    outputs = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md.outputs}
    for v in md.modelVariables:
        d = declared[v.name]
        assert (v.causality, v.variability) == (d.causality, d.variability)
        if d.type is float:
            assert v.unit == d.unit
        if d.start is not None:
            start = v.start == "true" if d.type is bool else d.type(v.start)
            assert start == d.start
        if d.min is not None:
            assert float(v.min) == d.min and float(v.max) == d.max
        if d.causality == "output":
            assert outputs[v.name] == sorted(d.depends_on)
    assert float(md.defaultExperiment.stepSize) == fmu_class(name).DEFAULT_EXPERIMENT[2]


@pytest.mark.parametrize("name", NAMES)
def test_fmu_ships_documentation_and_only_standard_library_code(fmu_dir, name):
    with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as zf:
        doc = zf.read("documentation/index.html").decode()
        code = {n: zf.read(n).decode() for n in zf.namelist() if n.startswith("resources/") and n.endswith(".py")}
    assert "Parameters" in doc and "LD_PRELOAD" in doc and "Model and equations" in doc
    for v in fmu_class(name).VARIABLES:
        assert f"<code>{v.name}</code>" in doc
    ours = {n: c for n, c in code.items() if "/pythonfmu/" not in n}
    assert ours
    for path, text in ours.items():
        assert not re.search(r"^\s*(import|from)\s+(numpy|scipy|matplotlib|fmpy|sympy)\b", text, re.M), path
