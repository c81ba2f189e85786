"""Which wiring is stable in which kind of host: the speed-driven twin of a torque-driven scenario, and the
stability limits of both wirings measured with our master and with libcosim (``python -m ujfmu.wiring``; the
figures are in docs/cosimulation.md).

Speed-driven wiring: Motor.omega -> joint.omega_in, joint.tau_in -> Motor.tau_load (the joint demands a torque
with inertia terms). Torque-driven wiring: MotorController.tau_motor -> joint.tau_in, joint.omega_in ->
MotorController.omega (the joint integrates its input shaft with the rotor inertia J_drive lumped on it).
"Our master" here runs its explicit scheme: the study is about hosts that couple explicitly.
"""

import copy
import math
import sys
from pathlib import Path

import numpy as np

from .build import DEFAULT_FMU_DIR
from .master import Connection, CosimulationError, cosimulate
from .scenario import Scenario

#: torque-driven FMU -> its speed-driven original
SPEED_DRIVEN = {"CardanJointTorqueDriven": "CardanJoint",
                "DoubleCardanDrivelineTorqueDriven": "DoubleCardanDriveline",
                "TwinJeffcottRotorTorqueDriven": "TwinJeffcottRotor", "RingCouplingTorqueDriven": "RingCoupling"}
#: the limit runs lift the torque limit, which would otherwise bound a diverging loop in a limit cycle
UNLIMITED = {"motor.tau_max": 1.0e5}
SCENARIO_DIR = Path(__file__).resolve().parent.parent / "scenarios"


def speed_driven_twin(scenario: Scenario) -> Scenario:
    """The same system wired speed-driven: MotorController -> Motor with J_rotor = the joint's J_drive, the
    torque-driven joint -> its speed-driven original, the two drive connections reversed; records renamed
    (tau_input_shaft -> tau_in), no reference."""
    twin = copy.copy(scenario)
    (motor, _), = [(n, c) for n, c in scenario.components.items() if c[0] == "MotorController"]
    (joint, (fmu, params)), = [(n, c) for n, c in scenario.components.items() if c[0] in SPEED_DRIVEN]
    j_drive = scenario.parameters_with_defaults(joint)["J_drive"]
    twin.components = dict(scenario.components)
    twin.components[motor] = ("Motor", dict(scenario.components[motor][1], J_rotor=j_drive,
                                            ideal_speed_source=False))
    twin.components[joint] = (SPEED_DRIVEN[fmu], {k: v for k, v in params.items()
                                                  if k not in ("J_drive", "omega_in_start")})
    drive = {f"{joint}.omega_in", f"{motor}.tau_motor"}
    twin.connections = [c for c in scenario.connections if c.source not in drive] + [
        Connection(f"{motor}.omega", f"{joint}.omega_in"), Connection(f"{joint}.tau_in", f"{motor}.tau_load")]
    twin.record = [n.replace(".tau_input_shaft", ".tau_in") for n in scenario.record]
    twin.tolerances, twin.extrapolated_tolerances, twin.not_compared, twin.reference_file = {}, {}, {}, None
    return twin


def with_changes(scenario: Scenario, changes: dict, step_size: float = None, stop_time: float = None) -> Scenario:
    """A copy of scenario with parameters {"comp.par": value} changed (and the step or stop time)."""
    out = scenario.with_values(changes)
    out.step_size = step_size or scenario.step_size
    out.stop_time = stop_time or scenario.stop_time
    return out


def _run(scenario: Scenario, engine: str, fmu_dir) -> np.ndarray | None:
    """The scenario's table from libcosim or our master's explicit scheme; None when it stopped (a component
    refused a step, or the coupling went unstable)."""
    try:
        if engine == "libcosim":
            from .libcosim_run import cosimulate_libcosim
            return cosimulate_libcosim(scenario, Path(fmu_dir))
        return cosimulate(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time,
                          scenario.step_size, scenario.record, coupling="explicit")
    except (CosimulationError, RuntimeError):
        return None


def runs_stably(scenario: Scenario, engine: str = "master", fmu_dir=DEFAULT_FMU_DIR) -> bool:
    """True when the run completes with every recorded speed within 3x the largest reference speed of the
    motor's profile; False when a component refuses a step (a port left its range) or a speed exceeds that."""
    (params,) = [scenario.parameters_with_defaults(n) for n, (f, _) in scenario.components.items()
                 if f in ("Motor", "MotorController")]
    bound = 3.0 * max(abs(params["omega_set"]), abs(params["omega_initial"]), 1.0)
    table = _run(scenario, engine, fmu_dir)
    if table is None:
        return False
    speeds = [n for n in scenario.record if ".omega" in n]
    return all(np.all(np.abs(table[n]) < bound) for n in speeds)


def accuracy(scenario: Scenario, reference, engine: str, fmu_dir=DEFAULT_FMU_DIR) -> str:
    """'x% / y%': the largest error of the recorded speeds / torques against reference, in % of the reference's
    range (torque-driven names: tau_input_shaft for tau_in), or 'diverged'."""
    table = _run(scenario, engine, fmu_dir)
    if table is None:
        return "diverged"
    errors = {"omega": 0.0, "tau": 0.0}
    for name in scenario.record:
        ref_name = name[:-len(".tau_in")] + ".tau_input_shaft" if name.endswith(".tau_in") else name
        kind = next((k for k in errors if f".{k}" in name), None)
        if kind and ref_name in reference.dtype.names:
            y = np.interp(reference["time"], table["time"], table[name])
            errors[kind] = max(errors[kind], np.max(np.abs(y - reference[ref_name])) / np.ptp(reference[ref_name]))
    return f"{100 * errors['omega']:.2g}% / {100 * errors['tau']:.2g}%"


