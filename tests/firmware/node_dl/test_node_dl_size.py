"""tests/firmware/node_dl/node_dl_size.py (make size-node-downlinks): it reports each downlink's node
library and fails a build with static data. Checked against a stand-in for arm-none-eabi-size that
prints fixed rows: a clean build passes with its sum printed (the witness), one with a .bss variable
(the seeded bug) fails with a message that says where to move it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent / "node_dl_size.py"


def fake_size(tmp_path: Path, rows: list[tuple[int, int, int, str]]) -> Path:
    lines = ["   text    data     bss     dec     hex filename"]
    lines += [f"{t} {d} {b} {t + d + b} {t + d + b:x} {name} (ex lib.a)" for t, d, b, name in rows]
    tool = tmp_path / "size"
    tool.write_text("#!/bin/sh\ncat <<'EOF'\n" + "\n".join(lines) + "\nEOF\n")
    tool.chmod(0o755)
    return tool


def run(tool: Path, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), "--size", str(tool), "--build", str(tmp_path),
                           "--archive", f"can={tmp_path / 'lib.a'}"], capture_output=True, text=True)


def test_clean_build_is_reported(tmp_path: Path) -> None:
    r = run(fake_size(tmp_path, [(900, 0, 0, "urb_mailbox.o"), (300, 0, 0, "urb_node_dl.o")]), tmp_path)
    assert r.returncode == 0, r.stderr
    assert "can    flash  1200 B" in r.stdout and "urb_node_dl 300" in r.stdout


def test_static_data_fails(tmp_path: Path) -> None:
    r = run(fake_size(tmp_path, [(900, 0, 0, "urb_mailbox.o"), (300, 0, 8, "urb_node_dl.o")]), tmp_path)
    assert r.returncode == 1
    assert "8 B of static data" in r.stderr and "caller-owned" in r.stderr
