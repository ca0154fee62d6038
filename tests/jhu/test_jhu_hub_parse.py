"""The host side of the broadcast read: hub memory written here from jhu-eth1394.md §2.10,
parsed by fw1394's host (``fw1394 jhu rt``); then the whole loop against served racks of
every firmware family, sequences past 255 included."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from udp_ports_support import quiet_udp_port

from fw1394.boards.qla1.eth_server import Eth1394Server
from fw1394.boards.qla1.rack import Rack
from fw1394.jhu.client import EthUdpClient
from fw1394.jhu.hub_parse import HubBoard, MixedFirmwareError, hub_read_quadlets, split_hub
from fw1394.jhu.rt_loop import RealTimeLoop
from fw1394.jhu.scan import Protocol, start
from fw1394.transport.eth1394_addresses import Endpoint

PORT = quiet_udp_port(span=9)


def block(board_id: int, length: int, marker: int) -> list[int]:
    """A real-time block (§4.5): timestamp, status (4 axes, board id), then ``marker``s."""
    return [0x11, 0x4000_0000 | board_id << 24, *([marker] * (length - 2))]


def test_rev4_6_reads_every_slot_by_board_number() -> None:
    boards = [HubBoard(1, 5), HubBoard(4, 5)]
    assert hub_read_quadlets(boards) == 272
    memory = [0] * 272
    for board in boards:
        memory[17 * board.board_id : 17 * board.board_id + 17] = [
            0x0123 << 16,
            *block(board.board_id, 16, 0xA0 + board.board_id),
        ]
    parsed = split_hub(memory, boards, 0x0123)
    assert parsed[1] == block(1, 16, 0xA1)
    assert parsed[4] == block(4, 16, 0xA4)
    # Rev 8 packing of the same two boards is not what a Rev 4-6 host reads.
    packed = [0x0123 << 16, *block(1, 16, 0xA1), 0x0123 << 16, *block(4, 16, 0xA4)]
    assert split_hub(packed + [0] * 238, boards, 0x0123) == {1: None, 4: None}


def test_rev7_compares_the_full_sequence() -> None:
    boards = [HubBoard(0, 7), HubBoard(3, 7)]
    assert hub_read_quadlets(boards) == 29 * 2 + 1
    sequence = 0x0201  # low byte 1: a Rev 8 style check would take 0x0301 too
    memory = [sequence << 16 | 0x12, *block(0, 28, 5), sequence << 16 | 0x30, *block(3, 28, 6)]
    memory.append(0x0030_0040)
    parsed = split_hub(memory, boards, sequence)
    assert parsed == {0: block(0, 28, 5), 3: block(3, 28, 6)}
    stale = list(memory)
    stale[29] = 0x0301 << 16 | 0x30
    assert split_hub(stale, boards, sequence) == {0: block(0, 28, 5), 3: None}


def test_rev8_low_byte_size_and_mismatch_bit() -> None:
    boards = [HubBoard(2, 8), HubBoard(6, 9)]
    assert hub_read_quadlets(boards) == 2 * 33 + 1
    sequence = 0x0405
    memory = [33 << 24 | 0x05 << 16 | 7, *block(2, 32, 1), 33 << 24 | 0x05 << 16 | 9]
    memory += [*block(6, 32, 2), 0]
    assert split_hub(memory, boards, sequence) == {2: block(2, 32, 1), 6: block(6, 32, 2)}
    flagged = list(memory)
    flagged[33] |= 0x8000  # the firmware saw this board's block of another round
    assert split_hub(flagged, boards, sequence)[6] is None


def test_a_zero_header_or_status_ends_the_parse() -> None:
    boards = [HubBoard(0, 7), HubBoard(1, 7)]
    good = [0x0007 << 16, *block(0, 28, 1)]
    second = [0x0007 << 16, *block(1, 28, 2)]
    zero_status = [*good[:2], 0, *good[3:]]
    assert split_hub(zero_status + second + [0], boards, 7) == {0: None, 1: None}


# -- any hub memory, parsed as §2.10 says --------------------------------------------------------

#: §2.10 and §4.5: a Rev 4-6 slot and a Rev 7 block are 17 and 29 quadlets with the header;
#: a Rev 8+ QLA block is 1 + 4 + 2 * 4 + 5 * 4 = 33.
SLOT_REV4_6, BLOCK_REV7, BLOCK_REV8 = 17, 29, 33


def spec_parse(
    words: list[int], ids: list[int], firmware: int, sequence: int
) -> dict[int, list[int] | None]:
    """The host's parse (§2.10, BasePort::ReadAllBoardsBroadcast), board by board."""
    parsed: dict[int, list[int] | None] = dict.fromkeys(ids, None)
    position = 0
    for board_id in sorted(ids):
        if firmware < 7:
            position = SLOT_REV4_6 * board_id
        header = words[position] if position < len(words) else 0
        status = words[position + 2] if position + 2 < len(words) else 0
        if header == 0 or status == 0:
            break
        if firmware >= 8:
            size = header >> 24
            good = (
                header >> 16 & 0xFF == sequence & 0xFF
                and not header & 0x8000
                and size == BLOCK_REV8
            )
        else:
            size = SLOT_REV4_6 if firmware < 7 else BLOCK_REV7
            good = header >> 16 == sequence & 0xFFFF and status >> 28 == 4
        found = words[position + 1 : position + size]
        if good and status >> 24 & 0xF == board_id and len(found) == size - 1:
            parsed[board_id] = found
        position += max(size, 1)
    return parsed


