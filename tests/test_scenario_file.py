"""Scenario files: errors name the file and the field."""

import copy
import math
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path
import numpy as np

import pytest

from ujfmu.scenario import Scenario, ScenarioError

GOOD = """
[experiment]
stop_time = 1.0
step_size = 1e-3
[components.j]
fmu = "CardanJoint"
inputs = { omega_in = 10.0, tau_load = 0.1 }
[components.l]
fmu = "Load"
[[connections]]
from = "j.omega_out"
to = "l.omega"
[output]
record = ["j.tau_in"]
"""


REF = '\n[reference]\nfile = "r.csv"\n[reference.tolerance]\n"j.tau_in" = { rel_range = 0.01 }'


def write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def test_good_file_loads(tmp_path):
    s = Scenario(write(tmp_path, GOOD))
    assert s.parameters_with_defaults("j")["J1"] == 2e-7 and len(s.time_grid()) == 1001
    assert s.coupling == "implicit" and s.output_interval == 1
    assert Scenario(write(tmp_path, GOOD.replace("step_size = 1e-3", "step_size = 1e-3\noutput_interval = 10"))
                    ).output_interval == 10
    assert Scenario(write(tmp_path, GOOD.replace("step_size = 1e-3", 'step_size = 1e-3\ncoupling = "explicit"'))
                    ).coupling == "explicit"


@pytest.mark.parametrize("old, new, field", [
    ('fmu = "Load"', 'fmu = "Loud"', "components.l.fmu"),
    ('to = "l.omega"', 'to = "l.omegaa"', "connections[0].to"),
    ('to = "l.omega"', 'to = "x.omega"', "unknown component"),
    ('fmu = "Load"', 'fmu = "Load"\ninputs = { omega = 1.0 }', "connections[0].to = 'l.omega' is also set under"),
    ('from = "j.omega_out"', 'from = "j.omega_in"', "not an output"),
    ('step_size = 1e-3', 'step_size = "fast"', "experiment.step_size"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J3 = 1 }', "parameters.J3"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\norbits = [["j.tau_in"]]', "output.orbits[0]"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nspectra = ["j.M_x"]', "output.spectra"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nplot = ["j.phi_out"]', "output.plot"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nsteady_from = "late"', "output.steady_from"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nsteady_from = 1.0', "output.steady_from = 1.0 s must lie in"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nrecrod = ["j.M_x"]', "[output]: unknown field(s) recrod"),
    # connections between mismatched units, or an input fed twice
    ('from = "j.omega_out"', 'from = "j.tau_in"', "units differ"),
    ('to = "l.omega"', 'to = "l.omega"\n[[connections]]\nfrom = "j.omega_out"\nto = "l.omega"', "already fed"),
    # bad numbers: out of range (named with the range), wrong type, non-finite
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J1 = -1.0 }', "outside its allowed range"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J1 = "heavy" }', "must be a number"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J1 = nan }', "not a finite number"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J2 = true }', "must be a number"),
    # misspelt tables and fields
    ('[experiment]', '[experimment]', "unknown top-level field(s) experimment"),
    ('fmu = "Load"', 'fmu = "Load"\nparameter = { T0 = 1.0 }', "components.l: fields are fmu, parameters and inputs"),
    # messages that say what to write instead
    ('fmu = "Load"',
     'fmu = "Load"\n[components.m]\nfmu = "Motor"\nparameters = { profile = 1.5 }\ninputs = { tau_load = 0.0 }',
     "must be an integer in [0, 3] (Speed profile: 0 constant, 1 ramp from rest at t = 0 s (the time axis, not the "
     "start time), 2 step at t_step, 3 ramp from omega_initial to omega_set at accel from t_step (up or down))"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { bend_angle = "20deg" }',
     "must be a number in rad (scenario values, in a file or from Python, are SI numbers: angles in rad, speeds in "
     "rad/s; `ujfmu run --set` and `ujfmu sweep --param` take deg and rpm suffixes"),
    # what the model refuses in its parameters together, before anything runs, with the remedy
    ('fmu = "Load"',
     'fmu = "Load"\n[components.m]\nfmu = "Motor"\nparameters = { profile = 1, omega_set = -150.0 }\n'
     'inputs = { tau_load = 0.0 }',
     "components.m.parameters: omega_set = -150.0 rad/s is outside its allowed range [0, 1e+04] rad/s for the ramp "
     "profile (profile = 1), which runs up from rest; to run in reverse, use the ramp between two speeds"),
    ('fmu = "Load"', 'fmu = "Lood"', "components.l.fmu = 'Lood' is not one of"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJiont"', "(did you mean 'CardanJoint'?)"),
    ('stop_time = 1.0', 'stop_time = 1e-4', "must be a whole number (at least 1) of communication steps"),
    ('stop_time = 1.0', 'stop_time = 1.0005', "must be a whole number (at least 1) of communication steps"),
    ('inputs = { omega_in = 10.0, tau_load = 0.1 }', 'inputs = { omega = 1.0 }', "components.j.inputs.omega"),
    # an input nothing feeds must be set explicitly (it would silently stay at its start value)
    ('inputs = { omega_in = 10.0, tau_load = 0.1 }', 'inputs = { omega_in = 10.0 }',
     "input(s) j.tau_load not connected"),
    ('stop_time = 1.0', 'stop_time = 1.0\nstop_time = 2.0', "line 4"),
    # coupling scheme: one of the known ones; misspelt experiment fields
    ('step_size = 1e-3', 'step_size = 1e-3\ncoupling = "implicitly"', "experiment.coupling"),
    ('step_size = 1e-3', 'step_size = 1e-3\ncoupling = 1', "experiment.coupling"),
    ('step_size = 1e-3', 'step_size = 1e-3\noutput_interval = 0', "experiment.output_interval"),
    ('step_size = 1e-3', 'step_size = 1e-3\noutput_interval = 2.5', "experiment.output_interval"),
    ('step_size = 1e-3', 'step_size = 1e-3\ncoupler = "explicit"', "unknown field(s) coupler"),
    ('stop_time = 1.0', 'stoptime = 1.0', "[experiment]: unknown field(s) stoptime"),   # not "stop_time = None"
    # [reference]: every recorded signal compared or not_compared with a reason; tolerances well-formed
    ('record = ["j.tau_in"]', 'record = ["j.tau_in", "j.M_x"]' + REF, "output.record: j.M_x neither compared"),
    # the provisional band it suggests: relative for a signal, absolute for a running angle (its range grows)
    ('record = ["j.tau_in"]', 'record = ["j.tau_in", "j.M_x", "j.phi_out"]' + REF,
     '"j.M_x" = { rel_range = 0.05 }; "j.phi_out" = { abs = 0.05 } (it grows along the run: an absolute band, in its unit)'),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in", "j.M_x"]' + REF + '\n[reference.not_compared]\n"j.M_x" = " "',
     "reference.not_compared.j.M_x"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF + '\n[reference.not_compared]\n"j.M_y" = "why"',
     "reference.not_compared.j.M_y: not a recorded signal"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF + '\n[reference.not_compared]\n"j.tau_in" = "why"',
     "also has a [reference.tolerance]"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF.replace("0.01", "-0.01"), "must not be negative"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF.replace("rel_range", "relrange"),
     "reference.tolerance.j.tau_in"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF + '\n[reference.extrapolated]\n"j.M_x" = { abs = 1 }',
     "reference.extrapolated.j.M_x: not a recorded signal"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF.replace("file =", "fil ="), "[reference]: unknown field"),
    # a value typed with a human unit is refused with the SI number it stands for
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { bend_angle = "8deg" }',
     "bend_angle = '8deg' must be a number in rad (scenario values"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { bend_angle = " 8.5 deg" }',
     "' 8.5 deg' is 0.148353 rad"),
    # a misspelt signal gets the recorded one it is close to; a band that allows nothing is refused
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF + '\n[reference.extrapolated]\n"j.tau_inn" = { abs = 1 }',
     "reference.extrapolated.j.tau_inn: not a recorded signal (did you mean 'j.tau_in'?)"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF.replace("rel_range = 0.01", "rel_range = 0"),
     "reference.tolerance.j.tau_in = {'rel_range': 0} allows no error at all"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]' + REF.replace("rel_range = 0.01", "rel_range = 0.0, abs = 0.0"),
     "allows no error at all, which no computation meets"),
])
def test_bad_field_is_named(tmp_path, old, new, field):
    path = write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(ScenarioError) as err:
        Scenario(path)
    assert str(path) in str(err.value) and field in str(err.value)


