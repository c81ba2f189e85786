"""Build the FMI 3.0 FMUs (``ujfmu build --fmi 3``): pythonfmu3 packaging of the same models as the FMI 2.0 FMUs.

Each FMU holds exactly the files of its FMI 2.0 twin (the shared plumbing ``ujfmu.fmu`` and its own model's
``ujfmu/models/<stem>/model.py`` and ``fmu.py``: equations and declaration), the FMI 3.0 layer ``ujfmu.fmu3`` and
pythonfmu3's runtime, in a package named after the FMU and a hash of all of it (``ujfmu3_cardanjoint_<hash>``),
so FMI 2.0 and 3.0 FMUs and different builds never shadow each
other's modules in a host's interpreter. The ``ujfmu.fmu`` declarations import pythonfmu's pure-Python part,
which is shipped too (standard library only).

The modelDescription.xml is written here from the declaration (pythonfmu3 0.3.4 writes no units, ranges,
dependencies or display units, copies canSerializeFMUState into canHandleVariableCommunicationStepSize and
needsCompletedIntegratorStep, and its ``terminals`` option packs the wrong file): unit definitions with display
units, unit and range of every Float64, output dependencies, continuous states and their derivatives for Model
Exchange, InitialUnknowns. terminalsAndIcons/terminalsAndIcons.xml groups each shaft end's angle, speed and
torque into a terminal after the Modelica rotational flange (``TERMINALS``).
"""

import hashlib
import html
import shutil
import sys
import tempfile
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from . import __version__
from .build import (DEFAULT_FMU_DIR, FMUS, PACKAGE_DIR, UNITS, documentation_html, fmu_class, source_hash,
                    stage_runtime, write_archive)

#: default folder of the FMI 3.0 FMUs (same file names as the FMI 2.0 ones: a scenario runs either version with
#: --fmu-dir)
DEFAULT_FMU3_DIR = DEFAULT_FMU_DIR / "fmi3"
_FLANGE_KIND = "Modelica.Mechanics.Rotational.Interfaces.Flange_{}"

#: FMU name -> its terminals: (terminal name, "a" or "b", description, ((member, variable, variableKind), ...));
#: the drivetrain FMUs not listed have DRIVETRAIN_TERMINALS. Members after Modelica's rotational flange:
#: phi (angle, signal), tau (cut torque, inflow: positive into this FMU's shaft), plus w (speed, signal).
DRIVETRAIN_TERMINALS = (
    ("flange_a", "a", "Input shaft end (driving side)",
     (("phi", "phi_in", "signal"), ("w", "omega_in", "signal"), ("tau", "tau_in", "inflow"))),
    ("flange_b", "b", "Output shaft end (driven side)",
     (("phi", "phi_out", "signal"), ("w", "omega_out", "signal"), ("tau", "tau_load", "outflow"))),
)
TERMINALS = {
    "Motor": (("flange_b", "b", "Rotor shaft end",
               (("phi", "phi", "signal"), ("w", "omega", "signal"), ("tau", "tau_load", "outflow"))),),
    "Load": (("flange_a", "a", "Shaft end of the driven machine",
              (("phi", "phi", "signal"), ("w", "omega", "signal"), ("tau", "tau", "inflow"))),),
    "MotorController": (("flange_b", "b", "Drive torque on the rotor of the torque-driven joint it drives",
                         (("w", "omega", "signal"), ("tau", "tau_motor", "outflow"))),),
}


#: the relative tolerance the DefaultExperiment proposes to a solver that integrates the Model Exchange FMUs (fmpy's
#: simulate_fmu takes it; its own default, 1e-5, left the twin rotor's lateral motion off by 1e-3 of its range): the
#: one `ujfmu run --model-exchange` uses and the ME results of docs/fmi3.md are quoted at
ME_TOLERANCE = 1e-8

def fmi3_hash(stem: str) -> str:
    """Hash of everything an FMI 3.0 FMU of model stem ships: the FMI 2.0 runtime's hash, the FMI 3.0 layer,
    pythonfmu3's version and this module (which writes its modelDescription)."""
    import pythonfmu3
    digest = hashlib.sha256(f"{source_hash(stem)} {pythonfmu3.__version__}".encode())
    for path in [Path(__file__), *sorted((PACKAGE_DIR / "fmu3").glob("*.py"))]:
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:10]


