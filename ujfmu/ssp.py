"""SSP export: a scenario as a System Structure Package (SSP 1.0) that other tools import.

``export_ssp`` writes ``<scenario>.ssp``, a zip with SystemStructure.ssd (components with their connectors,
units and the scenario's parameters as inline parameter sets, the connections, the units' definitions, and the default experiment with
the communication step as an OSP fixed-step annotation) and the FMUs under resources/. ``cosimulate_ssp`` runs
it with libcosim (``CosimExecution.from_ssp_file``), which the test suite compares with our fmpy master.
"""

import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

from .build import DEFAULT_FMU_DIR, UNITS, fmu_class

NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "osp": "https://opensimulationplatform.com/SSP/OSPAnnotations"}
_KIND = {"input": "input", "output": "output", "parameter": "parameter"}
_TYPE = {float: "Real", int: "Integer", bool: "Boolean"}


def _el(parent, tag, **attrib):
    prefix, name = tag.split(":")
    return ET.SubElement(parent, f"{{{NS[prefix]}}}{name}", {k: str(v) for k, v in attrib.items()})


def system_structure(scenario):
    """The SystemStructure.ssd document (ElementTree root) of a scenario."""
    for prefix, uri in NS.items():
        ET.register_namespace(prefix, uri)
    root = ET.Element(f"{{{NS['ssd']}}}SystemStructureDescription", name=scenario.name, version="1.0")
    system = _el(root, "ssd:System", name=scenario.name, description=scenario.title)
    elements = _el(system, "ssd:Elements")
    for name, (fmu, _) in scenario.components.items():
        params = scenario.start_values(name)
        comp = _el(elements, "ssd:Component", name=name, source=f"resources/{fmu}.fmu",
                   type="application/x-fmu-sharedlibrary")
        connectors = _el(comp, "ssd:Connectors")
        declared = {v.name: v for v in fmu_class(fmu).VARIABLES}
        for var in declared.values():
            if var.causality in ("input", "output"):
                c = _el(connectors, "ssd:Connector", name=var.name, kind=_KIND[var.causality])
                attrs = {"unit": var.unit} if var.type is float and var.unit else {}
                _el(c, f"ssc:{_TYPE[var.type]}", **attrs)
        if params:
            bindings = _el(comp, "ssd:ParameterBindings")
            values = _el(_el(bindings, "ssd:ParameterBinding"), "ssd:ParameterValues")
            pset = _el(values, "ssv:ParameterSet", version="1.0", name="scenario")
            plist = _el(pset, "ssv:Parameters")
            for pname, value in params.items():
                var = declared[pname]
                text = ("true" if value else "false") if var.type is bool else repr(var.type(value))
                _el(_el(plist, "ssv:Parameter", name=pname), f"ssv:{_TYPE[var.type]}", value=text)
    connections = _el(system, "ssd:Connections")
    for conn in scenario.connections:
        (sc, sv), (dc, dv) = conn.source.split(".", 1), conn.target.split(".", 1)
        _el(connections, "ssd:Connection", startElement=sc, startConnector=sv, endElement=dc, endConnector=dv)
    # every unit a connector names, defined as the FMUs' modelDescriptions define it (SSP 1.0: ssd:Units)
    used = sorted({v.unit for fmu, _ in scenario.components.values() for v in fmu_class(fmu).VARIABLES
                   if v.causality in ("input", "output") and v.type is float and v.unit})
    if used:
        units = _el(root, "ssd:Units")
        for unit in used:
            exponents, _ = UNITS[unit]
            _el(_el(units, "ssc:Unit", name=unit), "ssc:BaseUnit",
                **{k: e for k, e in zip(("kg", "m", "s", "rad"), exponents) if e})
    experiment = _el(root, "ssd:DefaultExperiment", startTime=repr(scenario.start_time),
                     stopTime=repr(scenario.stop_time))
    annotation = _el(_el(experiment, "ssd:Annotations"), "ssc:Annotation", type="com.opensimulationplatform")
    _el(_el(annotation, "osp:Algorithm"), "osp:FixedStepAlgorithm", baseStepSize=repr(scenario.step_size))
    ET.indent(root)
    return root


def export_ssp(scenario, out_dir=Path("results"), fmu_dir=DEFAULT_FMU_DIR):
    """Write <out_dir>/<scenario>.ssp; returns its path."""
    scenario.check_fmus(fmu_dir)
    out = Path(out_dir) / f"{scenario.name}.ssp"
    out.parent.mkdir(parents=True, exist_ok=True)
    ssd = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(system_structure(scenario), encoding="utf-8")
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("SystemStructure.ssd", ssd)
        for fmu in sorted({fmu for fmu, _ in scenario.components.values()}):
            zf.write(Path(fmu_dir) / f"{fmu}.fmu", f"resources/{fmu}.fmu")
    return out


def cosimulate_ssp(ssp_path, scenario):
    """Run an exported .ssp with libcosim; structured array 'time' + scenario.record."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    from .libcosim_run import record
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(str(Path(ssp_path).resolve()))
    index = {name: execution.slave_index_from_instance_name(name) for name in scenario.components}
    variables = {name: {v.name.decode(): (v.reference, v.type) for v in execution.slave_variables(i)}
                 for name, i in index.items()}
    return record(execution, scenario, index, variables)