def test_not_compared_signals_are_listed_with_their_reason(tmp_path):
    """`ujfmu run` and `ujfmu check` print the summary: it names each uncompared signal and why."""
    from ujfmu.scenario_run import ScenarioResult
    text = GOOD.replace('record = ["j.tau_in"]', 'record = ["j.tau_in", "j.M_x"]' + REF
                        + '\n[reference.not_compared]\n"j.M_x" = "no reference for it"')
    scenario = Scenario(write(tmp_path, text))
    assert scenario.not_compared == {"j.M_x": "no reference for it"} and list(scenario.tolerances) == ["j.tau_in"]
    assert "not compared: j.M_x: no reference for it" in ScenarioResult(scenario, None).summary()


def test_a_signal_recorded_from_python_is_checked_before_anything_runs(tmp_path, fmu_dir):
    """A record name appended to a read Scenario from Python (an energy auditor's joint.stored_energy, which the
    CardanJoint has not) is a ScenarioError naming it before the run, as a file's is, not a co-simulation error."""
    from ujfmu.scenario_run import run_scenario
    scenario = Scenario(write(tmp_path, GOOD))
    scenario.record.append("j.stored_energy")
    with pytest.raises(ScenarioError, match=r"record\[1\] = 'j.stored_energy': CardanJoint has no variable"):
        run_scenario(scenario, fmu_dir=fmu_dir, out_dir=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_missing_fmu_is_named_before_anything_runs(tmp_path):
    from ujfmu.scenario_run import run_scenario
    path = write(tmp_path, GOOD)
    with pytest.raises(ScenarioError) as err:
        run_scenario(path, fmu_dir=tmp_path / "nowhere", out_dir=tmp_path / "out", progress=False)
    assert str(path) in str(err.value) and "components.j.fmu" in str(err.value) and "ujfmu build" in str(err.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("t0, t1", [(0.0, 0.5), (0.2, 1.0)])
def test_a_reference_that_does_not_cover_the_run_is_an_error_before_anything_runs(tmp_path, fmu_dir, t0, t1):
    """Beyond its ends a reference would be held at its end values: the run is refused, naming both spans. A file
    the scenario names no generator for (measured data) is to be extended, or the experiment shortened, not
    regenerated (a bench engineer had been sent to `ujfmu references`, which refuses it); a row that is not a
    finite solution is to be removed or filled."""
    from ujfmu.scenario_run import run_scenario
    (tmp_path / "r.csv").write_text(f'"time","j.tau_in"\n{t0},0.0\n{t1},1.0\n')
    path = write(tmp_path, GOOD + REF)
    with pytest.raises(ScenarioError) as err:
        run_scenario(path, fmu_dir=fmu_dir, out_dir=tmp_path / "out", progress=False)
    assert f"covers t = {t0:g} to {t1:g} s" in str(err.value) and "ujfmu references" not in str(err.value)
    assert "set the scenario's [experiment] start_time and stop_time within the reference's span" in str(err.value)
    assert "extend the file (it names no generator" in str(err.value)
    assert not (tmp_path / "out").exists()
    for rows, words in (("0,0.0\n0.5,nan\n1,1.0", r"has nan in column j.tau_in .*: remove that row, or fill it"),
                        ("0,0.0\n0.5,1.0\n0.5,1.0\n1,1.0", r"data row 3: 0.5 after 0.5\).*: sort its rows by time "
                                                          "and keep one row per time"),
                        ("0,0.0", "has 1 row of data.*: give it a row at least at the run's start and stop times")):
        (tmp_path / "r.csv").write_text(f'"time","j.tau_in"\n{rows}\n')
        with pytest.raises(ScenarioError, match=words):
            run_scenario(path, fmu_dir=fmu_dir, out_dir=tmp_path / "out", progress=False)


def test_a_fail_against_a_measured_reference_names_the_model_first(tmp_path, fmu_dir):
    """A reference the scenario names no generator for (bench data): a FAIL's advice names the model and its
    parameters first, and the noise, not the step (a bench engineer's wrong stiffness had been blamed on the step);
    the RMS error stands beside the max."""
    from ujfmu.scenario_run import run_scenario
    # the run's tau_in is about 0.1 (the load's torque through Feng's joint, whose 0.3 deg errors swing it by 0.1%)
    (tmp_path / "r.csv").write_text('"time","j.tau_in"\n0,0.5\n1,0.5\n')
    result = run_scenario(write(tmp_path, GOOD + REF), fmu_dir=fmu_dir, out_dir=None, progress=False, plot=False)
    summary = result.summary()
    assert result.failed and "the model or its parameters likely differ from what the file holds" in summary
    assert "if the error shrinks with the step it is the coupling's" not in summary
    (check,) = result.checks
    assert check.rms_error == pytest.approx(0.4, rel=3e-3) and f", RMS {check.rms_error:.3e} N.m" in str(check)


def test_the_allowed_error_scales_with_the_reference_over_the_run_only():
    """A reference longer than the run: the band is rel_range times the reference's range within the run."""
    import numpy as np

    from ujfmu.scenario import Tolerance
    from ujfmu.scenario_run import compare
    ref = np.rec.fromarrays([np.linspace(0.0, 6.0, 61), np.linspace(0.0, 60.0, 61)], names="time,x")
    run = np.rec.fromarrays([np.linspace(0.0, 2.0, 21), np.linspace(0.0, 20.0, 21) + 0.3], names="time,x")
    (check,) = compare(run, ref, {"x": Tolerance(rel_range=0.01)})
    assert check.reference_range == pytest.approx(20.0) and check.allowed == pytest.approx(0.2) and not check.passed


def _reference_made_for(tmp_path, text):
    """A reference file r.csv whose provenance line names the setup of the scenario text (as `ujfmu references`
    writes it), covering the run."""
    from ujfmu.references import SETUP_TAG
    digest = Scenario(write(tmp_path, text)).setup_digest()
    (tmp_path / "r.csv").write_text(f'# made by hand {SETUP_TAG}{digest}]\n"time","j.tau_in"\n0,0.0\n1,1.0\n')


@pytest.mark.parametrize("old, new", [
    ("omega_in = 10.0", "omega_in = 12.0"),                                            # a set input
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J2 = 2e-5 }'),           # a parameter
    ('fmu = "Load"', 'fmu = "Load"\nparameters = { c2 = 1e-6 }'),                        # another component's
    ("stop_time = 1.0", "start_time = 0.5\nstop_time = 1.0"),                            # the start time
    ('[[connections]]\nfrom = "j.omega_out"\nto = "l.omega"\n', 'inputs = { omega = 5.0 }\n'),  # the wiring
])
def test_a_reference_made_for_another_setup_is_refused_naming_the_remedy(tmp_path, old, new):
    """Edit a parameter, a set input, the wiring or the start time after the reference was made: the comparison
    would check the run against another system, so reading the reference fails and says how to regenerate it."""
    _reference_made_for(tmp_path, GOOD + REF)
    changed = (GOOD + REF).replace(old, new)
    assert changed != GOOD + REF
    scenario = Scenario(write(tmp_path, changed))
    with pytest.raises(ScenarioError) as err:
        scenario.read_reference()
    assert "made for another setup" in str(err.value) and f"ujfmu references {scenario.path}" in str(err.value)


@pytest.mark.parametrize("old, new", [
    ("omega_in = 10.0", "omega_in = 10"),                                                # 10 and 10.0 are one value
    ("stop_time = 1.0", "stop_time = 0.5"),                                              # within the reference's span
    ("step_size = 1e-3", "step_size = 5e-4"),                                            # interpolated
    ('"j.tau_in" = { rel_range = 0.01 }', '"j.tau_in" = { rel_range = 0.02 }'),           # tolerances
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nplot = ["j.tau_in"]'),               # what is plotted
    ("[experiment]", 'title = "renamed"\n[experiment]'),                                 # the title
])
def test_a_reference_stays_valid_when_only_the_run_or_its_checks_change(tmp_path, old, new):
    _reference_made_for(tmp_path, GOOD + REF)
    changed = (GOOD + REF).replace(old, new)
    assert changed != GOOD + REF
    assert list(Scenario(write(tmp_path, changed)).read_reference()["j.tau_in"]) == [0.0, 1.0]


def test_a_reference_made_with_other_fmu_defaults_is_refused_naming_the_remedy(tmp_path, monkeypatch):
    """The scenario leaves the joint's J2 and the load's c2 at their FMU defaults: a reference made for them, read
    after an update changed one of those defaults, solved another system. Reading it fails and says how to
    regenerate it; a default the scenario sets itself, or of an input a connection feeds, does not count."""
    from ujfmu.models.cardan_joint.fmu import CardanJoint
    from ujfmu.models.load.fmu import Load
    from ujfmu.references import DEFAULTS_TAG, SETUP_TAG

    def made_for(text):
        scenario = Scenario(write(tmp_path, text + REF))
        (tmp_path / "r.csv").write_text(f"# by hand {SETUP_TAG}{scenario.setup_digest()}] {DEFAULTS_TAG}"
                                        f'{scenario.defaults_digest()}]\n"time","j.tau_in"\n0,0.0\n1,1.0\n')
        return scenario.path

    def with_default(cls, name, start):
        changed = []
        for v in cls.VARIABLES:
            if v.name == name:
                v = copy.copy(v)
                v.start = start
            changed.append(v)
        monkeypatch.setattr(cls, "VARIABLES", tuple(changed))

    path = made_for(GOOD)
    with_default(Load, "omega", 3.0)   # fed by j.omega_out
    assert len(Scenario(path).read_reference()) == 2
    with_default(CardanJoint, "J2", 7e-3)
    with pytest.raises(ScenarioError) as err:
        Scenario(path).read_reference()
    assert "made with other FMU defaults" in str(err.value) and f"ujfmu references {path}" in str(err.value)
    monkeypatch.undo()
    path = made_for(GOOD.replace('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J2 = 1e-3 }'))
    with_default(CardanJoint, "J2", 7e-3)   # the scenario's own value holds
    assert len(Scenario(path).read_reference()) == 2


def test_a_parameter_an_update_adds_at_its_neutral_value_keeps_the_references(tmp_path, monkeypatch):
    """An update that adds a parameter whose default leaves the model as it was (the Motor's tau_initial = 0: the
    drive starts from zero torque, as before) keeps every reference made before it; the same parameter with a
    default off its neutral value changes the system, and the reference is refused."""
    from ujfmu.fmu.base import parameter
    from ujfmu.models.load.fmu import Load
    from ujfmu.references import DEFAULTS_TAG, SETUP_TAG
    scenario = Scenario(write(tmp_path, GOOD + REF))
    (tmp_path / "r.csv").write_text(f"# by hand {SETUP_TAG}{scenario.setup_digest()}] {DEFAULTS_TAG}"
                                    f'{scenario.defaults_digest()}]\n"time","j.tau_in"\n0,0.0\n1,1.0\n')
    declared = Load.VARIABLES
    monkeypatch.setattr(Load, "VARIABLES", declared + (parameter("T_new", 0.0, "N.m", "a feature", neutral=0.0),))
    assert len(Scenario(scenario.path).read_reference()) == 2
    monkeypatch.setattr(Load, "VARIABLES", declared + (parameter("T_new", 0.5, "N.m", "a feature", neutral=0.0),))
    with pytest.raises(ScenarioError, match="made with other FMU defaults"):
        Scenario(scenario.path).read_reference()


def test_a_reference_without_a_setup_digest_is_read_as_it_is(tmp_path):
    """A reference made by another tool has no setup digest: it is compared, as before."""
    (tmp_path / "r.csv").write_text('# measured on the test rig\n"time","j.tau_in"\n0,0.0\n1,1.0\n')
    assert len(Scenario(write(tmp_path, GOOD + REF)).read_reference()) == 2


@pytest.mark.parametrize("old, new", [("cardan_chain", "cardan_joint"), ("double_cardan", "double_cardan_driveline"),
                                      ("twin_jeffcott", "twin_jeffcott_rotor")])
def test_a_former_generator_name_is_refused_naming_todays(tmp_path, old, new):
    with pytest.raises(ScenarioError) as err:
        Scenario(write(tmp_path, GOOD + REF.replace('file = "r.csv"', f'file = "r.csv"\ngenerator = "{old}"')))
    assert f"reference.generator = '{old}' is now called" in str(err.value)
    assert f'write generator = "{new}"' in str(err.value)


def test_an_unknown_generator_is_refused_naming_the_known_ones(tmp_path):
    with pytest.raises(ScenarioError) as err:
        Scenario(write(tmp_path, GOOD + REF.replace('file = "r.csv"', 'file = "r.csv"\ngenerator = "cardan"')))
    assert "reference.generator = 'cardan' is not a reference generator (known: cardan_joint, " in str(err.value)


@pytest.mark.parametrize("old, new, words", [
    ('to = "l.omega"', 'to = "l.omegaa"', "(did you mean l.omega?); its inputs: omega"),
    ('from = "j.omega_out"', 'from = "j.omega_ou"', "(did you mean j.omega_out?); its outputs: "),
    ('record = ["j.tau_in"]', 'record = ["j.tau_ni"]', "(did you mean j.tau_in?); its outputs and inputs: "),
])
def test_a_misspelt_port_is_named_with_the_closest_port_and_the_components_ports(tmp_path, old, new, words):
    with pytest.raises(ScenarioError) as err:
        Scenario(write(tmp_path, GOOD.replace(old, new)))
    assert words in str(err.value)


def test_a_scenario_path_without_toml_names_the_file_that_exists(tmp_path, capsys, monkeypatch):
    """`ujfmu run scenarios/x` when scenarios/x.toml exists: the error names scenarios/x.toml; a mistyped name
    gets the closest names of its folder and of the bundled scenarios; a name like none of them gets no guess."""
    from ujfmu.cli import main
    from ujfmu.scenario import BUNDLED_SCENARIOS
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "my_rig.toml").write_text(GOOD)
    monkeypatch.chdir(tmp_path)
    assert main(["run", "scenarios/my_rig", "--no-plot"]) == 2
    assert "scenarios/my_rig: scenario file not found; did you mean scenarios/my_rig.toml?" in capsys.readouterr().err
    with pytest.raises(ScenarioError, match=r"did you mean scenarios/my_rig.toml\?"):
        Scenario("scenarios/my_rgi.toml")
    with pytest.raises(ScenarioError) as err:
        Scenario("scenarios/twin_jefcott_steady")
    assert f"did you mean {BUNDLED_SCENARIOS / 'twin_jeffcott_steady.toml'} or " in str(err.value)   # closest first
    with pytest.raises(ScenarioError) as err:
        Scenario("scenarios/zzzz")
    assert str(err.value) == "scenarios/zzzz: scenario file not found"
    # a misspelt folder of scenarios (a CI trial's `check scenarios/tema/`) gets the folder that holds them
    (tmp_path / "scenarios" / "team").mkdir()
    (tmp_path / "scenarios" / "team" / "truck.toml").write_text(GOOD)
    with pytest.raises(ScenarioError, match=r"scenarios/tema: scenario file not found; did you mean the folder "
                                            r"scenarios/team\?"):
        Scenario("scenarios/tema")
    # a bare name, as typed in a project of one's own: its scenarios/ folder is looked in too
    with pytest.raises(ScenarioError, match=r"did you mean scenarios/my_rig.toml\?"):
        Scenario("my_rig")


