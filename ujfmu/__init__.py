"""ujfmu: universal-joint driveline models as FMI 2.0 Co-Simulation FMUs.

Heavy imports (numpy, fmpy) live in the tooling modules, not here: ujfmu.fmu and ujfmu.models.<stem>.model/fmu run inside FMUs.
"""

__version__ = "0.1.0"


def run_scenario(path, **kwargs):
    """Co-simulate a scenario file; see ujfmu.scenario_run.run_scenario."""
    from .scenario_run import run_scenario as _run
    return _run(path, **kwargs)
