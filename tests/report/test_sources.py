"""The inputs of the report: TRLC requirement files and their checks, source markers, JUnit XML and
cmocka reports turned into records, and the static existence of every cited item."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from urb_report import history, junit, markers, requirements
from urb_report.records import ROOT, RecordError, read_record
from report_fixtures import baseline, catalogue, real_markers, state, write_records  # noqa: F401  (pytest fixtures)

REQS = ROOT / "spec" / "requirements"


def test_requirements_cover_every_category_with_unique_stable_ids(catalogue: requirements.Catalogue) -> None:
    tags = [r.tag for r in catalogue.requirements]
    assert len(tags) == len(set(tags)) >= 80
    assert all(re.fullmatch(r"urb\.[A-Z]+_\d{3}", t) for t in tags)
    assert {r.category for r in catalogue.requirements} == set(catalogue.categories)
    assert len(catalogue.categories) >= 13
    for r in catalogue.requirements:
        assert r.statement and r.rationale and r.source and r.methods and r.verified_by and r.version >= 1


@pytest.mark.parametrize("field,bad,message", [
    ("statement", "It waits. Then it stops for a while.", "one statement per requirement"),
    ("verified_by", '["tla:Bridge.NoSilentDrop", "unknown-kind:x"]', "known kind"),
    ("source", '"the paper somewhere"', "names its section, figure or table"),
])
def test_trlc_rejects_a_malformed_requirement(field: str, bad: str, message: str, tmp_path: Path) -> None:
    d = tmp_path / "requirements"
    shutil.copytree(REQS, d)
    f = d / "ordering.trlc"
    text = f.read_text()
    block = text[text.index("Requirement ORD_001"):]
    if field == "statement":
        new = block.replace(block[block.index("statement = '''"):block.index("'''", block.index("statement = '''") + 15) + 3],
                            f"statement = '''{bad}'''", 1)
    else:
        start = block.index(f"  {field} = ")
        end = block.index("\n", start) if field != "verified_by" else block.index("]", start) + 1
        new = block[:start] + f"  {field} = {bad}" + block[end:]
    f.write_text(text.replace(block, new))
    with pytest.raises(requirements.RequirementsError, match=message):
        requirements.load(d)


def test_a_model_checked_requirement_must_cite_its_mutant(tmp_path: Path) -> None:
    d = tmp_path / "requirements"
    shutil.copytree(REQS, d)
    f = d / "ordering.trlc"
    f.write_text(f.read_text().replace('"tlc-mutant:Bridge_WedgeAfterBusStuck"', '"tlc:MCBridge"'))
    with pytest.raises(requirements.RequirementsError, match="must-fail mutant"):
        requirements.load(d)


def test_a_changed_criterion_needs_a_version_step_a_history_entry_and_a_new_baseline(
        catalogue: requirements.Catalogue, tmp_path: Path) -> None:
    d = tmp_path / "requirements"
    shutil.copytree(REQS, d)
    baseline = tmp_path / "baseline.json"
    shutil.copy(REQS / "baseline.json", baseline)  # the committed one (LAT_003 is at version 2 there)
    assert history.update(catalogue, baseline) == []
    lat = d / "latency.trlc"
    old = "max <= 2.0 ms; mean linear"
    lat.write_text(lat.read_text().replace(old, "max <= 2.2 ms; mean linear"))
    cat = requirements.load(d)
    found = history.check(cat, history.read_baseline(baseline))
    assert [(f.requirement, "without a version step" in f.message) for f in found] == [("urb.LAT_004", True)]
    text = lat.read_text()
    i = text.index("Requirement LAT_004")
    lat.write_text(text[:i] + text[i:].replace("version = 1", "version = 2", 1))
    found = history.check(requirements.load(d), history.read_baseline(baseline))
    assert "without a Change" in found[0].message
    assert history.update(requirements.load(d), baseline), "an unexplained change must not be accepted"
    r_old = catalogue.by_tag()["urb.LAT_004"]
    r_new = requirements.load(d).by_tag()["urb.LAT_004"]
    (d / "history.trlc").write_text(
        "package urb\n\nChange LAT_004_v2 {\n  requirement = LAT_004\n  from_version = 1\n  to_version = 2\n"
        f"  old_text = {json.dumps(r_old.text)}\n  new_text = {json.dumps(r_new.text)}\n"
        '  reason = "the simulated UART start bit jitter was measured"\n  date = "2026-12-01"\n}\n')
    cat = requirements.load(d)
    assert [c.requirement for c in cat.changes] == ["urb.LAT_004"]
    assert "baseline.json is not updated" in history.check(cat, history.read_baseline(baseline))[0].message
    assert history.update(cat, baseline) == []
    assert history.check(cat, history.read_baseline(baseline)) == []


def test_the_committed_baseline_matches_the_requirements(catalogue: requirements.Catalogue) -> None:
    assert history.check(catalogue, history.read_baseline()) == [], "run `urb report --update-baseline`"


def test_markers_belong_to_the_item_they_stand_above_or_in() -> None:
    py = ("import pytest\n\n# lobster-trace: urb.A_001\n@pytest.mark.slow\ndef test_one():\n    pass\n\n"
          "class TestX:\n    # lobster-trace: urb.B_001, urb.C_001\n    def test_two(self):\n        pass\n"
          "x = 'lobster-trace: urb.NOT_001'\n")
    ms = markers.scan_text("tests/host/test_demo.py", py)
    assert [(m.item, m.evidence, m.requirements) for m in ms] == [
        ("test_one", "pytest:tests/host/test_demo.py::test_one", ("urb.A_001",)),
        ("TestX::test_two", "pytest:tests/host/test_demo.py::TestX::test_two", ("urb.B_001", "urb.C_001"))]
    c = ("/* lobster-trace: urb.A_001 */\nstatic void alpha(void **state)\n{\n}\n"
         "static void beta(void **state)\n{\n    /* lobster-trace: urb.B_001 */\n}\n"
         'int run(void) { return cmocka_run_group_tests_name("grp", t, NULL, NULL); }\n')
    assert [(m.item, m.evidence) for m in markers.scan_text("tests/firmware/x/test_x.c", c)] == [
        ("alpha", "cmocka:grp/alpha"), ("beta", "cmocka:grp/beta")]
    tla = "---- MODULE M ----\n(* doc *)\n\\* lobster-trace: urb.A_001\nInv == TRUE\n====\n"
    assert [m.evidence for m in markers.scan_text("spec/tla/M.tla", tla)] == ["tla:M.Inv"]
    impl = "# lobster-trace: urb.A_001\ndef f():\n    pass\n"
    (m,) = markers.scan_text("host/urb/x.py", impl)
    assert m.item == "f" and not m.is_activity


def test_the_repository_markers_name_existing_requirements(catalogue: requirements.Catalogue,
                                                          real_markers: list[markers.Marker]) -> None:
    tags = {r.tag for r in catalogue.requirements}
    assert real_markers and all(t in tags for m in real_markers for t in m.requirements)
    assert any(not m.is_activity for m in real_markers), "implementation markers in code"
    assert {m.language for m in real_markers} == {"C", "Python", "TLA+"}


def _pytest_functions(path: Path) -> set[str]:
    return set(re.findall(r"^\s*(?:async\s+)?def (test_\w+)\(", path.read_text(), re.M))


def test_every_cited_item_exists_in_the_sources(catalogue: requirements.Catalogue) -> None:
    """A renamed test, proof folder, mutant, WP function or fuzz target shows here before any record
    does (simulation criteria are named at run time: the gate checks those)."""
    groups = junit.cmocka_group_sources()
    manifest = json.loads((ROOT / "spec/tla/manifest.json").read_text())
    tlc = {m["name"] for m in manifest["models"] + manifest["mutants"]}
    fuzz_mutants = {(m["target"], m["name"]) for m in json.loads((ROOT / "tests/fuzz/mutants.json").read_text())}
    missing = []
    for r in catalogue.requirements:
        for e in r.verified_by:
            kind, _, name = e.partition(":")
            ok = True
            if kind == "pytest":
                file, _, test = name.partition("::")
                ok = (ROOT / file).is_file() and test.split("[")[0].split("::")[-1] in _pytest_functions(ROOT / file)
            elif kind == "cmocka":
                group, _, test = name.partition("/")
                ok = group in groups and f"void {test}(" in (ROOT / groups[group]).read_text()
            elif kind in ("tlc", "tlc-mutant"):
                ok = name in tlc
            elif kind == "tla":
                module, _, op = name.partition(".")
                ok = re.search(rf"^{op}\b.*==", (ROOT / f"spec/tla/{module}.tla").read_text(), re.M) is not None
            elif kind == "bmc":
                ok = (ROOT / "proofs/bmc" / name / "harness.c").is_file()
            elif kind == "bmc-mutant":
                folder, _, mutant = name.partition("/")
                ok = mutant in {m["name"] for m in json.loads((ROOT / "proofs/bmc" / folder / "mutants.json").read_text())}
            elif kind == "wp":
                unit, _, fn = name.partition("/")
                ok = fn in json.loads((ROOT / "proofs/framac" / unit / "expected.json").read_text())["functions"]
            elif kind == "eva":
                ok = (ROOT / "proofs/framac" / name / "expected.json").is_file()
            elif kind == "fuzz":
                ok = (ROOT / "tests/fuzz" / f"{name}.c").is_file()
            elif kind == "fuzz-mutant":
                ok = tuple(name.split("/", 1)) in fuzz_mutants
            elif kind == "sim":
                ok = name.split("/")[0] in {"fig15", "fig16", "table1", "fig18_19", "fig20", "bandwidth", "faults",
                                            "traces"}
            if not ok:
                missing.append(f"{r.tag}: {e}")
    assert not missing, missing


def test_pytest_junit_becomes_items_named_by_node_id(tmp_path: Path) -> None:
    xml = tmp_path / "j.xml"
    xml.write_text(
        '<testsuites><testsuite name="pytest">'
        '<testcase classname="tests.host.test_a" name="test_x[gcc]" file="tests/host/test_a.py" line="9" time="0.5"/>'
        '<testcase classname="tests.host.test_a.TestK" name="test_y" file="tests/host/test_a.py" line="20" time="0">'
        '<failure message="assert 1 == 2">trace</failure></testcase>'
        '<testcase classname="tests.host.test_a" name="test_z" file="tests/host/test_a.py" line="30">'
        '<skipped message="no java"/></testcase></testsuite></testsuites>')
    items = junit.pytest_items(junit.pytest_cases(xml))
    assert [(i.id, i.verdict) for i in items] == [
        ("pytest:tests/host/test_a.py::test_x[gcc]", "pass"), ("pytest:tests/host/test_a.py::TestK::test_y", "fail"),
        ("pytest:tests/host/test_a.py::test_z", "error")]
    assert items[0].source == "tests/host/test_a.py:10" and items[1].measured == "assert 1 == 2"
    assert items[2].measured.startswith("skipped")
    stateful = tmp_path / "s.xml"
    stateful.write_text('<testsuite><testcase classname="tests.host.test_protocol_ref.TestHostCoreVsBridgeTla" '
                        'name="runTest" file=".venv/lib/python3.11/site-packages/hypothesis/stateful.py" line="3"/>'
                        '<testcase classname="tests.host.test_protocol_ref.TestBridgeModelVsBridgeTla" name="runTest" '
                        'file=".venv/lib/python3.11/site-packages/hypothesis/stateful.py" line="3"/></testsuite>')
    assert [i.id for i in junit.pytest_items(junit.pytest_cases(stateful))] == [
        "pytest:tests/host/test_protocol_ref.py::TestHostCoreVsBridgeTla::runTest",
        "pytest:tests/host/test_protocol_ref.py::TestBridgeModelVsBridgeTla::runTest"]
    (tmp_path / "bad.xml").write_text("<html/>")
    with pytest.raises(RecordError, match="not JUnit"):
        junit.pytest_cases(tmp_path / "bad.xml")


def test_cmocka_results_of_both_compilers_are_merged_and_a_failure_under_one_fails(tmp_path: Path) -> None:
    (tmp_path / "clang.xml").write_text(
        '<testsuites><testsuite name="node_x" tests="2"><testcase name="a" time="0.001"></testcase>'
        '<testcase name="b" time="0"></testcase></testsuite></testsuites>')
    (tmp_path / "gcc.log").write_text(
        "[==========] Running 2 test(s).\n[ RUN      ] a\n[       OK ] a\n[ RUN      ] b\n[  FAILED  ] b\n"
        "[==========] 2 test(s) run.\n[  PASSED  ] 1 test(s).\n[  FAILED  ] 1 test(s), listed below:\n[  FAILED  ] b\n")
    cases, compilers = junit.cmocka_cases([("clang:prog", tmp_path / "clang.xml")], [("gcc:prog", tmp_path / "gcc.log")])
    items = {i.id: i for i in junit.cmocka_items(cases, compilers, {}, "make x")}
    assert items["cmocka:node_x/a"].verdict == "pass" and items["cmocka:node_x/a"].data["compilers"] == ["clang", "gcc"]
    assert items["cmocka:node_x/b"].verdict == "fail" and "gcc" in items["cmocka:node_x/b"].measured
    (tmp_path / "short.log").write_text("[==========] Running 1 test(s).\n[ RUN      ] a\n[       OK ] a\n")
    with pytest.raises(RecordError, match="the two builds differ"):
        junit.cmocka_cases([("clang:prog", tmp_path / "clang.xml")], [("gcc:prog", tmp_path / "short.log")])


def test_the_command_line_writes_a_record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    xml = tmp_path / "j.xml"
    xml.write_text('<testsuite><testcase classname="tests.t" name="test_a" file="tests/t.py" line="1"/></testsuite>')
    monkeypatch.setattr(junit, "write_record", lambda *a, **k: _write(tmp_path, *a, **k))
    assert junit.main(["pytest", str(xml), "--name", "pytest-x", "--seed", "5"]) == 0
    rec = read_record(tmp_path / "pytest-x.json")
    assert rec.activity == "pytest" and rec.provenance["seed"] == "5" and rec.items[0].id == "pytest:tests/t.py::test_a"
    (tmp_path / "empty.xml").write_text("<testsuite/>")
    assert junit.main(["pytest", str(tmp_path / "empty.xml")]) == 2


def _write(out: Path, *args: object, **kwargs: object) -> Path:
    from urb_report.records import write_record

    return write_record(*args, **{**kwargs, "out_dir": out})  # type: ignore[arg-type]