@pytest.mark.parametrize("old, new, says", [
    ('fmu = "Load"', 'fmu = "Load"\nparameters = { T_0 = 1.0 }', "has no parameter 'T_0' (did you mean T0 or T_h?)"),
    ('fmu = "Load"', 'fmu = "Load"\nparameters = { tau = 1.0 }', "(it is an output, which the FMU computes)"),
    ("inputs = { omega_in = 10.0, tau_load = 0.1 }", "inputs = { omega_in = 10.0, tau_load = 0.1, J2 = 1e-5 }",
     "has no input 'J2' (it is a parameter: set it under parameters)"),
    ('fmu = "Load"', 'fmu = "Load"\nparameters = { omega = 1.0 }', "(it is an input: connect it, or set it under inputs)"),
])
def test_a_name_in_the_wrong_table_or_misspelt_says_where_it_goes(tmp_path, old, new, says):
    text = GOOD.replace(old, new)
    assert text != GOOD
    with pytest.raises(ScenarioError) as err:
        Scenario(write(tmp_path, text))
    assert says in str(err.value)


def test_no_bundled_scenario_sets_parameters_its_models_warn_of():
    """The models' advice (a joint past 45 deg, a set speed past 1000 rad/s, the default error angles where they
    matter, a ring misalignment large against the ring, a ring's c_s left at another ring's) is silent on every
    bundled scenario: each sets what it means."""
    from pathlib import Path
    for path in sorted((Path(__file__).parent.parent / "scenarios").glob("*.toml")):
        assert Scenario(path).model_advice() == [], path


