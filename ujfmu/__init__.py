"""ujfmu: universal-joint driveline models as FMI 2.0 Co-Simulation FMUs.

Heavy imports (numpy, fmpy) live in the tooling modules, not here: ujfmu.fmu and ujfmu.models.<stem>.model/fmu run inside FMUs.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .scenario import Scenario
    from .scenario_run import ScenarioResult

__version__ = "0.1.0"
__all__ = ["run_scenario", "__version__"]   # what the package offers (os, Callable: its annotations')


def run_scenario(path: str | os.PathLike | Scenario, *, fmu_dir: str | os.PathLike = "fmus",
                 out_dir: str | os.PathLike | None = "results", plot: bool = True,
                 progress: Callable[[int, int], bool | None] | None = None,
                 model_exchange: bool = False) -> ScenarioResult:
    """Co-simulate a scenario (a file or a ujfmu.scenario.Scenario) and compare it with its reference.

    fmu_dir: the folder of the built FMUs (default fmus/ of the current directory; fmus/fmi3/ for model_exchange);
    out_dir: where the CSV and figures go (default results/ of the current directory; None writes nothing); plot:
    write the figures; progress: callable(steps_done, steps_total), returning False to stop the run
    (``ujfmu.master.RunStopped``); model_exchange: run the FMI 3.0 Model Exchange FMUs under CVode. See
    ujfmu.scenario_run.run_scenario."""
    from .scenario_run import run_scenario as _run
    return _run(path, fmu_dir=fmu_dir, out_dir=out_dir, plot=plot, progress=progress, model_exchange=model_exchange)
