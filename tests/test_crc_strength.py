"""The error-detection strength promised in spec/schema/README.md, measured."""

from __future__ import annotations

import urb_msgs
from urb_codegen.crc_strength import hamming_distance_at_least_4, longest_hd4, undetected
from urb_codegen.generate import load_bundled
from urb_codegen.model import MessageDecl


def _checked_messages() -> list[MessageDecl]:
    return [m for s in load_bundled() for sch in [*s.imports, s] for m in sch.messages.values() if m.checksum]


# lobster-trace: urb.CRC_001
def test_crc8_tier_ends_exactly_where_hamming_distance_4_ends() -> None:
    (link,) = {m.checksum.name: m.checksum for m in _checked_messages() if m.checksum}.values()
    crc8, crc16 = link.tiers
    assert longest_hd4(crc8.width, crc8.poly, 40) == crc8.max_covered == 14
    assert undetected(crc8.width, crc8.poly, 15) == (1, 0)  # one 2-bit pattern slips through at 15 bytes


# lobster-trace: urb.CRC_001
def test_every_checked_frame_length_has_hamming_distance_4() -> None:
    for msg in _checked_messages():
        cs = msg.checksum
        assert cs is not None
        for payload in range(msg.max_payload + 1):
            covered = msg.implicit_size + msg.fixed_size + payload
            tier = cs.tier_for(covered)
            assert hamming_distance_at_least_4(tier.width, tier.poly, covered), (msg.name, payload)


# lobster-trace: urb.PKT_005
def test_rs232_budget_ten_byte_read_response_is_twelve_bytes() -> None:
    from urb_msgs.urb_core import Status, UplinkResponse
    assert len(UplinkResponse(seq=1, status=Status.OK, data=bytes(10)).encode()) == 12
    assert urb_msgs.urb_core.UplinkResponse.MAX_SIZE == 1 + 32 + 2