SCENARIOS = Path(__file__).parent.parent / "scenarios"
OMAR_START = Path(__file__).parent.parent / "scenarios" / "double_cardan_omar_startup.toml"


@pytest.mark.parametrize("profile, start, end, warned", [(3, 0.0, 60.0, True), (3, 60.0, 0.0, True),
                                                         (2, 60.0, 0.0, True), (3, 30.0, 60.0, False),
                                                         (3, 10.0, -10.0, True), (3, -5.0, 5.0, True),
                                                         (2, -5.0, 5.0, False),
                                                         (0, 0.0, 0.0, True), (0, 0.0, 60.0, False),
                                                         (3, -30.0, -60.0, False)])
def test_a_load_that_chatters_is_named_where_a_ramp_or_step_passes_rest(profile, start, end, warned):
    """The chatter advice where the drive reaches rest: a ramp between two speeds from 0 (the Motor's own remedy for
    running in reverse) had left it unsaid, and a braking to 0 passes rest too, as does a reversal (a steering
    wheel turned from 10 to -10 rad/s) and a shaft held at rest (a steering wheel held still, which chattered at
    +-3.7 N.m); a ramp between two speeds above rest, or two below it, never does, nor a step at t_step = 0,
    which starts the run at its omega_set (Omar's start-up at 200 N.m, T0 h / J = 44 rad/s)."""
    scenario = Scenario(OMAR_START).with_parameters({"load.T0": 200.0, "motor.profile": profile,
                                                     "motor.omega_initial": start, "motor.omega_set": end})
    # the chatter's own words ("reverses at every step"), alone or in one remedy with a smoothed friction's
    assert any(a.startswith("load:") and "reverses at every step" in a for a in scenario.model_advice()) == warned


@pytest.mark.parametrize("t_step, warned", [(1.0, True), (-1.0, False), (100.0, False)])
def test_the_chatter_advice_takes_the_profile_within_the_run(t_step, warned):
    """A braking from 60 rad/s to rest at t_step passes rest within the 7 s run only where t_step is before its
    stop; a step before the start leaves the drive at rest from the start (no passage through it: a hold at 0 is
    named by its own case). A reviewer had the advice for a stop at 100 s after a 7 s run."""
    scenario = Scenario(OMAR_START).with_parameters({"load.T0": 200.0, "motor.profile": 3, "motor.omega_initial": 60.0,
                                                     "motor.omega_set": 0.0, "motor.t_step": t_step,
                                                     "motor.accel": 100.0})
    advice = [a for a in scenario.model_advice() if "reverses at every step" in a]
    assert bool(advice) == (warned or t_step < 0.0)   # before the start: held at rest over the run, also named


def test_the_friction_advice_takes_each_loads_own_drive(tmp_path):
    """Two drives, a slow one at 0.2 rad/s and a fast one at 100 rad/s, each with its own Load (T0 = 5 N.m,
    omega_smooth = 1 rad/s): only the slow drive's Load is smoothed at its speed, 0.2 / sqrt(0.2^2 + 1) = 0.196 T0;
    the fast one's torque is 0.99995 T0 (a reviewer's scenario had both named at the slow drive's speed). A load
    raised by T_change is named with the torque it reaches."""
    text = (EXPERIMENT + drive("slow", 0.2) + drive("fast", 100.0)
            + component("load_slow", "Load", "T0 = 0.0, T_change = 5.0, t_change = 0.5, omega_smooth = 1.0")
            + component("load_fast", "Load", "T0 = 5.0, omega_smooth = 1.0")
            + wires(("slow.omega", "load_slow.omega"), ("load_slow.tau", "slow.tau_load"), ("fast.omega",
                    "load_fast.omega"), ("load_fast.tau", "fast.tau_load"))
            + '[output]\nrecord = ["load_slow.tau"]\n')
    (advice,) = Scenario(write(tmp_path, text)).smoothed_friction()
    assert advice.startswith("load_slow: its constant torque T0 + T_change = 5 N.m reverses smoothly")
    assert f"at slow.omega_set = 0.2 rad/s it gives {0.2 / math.hypot(0.2, 1.0):.3g} T0 + T_change" in advice


@pytest.mark.parametrize("kp, warned", [(80.0, False), (150.0, True)])
def test_a_sampled_pi_too_fast_for_its_step_is_named(kp, warned):
    """The stiff torque-driven double Cardan: its MotorController's torque accelerates J_drive = 0.05 kg.m2 at once
    (the shaft's compliance behind it), so the PI sampled at 1 ms has its pole at 1 - Kp h / J: beyond -1 from
    Kp = 100 (a control engineer's run diverged explicitly, and the implicit scheme had hidden it). Named at Kp =
    150 (ratio 3) with the Kp and the step that would do; not at 80 (1.6)."""
    scenario = Scenario(SCENARIOS / "double_cardan_stiff_torque_driven.toml").with_parameters({"motor.Kp": kp})
    advice = [a for a in scenario.model_advice() if a.startswith("motor: its PI reads the speed once a step")]
    assert bool(advice) == warned
    if warned:
        assert "Kp h / J = 150 x 0.001 / 0.05 = 3," in advice[0] and "Lower Kp below 100 or the step below" in advice[0]


def test_a_sampled_pi_is_judged_at_the_smallest_inertia_over_a_turn():
    """The heavy torque-driven CardanJoint reflects J_drive + J1 + J2 r^2 at its input, r from cos 20 deg to
    1 / cos 20 deg over a turn: 0.1866 to 0.2365 kg.m2. At Kp = 382.5 the sampled loop passes Kp h / J = 2 where J
    is smallest (2.05) though not at the start angle (1.62), and it diverged there (a reviewer's run): named, with
    J near its smallest (16 angles a turn)."""
    scenario = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml").with_parameters({"motor.Kp": 382.5})
    (advice,) = [a for a in scenario.model_advice() if a.startswith("motor: its PI reads the speed once a step")]
    inertia = float(advice.split("Kp h / J = 382.5 x 0.001 / ")[1].split(" =")[0])
    assert 0.1866 <= inertia < 0.1866 * 1.01


@pytest.mark.parametrize("t_step, warned", [(0.0, True), (0.01, False)])
def test_a_motors_step_at_the_start_is_named(t_step, warned):
    """A Motor's step profile at t_step = 0 starts its rotor at omega_set (the profile's speed at the start), the
    driveline turning with it: no launch, where a motorsport trial had meant one (its MotorController twin launched
    from rest). Named; a step after the start is not."""
    scenario = Scenario(OMAR_START).with_parameters({"motor.profile": 2, "motor.omega_initial": 0.0,
                                                     "motor.omega_set": 60.0, "motor.t_step": t_step})
    advice = [a for a in scenario.model_advice() if a.startswith("motor: its step profile steps at")]
    assert bool(advice) == warned
    if warned:
        assert "the Motor starts at omega_set = 60 rad/s" in advice[0]


