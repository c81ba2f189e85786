"""What ujfmu takes from outside and acts on (docs/security.md): scenario files cannot make `ujfmu references`
write outside the scenario's folder; sweep names cannot leave the output folder; a damaged or
forged sweep journal is skipped line by line, never run or crashed on; FMU archives with escaping entries extract
inside their folder; SSP packages hold only the SSD and known FMUs; dask clients get the dask config's TLS
settings and refuse an unencrypted scheduler when encryption is required."""

import json
import tempfile
import uuid
import zipfile
from pathlib import Path

import pytest

from ujfmu import sweep as sweep_module
from ujfmu.cli import main
from ujfmu.scenario import Scenario, ScenarioError
from ujfmu.sweep import Sweep, SweepSettings, parse_axis

SCENARIOS = Path(__file__).parents[1] / "scenarios"

SCENARIO = """
[experiment]
stop_time = 0.01
step_size = 1e-3
[components.motor]
fmu = "Motor"
[components.load]
fmu = "Load"
[[connections]]
from = "motor.omega"
to = "load.omega"
[[connections]]
from = "load.tau"
to = "motor.tau_load"
[output]
record = ["motor.omega"]
[reference]
file = "{file}"
generator = "cardan_joint"
[reference.tolerance]
"motor.omega" = {{ rel_range = 0.01 }}
"""


def scenario_file(folder, file):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "s.toml"
    path.write_text(SCENARIO.format(file=file))
    return path


@pytest.mark.parametrize("file", ["../outside.csv", "references/../../outside.csv", "/tmp/outside.csv"])
def test_references_are_never_written_outside_the_scenario_folder(tmp_path, file, capsys):
    path = scenario_file(tmp_path / "scenarios", file)
    with pytest.raises(ScenarioError, match="outside the scenario's folder"):
        Scenario(path).reference_output()
    assert main(["references", str(path)]) == 2          # the command says why and writes nothing
    assert "writes only inside it" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["s.toml", "scenarios"]
    assert not Path(file).is_absolute() or not Path(file).exists()


@pytest.mark.parametrize("file", ["references/x.py", ".", 3])
def test_reference_files_must_be_csv_paths(tmp_path, file):
    path = scenario_file(tmp_path, "x.csv")
    path.write_text(path.read_text().replace('"x.csv"', repr(file) if isinstance(file, int) else f'"{file}"'))
    with pytest.raises(ScenarioError, match="must be the path of a .csv file"):
        Scenario(path)


def test_a_symlink_out_of_the_scenario_folder_is_refused(tmp_path):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    folder = tmp_path / "scenarios"
    folder.mkdir()
    (folder / "references").symlink_to(outside, target_is_directory=True)
    with pytest.raises(ScenarioError, match="outside the scenario's folder"):
        Scenario(scenario_file(folder, "references/x.csv")).reference_output()


def test_reference_files_inside_the_scenario_folder_are_written_there(tmp_path):
    scenario = Scenario(scenario_file(tmp_path / "scenarios", "references/deep/x.csv"))
    assert scenario.reference_output() == (tmp_path / "scenarios" / "references" / "deep" / "x.csv").resolve()


def test_tolerance_tables_take_only_their_two_numbers(tmp_path):
    path = scenario_file(tmp_path, "r.csv")
    path.write_text(path.read_text().replace("rel_range = 0.01", "rel_range = 0.01, __class__ = 1"))
    with pytest.raises(ScenarioError, match="must be { rel_range"):
        Scenario(path)


@pytest.fixture
def brutti_parts():
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=2)
    return scenario, [parse_axis("motor.omega_set=1000:2000:1000rpm", scenario)], settings


@pytest.mark.parametrize("name", ["../escaped", "a/b", "..", ".hidden", "x\\y", "nul\0"])
def test_sweep_names_cannot_leave_the_output_folder(brutti_parts, tmp_path, fmu_dir, name):
    scenario, axes, settings = brutti_parts
    with pytest.raises(ScenarioError, match="plain file name"):
        Sweep(scenario, axes, settings, out_dir=tmp_path / "out", name=name, fmu_dir=fmu_dir)
    assert not any(tmp_path.iterdir())


