"""Each FMU ships only its own model plus the shared FMI plumbing, and its build digest covers exactly that."""

import shutil
import zipfile

import pytest

from ujfmu.build import FMUS, PACKAGE_DIR
from ujfmu.fmu.base import runtime_files, sources_digest

STEMS = sorted({stem for stem, _ in FMUS.values()})


def shipped_runtime(path):
    """Paths of the FMU's runtime package relative to its root (resources/<package>/...)."""
    with zipfile.ZipFile(path) as zf:
        names = [n for n in zf.namelist() if n.startswith("resources/ujfmu_") and "/" in n[len("resources/"):]]
    return sorted(n.split("/", 2)[2] for n in names)


@pytest.mark.parametrize("name", list(FMUS))
def test_fmu_ships_its_own_model_and_the_plumbing_only(fmu_dir, name):
    stem = FMUS[name][0]
    shipped = shipped_runtime(fmu_dir / f"{name}.fmu")
    assert shipped == sorted(["__init__.py"] + runtime_files(stem))   # the package's own __init__: its name only
    assert f"models/{stem}/model.py" in shipped and f"models/{stem}/fmu.py" in shipped
    assert not [p for p in shipped if p.startswith("models/") and p.split("/")[1] not in (stem, "__init__.py",
                                                                                         "protocol.py")]
    assert not [p for p in shipped if p.endswith(("reference.py", ".toml", ".md"))]


def test_digest_covers_what_the_fmu_ships_and_nothing_else(tmp_path):
    """A change to one model's equations changes that model's digest only; a change to the plumbing changes all."""
    root = tmp_path / "ujfmu"
    shutil.copytree(PACKAGE_DIR / "fmu", root / "fmu", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(PACKAGE_DIR / "models", root / "models", ignore=shutil.ignore_patterns("__pycache__"))
    before = {stem: sources_digest(stem, root) for stem in STEMS}
    assert before == {stem: sources_digest(stem) for stem in STEMS}
    assert len(set(before.values())) == len(STEMS)
    for changed in STEMS:
        for extra in ("reference.py", "README.md"):   # not shipped: no digest changes
            if (root / "models" / changed / extra).exists():
                (root / "models" / changed / extra).write_text("changed\n")
        assert {stem: sources_digest(stem, root) for stem in STEMS} == before
        model = root / "models" / changed / "model.py"
        model.write_text(model.read_text() + "\n# changed\n")
        after = {stem: sources_digest(stem, root) for stem in STEMS}
        assert [stem for stem in STEMS if after[stem] != before[stem]] == [changed]
        before = after
    (root / "fmu" / "rk4.py").write_text((root / "fmu" / "rk4.py").read_text() + "\n# changed\n")
    assert all(sources_digest(stem, root) != before[stem] for stem in STEMS)


def test_a_rebuild_of_the_same_sources_gives_the_same_bytes(tmp_path, fmu_dir, fmu3_dir, monkeypatch):
    """FMUs had differed byte for byte between builds (pythonfmu's random guid and build time, the archive's file
    dates), so a CI cache or a checksum could not tell a changed FMU from a rebuilt one: a rebuild of the same
    sources is now the same file, FMI 2.0 and 3.0, its guid a function of the sources; SOURCE_DATE_EPOCH dates the
    archive's files."""
    from ujfmu.build import build_fmu
    from ujfmu.build3 import build_fmu3
    again, again3 = build_fmu("Load", tmp_path / "2"), build_fmu3("Load", tmp_path / "3")
    assert again.read_bytes() == (fmu_dir / "Load.fmu").read_bytes()
    assert again3.read_bytes() == (fmu3_dir / "Load.fmu").read_bytes()
    with zipfile.ZipFile(again) as archive:
        assert {i.date_time for i in archive.infolist()} == {(1980, 1, 1, 0, 0, 0)}
        described = archive.read("modelDescription.xml")
        assert b"generationDateAndTime" not in described and b'generationTool="ujfmu ' in described
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")   # 2026-01-01 00:00:00 UTC
    with zipfile.ZipFile(build_fmu("Load", tmp_path / "epoch")) as archive:
        assert {i.date_time for i in archive.infolist()} == {(2026, 1, 1, 0, 0, 0)}


def test_a_source_date_a_zip_cannot_hold_or_not_a_number_spoils_no_fmu(tmp_path, monkeypatch, capsys):
    """SOURCE_DATE_EPOCH past 2107 had crashed the build after it had emptied the FMU already there (a 22-byte zip):
    it is held at the last date a zip holds, the archive is written beside the FMU and moved over it, and a value
    that is no whole number is refused before anything is built."""
    from ujfmu.build import ZIP_DATES, build_fmu
    from ujfmu.cli import main
    good = build_fmu("Load", tmp_path)
    for far in ("4400000000", "10" * 9):   # 2109, and past the years a clock can hold
        monkeypatch.setenv("SOURCE_DATE_EPOCH", far)
        with zipfile.ZipFile(build_fmu("Load", tmp_path)) as archive:
            assert {i.date_time for i in archive.infolist()} == {ZIP_DATES[1]}
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "abc")
    before = good.read_bytes()
    assert main(["--fmu-dir", str(tmp_path), "build", "Load"]) == 2
    assert "SOURCE_DATE_EPOCH = 'abc' must be a whole number" in capsys.readouterr().err
    assert good.read_bytes() == before and not list(tmp_path.glob("*.partial"))