def build_all3(dest=DEFAULT_FMU3_DIR, names=None) -> list:
    """Build the named FMI 3.0 FMUs (default: all) into dest; returns their paths."""
    return [build_fmu3(name, dest) for name in (names or FMUS)]


def build_fmu3(name: str, dest=DEFAULT_FMU3_DIR) -> Path:
    """Build <dest>/<name>.fmu, FMI 3.0 Co-Simulation (and Model Exchange where the model offers it)."""
    import pythonfmu
    import pythonfmu3
    from pythonfmu3 import FmuBuilder

    from .fmu.base import runtime_files
    from .fmu3.base import STATES

    stem, cls_name = FMUS[name]
    model = fmu_class(name)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    unique = f"ujfmu3_{name.lower()}_{fmi3_hash(stem)}"
    with tempfile.TemporaryDirectory(prefix="ujfmu_build3_") as tmp:
        stage = Path(tmp)
        package = stage_runtime(stage / unique, f"ujfmu {__version__} runtime for {name}.fmu (FMI 3.0).",
                                runtime_files(stem) + [f"fmu3/{p.name}"
                                                       for p in sorted((PACKAGE_DIR / "fmu3").glob("*.py"))])
        shipped = stage / "pythonfmu"   # the pure-Python part the declarations import (not its builder's binaries)
        shipped.mkdir()
        for path in Path(pythonfmu.__file__).parent.glob("*.py"):
            shutil.copy2(path, shipped)
        entry = stage / f"{unique}_entry.py"
        entry.write_text(
            f'"""pythonfmu3 entry point of {name}.fmu (generated by ujfmu.build3)."""\n'
            "from pythonfmu3 import Fmi3SlaveBase\n"
            f"from {unique}.models.{stem}.fmu import {cls_name} as _model\n"
            f"from {unique}.fmu3.base import fmi3_class\n\n"
            f"_fmu = fmi3_class(_model)\n\n\n"
            f"class {name}(_fmu, Fmi3SlaveBase):\n"
            f'    """{name}: FMI 3.0 FMU of ujfmu."""\n')
        docs = stage / "documentation"
        docs.mkdir()
        (docs / "index.html").write_text(documentation_html3(name, model, name in STATES))
        sys.path.insert(0, str(stage))
        try:
            built = FmuBuilder.build_FMU(entry, dest=dest, project_files=[package, shipped],
                                         documentation_folder=docs)
        finally:
            sys.path.remove(str(stage))
            for mod in [m for m in sys.modules if m == unique or m.startswith(unique + ".") or m == entry.stem]:
                del sys.modules[mod]
    built = Path(built)
    if built.name != f"{name}.fmu":
        built = built.replace(dest / f"{name}.fmu")
    _finish(built, name, model, pythonfmu3.__version__)
    return built


def _finish(fmu_path, name, model, pythonfmu3_version):
    """Replace pythonfmu3's modelDescription.xml by ours and add terminalsAndIcons.xml."""
    with zipfile.ZipFile(fmu_path) as zf:
        entries = {info.filename: zf.read(info) for info in zf.infolist()}
    entries["modelDescription.xml"] = model_description3(name, model, pythonfmu3_version)
    entries["terminalsAndIcons/terminalsAndIcons.xml"] = terminals_and_icons(name, model)
    write_archive(fmu_path, entries)


