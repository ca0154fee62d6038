"""The generator reaches every register and node; the model-free data oracle learns.

Reach: a JHU Eth1394 board addresses registers by quadlet index (offset 0x1f
is register 0x1f, not a misaligned byte), a 1394 node's CSR space by byte;
other nodes are any of the 62 IDs besides the target's, and broadcast.

The data oracle is driven here by a register file written in the test: a
dict of quadlets with the behaviours a board may have (read-only, only some
bits implemented, a write that changes another register).
"""

from __future__ import annotations

import random
from collections import Counter
from typing import Any

import pytest

from fw1394.fuzz.generate import Generator
from fw1394.fuzz.learned import LearnedRegisters
from fw1394.fuzz.offsets import CSR_BASE, offset_model
from fw1394.packets import (
    BlockWriteRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    decode,
)
from fw1394.packets.nodeid import node_id

TARGET = node_id(0)
CASES = 20_000


def requests(generator: Generator, count: int) -> list[Any]:
    out: list[Any] = []
    for _ in range(count):
        try:
            out.append(decode(generator.valid(), strict=False))
        except ValueError:
            continue
    return out


def test_an_index_addressed_board_gets_every_register_index_and_every_node() -> None:
    generator = Generator(TARGET, offset_model(None, quadlet_index=True), random.Random(5))
    packets = requests(generator, CASES)
    offsets = {p.offset for p in packets if hasattr(p, "offset")}
    assert set(range(0x50)) <= offsets  # 0x1f included: no offset is forced to a multiple of 4
    assert any(o % 4 for o in offsets if o > 0x50)
    destinations = {p.destination_id & 0x3F for p in packets if hasattr(p, "destination_id")}
    assert destinations == set(range(64))  # all 63 node IDs and broadcast


def test_other_nodes_are_drawn_alike() -> None:
    # 14 % of destinations go to the other 62 IDs alike: about 45 each in 20,000.
    generator = Generator(TARGET, offset_model(None, quadlet_index=True), random.Random(8))
    drawn = Counter(generator.destination() & 0x3F for _ in range(CASES))
    assert min(drawn[node] for node in range(1, 63)) >= 25


def test_a_byte_addressed_node_gets_misaligned_csr_offsets() -> None:
    generator = Generator(TARGET, offset_model(None), random.Random(6))
    offsets = {p.offset for p in requests(generator, CASES) if hasattr(p, "offset")}
    csr = [o for o in offsets if CSR_BASE <= o < CSR_BASE + 0x800]
    assert {o % 4 for o in csr} == {0, 1, 2, 3}


def test_a_mapped_boards_registers_and_their_neighbours_are_reached() -> None:
    model = offset_model("qla1")
    assert 0x1F not in model.registers  # not in the map: reached as a neighbour
    generator = Generator(TARGET, model, random.Random(7))
    offsets = {p.offset for p in requests(generator, CASES) if hasattr(p, "offset")}
    assert set(model.registers) <= offsets and 0x1F in offsets


# -- the data oracle ------------------------------------------------------------------------
class Board:
    """A register file: memory-like registers, a read-only one, one with 16 bits, and
    (``corrupting``) a write to 0x21 that also changes 0x31."""

    def __init__(self, corrupting: bool = False) -> None:
        self.registers: dict[int, int] = {}
        self.corrupting = corrupting

    def write(self, index: int, value: int) -> None:
        if index == 4:
            return  # read-only
        if index == 3:
            value &= 0xFFFF  # only 16 bits implemented
        self.registers[index] = value
        if self.corrupting and index == 0x21:
            self.registers[0x31] = value ^ 0xFFFF0000

    def read(self, index: int) -> QuadletReadResponse:
        value = 0x514C4131 if index == 4 else self.registers.get(index, 0)
        return QuadletReadResponse(
            destination_id=0xFFFE, tlabel=1, source_id=TARGET, rcode=0, quadlet_data=value
        )


def write(index: int, value: int) -> QuadletWriteRequest:
    return QuadletWriteRequest(
        destination_id=TARGET, tlabel=2, source_id=0xFFFE, offset=index, quadlet_data=value
    )


def exercise(board: Board, oracle: LearnedRegisters, rounds: int, seed: int) -> list[str]:
    """Writes and read-backs of registers 0-5, 0x21 and 0x31, with sweeps between."""
    rng = random.Random(seed)
    found = []
    for round_number in range(rounds):
        index = rng.choice((0, 1, 2, 3, 4, 5, 0x21, 0x31))
        value = rng.getrandbits(32)
        oracle.wrote(write(index, value), accepted=True)
        board.write(index, value)
        if (v := oracle.read_back(index, board.read(index))) is not None:
            found.append(v.signature)
        if round_number % 4 == 3:
            for register in oracle.registers:
                if (v := oracle.swept(register, board.read(register), "")) is not None:
                    found.append(v.signature)
                marker = oracle.marker(register)
                board.write(register, marker)
                if (v := oracle.read_back(register, board.read(register))) is not None:
                    found.append(v.signature)
    return found


def test_a_board_whose_registers_keep_their_writes_gives_no_finding() -> None:
    oracle = LearnedRegisters(quadlet_index=True)
    assert exercise(Board(), oracle, 400, seed=1) == []
    learned = set(oracle.registers)
    assert {0, 1, 2, 5, 0x21, 0x31} <= learned and 4 not in learned


def test_a_write_that_changes_another_register_is_reported() -> None:
    found = exercise(Board(corrupting=True), LearnedRegisters(quadlet_index=True), 400, seed=1)
    assert "learned:changed" in found
    assert "learned:not-read-back" not in found


def test_a_register_that_loses_a_bit_it_kept_before_is_reported() -> None:
    oracle = LearnedRegisters(quadlet_index=True)
    for value in (0x0000_0001, 0x8000_0000):  # bit 0 and bit 31 both kept as 1 and 0
        oracle.wrote(write(0x1F, value), accepted=True)
        assert oracle.read_back(0x1F, _response(value)) is None
    oracle.wrote(write(0x1F, 0x8000_0001), accepted=True)
    violation = oracle.read_back(0x1F, _response(0x8000_0000))
    assert violation is not None and violation.signature == "learned:not-read-back"
    assert "0x1f" in violation.observed


def test_a_block_write_that_wraps_past_0xffff_touches_register_0() -> None:
    oracle = LearnedRegisters(quadlet_index=True)
    for value in (5, 6):
        oracle.wrote(write(0, value), accepted=True)
        oracle.read_back(0, _response(value))
    block = BlockWriteRequest(
        destination_id=TARGET, tlabel=3, source_id=0xFFFE, offset=0xFFFE, data=bytes(16)
    )
    oracle.wrote(block, accepted=True)
    assert oracle.swept(0, _response(0), "") is None  # touched: not a change by another


@pytest.mark.parametrize("accepted", [True, False])
def test_a_write_the_contract_drops_teaches_nothing(accepted: bool) -> None:
    oracle = LearnedRegisters(quadlet_index=True)
    for value in (5, 6):
        oracle.wrote(write(7, value), accepted=accepted)
        oracle.read_back(7, _response(value))
    assert (7 in oracle.registers) is accepted


def _response(value: int) -> QuadletReadResponse:
    return QuadletReadResponse(
        destination_id=0xFFFE, tlabel=1, source_id=TARGET, rcode=0, quadlet_data=value
    )
