"""The reference generators' self-checks (ujfmu.references.*.self_check / energy_audit): each committed
reference satisfies its own conservation law and closed-form limits, and a plausible bug in a reference (a
dropped inertia term, swapped moment components, a sign) makes the check fail before anything is written.
`test_committed_reference_regenerates` (tests/test_scenarios.py) runs every check inside every generator."""

import ast
from pathlib import Path

import numpy as np
import pytest

from ujfmu.models.cardan_joint import reference as cardan_joint_reference
from ujfmu.models.double_cardan_driveline import reference as double_cardan
from ujfmu.models.ring_coupling import reference as ring_coupling
from ujfmu.models.twin_jeffcott_rotor import reference as twin_jeffcott
from ujfmu.references import read_reference
from ujfmu.references.common import ReferenceCheckError
from ujfmu.scenario import Scenario

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def committed(name):
    scenario = Scenario(SCENARIOS / f"{name}.toml")
    table, _ = read_reference(scenario.reference_file)
    return scenario, table["time"], {n: np.array(table[n]) for n in table.dtype.names}


def test_twin_rotor_energy_audit_catches_a_reference_without_the_gearbox_inertia():
    """The input torque without J_gb*alpha hides under a loose run-up tolerance, not under the audit."""
    scenario, t, cols = committed("twin_jeffcott_runup")
    twin_jeffcott.energy_audit(scenario, t, cols, "rotor", "load")
    j_gb = scenario.parameters_with_defaults("rotor")["J_gb"]
    cols["rotor.tau_in"] = cols["rotor.tau_in"] - j_gb * np.gradient(cols["motor.omega"], t)
    with pytest.raises(ReferenceCheckError, match="input_work against the integral"):
        twin_jeffcott.energy_audit(scenario, t, cols, "rotor", "load")


def test_twin_rotor_energy_audit_catches_a_dissipation_sign():
    scenario, t, cols = committed("twin_jeffcott_steady")
    twin_jeffcott.energy_audit(scenario, t, cols, "rotor", "load")
    cols["rotor.dissipated_energy"] = -cols["rotor.dissipated_energy"]
    with pytest.raises(ReferenceCheckError, match="stored energy against"):
        twin_jeffcott.energy_audit(scenario, t, cols, "rotor", "load")


@pytest.mark.parametrize("bug, law", [
    (lambda c: c.update({"joint.M_x": c["joint.M_y"], "joint.M_y": c["joint.M_x"]}), "torque balance"),
    (lambda c: c.update({"load.tau": -c["load.tau"]}), "kinetic energy"),
    (lambda c: c.update({"joint.omega_out": c["motor.omega"] * 1.2}), "kinetic energy"),
])
def test_cardan_reference_checks(bug, law):
    scenario, t, cols = committed("cardan_constant_speed")
    cols["joint.alpha_in"] = np.zeros_like(t)          # ideal constant speed source
    cardan_joint_reference.self_check(scenario, t, cols)
    bug(cols)
    with pytest.raises(ReferenceCheckError, match=law):
        cardan_joint_reference.self_check(scenario, t, cols)


def test_cardan_velocity_ratio_limit():
    """cos(theta) <= omega2/omega1 <= 1/cos(theta): a ratio past 1/cos(theta) is caught even when the energy
    balance is kept (driven side massless, load scaled to match)."""
    scenario, t, cols = committed("cardan_constant_speed")
    cols["joint.alpha_in"] = np.zeros_like(t)
    scenario.components["joint"][1].update(J2=0.0)
    cols["joint.omega_out"] = cols["joint.omega_out"] * 1.2
    cols["load.tau"] = cols["load.tau"] / 1.2
    with pytest.raises(ReferenceCheckError, match="velocity ratio"):
        cardan_joint_reference.self_check(scenario, t, cols)


@pytest.mark.parametrize("bug, law", [
    (lambda c: c.update({"driveline.tau_in": 0.999 * c["driveline.tau_in"]}), "stored energy"),
    (lambda c: c.update({"driveline.omega_out": c["driveline.omega_out"] * (1 + 1e-9)}), "constant-velocity"),
])
def test_double_cardan_reference_checks(bug, law):
    scenario, t, cols = committed("double_cardan_brutti_rigid")
    double_cardan.self_check(scenario, t, cols)
    bug(cols)
    with pytest.raises(ReferenceCheckError, match=law):
        double_cardan.self_check(scenario, t, cols)


