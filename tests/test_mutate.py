"""The mutant list of `ujfmu mutate` (mutants.toml): every mutant applies to the current code, the list covers the
physics, the FMU layer, the master, the scenario comparison and the reference generators, and a mutant run
restores the file it changed."""


from ujfmu.mutate import AREAS, DEFAULT_LIST, REPOSITORY, Mutant, area, load_mutants, run_mutant, score


def test_every_mutant_applies_exactly_once_and_names_its_tests():
    mutants = load_mutants(DEFAULT_LIST)
    for m in mutants:
        text = (REPOSITORY / m.file).read_text()
        assert text.count(m.find) == 1, (m.id, text.count(m.find))
        assert m.replace != m.find and (m.equivalent or m.tests), m.id
        for spec in m.tests:
            assert (REPOSITORY / spec.split("::")[0]).is_file(), (m.id, spec)
        for name in m.regenerate:
            assert (REPOSITORY / "scenarios" / f"{name}.toml").is_file(), (m.id, name)
    per_area = {a: sum(area(m) == a for m in mutants) for a in AREAS}
    assert min(per_area.values()) >= 5 and all(area(m) for m in mutants), per_area


def test_a_mutant_run_restores_the_file(tmp_path):
    (tmp_path / "tests").mkdir()
    (tmp_path / "mod.py").write_text("def sign(x):\n    return 1 if x > 0 else -1\n")
    (tmp_path / "tests" / "test_mod.py").write_text("from mod import sign\n\n\ndef test_sign():\n"
                                                     "    assert sign(0.5) == 1 and sign(-2) == -1\n")
    flip = Mutant("flip", "mod.py", "1 if x > 0 else -1", "-1 if x > 0 else 1", ["tests/test_mod.py"])
    noop = Mutant("noop", "mod.py", "x > 0", "x >= 0", ["tests/test_mod.py"])
    outcomes = [run_mutant(m, tmp_path, timeout=120, niceness=0) for m in (flip, noop)]
    assert [o.status for o in outcomes] == ["killed", "survived"], [o.detail for o in outcomes]
    assert "x > 0 else -1" in (tmp_path / "mod.py").read_text()
    assert score(["killed", "survived", "equivalent", "timeout"]) == (2, 3, 2 / 3)
    assert run_mutant(Mutant("gone", "mod.py", "nowhere", "x", ["t"]), tmp_path).status == "error"
