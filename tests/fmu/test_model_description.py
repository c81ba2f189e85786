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


def _messages(fmu_dir, name, categories, parameters):
    """(category, status, message) of every message the FMU passes to a host that turned logging on with these
    categories (fmi2SetDebugLogging), over initialization with the parameters given and one step."""
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

    from ujfmu.master import extracted
    unzip_dir, md = extracted(fmu_dir / f"{name}.fmu")   # once per process, removed at its exit
    got = []

    def logger(env, instance, status, category, message):
        got.append((category.decode() if category else "", status, message.decode()))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip_dir), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="categories")
    slave.instantiate(callbacks=callbacks, loggingOn=True)
    try:
        slave.setDebugLogging(True, categories)
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        refs = {v.name: v.valueReference for v in md.modelVariables}
        slave.setReal([refs[n] for n in parameters], list(parameters.values()))
        try:
            slave.exitInitializationMode()
            slave.doStep(0.0, 1e-3)
        except Exception:
            pass   # the refusal's message is what is looked at
    finally:
        slave.freeInstance()
    return got


@pytest.mark.parametrize("name", NAMES)
def test_every_declared_log_category_is_one_the_fmu_logs_under(fmu_dir, name):
    """pythonfmu's C layer passes a message to the host only where its category is one the host enabled by name
    (or none is named): a declared category that no message carries (its own ``logAll``) passes nothing."""
    md = read_model_description(str(fmu_dir / f"{name}.fmu"))
    assert [c.name for c in md.logCategories] == [f"logStatus{s}" for s in ("Warning", "Discard", "Error", "Fatal")]


@pytest.mark.parametrize("enabled", [[], ["logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal"]])
def test_a_host_enabling_the_declared_categories_gets_warnings_and_errors(fmu_dir, enabled):
    """None named (all) or every declared category named: the warning that the default error angles change a
    small bend's swing, and a refused parameter's error, each under its status's category."""
    warned = _messages(fmu_dir, "CardanJoint", enabled, {"bend_angle": 0.192})
    assert any(c == "logStatusWarning" and "error_angle_beta" in m for c, s, m in warned), warned
    refused = _messages(fmu_dir, "CardanJoint", enabled, {"bend_angle": 20.0})
    assert any(c == "logStatusError" and "bend_angle" in m for c, s, m in refused), refused
    assert {c for c, s, m in warned + refused} <= {"logStatusWarning", "logStatusError", "logStatusFatal"} | {""}


def test_a_message_of_status_ok_goes_under_a_declared_category():
    """pythonfmu files an ok message under its logAll, which the FMUs no longer declare (a host naming
    the declared categories would drop it): the FMUs' log puts it under logStatusWarning, and every other status
    under its own."""
    from pythonfmu.enums import Fmi2Status

    from ujfmu.models.load.fmu import Load
    inst = Load(instance_name="log")
    for status, category in ((Fmi2Status.ok, "logStatusWarning"), (Fmi2Status.warning, "logStatusWarning"),
                             (Fmi2Status.error, "logStatusError")):
        inst.log("a message", status)
        assert (inst.log_queue[-1].status, inst.log_queue[-1].category) == (status, category)
        assert inst.log_queue[-1].category in Load.log_categories