@st.composite
def hub_memories(draw: st.DrawFn) -> tuple[list[int], list[int], int, int]:
    """Hub memory of a round, laid out by §2.10, then damaged here and there."""
    firmware = draw(st.sampled_from([4, 6, 7, 8, 9]))
    ids = sorted(draw(st.lists(st.integers(0, 15), min_size=1, max_size=8, unique=True)))
    sequence = draw(st.integers(0, 0xFFFF))
    size = SLOT_REV4_6 if firmware < 7 else BLOCK_REV7 if firmware == 7 else BLOCK_REV8
    memory = [0] * (16 * SLOT_REV4_6) if firmware < 7 else []
    headers = []
    for board_id in ids:
        if firmware >= 8:
            header = size << 24 | (sequence & 0xFF) << 16 | draw(st.integers(0, 0x7FFF))
        else:
            header = sequence << 16 | draw(st.integers(0, 0xFFFF))
        status = 4 << 28 | board_id << 24 | draw(st.integers(0, 0xFFFFFF))
        data = draw(st.lists(st.integers(0, 0xFFFFFFFF), min_size=size - 3, max_size=size - 3))
        slot = [header, draw(st.integers(0, 0xFFFFFFFF)), status, *data]
        headers.append(SLOT_REV4_6 * board_id if firmware < 7 else len(memory))
        if firmware < 7:
            memory[SLOT_REV4_6 * board_id : SLOT_REV4_6 * (board_id + 1)] = slot
        else:
            memory += slot
    for _ in range(draw(st.integers(0, 3))):  # damage: a header, a status or any quadlet
        start = draw(st.sampled_from(headers))
        where = draw(st.sampled_from([start, start + 2, draw(st.integers(0, len(memory) - 1))]))
        memory[where] = draw(
            st.sampled_from(
                [
                    0,
                    draw(st.integers(0, 0xFFFFFFFF)),
                    memory[where] ^ 0x8000,  # Rev 8+: the mismatch bit
                    memory[where] ^ 1 << 16,  # the sequence's low byte
                    memory[where] ^ 1 << 24,  # Rev 8+ size, or the sequence's high byte;
                    # or, in a status, the board
                    memory[where] ^ 1 << 28,  # a status's axes
                ]
            )
        )
    if draw(st.booleans()):  # a header the firmware flagged (Rev 8+; before, an update time)
        memory[draw(st.sampled_from(headers))] ^= 0x8000
    memory = memory[: draw(st.integers(0, len(memory)))] if draw(st.booleans()) else memory
    return memory, ids, firmware, sequence


@settings(max_examples=300, deadline=None)
@given(hub_memories())
def test_the_parse_of_any_hub_memory_is_the_hosts(
    case: tuple[list[int], list[int], int, int],
) -> None:
    memory, ids, firmware, sequence = case
    boards = [HubBoard(board_id, firmware) for board_id in ids]
    assert split_hub(memory, boards, sequence) == spec_parse(memory, ids, firmware, sequence)
    assert split_hub(tuple(memory), boards, sequence) == spec_parse(memory, ids, firmware, sequence)


def test_mixed_families_are_refused() -> None:
    with pytest.raises(MixedFirmwareError):
        hub_read_quadlets([HubBoard(0, 7), HubBoard(1, 8)])
    with pytest.raises(MixedFirmwareError):
        hub_read_quadlets([HubBoard(0, 3), HubBoard(1, 3)])
    assert hub_read_quadlets([HubBoard(0, 4), HubBoard(1, 6)]) == 272


@pytest.mark.process
@pytest.mark.parametrize(
    ("firmware", "ids", "cycles"),
    [(4, [0, 2, 5], 40), (6, [1, 3], 40), (7, [0, 1, 3], 300), (8, [0, 1, 2, 3], 40)],
)
def test_broadcast_read_every_cycle_against_a_served_rack(
    firmware: int, ids: list[int], cycles: int
) -> None:
    port = PORT + firmware
    server = Eth1394Server(Rack(ids, firmware=firmware), Endpoint("127.0.0.1", port))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        # Ten times the host library's 20 ms: every absent node of the scan waits it.
        with EthUdpClient(Endpoint("127.0.0.1", port), receive_timeout=0.2) as client:
            scan = start(client)
            assert sorted(b.board_id for b in scan.boards) == ids
            loop = RealTimeLoop(client, scan, Protocol.BC_QRW)
            failed = []
            for _ in range(cycles):
                blocks = loop.cycle()
                if any(value is None for value in blocks.values()):
                    failed.append(loop.sequence)
            assert not failed, f"cycles with a missing board: {failed[:5]}"
            assert loop.sequence == cycles  # past 255 at firmware 7
    finally:
        server.stop()
        thread.join(5)
        server.close()
