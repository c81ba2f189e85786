"""Documentation: one bibliography (docs/references.md, generated), cited by key from the physics, the docs and
every FMU's documentation/index.html, which carries it with the step-size and logging guidance; nothing points at
files a user does not have."""

import re
import subprocess
import zipfile
from pathlib import Path

import pytest

from ujfmu.bibliography import BY_KEY, FMU_SOURCES, REFERENCES, markdown
from ujfmu.build import FMUS

REPO = Path(__file__).parents[1]


def test_references_md_is_the_generated_bibliography():
    assert (REPO / "docs" / "references.md").read_text() == markdown(), \
        ("regenerate: python -c \"from ujfmu.bibliography import markdown; print(markdown(), end='')\" > "
         "docs/references.md")
    for r in REFERENCES:
        assert r.authors and r.title and r.venue and 1900 < r.year < 2100


def tracked_text_files():
    names = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    for name in names:
        path = REPO / name
        if path.suffix in (".py", ".md", ".toml", ".txt", ".html", ".c", ".cfg") and path.is_file():
            yield name, path.read_text(errors="replace")


def test_nothing_points_at_the_authors_paper_folder():
    pattern = re.compile(r"\.\./shared|shared[/]papers|\bpaper 00\d|\b00\d_[0-9a-f]{16}\b")
    offenders = [name for name, text in tracked_text_files() if pattern.search(text) and name != "tests/test_docs.py"]
    assert offenders == []


def test_physics_and_model_docs_cite_existing_keys():
    cited = set()
    for folder, suffix in (("ujfmu/models", "*/model.py"), ("ujfmu/models", "*/README.md"), ("docs", "*.md")):
        for path in (REPO / folder).glob(suffix):
            keys = set(re.findall(r"\[([A-Z][a-z]+\d{4})\]", path.read_text()))
            assert keys <= set(BY_KEY), (path, keys - set(BY_KEY))
            cited |= keys
    assert cited == set(BY_KEY)   # every reference is used somewhere


@pytest.mark.parametrize("name", list(FMUS))
def test_fmu_documentation_carries_sources_bibliography_and_guidance(fmu_dir, name):
    with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as zf:
        page = zf.read("documentation/index.html").decode()
    for key in FMU_SOURCES[name]:
        assert f"[{key}] {BY_KEY[key].authors}" in page
    assert all(f"[{r.key}]" in page for r in REFERENCES) and "<h2>Bibliography</h2>" in page
    assert "Errors appear only with FMU logging enabled" in page and "<h2>Step size and stability</h2>" in page
    assert "../shared" not in page and "paper 00" not in page


@pytest.mark.parametrize("name, words", [("Motor", "Its rotor and PI speed controller are integrated together"),
                                         ("MotorController", "Its speed controller sees the speed"),
                                         ("Load", "T0 h / J above omega_smooth"),
                                         ("CardanJoint", "smaller than half of it for this FMU"),
                                         ("RingCoupling", "A drivetrain FMU driven by the speed")])
def test_each_fmus_stability_guidance_is_about_its_own_ports(fmu_dir, name, words):
    """The Motor's and Load's pages had carried the drivetrain FMUs' guidance on omega_in and tau_in, ports they
    do not have (a first-day trial); each page's guidance is its own kind's: the Motor's PI, integrated with its
    rotor inside each step, is not the MotorController's sampled one (a control engineer had read the latter's
    Kp h / J limit on the Motor's page)."""
    with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as zf:
        page = zf.read("documentation/index.html").decode()
    guidance = page.split("<h2>Step size and stability</h2>")[1].split("<h2>")[0]
    assert words in guidance
    assert ("<code>omega_in</code>" in guidance) == (name in ("CardanJoint", "RingCoupling"))