@pytest.mark.parametrize("name, bug", [
    ("ring_coupling_fig3", lambda c: c.update({"coupling.tau_in": -c["coupling.tau_in"]})),
    ("ring_coupling_startup", lambda c: c.update({"load.tau": 0.99 * c["load.tau"]})),
])
def test_ring_coupling_energy_balance(name, bug):
    """For the pendulum closed form the balance is the first integral of y'' + A_e sin y = 0."""
    scenario, t, cols = committed(name)
    load = "load" if "load" in scenario.components else None
    ring_coupling.self_check(scenario, t, cols, "coupling", load)
    bug(cols)
    with pytest.raises(ReferenceCheckError, match="energy against"):
        ring_coupling.self_check(scenario, t, cols, "coupling", load)


def reference_modules():
    """(module name, path) of every reference module: the shared ujfmu/references and each model's reference.py."""
    root = Path(__file__).parents[1]
    paths = (sorted((root / "ujfmu" / "references").glob("*.py"))
             + sorted((root / "ujfmu" / "models").glob("*/reference.py")))
    return [(".".join(p.relative_to(root).with_suffix("").parts), p) for p in paths]


def imported_modules(module, path):
    """Absolute names of every module imported by the file at path (module: its own dotted name)."""
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            yield base
            yield from (f"{base}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            yield from (a.name for a in node.names)


def test_references_do_not_import_the_code_they_check():
    """References stay independent: no reference module (ujfmu/references, ujfmu/models/*/reference.py) imports any
    ujfmu module outside ujfmu.references: not a model's equations or FMU, not the FMU plumbing."""
    modules = reference_modules()
    assert len(modules) >= 6 and any(m.endswith("cardan_joint.reference") for m, _ in modules)
    for module, path in modules:
        for name in imported_modules(module, path):
            assert not name.startswith("ujfmu") or name.startswith("ujfmu.references"), (path, name)


def test_reference_import_rule_catches_a_model_import(tmp_path):
    """The rule above fails on a reference that imports a model, absolutely or relatively."""
    bad = tmp_path / "reference.py"
    for line in ("from ujfmu.models.cardan_joint import model", "from ..cardan_joint.model import joint_torques",
                 "from . import model", "import ujfmu.fmu.rk4"):
        bad.write_text(line + "\n")
        names = list(imported_modules("ujfmu.models.cardan_joint.reference", bad))
        assert any(n.startswith("ujfmu") and not n.startswith("ujfmu.references") for n in names), (line, names)
    bad.write_text("from ...references.common import pi_law\n")
    assert list(imported_modules("ujfmu.models.cardan_joint.reference", bad)) == [
        "ujfmu.references.common", "ujfmu.references.common.pi_law"]


def test_references_motor_and_load_laws_written_out_again():
    """The references' own copies of the Motor and Load laws (references.common), at the branches the committed
    scenarios never reach: the step profile, and the PI law in saturation with conditional integration."""
    from ujfmu.references.common import load_torque, pi_law, profile
    p = dict(profile=2, omega_set=10.0, accel=1.0, t_step=0.5, omega_initial=2.0, Kp=2.0, Ki=10.0, tau_max=5.0)
    w, a, angle = profile(p, np.array([0.25, 0.75]))
    np.testing.assert_array_equal(w, [2.0, 10.0])
    np.testing.assert_array_equal(a, [0.0, 0.0])
    np.testing.assert_allclose(angle, [0.5, 2.0 * 0.5 + 10.0 * 0.25], rtol=1e-15)
    t = np.full(6, 0.75)                                   # reference speed 10
    speed = np.array([9.0, 0.0, 9.0, 11.0, 20.0, 9.0])     # errors 1, 10, 1, -1, -10, 1
    integral = np.array([0.1, 0.0, 1.0, 1.0, 0.0, -1.0])   # u = 3, 20, 12, 8, -20, -8
    tau, di = pi_law(p, t, speed, integral)
    np.testing.assert_allclose(tau, [3.0, 5.0, 5.0, 5.0, -5.0, -5.0])
    # integrate unless saturated with the error driving further into saturation
    np.testing.assert_allclose(di, [1.0, 0.0, 0.0, -1.0, 0.0, 1.0])
    law = dict(T0=0.2, c1=0.01, c2=0.017, omega_smooth=0.1)
    w = np.array([-50.0, 0.0, 50.0])
    mag = np.sqrt(w * w + 0.01)
    np.testing.assert_allclose(load_torque(law, w, 0.0), 0.2 * w / mag + 0.01 * w + 0.017 * w * mag, rtol=1e-15)
    # a load step at 2 s and a ramp from 2 s to 3 s: T0 + T_change after, linear between
    ramp = dict(law, T_change=0.3, t_change=2.0, ramp_time=1.0)
    times = np.array([1.0, 2.0, 2.5, 3.0, 9.0])
    np.testing.assert_allclose(load_torque(ramp, 50.0, times) - load_torque(law, 50.0, 0.0),
                               0.3 * np.array([0.0, 0.0, 0.5, 1.0, 1.0]) * 50.0 / np.sqrt(2500.01), rtol=1e-12)
    step = dict(ramp, ramp_time=0.0)
    np.testing.assert_allclose(load_torque(step, 50.0, times) - load_torque(law, 50.0, 0.0),
                               0.3 * np.array([0.0, 1.0, 1.0, 1.0, 1.0]) * 50.0 / np.sqrt(2500.01), rtol=1e-12)


def rewired(tmp_path, name, *edits):
    """The committed scenario name with text edits (old, new) applied, as a Scenario in tmp_path."""
    text = (SCENARIOS / f"{name}.toml").read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return Scenario(path)


UNLOADED_DRIVELINE = ('[[connections]]\nfrom = "load.tau"\nto = "driveline.tau_load"\n', ""), \
    ('fmu = "DoubleCardanDriveline"\nparameters = {}', 'fmu = "DoubleCardanDriveline"\nparameters = {}\n'
                                                         'inputs = { tau_load = 5.0 }')


#: the driveline component renamed 'shaft' (its generator's name unchanged)
RENAMED_DRIVELINE = [("[components.driveline]", "[components.shaft]"), ('"driveline.', '"shaft.')]


@pytest.mark.parametrize("name, edits, words", [
    ("double_cardan_omar_torsional", UNLOADED_DRIVELINE, ["connection(s) missing: load.tau -> driveline.tau_load"]),
    ("double_cardan_omar_torsional", RENAMED_DRIVELINE,
     ["no component 'driveline' (DoubleCardanDriveline or DoubleCardanDrivelineTorqueDriven)",
      "component(s) 'shaft' (DoubleCardanDriveline) not part of it", "connection(s) missing: motor.omega -> "
      "driveline.omega_in", "it does not model: motor.omega -> shaft.omega_in"]),
    ("cardan_heavy_torque_driven", [("[components.load]", "[components.fan]"), ('"load.', '"fan.')],
     ["no component 'load' (Load)", "component(s) 'fan' (Load) not part of it",
      "connection(s) missing: joint.omega_out -> load.omega, load.tau -> joint.tau_load",
      "torque-driven (MotorController, CardanJointTorqueDriven, Load; connections joint.omega_in -> motor.omega"]),
    ("twin_jeffcott_runup", [('[[connections]]\nfrom = "rotor.tau_in"\nto = "motor.tau_load"\n', ""),
                             ('fmu = "Motor"\n', 'fmu = "Motor"\ninputs = { tau_load = 0.0 }\n')],
     ["connection(s) missing: rotor.tau_in -> motor.tau_load", "a PI motor"]),
    ("ring_coupling_fig3", [("inputs = { tau_load = 0.0 }", "inputs = { tau_load = 2.0 }")],
     ["coupling has no Load, so its tau_load must be 0, not 2.0"]),
])
def test_generators_refuse_a_wiring_they_do_not_model(tmp_path, name, edits, words):
    """A reference of another system would pass or fail the run for the wrong reason: each generator checks the
    components (names, FMUs) and connections against the topology it models and names what it expects."""
    from ujfmu.references import generate
    from ujfmu.references.common import WiringError
    scenario = rewired(tmp_path, name, *edits)
    with pytest.raises(WiringError, match="reference generator") as err:
        generate(scenario)
    for text in words:
        assert text in str(err.value)


def test_the_command_line_names_the_expected_wiring_without_a_traceback(tmp_path, capsys):
    from ujfmu.cli import main
    scenario = rewired(tmp_path, "double_cardan_omar_torsional", *RENAMED_DRIVELINE)
    assert main(["references", str(scenario.path)]) == 2
    err = capsys.readouterr().err
    assert "ujfmu: error:" in err and "components 'motor', 'driveline', 'load'" in err and "Traceback" not in err
    assert err.count(str(scenario.path)) == 1, err   # named once


def test_a_solve_sliding_on_a_discontinuity_stops_with_the_reason_instead_of_crawling():
    """The PI motor's conditional integration held at tau_max makes a right-hand side that switches at every step
    (a sliding mode): DOP853 crawled at 5e-10 s steps and `ujfmu references` ran for 21 minutes without a word.
    y' = 1 - 2 H(y - 1/2) - a PI integrator switched on and off about its limit in one line - slides on y = 1/2
    from t = 0.5 s: the solve stops there with ReferenceStallError naming the time and the PI limit, and a smooth
    solve of the same span is untouched (y' = -y: exp(-t))."""
    from ujfmu.references.common import ReferenceStallError, solve_piecewise
    motor = {"profile": 0, "Kp": 5.0, "ideal_speed_source": False}
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ReferenceStallError) as info:
        solve_piecewise(lambda time, y: np.array([1.0 if y[0] < 0.5 else -1.0]), np.array([0.0]), t, motor,
                        1e-10, 1e-12)
    at = float(str(info.value).split("stalled at t = ")[1].split()[0])
    assert at == pytest.approx(0.5, abs=1e-3) and "tau_max" in str(info.value)
    smooth = solve_piecewise(lambda time, y: -y, np.array([1.0]), t, motor, 1e-10, 1e-12)
    assert np.allclose(smooth[0], np.exp(-t), rtol=1e-8)


