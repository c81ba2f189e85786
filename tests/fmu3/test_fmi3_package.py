"""The FMI 3.0 FMUs as files: fmpy's validation, interface kinds, units and ranges from the one declaration,
terminals after the Modelica rotational flange, documentation."""

import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import fmpy
from fmpy.validation import validate_fmu
import pytest
from fmpy import read_model_description

from ujfmu.build import FMUS, UNITS, fmu_class
from ujfmu.fmu3.base import STATES

NAMES = list(FMUS)


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_validate_finds_no_problem(fmu3_dir, name):
    assert validate_fmu(str(fmu3_dir / f"{name}.fmu")) == []


@pytest.mark.parametrize("name", NAMES)
def test_interface_kinds_units_and_ranges_follow_the_declaration(fmu3_dir, name):
    md = read_model_description(str(fmu3_dir / f"{name}.fmu"))
    assert md.fmiVersion == "3.0"
    assert md.coSimulation is not None and md.coSimulation.canGetAndSetFMUstate
    assert (md.modelExchange is not None) == (name in STATES)
    variables = {v.name: v for v in md.modelVariables}
    for var in fmu_class(name).VARIABLES:
        v = variables[var.name]
        assert v.causality == var.causality and v.variability == var.variability
        if var.type is float:
            assert v.type == "Float64" and v.unit == var.unit
            for key in ("min", "max"):
                expected = getattr(var, key)
                assert (getattr(v, key) is None) if expected is None else float(getattr(v, key)) == expected
        if var.causality in ("parameter", "input"):
            start = v.start == "true" if var.type is bool else var.type(v.start)
            assert start == var.start
    units = {u.name: u for u in md.unitDefinitions}
    for unit, (_, display) in UNITS.items():
        if unit in units:
            assert {d.name: d.factor for d in units[unit].displayUnits} == pytest.approx(display)
    assert {"deg"} <= {d.name for d in units["rad"].displayUnits} if "rad" in units else True
    # outputs depend directly on the inputs the declaration names (and, with Model Exchange, on the states)
    states = {v.name for v in md.modelVariables if v.name.startswith("x.")}
    for unknown in md.outputs:
        var = next(x for x in fmu_class(name).VARIABLES if x.name == unknown.variable.name)
        assert {d.name for d in unknown.dependencies} == set(var.depends_on) | states


def test_model_exchange_states_and_derivatives(fmu3_dir):
    md = read_model_description(str(fmu3_dir / "DoubleCardanDrivelineTorqueDriven.fmu"))
    assert md.numberOfContinuousStates == 6
    derivatives = {d.variable.name: d.variable.derivative.name for d in md.derivatives}
    assert derivatives == {f"der(x.{n})": f"x.{n}" for n in ("phi1", "omega1", "phi4", "omega4", "phi", "dphi")}
    assert read_model_description(str(fmu3_dir / "Load.fmu")).numberOfContinuousStates == 0
    # the relative tolerance a host's solver takes from the default experiment (fmpy's simulate_fmu does; at its own
    # 1e-5 a twin rotor's lateral motion was off by 1e-3 of its range): the one our ME results are quoted at
    from ujfmu.model_exchange import simulate_scenario_me
    assert float(md.defaultExperiment.tolerance) == simulate_scenario_me.__defaults__[0] == 1e-8


def _terminals(path):
    with zipfile.ZipFile(path) as zf:
        return zf.read("terminalsAndIcons/terminalsAndIcons.xml")


@pytest.mark.parametrize("name", NAMES)
def test_terminals_validate_against_the_fmi3_schema_and_name_existing_variables(fmu3_dir, name):
    from lxml import etree
    schema = etree.XMLSchema(file=str(Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3TerminalsAndIcons.xsd"))
    data = _terminals(fmu3_dir / f"{name}.fmu")
    assert schema.validate(etree.fromstring(data)), schema.error_log
    names = {v.name for v in read_model_description(str(fmu3_dir / f"{name}.fmu")).modelVariables}
    terminals = ET.fromstring(data).find("Terminals")
    assert len(terminals) >= 1
    for member in terminals.iter("TerminalMemberVariable"):
        assert member.get("variableName") in names


def _members(path):
    return {t.get("name"): (t.get("terminalKind"), t.get("matchingRule"),
                            {m.get("memberName"): (m.get("variableName"), m.get("variableKind")) for m in t})
            for t in ET.fromstring(_terminals(path)).find("Terminals")}


def test_flanges_follow_the_modelica_rotational_flange_and_sign_convention(fmu3_dir):
    """flange_a/flange_b with phi, w, tau; tau is the cut torque into the FMU's shaft (inflow) or out (outflow):
    the joint's tau_in is what the driver applies (into the input shaft), its tau_load opposes the output shaft
    (out of it), the Load's tau is what the shaft applies to it, the Motor's tau_load what it loses."""
    kind = "Modelica.Mechanics.Rotational.Interfaces.Flange_{}"
    joint = _members(fmu3_dir / "CardanJoint.fmu")
    assert joint == {
        "flange_a": (kind.format("a"), "bus", {"phi": ("phi_in", "signal"), "w": ("omega_in", "signal"),
                                                 "tau": ("tau_in", "inflow")}),
        "flange_b": (kind.format("b"), "bus", {"phi": ("phi_out", "signal"), "w": ("omega_out", "signal"),
                                                 "tau": ("tau_load", "outflow")})}
    assert _members(fmu3_dir / "CardanJointTorqueDriven.fmu") == joint
    assert _members(fmu3_dir / "Load.fmu")["flange_a"][2]["tau"] == ("tau", "inflow")
    assert _members(fmu3_dir / "Motor.fmu")["flange_b"][2]["tau"] == ("tau_load", "outflow")
    assert _members(fmu3_dir / "MotorController.fmu")["flange_b"][2] == {"w": ("omega", "signal"),
                                                                           "tau": ("tau_motor", "outflow")}


@pytest.mark.parametrize("name", ["CardanJoint", "CardanJointTorqueDriven"])
def test_documentation_is_carried(fmu3_dir, name):
    with zipfile.ZipFile(fmu3_dir / f"{name}.fmu") as zf:
        page = zf.read("documentation/index.html").decode()
    assert "FMI 3.0" in page and "Feng" in page and "flange_a" in page
    assert ("Model Exchange" in page) == (name in STATES)
    # its errors in FMI 3.0's terms (the FMI 2.0 page's fmi2 calls and "only with logging enabled" had stood there)
    assert "fmi2" not in page and "fmi3DoStep returns fmi3Discard" in page and "whether or not logging" in page
    assert ("NaN derivatives" in page) == (name in STATES)


@pytest.mark.parametrize("name", ["CardanJoint", "DoubleCardanDrivelineTorqueDriven"])
def test_fmu_code_imports_only_the_standard_library_and_pythonfmu(fmu3_dir, name):
    import ast
    import sys
    with zipfile.ZipFile(fmu3_dir / f"{name}.fmu") as zf:
        code = {n: zf.read(n).decode() for n in zf.namelist() if n.endswith(".py")
                and not n.startswith(("resources/pythonfmu/", "resources/pythonfmu3/"))}
    assert any("/fmu3/" in n for n in code) and any(n.endswith("/model.py") for n in code)
    allowed = set(sys.stdlib_module_names) | {"pythonfmu", "pythonfmu3"}
    for path, text in code.items():
        for node in ast.walk(ast.parse(text)):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 else []
            for module in names:
                top = module.split(".")[0]
                assert top in allowed or top.startswith("ujfmu3_"), f"{path} imports {module}"
