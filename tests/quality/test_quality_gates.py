"""The three quality gates end to end on seeded code: each real tool chain must report the seeded
problem, the gate must fail while nothing explains it, pass once a justification or deviation does,
and fail again when an entry goes stale.

  coverage  gcc --coverage + gcovr and clang-19 -fcoverage-mcdc + llvm-cov (tools/coverage.py):
            an untaken branch, a line never run, an MC/DC condition without an independence pair,
            a decision clang 19 cannot measure
  misra     cppcheck's MISRA addon (tools/misra.py): a seeded violation of rule 15.5 and 17.8
  static    clang-tidy 19 and gcc -fanalyzer (tools/static_analysis.py): a seeded null dereference
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

COVERAGE: ModuleType = load_module("urb_tools_coverage", Path("tools/coverage.py"))
MISRA: ModuleType = load_module("urb_tools_misra", Path("tools/misra.py"))
STATIC: ModuleType = load_module("urb_tools_static_analysis", Path("tools/static_analysis.py"))

SEEDED_C = """\
#include <stdbool.h>

int classify(int x)
{
    if (x > 10) {
        return 1;
    }
    return 0;
}

int both(int a, int b)
{
    if ((a != 0) && (b != 0)) {
        return 1;
    }
    return 0;
}

static bool id(bool v)
{
    return v;
}

int nested(int a, int b, int c)
{
    return (a && id(b || c)) ? 1 : 0;
}
"""

MAIN_C = """\
int classify(int x);
int both(int a, int b);
int nested(int a, int b, int c);