def _xml(root) -> bytes:
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def model_description3(name: str, model, pythonfmu3_version: str = "") -> bytes:
    """modelDescription.xml (FMI 3.0) of the FMU of model, from its declaration."""
    from .fmu3.base import NOMINALS, STATES, event_indicator_variables, fmi3_variables

    variables = fmi3_variables(model)
    vr = {var.name: i for i, (var, _) in enumerate(variables, start=1)}
    me = name in STATES
    states = [vr[v.name] for v, der in variables if v.causality == "local" and der is None and v.name[:2] == "x."]
    doc = next(c.__doc__ for c in model.__mro__ if c.__doc__).strip().splitlines()[0]
    token = uuid.uuid5(uuid.NAMESPACE_URL, f"ujfmu3/{name}/{fmi3_hash(FMUS[name][0])}")
    root = ET.Element("fmiModelDescription", fmiVersion="3.0", modelName=name,
                      instantiationToken="{" + str(token) + "}",
                      description=doc, author=model.author, license=model.license, version=__version__,
                      generationTool=f"ujfmu {__version__} (pythonfmu3 {pythonfmu3_version})",
                      variableNamingConvention="structured")
    common = dict(modelIdentifier=name, needsExecutionTool="true", canBeInstantiatedOnlyOncePerProcess="false",
                  canGetAndSetFMUState="true", canSerializeFMUState="true")
    if me:
        ET.SubElement(root, "ModelExchange", dict(common, needsCompletedIntegratorStep="false"))
    ET.SubElement(root, "CoSimulation", dict(common, canHandleVariableCommunicationStepSize="true"))
    unit_defs = ET.SubElement(root, "UnitDefinitions")
    for unit in sorted({v.unit for v, _ in variables if v.type is float} | {"s"}):
        exponents, display = UNITS[unit]
        u = ET.SubElement(unit_defs, "Unit", name=unit)
        ET.SubElement(u, "BaseUnit", {k: str(e) for k, e in zip(("kg", "m", "s", "rad"), exponents) if e})
        for dname, factor in display.items():
            ET.SubElement(u, "DisplayUnit", name=dname, factor=repr(factor))
    categories = ET.SubElement(root, "LogCategories")
    for status in ("Warning", "Discard", "Error", "Fatal"):
        ET.SubElement(categories, "Category", name=f"logStatus{status}",
                      description=f"Log messages with fmi3{status} status.")
    start, stop, step = model.DEFAULT_EXPERIMENT
    ET.SubElement(root, "DefaultExperiment", startTime=repr(float(start)), stopTime=repr(float(stop)),
                  stepSize=repr(float(step)), tolerance=repr(ME_TOLERANCE))
    model_vars = ET.SubElement(root, "ModelVariables")
    ET.SubElement(model_vars, "Float64", name="time", valueReference="0", causality="independent",
                  variability="continuous", description="Simulation time", unit="s")
    for var, derivative_of in variables:
        tag = {float: "Float64", int: "Int32", bool: "Boolean"}[var.type]
        attrs = dict(name=var.name, valueReference=str(vr[var.name]), causality=var.causality,
                     variability=var.variability, description=var.description)
        if var.type is float:
            attrs["unit"] = var.unit
        if var.type is not bool:
            for key in ("min", "max"):
                if getattr(var, key) is not None:
                    attrs[key] = repr(var.type(getattr(var, key)))
        if var.causality in ("parameter", "input"):
            attrs["start"] = repr(var.type(var.start)) if var.type is not bool else str(var.start).lower()
        if derivative_of is not None:
            attrs["derivative"] = str(vr[derivative_of])
        if var.name.startswith("x.") and var.unit in NOMINALS:   # as fmi3GetNominalsOfContinuousStates gives
            attrs["nominal"] = repr(NOMINALS[var.unit])
        ET.SubElement(model_vars, tag, attrs)
    structure = ET.SubElement(root, "ModelStructure")
    outputs = [v for v, _ in variables if v.causality == "output"]
    for v in outputs:
        deps = [vr[d] for d in v.depends_on] + states
        ET.SubElement(structure, "Output", valueReference=str(vr[v.name]), dependencies=" ".join(map(str, deps)))
    derivatives = [v for v, der in variables if der is not None]
    for v in derivatives:
        ET.SubElement(structure, "ContinuousStateDerivative", valueReference=str(vr[v.name]))
    for v in outputs + [v for v, der in variables if v.causality == "local" and der is None
                        and v.name.startswith("x.")] + derivatives:
        ET.SubElement(structure, "InitialUnknown", valueReference=str(vr[v.name]))
    for v, _ in event_indicator_variables(model):
        ET.SubElement(structure, "EventIndicator", valueReference=str(vr[v.name]))
    return _xml(root)


def terminals(name: str, model) -> tuple:
    """The terminals of the FMU (see TERMINALS), each member's variable present in model's declaration."""
    declared = {v.name for v in model.VARIABLES}
    found = []
    for terminal, side, description, members in TERMINALS.get(name, DRIVETRAIN_TERMINALS):
        present = tuple(m for m in members if m[1] in declared)
        if present:
            found.append((terminal, side, description, present))
    return tuple(found)


