"""The CAN downlink's segmentation against pycyphal, an independent implementation of Cyphal/CAN.

tests/firmware/can/test_can.c in its `vectors` mode prints the frames urb_can_tx_next() cuts from a
payload of every length 0..32 with transfer ids 0, 1, 17 and 31; pycyphal's own transfer
serializer (pycyphal.transport.can, classic CAN, 7 payload bytes per frame) must produce the same
data bytes, tail bytes included. A second test shows the comparison can fail: two seeded bugs of
the segmenter differ from pycyphal.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

pycyphal_can = pytest.importorskip("pycyphal.transport.can._session._transfer_sender")

ROOT = Path(__file__).resolve().parents[3]
PAYLOAD = bytes((i * 37 + 11) & 0xFF for i in range(32))
TIDS = (0, 1, 17, 31)


def _build(tmp: Path) -> Path:
    exe = tmp / "test_can"
    srcs = [
        "tests/firmware/can/test_can.c", "tests/firmware/can/can_bus.c", "tests/firmware/dl_common/fake_mailbox.c",
        "firmware/downlink/can/urb_can_transfer.c", "firmware/downlink/can/urb_can_master.c",
        "firmware/downlink/can/urb_can_slave.c", "gen/c/urb_core.c", "gen/c/urb_can_wire.c", "gen/c/urb_runtime.c",
    ]
    cmd = ["gcc", "-std=c99", "-O1", "-D_DEFAULT_SOURCE", "-Ifirmware/include", "-Igen/c", "-Itests/firmware/can",
           "-Itests/firmware/dl_common", *srcs, "-lcmocka", "-o", str(exe)]
    subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    return exe


def _c_frames(exe: Path) -> dict[tuple[int, int], list[bytes]]:
    out = subprocess.run([str(exe), "vectors"], check=True, capture_output=True, text=True).stdout
    frames: dict[tuple[int, int], list[bytes]] = {}
    for line in out.splitlines():
        key, _, rest = line.partition(":")
        length, tid = (int(x) for x in key.split())
        frames[(length, tid)] = [bytes.fromhex(h) for h in rest.split()]
    return frames


def _pycyphal_frames(length: int, tid: int) -> list[bytes]:
    frames = pycyphal_can.serialize_transfer(
        compiled_identifier=0, transfer_id=tid, fragmented_payload=[memoryview(PAYLOAD[:length])],
        max_frame_payload_bytes=7,
    )
    return [bytes(f.compile().data) for f in frames]


def test_every_length_matches_pycyphal(tmp_path: Path) -> None:
    c = _c_frames(_build(tmp_path))
    assert len(c) == 33 * len(TIDS)
    for length in range(33):
        for tid in TIDS:
            want = _pycyphal_frames(length, tid)
            assert c[(length, tid)] == want, f"length {length}, transfer id {tid}"
    # the facts the design rests on: a 32-byte mailbox is 5 frames, 7 bytes is the longest single frame
    assert len(c[(32, 0)]) == 5
    assert len(c[(7, 0)]) == 1 and len(c[(8, 0)]) == 2


def test_seeded_bug_differs_from_pycyphal(tmp_path: Path) -> None:
    """The comparison can fail: the C segmenter with its CRC appended least significant byte first
    (URB_MUTANT_CAN_CRC_LITTLE_ENDIAN) and with toggle 0 in a first frame differ from pycyphal."""
    for mutant in ("URB_MUTANT_CAN_CRC_LITTLE_ENDIAN", "URB_MUTANT_CAN_START_TOGGLE_0"):
        exe = tmp_path / mutant
        srcs = ["tests/firmware/can/test_can.c", "tests/firmware/can/can_bus.c", "tests/firmware/dl_common/fake_mailbox.c",
                "firmware/downlink/can/urb_can_transfer.c", "firmware/downlink/can/urb_can_master.c",
                "firmware/downlink/can/urb_can_slave.c", "gen/c/urb_core.c", "gen/c/urb_can_wire.c", "gen/c/urb_runtime.c"]
        subprocess.run(["gcc", "-std=c99", "-O1", "-D_DEFAULT_SOURCE", f"-D{mutant}", "-Ifirmware/include", "-Igen/c",
                        "-Itests/firmware/can", "-Itests/firmware/dl_common", *srcs, "-lcmocka", "-o", str(exe)],
                       cwd=ROOT, check=True, capture_output=True, text=True)
        c = _c_frames(exe)
        differ = [k for k in c if c[k] != _pycyphal_frames(*k)]
        assert differ, f"{mutant}: no transfer differs from pycyphal"
