"""Helpers of the RTL tests."""

from __future__ import annotations

import random

from fw1394.fuzz.contract import CONTRACTS, silence_reason
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.trial import wire_of
from fw1394.packets import QuadletWriteRequest


def bad_crc_writes(seed: int, cases: int) -> list[int]:
    """The cases (1-based) of a seeded rtl:thesis campaign that are quadlet writes to
    node 0 with a bad header CRC (the campaign's generator, run alone)."""
    generator = Generator(0xFFC0, offset_model("snake2010"), random.Random(seed))
    found = []
    for case in range(1, cases + 1):
        wire = wire_of(generator.case()[0])
        if isinstance(wire.packet, QuadletWriteRequest):
            reason = silence_reason(wire.packet, wire.damaged, 0xFFC0, CONTRACTS["thesis"])
            if reason == "bad-header-crc":
                found.append(case)
    return found
