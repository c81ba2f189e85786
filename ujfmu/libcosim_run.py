"""Run a scenario under libcosim (libcosimpy): a second, independent co-simulation engine for the same FMUs.

libcosim's fixed-step algorithm steps every FMU and then transfers all connections (Jacobi); it does not order
direct-feedthrough transfers, so its results differ from the ujfmu master by O(step size).
"""

import numpy as np


def cosimulate_libcosim(scenario, fmu_dir):
    """Structured array 'time' + scenario.record, sampled after every communication step."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)
    step_ns = int(round(scenario.step_size * 1e9))
    execution = CosimExecution.from_step_size(step_ns)
    index, variables = {}, {}
    for comp in scenario.master_components(fmu_dir):
        slave = CosimLocalSlave(fmu_path=str(comp.fmu.resolve()), instance_name=comp.name)
        index[comp.name] = execution.add_local_slave(slave)
        variables[comp.name] = {v.name.decode(): (v.reference, v.type)
                                for v in execution.slave_variables(index[comp.name])}
        for pname, value in comp.parameters.items():
            vr, _ = variables[comp.name][pname]
            if isinstance(value, bool):
                ok = execution.boolean_initial_value(index[comp.name], vr, value)
            elif isinstance(value, int) and not isinstance(value, bool) and _is_integer(scenario, comp.name, pname):
                ok = execution.integer_initial_value(index[comp.name], vr, value)
            else:
                ok = execution.real_initial_value(index[comp.name], vr, float(value))
            if not ok:
                raise RuntimeError(f"libcosim refused {comp.name}.{pname} = {value!r}")
    for conn in scenario.connections:
        (sc, sv), (dc, dv) = conn.source.split(".", 1), conn.target.split(".", 1)
        execution.connect_real_variables(index[sc], variables[sc][sv][0], index[dc], variables[dc][dv][0])
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    groups = {}
    for name in scenario.record:
        comp, var = name.split(".", 1)
        groups.setdefault(comp, []).append((name, variables[comp][var][0]))
    n_steps = int(round((scenario.stop_time - scenario.start_time) / scenario.step_size))
    rows = np.empty((n_steps, len(scenario.record) + 1))
    order = [name for comp in groups for name, _ in groups[comp]]
    for k in range(n_steps):
        if not execution.step(1):
            raise RuntimeError(f"libcosim step {k} failed")
        row = [scenario.start_time + (k + 1) * scenario.step_size]
        for comp, items in groups.items():
            row += observer.last_real_values(index[comp], [vr for _, vr in items])
        rows[k] = row
    columns = ["time"] + order
    table = np.rec.fromarrays(rows.T, names=columns)
    return table[["time"] + list(scenario.record)]


def _is_integer(scenario, comp, pname):
    from .build import fmu_class
    return next(v.type for v in fmu_class(scenario.components[comp][0]).VARIABLES if v.name == pname) is int