@pytest.mark.parametrize("changes, said", [
    ({"motor.profile": 0}, "its speed reference starts at 60 rad/s, driveline's input shaft at omega_in_start = 0"),
    ({"motor.profile": 0, "driveline.omega_in_start": 60.0}, None),
    ({}, None),   # the scenario's ramp from rest: launched from rest as meant
    ({"motor.profile": 3, "motor.omega_initial": 20.0, "motor.t_step": 0.5}, "starts at 20 rad/s"),
    ({"motor.profile": 2, "motor.omega_initial": 20.0, "motor.t_step": 0.0, "driveline.omega_in_start": 20.0},
     "starts at 60 rad/s"),   # stepped at the start: the reference is omega_set there
])
def test_a_controller_whose_reference_starts_away_from_its_shafts_start_is_named(changes, said):
    """A truck engineer's PI run at speed started its torque-driven shaft at 0 rad/s (its omega_in_start) and the
    controller launched it into its torque limit: the MotorController's reference (omega_initial, omega_set) does not
    set the shaft's start. Named before the run, with the parameter that starts it at speed."""
    scenario = Scenario(SCENARIOS / "double_cardan_stiff_torque_driven.toml").with_parameters(changes)
    advice = [a for a in scenario.model_advice() if a.startswith("motor: its speed reference starts at")]
    assert len(advice) == (said is not None)
    if said:
        assert said in advice[0] and "set driveline.omega_in_start = " in advice[0]


@pytest.mark.parametrize("changes, times, settled, span", [
    # a slew from 1.0 to 0.2 rad/s settles at 0.2 (a float equality had dropped it: 1 - 0.8 != 0.2)
    ({"motor.profile": 3, "motor.omega_initial": 1.0, "motor.omega_set": 0.2, "motor.t_step": 0.5}, (0.0, 7.0),
     [("omega_initial", 1.0), ("omega_set", 0.2)], (0.2, 1.0)),
    # Omar's ramp (15 rad/s2 to 80) seen from 10 s on: at 80 throughout, never near rest
    ({}, (10.0, 10.5), [("omega_set", 80.0)], (80.0, 80.0)),
    # the ramp cut at 0.1 s: 1.5 rad/s reached, omega_set not (no settled speed, whose label it had taken)
    ({}, (0.0, 0.1), [], (0.0, 1.5)),
    # a step after the stop: only omega_initial
    ({"motor.profile": 2, "motor.omega_initial": 5.0, "motor.omega_set": 0.0, "motor.t_step": 100.0}, (0.0, 7.0),
     [("omega_initial", 5.0)], (5.0, 5.0)),
])
def test_a_drives_speeds_are_those_of_its_profile_within_the_run(changes, times, settled, span):
    """The speeds a drive settles at and the range it spans between the start and the stop, from its profile
    (a reviewer's cases)."""
    scenario = Scenario(OMAR_START).with_parameters(changes)
    scenario.start_time, scenario.stop_time = times
    found, (lo, hi) = scenario._drive_speeds("motor")
    assert [(name, pytest.approx(speed)) for name, speed in found] == settled
    assert (lo, hi) == (pytest.approx(span[0]), pytest.approx(span[1]))


def test_a_loads_drive_is_found_through_a_chain_and_not_guessed(tmp_path):
    """A Load behind a ring coupling and a joint in series is driven by the motor at their head (a reviewer's chain
    had been given a second, slow motor's speed); a Load fed from elsewhere has no drive, and no speed advice."""
    text = (EXPERIMENT + drive("motor", 100.0) + drive("slow", 0.5) + component("ring", "RingCoupling")
            + component("joint", "CardanJoint") + component("load", "Load", "T0 = 5.0, omega_smooth = 1.0")
            + component("load_slow", "Load", "T0 = 5.0, omega_smooth = 1.0")
            + wires(("motor.omega", "ring.omega_in"), ("ring.omega_out", "joint.omega_in"),
                    ("joint.omega_out", "load.omega"), ("load.tau", "joint.tau_load"),
                    ("joint.tau_in", "ring.tau_load"), ("ring.tau_in", "motor.tau_load"),
                    ("slow.omega", "load_slow.omega"), ("load_slow.tau", "slow.tau_load"))
            + '[output]\nrecord = ["load.tau"]\n')
    scenario = Scenario(write(tmp_path, text))
    assert scenario._load_drives("load") == ["motor"] and scenario._load_drives("load_slow") == ["slow"]
    assert [a.partition(":")[0] for a in scenario.smoothed_friction()] == ["load_slow"]


def test_a_load_change_after_the_run_is_not_its_torque():
    """T0 = 0 and a change to 5 N.m at 100 s, after Omar's 7 s start-up: the Load gives 0 over the run, so no
    smoothed-friction advice names 5 N.m (a reviewer's case); a change within the run is named."""
    base = {"motor.profile": 0, "motor.omega_set": 0.2, "load.T0": 0.0, "load.T_change": 5.0}
    assert Scenario(OMAR_START).with_parameters({**base, "load.t_change": 100.0}).smoothed_friction() == []
    (advice,) = Scenario(OMAR_START).with_parameters({**base, "load.t_change": 1.0}).smoothed_friction()
    assert "T0 + T_change = 5 N.m" in advice


def test_a_load_both_smoothed_and_chattering_gets_one_remedy():
    """Omar's start-up slewing from rest to 0.5 rad/s against 20 N.m with omega_smooth = 0.1 rad/s: the friction is
    smoothed at the set speed (0.98 T0) and the load chatters near rest (T0 h / J = 4.4 rad/s, 44x omega_smooth).
    The two remedies had contradicted each other (widen omega_smooth to 4.44; lower it to 0.05): one advice now
    gives omega_smooth <= 0.05 rad/s with a step <= J 0.05 / T0 = 1.125e-5 s."""
    scenario = Scenario(OMAR_START).with_parameters({"load.T0": 20.0, "load.omega_smooth": 0.1, "motor.profile": 3,
                                                     "motor.omega_initial": 0.0, "motor.omega_set": 0.5})
    (advice,) = [a for a in scenario.model_advice() if a.startswith("load:")]
    assert "lower omega_smooth to at most 0.05 rad/s" in advice and "with a step of at most 1.12e-05 s" in advice
    assert "Widen omega_smooth" not in advice


EXPERIMENT = "[experiment]\nstop_time = 1.0\nstep_size = 1e-3\n"


def component(name, fmu, parameters=""):
    """A [components.<name>] table of a scenario text."""
    return f'[components.{name}]\nfmu = "{fmu}"\n' + (f"parameters = {{ {parameters} }}\n" if parameters else "")


def drive(name, speed):
    """An ideal speed source at a constant speed [rad/s]."""
    return component(name, "Motor", f"ideal_speed_source = true, profile = 0, omega_set = {speed}")


def wires(*pairs):
    """[[connections]] of a scenario text, (from, to) each."""
    return "".join(f'[[connections]]\nfrom = "{a}"\nto = "{b}"\n' for a, b in pairs)


@pytest.mark.parametrize("speed, smooth, torque, share", [(0.2, 0.1, 5.0, 2 / math.sqrt(5)), (-0.3, 0.1, 5.0,
                                                           3 / math.sqrt(10)), (1.0, 0.1, 5.0, None),
                                                          (0.2, 0.1, 0.0, None), (0.0, 0.1, 5.0, None)])
def test_a_friction_smoothed_at_the_running_speed_is_named(speed, smooth, torque, share):
    """A Load's T0 reverses over omega_smooth: at a set speed of 2 omega_smooth its torque is T0 omega /
    sqrt(omega^2 + omega_smooth^2) = 0.894 T0, which a steering engineer's sweep at 0.2 rad/s had taken for T0
    (mean tau_in 4.47 N.m for 5). Named below 0.99 T0, whatever the direction; not at 10 omega_smooth (0.995), nor
    without a T0, nor at rest (the chatter advice's case)."""
    scenario = Scenario(OMAR_START).with_parameters({"motor.profile": 0, "motor.omega_set": speed,
                                                     "load.omega_smooth": smooth, "load.T0": torque})
    advice = scenario.smoothed_friction()
    assert len(advice) == (share is not None), advice
    if share is not None:
        assert advice[0].startswith(f"load: its constant torque T0 = {torque:g} N.m reverses smoothly")
        assert f"at motor.omega_set = {abs(speed):g} rad/s it gives {share:.3g} T0" in advice[0]
        assert f"lower omega_smooth to at most {abs(speed) / 10:.3g} rad/s" in advice[0]