def test_an_integral_checked_on_a_coarse_grid_allows_simpsons_error_and_no_more():
    """A stiff shaft's torsional mode sampled coarsely (1500 rad/s every 1 ms, 4.2 samples a period): Simpson's
    rule on the sampled power misses its exact integral by far more than 1e-6 of it, which had failed a correct
    reference's self-check. check_integral allows the quadrature's error estimate (fourth differences, as the
    energy balance does; conservative while the grid resolves the power) and still fails an integral 5% off."""
    from ujfmu.references.common import ReferenceCheckError, check_integral, simpson_error, work
    t = np.linspace(0.0, 1.0, 1001)
    omega, p0, a = 1500.0, 100.0, 10.0
    power = p0 + a * np.sin(omega * t)
    exact = p0 * t + a * (1.0 - np.cos(omega * t)) / omega
    missed = np.max(np.abs(work(t, power) - exact))
    assert 1e-6 * p0 < missed <= simpson_error(t, power)
    scenario = type("S", (), {"path": "stiff.toml"})()
    check_integral(scenario, "input_work", t, exact, power, 1e-6)
    with pytest.raises(ReferenceCheckError, match="stiff.toml: reference self-check failed: input_work"):
        check_integral(scenario, "input_work", t, 1.05 * exact, power, 1e-6)


