"""The bridge proof views (proofs/bmc/stubs/bridge_view.py) apply to the current urb_bridge.h and
refuse a header they no longer match, so a proof never runs on a view that silently went stale."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
VIEW = ROOT / "proofs/bmc/stubs/bridge_view.py"
HEADER = ROOT / "firmware/include/urb_bridge.h"


def run_view(view: str, header: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(VIEW), view, str(header)], capture_output=True, text=True, check=False)


@pytest.mark.parametrize("view", ["uplink", "fifo"])
def test_view_slims_the_current_header_once(view: str, tmp_path: Path) -> None:
    header = tmp_path / "urb_bridge.h"
    header.write_text(HEADER.read_text(encoding="utf-8"), encoding="utf-8")
    assert run_view(view, header).returncode == 0
    slimmed = header.read_text(encoding="utf-8")
    assert len(slimmed) < len(HEADER.read_text(encoding="utf-8")), "the view removed nothing"
    assert "typedef struct" in slimmed and "urb_bridge_t;" in slimmed
    assert run_view(view, header).returncode == 0
    assert header.read_text(encoding="utf-8") == slimmed, "a second run changes nothing"


@pytest.mark.parametrize(("view", "edit"), [
    ("uplink", ("    /* Frame assemblers. */", "    /* Assemblers. */")),
    ("fifo", ("uint8_t usb_buf[2][URB_BRIDGE_USB_BUF];", "uint8_t usb_buf[3][URB_BRIDGE_USB_BUF];")),
])
def test_view_refuses_a_header_it_no_longer_matches(view: str, edit: tuple[str, str], tmp_path: Path) -> None:
    text = HEADER.read_text(encoding="utf-8")
    assert text.count(edit[0]) == 1
    header = tmp_path / "urb_bridge.h"
    header.write_text(text.replace(*edit), encoding="utf-8")
    result = run_view(view, header)
    assert result.returncode != 0 and "update the view" in result.stderr


def test_unknown_view_is_a_usage_error(tmp_path: Path) -> None:
    result = run_view("node", tmp_path / "urb_bridge.h")
    assert result.returncode == 2 and "usage: bridge_view.py uplink|fifo" in result.stderr
