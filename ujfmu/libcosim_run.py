"""Run a scenario under libcosim (libcosimpy): a second, independent co-simulation engine for the same FMUs.

libcosim's fixed-step algorithm steps every FMU and then transfers all connections (Jacobi); it does not order
direct-feedthrough transfers, so its results differ from the ujfmu master by O(step size).
"""

import numpy as np


def cosimulate_libcosim(scenario, fmu_dir):
    """Structured array 'time' + scenario.record, sampled after every communication step."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    step_ns = int(round(scenario.step_size * 1e9))
    execution = CosimExecution.from_step_size(step_ns)
    set_initial = {CosimVariableType.REAL.value: (execution.real_initial_value, float),
                   CosimVariableType.INTEGER.value: (execution.integer_initial_value, int),
                   CosimVariableType.BOOLEAN.value: (execution.boolean_initial_value, bool)}
    index, variables = {}, {}
    for comp in scenario.master_components(fmu_dir):
        slave = CosimLocalSlave(fmu_path=str(comp.fmu.resolve()), instance_name=comp.name)
        index[comp.name] = execution.add_local_slave(slave)
        variables[comp.name] = {v.name.decode(): (v.reference, v.type)
                                for v in execution.slave_variables(index[comp.name])}
        for pname, value in comp.parameters.items():
            vr, vtype = variables[comp.name][pname]
            setter, cast = set_initial[vtype]
            if not setter(index[comp.name], vr, cast(value)):
                raise RuntimeError(f"libcosim refused {comp.name}.{pname} = {value!r}")
    for conn in scenario.connections:
        (sc, sv), (dc, dv) = conn.source.split(".", 1), conn.target.split(".", 1)
        execution.connect_real_variables(index[sc], variables[sc][sv][0], index[dc], variables[dc][dv][0])
    return record(execution, scenario, index, variables)


def record(execution, scenario, index, variables):
    """Step the execution over the scenario's grid; structured array 'time' + scenario.record, sampled after
    every communication step. index: component -> slave index; variables: component -> {name: (vr, type)}."""
    from libcosimpy.CosimObserver import CosimObserver
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    groups = {}
    for name in scenario.record:
        comp, var = name.split(".", 1)
        groups.setdefault(comp, []).append((name, variables[comp][var][0]))
    times = scenario.time_grid()[1:]
    rows = np.empty((len(times), len(scenario.record) + 1))
    order = [name for comp in groups for name, _ in groups[comp]]
    for k, t in enumerate(times):
        if not execution.step(1):
            raise RuntimeError(f"libcosim step {k} failed")
        row = [t]
        for comp, items in groups.items():
            row += observer.last_real_values(index[comp], [vr for _, vr in items])
        rows[k] = row
    columns = ["time"] + order
    table = np.rec.fromarrays(rows.T, names=columns)
    return table[["time"] + list(scenario.record)]