@pytest.mark.parametrize("torque, warned", [(5.0, False), (8.0, False), (10.0, True), (200.0, True)])
def test_a_load_that_chatters_from_rest_is_named_before_the_run(torque, warned):
    """One 1 ms step of a Load's constant torque T0 moves Omar's 4.5 g.m2 output by T0 h / J: 1.1 rad/s at his 5
    N.m, about its 1 rad/s omega_smooth (its start-up runs, and at 8 N.m), 44 rad/s at 200 N.m, where a start
    from rest reverses the torque at every step and the run stopped as a coupling instability with a wrong remedy
    (a first-day trial). It stops so from 10 N.m (2.2 rad/s), which the advice had left unsaid below 10x (a marine
    trial's stall at 3.3-8x). The advice names the load, the inertia, the ratio and both remedies, computed here
    from T0, J, h."""
    scenario = Scenario(OMAR_START).with_parameters({"load.T0": torque})
    advice = [a for a in scenario.model_advice() if a.startswith("load:")]
    (chatter,) = scenario.load_chatter()
    assert chatter.ratio == pytest.approx(torque * 1e-3 / 0.0045 / 1.0)
    assert bool(advice) == warned
    if warned:
        reach = torque * 1e-3 / 0.0045
        assert (f"moves driveline's output inertia J = 0.0045 kg.m2 by T0 h / J = {reach:.3g} rad/s, {reach:.3g}x "
                "omega_smooth" in advice[0])
        assert (f"Widen omega_smooth to at least {reach:.3g} rad/s, or take a step of at most "
                f"{0.0045 / torque:.3g} s" in advice[0])
    # a load raised later by T_change chatters with the torque it reaches, named as such
    (raised,) = Scenario(OMAR_START).with_parameters({"load.T0": 0.2, "load.T_change": torque}).load_chatter()
    assert raised.torque == 0.2 + torque and raised.text().startswith(f"load: its constant torque T0 + T_change = "
                                                                       f"{0.2 + torque:g} N.m reverses")


def test_every_problem_of_a_file_is_named_in_one_reading(tmp_path):
    """Several independent mistakes (a misspelt and an out-of-range parameter, a misspelt port in a connection and in
    the record, an unknown field in [experiment]) are all named at once, one a line, so a file is fixed in one
    pass; a connection to a component whose FMU is unknown is not named again, nor are the inputs a misspelt
    connection was meant to feed."""
    text = (GOOD.replace('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { bend_anlge = 0.1, J1 = -1.0 }')
            .replace('to = "l.omega"', 'to = "l.omegaa"').replace('record = ["j.tau_in"]', 'record = ["j.tau_inn"]')
            .replace("step_size = 1e-3", "step_size = 1e-3\nstop_tme = 2.0"))
    with pytest.raises(ScenarioError) as error:
        Scenario(write(tmp_path, text))
    lines = str(error.value).splitlines()
    assert lines[0] == f"{tmp_path / 's.toml'}: 5 problems:"
    for line, words in zip(lines[1:], ["[experiment]: unknown field(s) stop_tme", "parameters.bend_anlge",
                                       "parameters.J1", "connections[0].to = 'l.omegaa'", "output.record[0]"]):
        assert line.startswith("  - ") and words in line, (line, words)
    unknown_fmu = GOOD.replace('fmu = "Load"', 'fmu = "Loud"').replace('record = ["j.tau_in"]', 'record = ["j.tau_inn"]')
    with pytest.raises(ScenarioError) as error:
        Scenario(write(tmp_path, unknown_fmu))
    assert "2 problems" in str(error.value) and "components.l.fmu" in str(error.value)
    assert "connections" not in str(error.value) and "not connected" not in str(error.value)


@pytest.mark.parametrize("old, new", [('[output]\nrecord = ["j.tau_in"]\n', ""),
                                      ('record = ["j.tau_in"]', "record = []")])
def test_a_file_that_records_nothing_is_refused_naming_what_it_could_record(tmp_path, old, new):
    """A scenario without [output] (or with an empty record) had run, written a CSV of times alone and exited 0:
    nothing recorded, nothing checked. It is a file problem naming the components' outputs."""
    with pytest.raises(ScenarioError, match=r"output.record: no signal is recorded.*e\.g\. record = \['j\.omega_out'"
                                            r".*l\.tau"):
        Scenario(write(tmp_path, GOOD.replace(old, new)))


@pytest.mark.parametrize("old, new, says", [
    ("stop_time = 1.0", "stop_time = 5.0\n", "whole number (at least 1) of communication steps of step_size = 0.003 s "
                                              "(e.g. stop_time = 4.998 or 5.001 s, or a step_size that divides 5 s "
                                              "such as 0.0025 s)"),
    ("stop_time = 1.0\n", "", "experiment.stop_time is missing: give it a number (seconds)"),
])
def test_experiment_times_that_do_not_fit_say_what_would(tmp_path, old, new, says):
    """A stop time that is no whole number of steps names two that are and a round step that divides the span; a
    missing time is named missing (it had read 'stop_time = None must be a finite number')."""
    text = GOOD.replace(old, new).replace("step_size = 1e-3", "step_size = 0.003")
    with pytest.raises(ScenarioError) as err:
        Scenario(write(tmp_path, text))
    assert says in str(err.value)


def test_an_experiment_changed_after_loading_is_checked_before_a_run(fmu_dir):
    """A caller that sets step_size < 0 or stop_time = NaN on a loaded scenario (an optimizer's copy) had a reference
    span message that contradicted itself, or a bare ValueError from int(): run_scenario names the field first."""
    from ujfmu.scenario_run import run_scenario
    for name, value, words in (("step_size", -1e-3, "step_size = -0.001 s must be > 0"),
                               ("stop_time", float("nan"), "stop_time = nan must be a finite number"),
                               ("stop_time", -1.0, "stop_time = -1.0 s after start_time = 0.0 s"),
                               ("stop_time", 6.0005, r"must be a whole number .* \(e.g. stop_time = 6 or 6.001 s"),
                               ("step_size", 1e-320, "more than the 1e\\+09 a run may take"),
                               ("steady_from", "2 s", "steady_from = '2 s' must be a finite number")):
        scenario = Scenario(Path(__file__).parents[1] / "scenarios" / "cardan_startup.toml")
        setattr(scenario, name, value)
        with pytest.raises(ScenarioError, match=words):
            run_scenario(scenario, fmu_dir, out_dir=None)
    scenario = Scenario(Path(__file__).parents[1] / "scenarios" / "cardan_startup.toml")
    scenario.steady_from = None   # unset, as 0: it had crashed after the run, comparing None with a time
    assert run_scenario(scenario, fmu_dir, out_dir=None, plot=False).passed


def test_numpy_numbers_from_a_sampling_loop_are_taken_as_the_numbers_they_hold():
    """A Monte Carlo loop hands over numpy scalars (np.int64, np.float32, np.bool_, 0-d arrays): they had been
    refused as "must be a number"; they are taken as the Python int, float or bool they hold, and still checked
    (a numpy number outside its range, or a float for a Boolean, is refused as a Python one is)."""
    import numpy as np
    scenario = Scenario(OMAR_START)
    changed = scenario.with_parameters({"driveline.k_theta": np.int64(90), "driveline.beta1": np.float32(0.2),
                                        "driveline.rigid_intermediate_shaft": np.bool_(False),
                                        "motor.omega_set": np.array(50.0)})
    values = changed.start_values("driveline")
    assert values["k_theta"] == 90 and type(values["k_theta"]) is int
    assert type(values["beta1"]) is float and values["rigid_intermediate_shaft"] is False
    assert changed.start_values("motor")["omega_set"] == 50.0
    with pytest.raises(ScenarioError, match="outside its allowed range"):
        scenario.with_parameters({"driveline.beta1": np.float64(2.0)})
    with pytest.raises(ScenarioError, match="rigid_intermediate_shaft"):
        scenario.with_parameters({"driveline.rigid_intermediate_shaft": np.float64(1.0)})


@pytest.mark.parametrize("section, old, new, meant", [
    ("output", 'record = ["j.tau_in"]', 'record = ["j.tau_in"]\nplot = ["j.tau_in"]\nsteady_form = 0.5',
     "steady_from"),
    ("experiment", "stop_time = 1.0", "stop_tme = 1.0", "stop_time"),
    ("reference", 'file = "r.csv"', 'fiel = "r.csv"', "file")])