int main(void)
{
    int sum = classify(1) + both(1, 1) + both(0, 1);
    for (int k = 0; k < 8; k++) {
        sum += nested(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    }
    return sum == 4 ? 0 : 1;
}
"""

SCOPE = '[scope]\nfiles = ["src/*.c"]\n'
CLANG_FLAGS = "-O0 -g -fprofile-instr-generate -fcoverage-mapping -fcoverage-mcdc"


def _need(*tools: str) -> None:
    missing = [t for t in tools if shutil.which(t) is None]
    if missing:
        pytest.fail(f"missing {', '.join(missing)}: run `make setup` (tools/setup.sh installs them)")


def _record(directory: Path, name: str) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((directory / f"{name}.json").read_text())
    return data


def _items(record: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {i["id"]: i for i in record["items"]}


@pytest.fixture(scope="module")
def coverage_project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The seeded project, built with both instrumentations; its programs have run once."""
    _need("gcc", "clang-19", "llvm-cov-19", "llvm-profdata-19")
    root = tmp_path_factory.mktemp("cov")
    (root / "src").mkdir()
    (root / "src" / "seeded.c").write_text(SEEDED_C)
    (root / "main.c").write_text(MAIN_C)
    for cc, sub, flags in (("gcc", "gcc", "-O0 -g --coverage"), ("clang-19", "clang", CLANG_FLAGS)):
        out = root / "build" / sub
        out.mkdir(parents=True)
        for src in ("src/seeded.c", "main.c"):
            subprocess.run([cc, "-std=c99", *flags.split(), "-c", src, "-o", str(out / (Path(src).stem + ".o"))],
                           cwd=root, check=True, capture_output=True)
        subprocess.run([cc, *flags.split(), str(out / "seeded.o"), str(out / "main.o"), "-o", str(out / "t")],
                       cwd=root, check=True, capture_output=True)
    (root / "just.toml").write_text(SCOPE)
    rc = COVERAGE.main(["--root", str(root), "--build", "build", "--justifications", "just.toml",
                        "--run", "build/gcc/t build/clang/t", "--llvm-objects", "build/clang/t",
                        f"--clang-flags={CLANG_FLAGS}", "--clang-cflags=-std=c99", "--evidence", str(root / "ev")])
    assert rc == 1, "the seeded gaps must fail the coverage gate"
    return root


def _coverage(root: Path, justifications: str) -> tuple[int, dict[str, dict[str, Any]]]:
    (root / "just.toml").write_text(SCOPE + justifications)
    rc = COVERAGE.main(["--root", str(root), "--build", "build", "--justifications", "just.toml", "--no-run",
                        "--llvm-objects", "build/clang/t", f"--clang-flags={CLANG_FLAGS}", "--clang-cflags=-std=c99",
                        "--evidence", str(root / "ev")])
    return rc, _items(_record(root / "ev", "coverage"))


JUSTIFIED = """
[[justification]]
id = "classify-large"
files = ["src/seeded.c"]
function = "classify"
anchors = ["if (x > 10) {", "return 1;"]
reason = "a seeded gap: the large-input path is left to another test"

[[justification]]
id = "both-second-condition"
files = ["src/seeded.c"]
function = "both"
kinds = ["mcdc", "branch"]
anchors = ["if ((a != 0) && (b != 0)) {"]
reason = "a seeded gap: no vector shows that b alone decides (b is never false)"

[[justification]]
id = "nested-decision"
files = ["src/seeded.c"]
function = "nested"
kinds = ["mcdc-unmeasured"]
reason = "a seeded nested decision: gcc's branch counts cover each of its conditions"
"""


def test_coverage_reports_each_seeded_gap_and_fails_without_justification(coverage_project: Path) -> None:
    rc, items = _coverage(coverage_project, "")
    assert rc == 1
    item = items["coverage:src/seeded.c"]
    assert item["verdict"] == "fail"
    assert item["data"]["unjustified_counts"] == {"line": 1, "branch": 2, "mcdc": 1, "mcdc-unmeasured": 1}
    text = "\n".join(item["data"]["unjustified"])
    assert "src/seeded.c:5: branch (1 of 2 branch outcomes never taken) in classify()" in text
    assert "src/seeded.c:6: line (never executed) in classify(): return 1;" in text
    assert "src/seeded.c:13: branch (1 of 4 branch outcomes never taken) in both()" in text
    assert "mcdc (no independence pair for C2 `(b != 0)` of 2 conditions) in both()" in text
    assert "mcdc-unmeasured" in text and "in nested()" in text
    # the witness that the measurement reached the code: everything else is counted as covered
    assert item["data"]["lines"]["covered"] > 0 and item["data"]["mcdc_conditions"]["covered"] >= 1


def test_coverage_passes_when_every_gap_is_justified_and_fails_on_a_stale_one(coverage_project: Path) -> None:
    rc, items = _coverage(coverage_project, JUSTIFIED)
    assert rc == 0, items
    assert items["coverage:src/seeded.c"]["verdict"] == "pass"
    assert items["coverage-justification:classify-large"]["verdict"] == "pass"
    stale = JUSTIFIED + """
[[justification]]
id = "covered-already"
files = ["src/seeded.c"]
function = "both"
anchors = ["return 0;"]
reason = "this line is covered, so the justification must be reported as stale"
"""
    rc, items = _coverage(coverage_project, stale)
    assert rc == 1
    assert items["coverage-justification:covered-already"]["verdict"] == "fail"
    assert items["coverage:src/seeded.c"]["verdict"] == "pass"


def test_a_source_in_scope_that_no_test_runs_is_an_error(coverage_project: Path) -> None:
    (coverage_project / "src" / "orphan.c").write_text("int orphan(void) { return 0; }\n")
    try:
        rc, _ = _coverage(coverage_project, JUSTIFIED)
        assert rc == 2
        rc, _ = _coverage(coverage_project, JUSTIFIED + '[[excluded]]\nfiles = ["src/orphan.c"]\n'
                          'reason = "an orphan source kept out of the seeded build on purpose"\n')
        assert rc == 0
    finally:
        (coverage_project / "src" / "orphan.c").unlink()


MISRA_C = """\
#include <stdint.h>

int32_t pick(int32_t a, int32_t b);

int32_t pick(int32_t a, int32_t b)
{
    if (a > b) {
        b = a;
        return b;
    }
    return b;
}
"""


def _misra(root: Path, deviations: str) -> tuple[int, dict[str, dict[str, Any]]]:
    (root / "dev.toml").write_text(deviations)
    rc = MISRA.main(["--root", str(root), "--sources", "src/m.c", "--cppcheck-args=--std=c99",
                     "--deviations", "dev.toml", "--build", "build/misra", "--evidence", str(root / "ev")])
    return rc, (_items(_record(root / "ev", "misra")) if rc != 2 else {})


def _deviation(ident: str, rule: str, category: str, status: str) -> str:
    return (f'[[deviation]]\nid = "{ident}"\nrule = "{rule}"\ncategory = "{category}"\nsummary = "a rule"\n'
            f'status = "{status}"\nfiles = ["src/*.c"]\nreason = "a seeded violation kept to test the gate"\n')


def test_misra_fails_on_a_seeded_violation_until_it_is_deviated(tmp_path: Path) -> None:
    assert Path(MISRA.cppcheck_command()).name == "cppcheck"
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "m.c").write_text(MISRA_C)
    rc, items = _misra(tmp_path, "")
    assert rc == 1
    assert items["misra:15.5@src/m.c:9"]["verdict"] == "fail"
    assert items["misra:17.8@src/m.c:8"]["verdict"] == "fail"
    rules = sorted({i.split(":")[1].split("@")[0] for i in items})
    deviations = "".join(_deviation(f"r{r.replace('.', '-')}", r, "advisory", "deviation") for r in rules)
    rc, items = _misra(tmp_path, deviations)
    assert rc == 0 and all(i["verdict"] == "pass" for i in items.values())
    rc, items = _misra(tmp_path, deviations + _deviation("stale", "2.7", "advisory", "deviation"))
    assert rc == 1 and items["misra-deviation:stale"]["verdict"] == "fail"