def stability_limit(stable, lo: float, hi: float, steps: int = 7) -> tuple:
    """(last stable, first unstable) value of a parameter by bisection in log scale, stable(lo) assumed true and
    stable(hi) false; (hi, None) when stable(hi) is true after all."""
    if stable(hi):
        return hi, None
    for _ in range(steps):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo, hi


def measure(fmu_dir=DEFAULT_FMU_DIR, out=sys.stdout) -> None:
    """Print the stability limits of docs/cosimulation.md, measured on the two bundled torque-driven scenarios
    and their speed-driven twins, in our master (ordered transfers) and libcosim (Jacobi)."""
    cardan = Scenario(SCENARIO_DIR / "cardan_heavy_torque_driven.toml")
    double = Scenario(SCENARIO_DIR / "double_cardan_stiff_torque_driven.toml")
    engines = ("master", "libcosim")

    def row(text, *values):
        print(text.ljust(64) + "".join(f"{v:>18}" for v in values), file=out, flush=True)

    def fmt(limit, scale=1.0):
        lo, hi = limit
        return f"> {lo * scale:.3g}" if hi is None else f"{lo * scale:.3g}-{hi * scale:.3g}"

    row("", *engines)
    row("(limits with tau_max = 1e5 N.m, so that the torque limit does not bound a diverging loop)")
    # the bundled cases at 1 ms: largest error against the monolithic reference, % of the reference's range
    from .references import read_reference
    for scenario in (cardan, double):
        reference = read_reference(scenario.reference_file)[0]
        for wiring, case in (("torque-driven", scenario), ("speed-driven", speed_driven_twin(scenario))):
            row(f"{scenario.name} {wiring}: speed / torque error", *(
                accuracy(case, reference, e, fmu_dir) for e in engines))
    def limits(scenario, parameter, lo, hi, step=None, stop=None, scale=1.0, **coupled):
        """The stability limit of one parameter in each engine; coupled: {other parameter: factor}."""
        def stable(value, engine):
            changes = {parameter: value, **{k: f * value for k, f in coupled.items()}, **UNLIMITED}
            return runs_stably(with_changes(scenario, changes, step, stop), engine, fmu_dir)
        return [fmt(stability_limit(lambda v: stable(v, e), lo, hi), scale) for e in engines]

    # CardanJoint: largest driven inertia J2, as the ratio J2 r_max^2 / J_rotor (r_max = 1/cos(bend))
    pj = cardan.parameters_with_defaults("joint")
    ratio = 1.0 / (math.cos(pj["bend_angle"]) ** 2 * pj["J_drive"])
    twin = speed_driven_twin(cardan)
    for h, stop in ((1e-3, 1.0), (1e-4, 0.2)):
        row(f"speed-driven CardanJoint, h = {h:g} s: J2 r_max^2 / J_rotor",
            *limits(twin, "joint.J2", 1e-4, 0.2, h, stop, ratio))
    row("torque-driven CardanJoint, h = 1 ms: J2 r_max^2 / J_rotor",
        *limits(cardan, "joint.J2", 0.2, 20.0, None, 1.0, ratio))
    # torque-driven: the sampled controller, Kp h / J_input (J_input = J_drive + J1 + J2 r_min^2), Ki = 10 Kp
    j_input = pj["J_drive"] + pj["J1"] + pj["J2"] * math.cos(pj["bend_angle"]) ** 2
    row("torque-driven CardanJoint, h = 1 ms: Kp h / J_input",
        *limits(cardan, "motor.Kp", 8.8, 2000.0, None, 1.0, cardan.step_size / j_input, **{"motor.Ki": 10.0}))
    # the heavy CardanJoint case behind a compliant flange: the flexible DoubleCardanDriveline with joint 2
    # straight is joint 1, a torsional spring-damper (k_theta, c_theta = 0.002 s k_theta) and J2 as J_load
    flange = with_changes(speed_driven_twin(double), {
        "driveline.beta1": pj["bend_angle"], "driveline.beta2": 0.0, "driveline.yoke_phase": 0.0,
        "driveline.J_load": pj["J2"], **{f"motor.{k}": v for k, v in cardan.components["motor"][1].items()},
        "motor.J_rotor": pj["J_drive"], **{f"load.{k}": v for k, v in cardan.components["load"][1].items()}})
    row("CardanJoint + compliant flange, h = 1 ms: k_theta [N.m/rad]",
        *limits(flange, "driveline.k_theta", 10.0, 2e5, None, 1.0))
    # DoubleCardanDriveline: largest k_theta (speed-driven: an elastic tau_in, a compliant input flange)
    twin = speed_driven_twin(double)
    for h in (1e-3, 2.5e-4):
        row(f"speed-driven DoubleCardanDriveline, h = {h:g} s: k_theta [N.m/rad]",
            *limits(twin, "driveline.k_theta", 100.0, 2e5, h, 0.6))
    row("torque-driven DoubleCardanDriveline, h = 1 ms: k_theta [N.m/rad]",
        *limits(double, "driveline.k_theta", 2e4, 2e6, None, 0.6))

def main(argv: list[str] | None = None) -> None:
    """``python -m ujfmu.wiring [--fmu-dir DIR]``: print the measured limits (needs the libcosim extra)."""
    import argparse

    from .extras import MissingExtraError, require
    parser = argparse.ArgumentParser(prog="python -m ujfmu.wiring", description=measure.__doc__)
    parser.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR,
                        help="folder of the built FMUs (default: fmus/ of the current directory)")
    args = parser.parse_args(argv)
    try:
        require("libcosimpy", "libcosim", "the wiring study's libcosim column")
    except MissingExtraError as exc:
        parser.error(str(exc))
    measure(args.fmu_dir)


if __name__ == "__main__":
    main()
