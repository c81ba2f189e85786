"""What FMI 3.0 costs per communication step against FMI 2.0: the same scenario, the same master, the FMI 2.0 and
the FMI 3.0 Co-Simulation FMUs of the same models (``ujfmu build`` and ``ujfmu build --fmi 3``), timed alternately
in one run (the fastest of each counts: noise only ever adds time). A figure for ``ujfmu bench``.

The FMI 3.0 FMUs run the same Python code per call; the differences are pythonfmu3's C++ layer against
pythonfmu's, and the FMI 3.0 argument lists, which our master reaches through one Python adapter per call
(``ujfmu.fmi3_host``).
"""

import math
import time

from .bench import STEP
from .master import Cosimulation
from .scenario import Scenario


def fmi3_step_cost_ratio(path, fmu_dir, fmu3_dir, repeats: int = 3) -> dict:
    """Microseconds per communication step (STEP, the scenario's coupling) with the FMI 2.0 and the FMI 3.0 FMUs,
    and their ratio FMI 3.0 / FMI 2.0."""
    scenario = Scenario(path)
    n_steps = int(round((scenario.stop_time - scenario.start_time) / STEP))
    best = {fmu_dir: math.inf, fmu3_dir: math.inf}
    for _ in range(repeats):
        for folder in best:
            with Cosimulation(scenario.master_components(folder), scenario.connections, STEP, scenario.record,
                              scenario.start_time, scenario.coupling) as cosim:
                started = time.perf_counter()
                cosim.run(n_steps)
                best[folder] = min(best[folder], time.perf_counter() - started)
    fmi2, fmi3 = (1e6 * best[d] / n_steps for d in (fmu_dir, fmu3_dir))
    return dict(scenario=scenario.name, steps=n_steps, fmi2_us_per_step=fmi2, fmi3_us_per_step=fmi3,
                fmi3_ratio=fmi3 / fmi2)
