"""The CAN proof views (proofs/bmc/stubs/can_master_view.py, can_slave_view.py) apply to the current
master and slave sources, leave no use of a member they moved, and refuse sources they no longer
match, so fw_can_master and fw_can_slave never run on a view that silently went stale."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
VIEW = ROOT / "proofs/bmc/stubs/can_master_view.py"
HEADER = Path("include/urb_can_master.h")
SOURCE = Path("downlink/can/urb_can_master.c")


def copy_firmware(tmp_path: Path, rels: tuple[Path, ...] = (HEADER, SOURCE)) -> Path:
    """A copy of the given firmware files (paths under firmware/) in tmp_path/firmware."""
    root = tmp_path / "firmware"
    for rel in rels:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / "firmware" / rel, root / rel)
    return root


def run_view(root: Path, view: Path = VIEW) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(view), str(root)], capture_output=True, text=True, check=False)


def test_view_applies_once_and_moves_every_use(tmp_path: Path) -> None:
    root = copy_firmware(tmp_path)
    assert run_view(root).returncode == 0
    header = (root / HEADER).read_text(encoding="utf-8")
    source = (root / SOURCE).read_text(encoding="utf-8")
    assert "next_tid[URB_CAN_LAST_ADDRESS + 1u][16]" not in header
    assert "extern uint8_t urb_view_next_tid[1][16];" in header
    for member in ("m->next_tid", "m->refusal", "m->sync_payload", "m->frame"):
        assert not re.search(re.escape(member) + r"(?!\w)", source), f"{member} left in the viewed source"
    assert "m->frames_sent" in source, "members that only start with a moved one's name stay"
    assert "urb_view_next_tid[URB_VIEW_TID_ROW(m->address)][s]" in source
    assert "a == urb_view_tid_address; a++" in source
    assert run_view(root).returncode == 0
    assert (root / HEADER).read_text(encoding="utf-8") == header, "a second run changes nothing"
    assert (root / SOURCE).read_text(encoding="utf-8") == source, "a second run changes nothing"


@pytest.mark.parametrize(("rel", "edit"), [
    (SOURCE, ("m->next_tid[m->address][s] =", "m->next_tid[m->mailbox][s] =")),
    (SOURCE, ("for (uint8_t a = 0u; a <= URB_CAN_LAST_ADDRESS; a++) {", "for (uint8_t a = 0u; a < 64u; a++) {")),
    (HEADER, ("    uint8_t refusal[1];\n", "    uint8_t refusal[2];\n")),
    (HEADER, ("    urb_can_frame_t frame;\n", "    urb_can_frame_t next_frame;\n")),
])
def test_view_refuses_sources_it_no_longer_matches(rel: Path, edit: tuple[str, str], tmp_path: Path) -> None:
    root = copy_firmware(tmp_path)
    text = (root / rel).read_text(encoding="utf-8")
    assert text.count(edit[0]) == 1
    (root / rel).write_text(text.replace(*edit), encoding="utf-8")
    result = run_view(root)
    assert result.returncode != 0 and "update the view" in result.stderr


def test_usage_error_without_a_folder() -> None:
    result = subprocess.run([sys.executable, str(VIEW)], capture_output=True, text=True, check=False)
    assert result.returncode == 2 and "usage: can_master_view.py" in result.stderr


SLAVE_VIEW = ROOT / "proofs/bmc/stubs/can_slave_view.py"
SLAVE_HEADER = Path("include/urb_can_slave.h")
SLAVE_SOURCE = Path("downlink/can/urb_can_slave.c")


def test_slave_view_applies_once_and_moves_every_use(tmp_path: Path) -> None:
    root = copy_firmware(tmp_path, (SLAVE_HEADER, SLAVE_SOURCE))
    assert run_view(root, SLAVE_VIEW).returncode == 0
    header = (root / SLAVE_HEADER).read_text(encoding="utf-8")
    source = (root / SLAVE_SOURCE).read_text(encoding="utf-8")
    assert "extern urb_can_frame_t urb_view_slave_frame;" in header and "    urb_can_frame_t frame;" not in header
    for member in ("s->frame", "s->answer"):
        assert not re.search(re.escape(member) + r"(?!\w)", source), f"{member} left in the viewed source"
    assert "s->frames_sent" in source
    assert run_view(root, SLAVE_VIEW).returncode == 0
    assert (root / SLAVE_SOURCE).read_text(encoding="utf-8") == source, "a second run changes nothing"


def test_slave_view_refuses_a_header_it_no_longer_matches(tmp_path: Path) -> None:
    root = copy_firmware(tmp_path, (SLAVE_HEADER, SLAVE_SOURCE))
    text = (root / SLAVE_HEADER).read_text(encoding="utf-8")
    (root / SLAVE_HEADER).write_text(text.replace("    urb_can_frame_t frame;\n", "    urb_can_frame_t out;\n"),
                                     encoding="utf-8")
    result = run_view(root, SLAVE_VIEW)
    assert result.returncode != 0 and "update the view" in result.stderr
