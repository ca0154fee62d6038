"""The shrinker keeps a finding's root cause: its verdict class and its packet's kind.

A violation that any packet with the data byte 0xca reproduces lets the
shrinker cut the header away; the case packet must still carry the tcode it
was found with (a quadlet write stays a quadlet write, IEEE 1394's tcode 0,
never another kind of packet that fails the same way).
"""

from __future__ import annotations

import pytest

from fw1394.crc import header_crc
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.trial import Entry


def _quadlet_write() -> bytes:
    # destination ffc0, tlabel 5, tcode 0 (quadlet write), source ffc1, offset 0x1234,
    # data cafef0d0 (alone, its last byte would read as tcode d), header CRC
    head = bytes.fromhex("ffc0 1400 ffc1 0000 0000 1234 cafe f0d0".replace(" ", ""))
    return head + header_crc(head).to_bytes(4, "big")


@pytest.mark.parametrize("tcode_byte", [0x00, 0x10, 0x40, 0x50])
def test_shrinking_keeps_the_tcode(tcode_byte: int) -> None:
    raw = bytearray(_quadlet_write())
    raw[3] = tcode_byte
    finding = Finding(
        oracle="silence",
        signature="bad-header-crc:write:ack_data_error",
        target="inproc:memory",
        settings={},
        expected="silence",
        observed="ack_data_error",
        case=1,
        label="",
        stream=[Entry("case", 0.0, bytes(raw))],
    )

    def replay(stream: list[Entry]) -> set[tuple[str, str]]:
        return {finding.key} if any(0xCA in entry.raw for entry in stream) else set()

    shrunk = shrink(finding, replay, budget=500)
    assert shrunk.shrunk and shrunk.reproduced
    assert len(shrunk.packet) < len(raw)
    assert shrunk.packet[3] >> 4 == tcode_byte >> 4