def test_a_compared_signal_the_generator_does_not_compute_is_named_before_a_reference_is_written(tmp_path,
                                                                                              monkeypatch):
    """A band on motor.omega_ref (which the generator does not solve for) had given a reference without the column;
    the run then stopped on 'no column motor.omega_ref' with no remedy. The generation stops first, naming the
    signal, the move to not_compared and what the generator computes, before it solves (a trial's double Cardan
    had solved for 2 minutes first): the generator's set-up alone names its columns."""
    from ujfmu.references import common, generate
    from ujfmu.scenario import ScenarioError

    def no_solve(*args, **kwargs):
        raise AssertionError("solved before the tolerances were checked")
    monkeypatch.setattr(common, "solve_ivp", no_solve)
    scenario = rewired(tmp_path, "cardan_startup", ('"motor.tau_motor", ', '"motor.tau_motor", "motor.omega_ref", '),
                       ('"motor.phi" = { abs = 0.0003 }', '"motor.phi" = { abs = 0.0003 }\n"motor.omega_ref" = '
                                                           '{ rel_range = 0.05 }'))
    with pytest.raises(ScenarioError, match=r"does not compute motor.omega_ref, which \[reference.tolerance\] "
                                            r"compares: move it to \[reference.not_compared\].*motor\.omega"):
        generate(scenario)