def test_a_misspelt_field_is_named_with_the_field_meant_and_nothing_else_is_blamed_on_it(tmp_path, section, old,
                                                                                       new, meant):
    """A misspelt [output] field (steady_form, a fresh-eyes trial's) was named, and the plotted signals were then
    said not to be recorded, which they were: the field is named with the one it likely misspells, alone."""
    text = (GOOD + REF).replace(old, new)
    assert text != GOOD + REF
    with pytest.raises(ScenarioError) as error:
        Scenario(write(tmp_path, text))
    message = str(error.value)
    assert f"[{section}]: unknown field(s) {new.split(chr(10))[-1].split(' =')[0]} (did you mean {meant}?)" in message
    assert "problems" not in message and "not a recorded signal" not in message


@pytest.mark.parametrize("field, value", [("running_speed", '"j.tua_in"'), ("plot", '["j.tua_in"]')])
def test_a_misspelt_recorded_signal_is_named_with_the_one_meant(tmp_path, field, value):
    """`running_speed = "motor.omgea"` was told to add the misspelt name to output.record: a name close to a
    recorded signal is asked whether it means that one; a name close to none is told to record it."""
    text = GOOD.replace('record = ["j.tau_in"]', f'record = ["j.tau_in"]\n{field} = {value}')
    with pytest.raises(ScenarioError, match=r"'j.tua_in' is not a recorded signal \(did you mean 'j.tau_in'\?\)"):
        Scenario(write(tmp_path, text))
    with pytest.raises(ScenarioError, match="'j.M_x' is not a recorded signal: add it to output.record"):
        Scenario(write(tmp_path, text.replace("j.tua_in", "j.M_x")))


