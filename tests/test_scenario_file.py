"""Scenario files: errors name the file and the field."""

import pytest

from ujfmu.scenario import Scenario, ScenarioError

GOOD = """
[experiment]
stop_time = 1.0
step_size = 1e-3
[components.j]
fmu = "CardanJoint"
[components.l]
fmu = "Load"
[[connections]]
from = "j.omega_out"
to = "l.omega"
[output]
record = ["j.tau_in"]
"""


def write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def test_good_file_loads(tmp_path):
    s = Scenario(write(tmp_path, GOOD))
    assert s.parameters_with_defaults("j")["J1"] == 2e-7 and len(s.time_grid()) == 1001


@pytest.mark.parametrize("old, new, field", [
    ('fmu = "Load"', 'fmu = "Loud"', "components.l.fmu"),
    ('to = "l.omega"', 'to = "l.omegaa"', "connections[0].to"),
    ('to = "l.omega"', 'to = "x.omega"', "unknown component"),
    ('from = "j.omega_out"', 'from = "j.omega_in"', "not an output"),
    ('step_size = 1e-3', 'step_size = "fast"', "experiment.step_size"),
    ('fmu = "CardanJoint"', 'fmu = "CardanJoint"\nparameters = { J3 = 1 }', "parameters.J3"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\norbits = [["j.tau_in"]]', "output.orbits[0]"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nspectra = ["j.M_x"]', "output.spectra"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nplot = ["j.phi_out"]', "output.plot"),
    ('record = ["j.tau_in"]', 'record = ["j.tau_in"]\nsteady_from = "late"', "output.steady_from"),
])
def test_bad_field_is_named(tmp_path, old, new, field):
    path = write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(ScenarioError) as err:
        Scenario(path)
    assert str(path) in str(err.value) and field in str(err.value)