def terminals_and_icons(name: str, model) -> bytes:
    """terminalsAndIcons/terminalsAndIcons.xml: one terminal per shaft end (see TERMINALS)."""
    root = ET.Element("fmiTerminalsAndIcons", fmiVersion="3.0")
    group = ET.SubElement(root, "Terminals")
    for terminal, side, description, members in terminals(name, model):
        el = ET.SubElement(group, "Terminal", name=terminal, matchingRule="bus",
                           terminalKind=_FLANGE_KIND.format(side), description=description)
        for member, variable, kind in members:
            ET.SubElement(el, "TerminalMemberVariable", variableName=variable, memberName=member, variableKind=kind)
    return _xml(root)


def errors_html3(name: str, model_exchange: bool) -> str:
    """The FMI 3.0 page's "Errors and logging": pythonfmu3 passes messages on with logging off too, reports an
    exception as fmi3Fatal, and Model Exchange refuses by NaN derivatives (``ujfmu.fmu3.base``)."""
    text = ("<h2>Errors and logging</h2><p>The FMU's messages reach the host's logger whether or not logging was "
            "asked for at instantiation. An invalid parameter makes fmi3ExitInitializationMode fail with a message "
            "naming the parameter and its allowed range (pythonfmu3 reports the failure as fmi3Fatal and adds a line "
            "of its own). In Co-Simulation a non-finite or out-of-range input, a step size that is not finite and "
            "positive, or a step the model cannot take refuses the step (fmi3DoStep returns fmi3Discard) with a "
            "logged error naming the cause; the instance stays usable. A start time other than 0 reaches the FMU "
            "with its first fmi3DoStep only (pythonfmu3 does not pass fmi3EnterInitializationMode's startTime on): "
            "outputs read before it are those of a start at 0.")
    if model_exchange:
        text += (" In Model Exchange a refused evaluation gives NaN derivatives, with the reason logged (each "
                 "reason three times in full, then once), on which the host's solver stops; the time follows "
                 "fmi3SetTime.")
        if name == "MotorController":
            text += (" Its event indicators mark the torque limit's switches, and fmi3UpdateDiscreteStates "
                     "announces the speed profile's next corner as a time event.")
    if name == "Load":
        text += (" Its torque's change (T_change at t_change, over ramp_time) is announced as time events by "
                 "fmi3UpdateDiscreteStates in Model Exchange.")
    return text + "</p>"


def documentation_html3(name: str, model, model_exchange: bool) -> str:
    """documentation/index.html of the FMI 3.0 FMU: the FMI 2.0 page's content, with the FMI 3.0 kinds, the
    Model Exchange states and the terminals."""
    from .fmu3.base import STATES

    page = documentation_html(name, model)
    kinds = "Co-Simulation and Model Exchange" if model_exchange else "Co-Simulation"
    page = page.replace("FMI 2.0 Co-Simulation FMU built with pythonfmu.",
                        f"FMI 3.0 {kinds} FMU built with pythonfmu3.")
    start = page.index("<h2>Errors and logging</h2>")
    end = page.index("</p>", start) + len("</p>")
    page = page[:start] + errors_html3(name, model_exchange) + page[end:]
    extra = []
    if model_exchange:
        rows = "".join(f"<tr><td><code>x.{n}</code></td><td>{html.escape(u)}</td><td>{html.escape(d)}</td></tr>"
                       for n, u, d in STATES[name].names)
        extra.append("<h2>Model Exchange</h2><p>The continuous states (local variables <code>x.*</code>, their "
                     "derivatives <code>der(x.*)</code>) are integrated by the host's solver; inputs are taken "
                     "at their current values (no step, no coupling delay).</p>"
                     f"<table><tr><th>state</th><th>unit</th><th>description</th></tr>{rows}</table>")
    rows = "".join(f"<tr><td><code>{t}</code></td><td>{_FLANGE_KIND.format(side)}</td><td>"
                   + ", ".join(f"{m} = <code>{v}</code> ({k})" for m, v, k in members)
                   + f"</td><td>{html.escape(d)}</td></tr>" for t, side, d, members in terminals(name, model))
    if rows:
        extra.append("<h2>Terminals</h2><p>terminalsAndIcons/terminalsAndIcons.xml, matchingRule bus: "
                     "tau inflow is positive into this FMU's shaft, outflow positive out of it.</p>"
                     f"<table><tr><th>terminal</th><th>terminalKind</th><th>members</th><th>description</th></tr>"
                     f"{rows}</table>")
    return page.replace("<h2>Default experiment</h2>", "".join(extra) + "<h2>Default experiment</h2>")