@pytest.mark.parametrize("category, status", [("mandatory", "deviation"), ("required", "disapplied")])
def test_misra_refuses_what_misra_compliance_forbids(tmp_path: Path, category: str, status: str) -> None:
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "m.c").write_text(MISRA_C)
    rc, _ = _misra(tmp_path, _deviation("x", "15.5", category, status))
    assert rc == 2


STATIC_C = """\
#include <stddef.h>

int deref(int flag);

int deref(int flag)
{
    int *p = NULL;
    if (flag != 0) {
        return *p;
    }
    return 0;
}
"""

def _static(root: Path, deviations: str) -> tuple[int, dict[str, dict[str, Any]]]:
    (root / "dev.toml").write_text(deviations)
    rc = STATIC.main(["--root", str(root), "--sources", "src/s.c", "--tidy", "clang-tidy-19", "--tidy-cflags=-std=c99",
                      "--gcc", "gcc", "--gcc-cflags=-std=c99 -O0", "--deviations", "dev.toml",
                      "--evidence", str(root / "ev")])
    return rc, _items(_record(root / "ev", "static"))


def test_static_analysis_fails_on_a_seeded_null_dereference_until_it_is_deviated(tmp_path: Path) -> None:
    _need("clang-tidy-19", "gcc")
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "s.c").write_text(STATIC_C)
    rc, items = _static(tmp_path, "")
    assert rc == 1
    assert items["static:clang-tidy/clang-analyzer-core.NullDereference@src/s.c:9"]["verdict"] == "fail"
    assert items["static:gcc-analyzer/Wanalyzer-null-dereference@src/s.c:9"]["verdict"] == "fail"
    deviation = ('[[deviation]]\nid = "seeded"\nrule = ["clang-tidy/clang-analyzer-core.NullDereference",'
                 ' "gcc-analyzer/Wanalyzer-null-dereference"]\nfiles = ["src/s.c"]\nanchors = ["return *p;"]\n'
                 'reason = "a seeded null dereference kept to test the gate"\n')
    rc, items = _static(tmp_path, deviation)
    assert rc == 0 and all(i["verdict"] == "pass" for i in items.values())
    (tmp_path / "src" / "s.c").write_text(STATIC_C.replace("return *p;", "return -1;"))
    rc, items = _static(tmp_path, deviation)
    assert rc == 1 and items["static-deviation:seeded"]["verdict"] == "fail"