def test_a_run_shorter_than_its_generated_reference_says_how_much_of_it_was_compared(tmp_path, fmu_dir, capsys):
    """A CI trial's scenario with stop_time edited from 6 s to 0.003 s (3 steps) passed against its generated
    reference without a word: the verdict line says the share of the reference's run that was compared, for a file
    cut short (or a smoke test of the first second) and for a caller's shorter run of a read Scenario alike; a run
    over the whole reference says nothing of it."""
    from ujfmu.scenario_run import run_scenario
    text = (SCENARIOS / "cardan_startup.toml").read_text().replace("stop_time = 6.0", "stop_time = 0.003")
    (tmp_path / "references").mkdir()
    shutil.copy(SCENARIOS / "references" / "cardan_startup.csv", tmp_path / "references")
    (tmp_path / "cardan_startup.toml").write_text(text)
    short = run_scenario(tmp_path / "cardan_startup.toml", fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert short.checked and short.summary().splitlines()[0].endswith(
        "(compared to t = 0.003 s of the 6 s its reference was made for: 0.05% of it)")
    part = Scenario(SCENARIOS / "cardan_startup.toml")
    part.stop_time = 0.6
    passed = run_scenario(part, fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert passed.passed and passed.summary().splitlines()[0].endswith(
        "(check --strict fails it: only a part of its reference's run: compared to t = 0.6 s of the 6 s its "
        "reference was made for: 10% of it)")
    whole = Scenario(SCENARIOS / "cardan_constant_speed.toml")
    assert "its reference was made for" not in run_scenario(whole, fmu_dir=fmu_dir, out_dir=None, plot=False).summary()
    # a gate under --strict checks each scenario over its course: a trial's copy cut to 3% of its reference passed
    from ujfmu.cli import main
    (tmp_path / "cardan_startup.toml").write_text(text.replace("stop_time = 0.003", "stop_time = 0.6"))
    junit = tmp_path / "report.xml"
    assert main(["--fmu-dir", str(fmu_dir), "check", str(tmp_path / "cardan_startup.toml"), "--no-plot", "--out",
                 str(tmp_path / "out"), "--strict", "--junit", str(junit)]) == 1
    said = capsys.readouterr()
    assert "0 passed, 1 failed (--strict: 1 by comparing only a part of its reference's run)" in said.out
    assert ("--strict: 1 scenario(s) compare only a part of the run their reference was made for: cardan_startup: "
            "compared to t = 0.6 s") in said.err
    failure = ET.parse(junit).getroot().find("testcase").find("failure")
    assert failure.get("message") == ("compared to t = 0.6 s of the 6 s its reference was made for: 10% of it, "
                                      "not its whole course (--strict)")
    assert main(["--fmu-dir", str(fmu_dir), "check", str(tmp_path / "cardan_startup.toml"), "--no-plot", "--out",
                 str(tmp_path / "out")]) == 0   # without --strict: a smoke test, said on its verdict line


def test_a_load_behind_a_joint_whose_output_follows_its_input_chatters_on_the_drivers_inertia(fmu_dir):
    """A CardanJoint's output follows its input, so a Load on it acts on what drives the input: cardan_startup's PI
    Motor (J_rotor = 1 g.m2) with T0 = 0.5 N.m and omega_smooth = 1e-4 rad/s (a fresh-eyes trial's) moves it by
    T0 h / J = 0.5 rad/s a step, 5000x omega_smooth: it had been left unsaid before the run (the joint has no
    output inertia of its own), and the run's failure at t = 0 advised the torque-driven wiring. The advice names
    the rotor's inertia, and so does an explicit run's failure; the implicit scheme iterates the Motor's tau_load,
    so its run starts without chatter and follows the ramp (the PI loop, type 2, tracks a ramp under a constant
    load without error); an ideal speed source, whose speed no torque moves, is named by none; a torque-driven
    joint's load acts on its J_drive."""
    from ujfmu.master import CosimulationError
    from ujfmu.scenario_run import run_scenario
    start = Scenario(SCENARIOS / "cardan_startup.toml").with_parameters({"load.T0": 0.5, "load.omega_smooth": 1e-4})
    (chatter,) = start.load_chatter()
    # the rotor's speed under T0 held over h against the loop's Kp = 0.2 N.m.s/rad: T0 (1 - exp(-Kp h / J)) / Kp
    reach = 0.5 * (1.0 - math.exp(-0.2 * 1e-3 / 1e-3)) / 0.2
    assert (chatter.inertia, chatter.gain, chatter.ratio) == (1e-3, 0.2, pytest.approx(reach / 1e-4))
    assert chatter.iterated and start.coupling == "implicit"
    said = "moves joint's output, which follows its input, and with it motor's rotor inertia J_rotor, J = 0.001 kg.m2"
    assert not any(said in a for a in start.model_advice())
    # a load near the Motor's 5 N.m limit may hold the shaft stalled at rest, where the iterated steps still ring:
    # advised under the implicit scheme too (a review's T0 = 4.9 N.m)
    stall = Scenario(SCENARIOS / "cardan_startup.toml").with_parameters({"load.T0": 4.9, "load.omega_smooth": 1e-4})
    assert not stall.load_chatter()[0].iterated and any("J_rotor" in a for a in stall.model_advice())
    start.stop_time = 0.2
    result = run_scenario(start, fmu_dir, out_dir=None, plot=False)
    table = result.table
    assert min(table["motor.omega"]) > -1e-4 and min(table["joint.omega_out"]) > -1e-4   # no reversal at rest
    late = table["time"] >= 0.1   # past the breakaway: the loop follows its 30 rad/s^2 ramp, the load at T0
    assert np.max(np.abs(table["motor.omega"][late] / (30.0 * table["time"][late]) - 1.0)) < 0.02
    assert np.all(np.abs(table["load.tau"][late] - 0.5) < 0.01 * 0.5)
    for bond in result.bonds:   # power passes each coupling without a chatter's residual
        assert bond.residual_abs < 0.01 * bond.transmitted, bond
    start.coupling = "explicit"
    assert any(said in a for a in start.model_advice())
    with pytest.raises(CosimulationError) as failed:
        run_scenario(start, fmu_dir, out_dir=None, plot=False)
    assert said in str(failed.value) and f"Widen omega_smooth to at least {reach:.3g} rad/s" in str(failed.value)
    # the step that would do: where the loop's hold meets omega_smooth, -J/Kp ln(1 - Kp omega_smooth / T0)
    assert f"take a step of at most {-1e-3 / 0.2 * math.log(1.0 - 0.2 * 1e-4 / 0.5):.3g} s" in str(failed.value)
    assert start.with_parameters({"motor.ideal_speed_source": True}).load_chatter() == []
    heavy = Scenario(SCENARIOS / "cardan_heavy_torque_driven.toml").with_parameters({"load.omega_smooth": 1e-4})
    (driven,) = [c for c in heavy.load_chatter() if c.driven == "joint"]
    assert driven.inertia == 0.01 and driven.holder == "its driven input shaft's J_drive"
    # a twin rotor's load acts on disc 2 behind the secondary shaft, its lateral coupling eliminated
    runup = Scenario(SCENARIOS / "twin_jeffcott_runup.toml").with_parameters({"rotor.J_M2": 0.02})   # not disc 1's
    (disc,) = runup.load_chatter()
    q = runup.parameters_with_defaults("rotor")
    j2 = q["J_M2"] + q["m_u2"] * q["e"] ** 2 - (q["m_u2"] * q["e"]) ** 2 / (q["M2"] + q["m_u2"])
    assert disc.holder == "" and disc.inertia == pytest.approx(j2, rel=1e-12)


def test_a_scenario_read_from_a_relative_path_keeps_its_files_after_a_change_of_directory(tmp_path, monkeypatch):
    """A notebook reads a scenario by a relative path, then changes directory: the reference file it names is the
    one beside the file (it had been looked for relative to the new directory, and reported missing), and a change
    of the object after reading is still told from the file it was read from."""
    from ujfmu.references import read_reference
    repo = Path(__file__).resolve().parents[1]
    monkeypatch.chdir(repo)
    scenario = Scenario("scenarios/cardan_constant_speed.toml")
    monkeypatch.chdir(tmp_path)
    committed, _ = read_reference(repo / "scenarios" / "references" / "cardan_constant_speed.csv")
    table, _ = scenario.reference()
    assert np.array_equal(table["time"], committed["time"]) and str(scenario.path).startswith("scenarios")
    scenario.components["joint"][1]["bend_angle"] = 0.2
    with pytest.raises(ScenarioError, match=r"changed after it was read from scenarios.cardan_constant_speed"):
        scenario.reference()


def test_a_scripts_setup_slips_are_scenario_errors_before_anything_runs_and_numpy_numbers_work(fmu_dir, tmp_path):
    """What a notebook sets on a read Scenario: numpy's integers and a tuple of signals work as a file's int and
    list do (an np.int64 output interval had been refused as not whole, a tuple had raised a bare TypeError); a
    coupling not among the schemes, a running speed that is a torque, a stop time given as a string are
    ScenarioErrors naming the field before an FMU is loaded; a float32 step is shown at its full value, not as the
    round step it is refused for."""
    import ujfmu
    base = Scenario(SCENARIOS / "cardan_constant_speed.toml").with_stop_time(0.05)
    numpy_set = base.with_parameters({}, name="numpy_set")
    numpy_set.output_interval, numpy_set.record = np.int64(5), ("joint.omega_out", "motor.omega")
    result = ujfmu.run_scenario(numpy_set, fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert result.table["time"].tolist() == pytest.approx([0.005 * k for k in range(11)])
    assert list(result.table.dtype.names) == ["time", "joint.omega_out", "motor.omega"]
    missing = tmp_path / "no_fmus"   # refused before the FMUs are looked for
    wrong = base.with_parameters({})
    wrong.coupling = "Explicit"
    with pytest.raises(ScenarioError, match="coupling = 'Explicit' must be one of"):
        ujfmu.run_scenario(wrong, fmu_dir=missing, out_dir=None)
    torque = base.with_parameters({})
    torque.running_speed = "joint.tau_in"
    with pytest.raises(ScenarioError, match=r"running_speed = 'joint.tau_in' is in N.m, not rad/s: .*joint.omega_out"):
        ujfmu.run_scenario(torque, fmu_dir=missing, out_dir=None)
    with pytest.raises(ScenarioError, match=r"with_stop_time\('1.0'\): the stop time must be a finite number"):
        base.with_stop_time("1.0")
    assert base.with_stop_time(np.float64(0.04)).stop_time == 0.04
    single = base.with_parameters({})
    single.step_size = np.float32(1e-3)
    with pytest.raises(ScenarioError, match=r"step_size = 0.0010000000475 s \(.* such as 0.001 s\)"):
        ujfmu.run_scenario(single, fmu_dir=missing, out_dir=None)


def test_a_files_running_speed_must_be_a_speed(tmp_path):
    """output.running_speed names the shaft whose revolutions the orders count: a torque is refused on reading,
    naming the scenario's speeds."""
    text = (SCENARIOS / "twin_jeffcott_steady.toml").read_text()
    assert text.count('running_speed = "motor.omega"') == 2   # [output]'s, then [sweep]'s
    path = tmp_path / "torque_speed.toml"
    path.write_text(text.replace('running_speed = "motor.omega"', 'running_speed = "rotor.tau_in"', 1))
    with pytest.raises(ScenarioError, match=r"output.running_speed = 'rotor.tau_in' is in N.m, not rad/s: "
                       r".*speeds: motor.omega, motor.omega_ref, rotor.omega_out"):
        Scenario(path)


def test_the_speed_driven_wiring_on_a_torque_driven_fmu_names_the_wiring_it_needs(tmp_path):
    """A speed-driven scenario's FMU swapped for its torque-driven variant (a trial's): each wrong-way connection
    says which causality the variant has and how to wire it; the other way round, which variant takes tau_in."""
    text = (SCENARIOS / "double_cardan_omar_torsional.toml").read_text()
    path = tmp_path / "td.toml"
    path.write_text(text.replace('fmu = "DoubleCardanDriveline"', 'fmu = "DoubleCardanDrivelineTorqueDriven"'))
    with pytest.raises(ScenarioError) as err:
        Scenario(path)
    assert ("connections[0].to = 'driveline.omega_in' is an output, not an input (DoubleCardanDrivelineTorqueDriven "
            "is the torque-driven variant: tau_in is its input and omega_in its output; wire a MotorController's "
            "tau_motor to tau_in") in str(err.value)
    text = (SCENARIOS / "double_cardan_stiff_torque_driven.toml").read_text()
    path.write_text(text.replace('fmu = "DoubleCardanDrivelineTorqueDriven"', 'fmu = "DoubleCardanDriveline"'))
    with pytest.raises(ScenarioError) as err:
        Scenario(path)
    assert ("is an output, not an input (DoubleCardanDriveline is driven by speed: omega_in is its input and tau_in "
            "its output; DoubleCardanDrivelineTorqueDriven takes tau_in)") in str(err.value)
    # the PI Motor's rotor inertia looked for on the MotorController: where it lives in this wiring
    with pytest.raises(ScenarioError, match=r"MotorController has no parameter 'J_rotor' \(the motor's rotor inertia "
                       r"is the driven machine's: set J_drive of the torque-driven FMU it drives;"):
        Scenario(SCENARIOS / "double_cardan_stiff_torque_driven.toml").with_parameters({"motor.J_rotor": 0.5})


def test_a_scenario_and_its_result_say_what_they_are_in_a_notebook(fmu_dir):
    """A notebook's repr of a Scenario names it, its file and components (it had been the default object repr); a
    result gives each column's unit, and its table, which its figures read, is read-only (a copy is not); an axis of
    one bare number is refused with the list to give."""
    import ujfmu
    from ujfmu.sweep import Axis
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml")
    assert repr(scenario) == (f"<Scenario cardan_constant_speed from {SCENARIOS / 'cardan_constant_speed.toml'}: "
                              "motor (Motor), joint (CardanJoint), load (Load)>")
    result = ujfmu.run_scenario(scenario.with_stop_time(0.01), fmu_dir=fmu_dir, out_dir=None, plot=False)
    assert [result.unit(c) for c in ("time", "joint.omega_out", "joint.tau_in", "joint.phi_out")] == [
        "s", "rad/s", "N.m", "rad"]
    with pytest.raises(ValueError, match="read-only"):   # a script's rpm conversion in place had changed its figures
        result.table["joint.omega_out"] *= 30.0 / math.pi
    rpm = result.table.copy()
    rpm["joint.omega_out"] *= 30.0 / math.pi
    for one in (5, np.array(5)):   # a 0-d array too
        with pytest.raises(ValueError, match=r"takes a sequence of numbers, not .*5.*: give \[5\] for one point"):
            Axis.of("load.c1", one)