def test_cli_sweep_name_with_a_path_is_an_error(fmu_dir, tmp_path, capsys):
    code = main(["--fmu-dir", str(fmu_dir), "sweep", str(SCENARIOS / "double_cardan_brutti_rigid.toml"),
                 "--param", "motor.omega_set=1000rpm", "--running-speed", "motor.omega", "--settle", "0.01",
                 "--name", "../../escaped", "--out", str(tmp_path / "out"), "--workers", "0", "--no-plot",
                 "--no-progress"])
    assert code == 2 and "plain file name" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_damaged_and_forged_journal_lines_are_skipped(brutti_parts, tmp_path, fmu_dir):
    scenario, axes, settings = brutti_parts
    sweep = Sweep(scenario, axes, settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    good = {"point": sweep.points[0], "status": "ok", "error": "", "wall_s": 0.5, "config": sweep.config}
    bad = [[1, 2], "text", None, {"config": sweep.config}, {**good, "status": "pwned"}, {**good, "error": 3},
           {**good, "point": {"motor.omega_set": "__import__('os')"}}, {**good, "point": [1]},
           {**good, "wall_s": "0.5"}]
    lines = [json.dumps(b) for b in bad] + ['{"cut', json.dumps(good)]
    sweep.journal.write_bytes("\n".join(lines).encode() + b"\n\xff\xfe\x00garbage\n")
    assert list(sweep.done().values()) == [good]
    assert sweep.damaged == 8   # every line that is no record, or one that cannot be read as a point (said)
    assert [r["status"] for r in sweep.table()] == ["ok", "missing"]
    sweep.write_csv()                                   # the table of the good line and the missing point


def test_fmu_archive_entries_cannot_escape_the_extraction_folder(tmp_path):
    from ujfmu.master import extracted
    marker = f"ujfmu_escape_{uuid.uuid4().hex}.txt"
    evil = tmp_path / "Evil.fmu"
    with zipfile.ZipFile(evil, "w") as zf:
        zf.writestr(f"../../../../../../../../tmp/{marker}", "escaped")
        zf.writestr(f"../{marker}", "escaped")
    with pytest.raises(Exception):                      # no modelDescription.xml: not an FMU
        extracted(evil)
    assert not (Path(tempfile.gettempdir()) / marker).exists() and not (Path("/tmp") / marker).exists()
    assert not (tmp_path.parent / marker).exists()
    assert not list(Path(tempfile.gettempdir()).glob(f"ujfmu_fmu_*/**/{marker}"))   # the refused folder is removed


def test_ssp_packages_hold_only_the_ssd_and_known_fmus(fmu_dir, tmp_path):
    from ujfmu.ssp import export_ssp
    path = tmp_path / "s.toml"
    path.write_text('title = "</ssd:System><evil/>"\n' + SCENARIO.format(file="references/x.csv"))
    ssp = export_ssp(Scenario(path), tmp_path / "out", fmu_dir)
    with zipfile.ZipFile(ssp) as zf:
        assert sorted(zf.namelist()) == ["SystemStructure.ssd", "resources/Load.fmu", "resources/Motor.fmu"]
        ssd = zf.read("SystemStructure.ssd").decode()
    assert "<evil/>" not in ssd and "&lt;/ssd:System&gt;&lt;evil/&gt;" in ssd
    assert ssp.parent == tmp_path / "out"


TLS = {"distributed.comm.tls.ca-file": "/certs/ca.pem", "distributed.comm.tls.client.cert": "/certs/client.pem",
       "distributed.comm.tls.client.key": "/certs/client.key", "distributed.comm.require-encryption": True}


class Recorder:
    """Stands in for distributed.Client / LocalCluster: records how it was called."""

    calls = []

    def __init__(self, *args, **kwargs):
        Recorder.calls.append((type(self).__name__, args, kwargs))


class FakeClient(Recorder):
    pass


class FakeCluster(Recorder):
    pass


@pytest.fixture
def fake_dask(monkeypatch):
    import distributed
    Recorder.calls = []
    monkeypatch.setattr(distributed, "Client", FakeClient)
    monkeypatch.setattr(distributed, "LocalCluster", FakeCluster)
    return Recorder.calls


def test_dask_clients_get_the_tls_settings_of_the_dask_config(fake_dask):
    import dask
    with dask.config.set(TLS):
        sweep_module.dask_client(scheduler="tls://cluster.example:8786")
        sweep_module.dask_client(workers=2)
    (kind, args, kwargs), (cluster_kind, _, cluster_kwargs), _ = fake_dask
    assert kind == "FakeClient" and args == ("tls://cluster.example:8786",)
    security = kwargs["security"]
    assert (security.tls_ca_file, security.tls_client_cert, security.tls_client_key) == \
        ("/certs/ca.pem", "/certs/client.pem", "/certs/client.key")
    assert security.require_encryption
    assert cluster_kind == "FakeCluster" and cluster_kwargs["security"].require_encryption


def test_an_unencrypted_scheduler_is_refused_when_the_config_requires_encryption(fake_dask):
    import dask
    with dask.config.set(TLS):
        with pytest.raises(ScenarioError, match="tls://"):
            sweep_module.dask_client(scheduler="tcp://cluster.example:8786")
    assert fake_dask == []
    sweep_module.dask_client(scheduler="tcp://127.0.0.1:8786")       # without the setting: as dask does
    assert not fake_dask[0][2]["security"].require_encryption


def test_no_module_of_ujfmu_unpickles_or_evaluates():
    """The data ujfmu reads (scenarios, references, journals, FMU states) is parsed, never unpickled or
    evaluated: no pickle, marshal, eval or exec in the package (dask's own transport aside)."""
    root = Path(__file__).parents[1] / "ujfmu"
    for path in root.rglob("*.py"):
        text = path.read_text()
        for word in ("import pickle", "pickle.load", "marshal", "eval(", "exec(", "allow_pickle", "yaml.load",
                     "shell=True", "os.system"):
            assert word not in text, (path.relative_to(root), word)