def test_a_load_step_is_in_the_monolithic_reference_and_the_run_follows_it(tmp_path, fmu_dir):
    """cardan_startup with its load raised by 0.3 N.m from t = 4 s over 10 ms (10 steps) and over 0.5 s: the
    reference solve restarts at the change's corners and the co-simulation, whose Load gives T(t) at each
    communication point, passes against it within the scenario's bands; the reference's load torque shows the
    change. (At once, the implicit scheme's blend of the motor's torn torque takes the step into the step before
    it: 0.12 rad/s on this 0.001 kg.m2 motor, past the bands; docs/cosimulation.md.)"""
    from ujfmu.references import generate, write_reference
    from ujfmu.scenario_run import run_scenario
    for ramp in ("0.01", "0.5"):
        scenario = rewired(tmp_path, "cardan_startup", (
            "omega_smooth = 1.0 }", f"omega_smooth = 1.0, T_change = 0.3, t_change = 4.0, ramp_time = {ramp} }}"))
        table, provenance = generate(scenario)
        write_reference(scenario.reference_file, table, provenance)
        before, after = np.searchsorted(table["time"], [3.9, 5.0])
        assert table["load.tau"][after] - table["load.tau"][before] > 0.29
        result = run_scenario(scenario, fmu_dir, out_dir=None)
        assert result.passed and not result.failed, result.summary()


def test_the_reference_solve_restarts_at_a_load_change_and_is_exact_across_it():
    """solve_piecewise restarts at a Load's corners (a step at 0.5003 s, off the output grid, and a ramp's two
    corners): each piece's right-hand side is then smooth, so even at a loose tolerance the integral of T(t) is
    exact to round-off, where one solve across the jump (or the kinks) keeps only its tolerance."""
    from ujfmu.references.common import load_level, solve_piecewise
    motor = dict(profile=0)
    t = np.linspace(0.0, 1.0, 101)
    for law, exact in ((dict(T0=1.0, T_change=2.0, t_change=0.5003, ramp_time=0.0),
                        t + 2.0 * np.maximum(t - 0.5003, 0.0)),
                       (dict(T0=1.0, T_change=2.0, t_change=0.2003, ramp_time=0.3),
                        t + 2.0 * np.where(t < 0.2003, 0.0, np.where(t < 0.5003, (t - 0.2003) ** 2 / 0.6,
                                                                     0.15 + (t - 0.5003))))):
        ys = solve_piecewise(lambda time, y: [float(load_level(law, time))], [0.0], t, motor, 1e-3, 1e-3, [law])
        assert np.max(np.abs(ys[0] - exact)) < 1e-12


def test_a_reference_solve_reports_its_progress_in_simulated_time():
    """`ujfmu references` of a stiff set-up took minutes with one line (a trial's): the solve reports how far it has
    come, in ms of simulated time over its whole span (pieces cut at a profile's corners included), rising to it;
    outside solve_progress nothing is reported."""
    from ujfmu.references.common import solve_piecewise, solve_progress
    calls = []
    t = np.linspace(0.0, 0.2, 201)

    def stiff(time_, y):   # DOP853 at its stability limit: about 2e4 evaluations over 0.2 s
        return np.array([-1e5 * (y[0] - np.cos(1e3 * time_))])
    ramp = {"profile": 1, "omega_set": 10.0, "accel": 100.0, "omega_initial": 0.0}   # a corner at 0.1 s
    with solve_progress(lambda done, total: calls.append((done, total))):
        y = solve_piecewise(stiff, np.array([1.0]), t, ramp, 1e-8, 1e-10)
    assert y.shape == (1, 201) and len(calls) >= 5 and {total for _, total in calls} == {200}
    assert all(b >= a for (a, _), (b, _) in zip(calls, calls[1:])) and 0 < calls[0][0] and 100 < calls[-1][0] <= 200
    before = len(calls)
    solve_piecewise(stiff, np.array([1.0]), t[:51], ramp, 1e-8, 1e-10)
    assert len(calls) == before
