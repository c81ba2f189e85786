"""SSP export: a scenario as a System Structure Package (SSP 1.0) that other tools import.

``export_ssp`` writes ``<scenario>.ssp``, a zip with SystemStructure.ssd (components with their connectors,
units and the scenario's parameters as inline parameter sets, the connections, the units' definitions, and the default experiment with
the communication step as an OSP fixed-step annotation) and the FMUs under resources/. ``cosimulate_ssp`` runs
it with libcosim (``CosimExecution.from_ssp_file``), which the test suite compares with our fmpy master.
"""

import io
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path
from types import SimpleNamespace

from .build import DEFAULT_FMU_DIR, UNITS, fmu_class, write_archive
from .scenario import description_attribute

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
    """Write <out_dir>/<scenario>.ssp; returns its path. Reproducible as the FMUs are (``build.write_archive``:
    entries sorted and dated SOURCE_DATE_EPOCH, else 1980-01-01): the same scenario and FMUs give the same bytes."""
    scenario.check_fmus(fmu_dir)
    out = Path(out_dir) / f"{scenario.name}.ssp"
    out.parent.mkdir(parents=True, exist_ok=True)
    ssd = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(system_structure(scenario), encoding="utf-8")
    write_archive(out, {"SystemStructure.ssd": ssd,
                        **{f"resources/{fmu}.fmu": (Path(fmu_dir) / f"{fmu}.fmu").read_bytes()
                           for fmu in {fmu for fmu, _ in scenario.components.values()}}})
    return out


def fmpy_arguments(scenario) -> dict:
    """Keyword arguments of fmpy's ``simulate_ssp`` (fmpy 0.3.32) that run an exported scenario as ujfmu runs it:
    its start and stop time and step (fmpy reads none of them from the package: it defaults to 1 s in 100 steps),
    and its parameters as the parameter set object fmpy reads (``.parameters``, each with ``.name`` 'comp.par' and
    ``.value``; Booleans as Python bools: fmpy sets a Boolean to value != 0). fmpy matches a parameter to a
    component by the prefix of its name, so components one of whose names begins another's (``motor``,
    ``motor2``) are refused here: rename one."""
    names = sorted(scenario.components)
    clash = [(a, b) for a in names for b in names if a != b and b.startswith(a)]
    if clash:
        raise ValueError(f"fmpy's simulate_ssp matches parameters to components by name prefix: {clash[0][0]!r} is "
                         f"a prefix of {clash[0][1]!r}, so it would take the other's parameters; rename one")
    values = [SimpleNamespace(name=f"{comp}.{par}", value=value)
              for comp in scenario.components for par, value in scenario.start_values(comp).items()]
    return dict(start_time=scenario.start_time, stop_time=scenario.stop_time, step_size=scenario.step_size,
                parameter_set=SimpleNamespace(parameters=values))


def packed_setup(ssp_path) -> tuple:
    """({"comp": fmu name}, {"comp.par": value}, sorted [(from, to)], start time [s]) of an .ssp package
    (:func:`system_structure`): its components, the values its parameter sets give (numbers; Booleans as bools),
    its connections and its default experiment's start."""
    with zipfile.ZipFile(ssp_path) as zf:
        root = ET.fromstring(zf.read("SystemStructure.ssd"))
    components, values = {}, {}
    for comp in root.iter(f"{{{NS['ssd']}}}Component"):
        components[comp.get("name")] = Path(comp.get("source")).stem
        for par in comp.iter(f"{{{NS['ssv']}}}Parameter"):
            (typed,) = list(par)
            text = typed.get("value")
            values[f"{comp.get('name')}.{par.get('name')}"] = (text == "true" if typed.tag.endswith("Boolean")
                                                                else float(text))
    connections = sorted((f"{c.get('startElement')}.{c.get('startConnector')}",
                          f"{c.get('endElement')}.{c.get('endConnector')}")
                         for c in root.iter(f"{{{NS['ssd']}}}Connection"))
    return components, values, connections, float(root.find("ssd:DefaultExperiment", NS).get("startTime"))


def _setup_differences(ssp_path, scenario) -> list:
    """What an .ssp package sets up otherwise than the scenario: its components (FMUs), the value of each start
    value either sets (a value left unset is the FMU's declared start), its connections and its start time."""
    components, packed, connections, start = packed_setup(ssp_path)
    ours = {name: fmu for name, (fmu, _) in scenario.components.items()}
    if components != ours:
        return [f"components {components} in the package, {ours} in the scenario"]
    declared = {f"{comp}.{v.name}": v.start for comp, fmu in ours.items() for v in fmu_class(fmu).VARIABLES
                if v.causality in ("parameter", "input")}
    given = {f"{comp}.{par}": value for comp in scenario.components
             for par, value in scenario.start_values(comp).items()}

    def value(table, name):
        v = table.get(name, declared.get(name))
        return v if isinstance(v, bool) or v is None else float(v)
    differ = [f"{name} = {value(packed, name)!r} in the package, {value(given, name)!r} in the scenario"
              for name in sorted(set(packed) | set(given)) if value(packed, name) != value(given, name)]
    wired = sorted((c.source, c.target) for c in scenario.connections)
    if connections != wired:
        differ.append(f"connections {sorted(set(connections) - set(wired))} only in the package, "
                      f"{sorted(set(wired) - set(connections))} only in the scenario")
    if start != scenario.start_time:
        differ.insert(0, f"start time {start!r} s in the package, {scenario.start_time!r} s in the scenario")
    return differ


def packed_fmi_versions(ssp_path) -> dict:
    """{FMU file inside the package: its fmiVersion} of an .ssp package ("" where its modelDescription cannot be
    read)."""
    with zipfile.ZipFile(ssp_path) as package:
        return {name: description_attribute(io.BytesIO(package.read(name)), "fmiVersion") or ""
                for name in package.namelist() if name.endswith(".fmu")}


def cosimulate_ssp(ssp_path, scenario):
    """Run an exported .ssp with libcosim at the scenario's step (libcosim's override of the package's); structured
    array 'time' + scenario.record. A package of FMI 3.0 FMUs, which libcosim cannot run, is refused with the engine
    that can, and one of another setup than the scenario's (:func:`_setup_differences`): its rows would be
    labelled, or its results taken, as the scenario's."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    from .libcosim_run import record
    fmi3 = sorted(name for name, version in packed_fmi_versions(ssp_path).items() if version.startswith("3"))
    if fmi3:
        raise ValueError(f"{ssp_path} holds FMI 3.0 FMUs ({', '.join(fmi3)}), and libcosim (libcosimpy) runs FMI 2.0 "
                         "FMUs only (it had said \"Unable to create execution from path\"): run it with Ecos, "
                         "ujfmu.engines.cosimulate_ecos(ssp_path, scenario, work_dir) (the bench extra), or export the "
                         "FMI 2.0 package (`ujfmu export-ssp` without --fmi 3) for libcosim")
    differ = _setup_differences(ssp_path, scenario)
    if differ:
        more = f" (and {len(differ) - 1} more)" if len(differ) > 1 else ""
        raise ValueError(f"{ssp_path} was exported from another setup than {scenario.path}'s: {differ[0]}{more}; "
                         "export it again from this scenario (`ujfmu export-ssp`, or export_ssp(scenario))")
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(str(Path(ssp_path).resolve()), int(round(scenario.step_size * 1e9)))
    index = {name: execution.slave_index_from_instance_name(name) for name in scenario.components}
    variables = {name: {v.name.decode(): (v.reference, v.type) for v in execution.slave_variables(i)}
                 for name, i in index.items()}
    return record(execution, scenario, index, variables)
