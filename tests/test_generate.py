"""Generation is deterministic, the committed output is fresh, and staleness is detected."""

from __future__ import annotations

import filecmp
import shutil
import subprocess
import sys
from pathlib import Path

from urb_codegen.generate import C_DIR, PY_DIR, check_fresh, generate, load_bundled


# lobster-trace: urb.PKT_007
def test_generation_is_deterministic(tmp_path: Path) -> None:
    schemas = load_bundled()
    first = generate(schemas, tmp_path / "a" / "c", tmp_path / "a" / "py")
    generate(load_bundled(), tmp_path / "b" / "c", tmp_path / "b" / "py")
    for path in first:
        twin = tmp_path / "b" / path.relative_to(tmp_path / "a")
        assert filecmp.cmp(path, twin, shallow=False), path


# lobster-trace: urb.PKT_007
def test_committed_output_is_fresh() -> None:
    result = check_fresh(load_bundled())
    assert result.fresh, result


# lobster-trace: urb.PKT_007
def test_staleness_is_detected(tmp_path: Path) -> None:
    c_dir, py_dir = tmp_path / "c", tmp_path / "py"
    shutil.copytree(C_DIR, c_dir)
    shutil.copytree(PY_DIR, py_dir, ignore=shutil.ignore_patterns("__pycache__"))
    schemas = load_bundled()
    assert check_fresh(schemas, c_dir, py_dir).fresh
    (c_dir / "urb_core.h").write_text((c_dir / "urb_core.h").read_text() + "\n/* edited by hand */\n")
    (py_dir / "sensorhex.py").unlink()
    (py_dir / "stray.py").write_text("# not generated\n")
    result = check_fresh(schemas, c_dir, py_dir)
    assert result.changed == [c_dir / "urb_core.h"]
    assert result.missing == [py_dir / "sensorhex.py"]
    assert result.extra == [py_dir / "stray.py"]


def test_every_generated_file_says_do_not_edit() -> None:
    for path in [*C_DIR.rglob("*.[ch]"), *PY_DIR.glob("*.py")]:
        head = path.read_text().splitlines()[:6]
        assert any("do not edit" in line for line in head), path


def test_gen_check_command_fails_on_a_stale_tree(tmp_path: Path) -> None:
    c_dir = tmp_path / "c"
    shutil.copytree(C_DIR, c_dir)
    (c_dir / "urb_runtime.c").write_text("/* stale */\n")
    cmd = [sys.executable, "-m", "urb.cli", "gen", "--check", "--c-out", str(c_dir)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 1
    assert f"changed: {c_dir / 'urb_runtime.c'}" in proc.stderr and "run `urb gen`" in proc.stderr


def test_demo_round_trips_every_message(tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "urb.cli", "demo", "--samples", "5", "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "all round trips identical" in proc.stdout
    assert "UplinkResponse" in proc.stdout and "5/5" in proc.stdout


def test_generation_overwrites_a_corrupted_output_file(tmp_path: Path) -> None:
    # a generated file mangled into bytes that are not UTF-8 is rewritten, not a UnicodeDecodeError
    c_dir, py_dir = tmp_path / "c", tmp_path / "py"
    shutil.copytree(C_DIR, c_dir)
    shutil.copytree(PY_DIR, py_dir)
    (c_dir / "urb_core.c").write_bytes(b"\xff\xfe not C \x80\n")
    generate(load_bundled(), c_dir, py_dir)
    assert filecmp.cmp(c_dir / "urb_core.c", C_DIR / "urb_core.c", shallow=False)
    assert check_fresh(load_bundled(), c_dir, py_dir).fresh
