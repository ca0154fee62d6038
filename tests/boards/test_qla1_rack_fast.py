"""The rack's one-pass real-time cycle against the general path, board by board.

The general path (each cabled port in turn, hub broadcasts passed board to board)
is the reference: for any rack, register contents, commands and times, a datagram
every port gets must give the same replies and leave every board, responder and
port in the same state whichever path serves it. Anything the fast path does not
take it must decline before touching anything.
"""

from __future__ import annotations

import copy
import dataclasses
import struct
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.qla1.board import DEFECT_RT_WRITE_ANY_BOARD, Qla1Board
from fw1394.boards.qla1.ethernet import Reply
from fw1394.boards.qla1.firewire import hub_broadcast
from fw1394.boards.qla1.rack import Rack
from fw1394.boards.qla1.rack_fast import RackFastPath
from fw1394.boards.qla1.regs import HUB_QUERY
from fw1394.boards.qla1.rt_blocks import RtWrite, decode_rev8_write, split_rev8_write
from fw1394.packets import BlockReadRequest, BlockWriteRequest, QuadletWriteRequest, Request
from fw1394.packets.eth1394_fast import request_datagram
from fw1394.packets.fast import encode_packet

HOST = ("127.0.0.1", 40000)
HOST_ID = 0xFFD0
EVERY_NODE = 0xFFFF
LOCAL_BUS_IDS = 0xFFC0
DAC_VALID = 1 << 31
RT_BLOCK_QUADLETS = 6  # header, 4 DAC commands, control
NO_SHARE = RtWrite((), ())


def snapshot(value: Any) -> Any:
    """Everything an object holds, as plain data (callables only named)."""
    if value is None or isinstance(value, int | float | str | bytes):
        return value
    if isinstance(value, bytearray):
        return bytes(value)
    if callable(value):
        return "callable"  # a method or handler: behaviour, not state
    if isinstance(value, list | tuple):
        return [type(value).__name__, [snapshot(item) for item in value]]
    if isinstance(value, dict):
        # Items in order: a hub's blocks must also be kept in the same order.
        return [(snapshot(key), snapshot(item)) for key, item in value.items()]
    if isinstance(value, set | frozenset):
        return sorted(value)
    if dataclasses.is_dataclass(value) and not hasattr(value, "__dict__"):
        names = [f.name for f in dataclasses.fields(value)]
    else:
        names = list(vars(value))
    held = ((name, getattr(value, name)) for name in names)
    return [type(value).__name__, [(n, snapshot(v)) for n, v in held]]


def rack_state(rack: Rack) -> Any:
    return [snapshot(member) for member in rack.members], snapshot(rack.bus)


def same_snapshot(a: Any, b: Any) -> bool:
    """``snapshot(a) == snapshot(b)``, walking both at once without building either."""
    if a is b:
        return True
    if type(a) is not type(b):
        return bool(snapshot(a) == snapshot(b))
    if a is None or isinstance(a, int | float | str | bytes | bytearray):
        return bool(a == b)
    if callable(a):
        return True
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(map(same_snapshot, a, b))
    if isinstance(a, dict):
        return len(a) == len(b) and all(
            same_snapshot(key, other_key) and same_snapshot(item, other_item)
            for (key, item), (other_key, other_item) in zip(a.items(), b.items(), strict=True)
        )
    if isinstance(a, set | frozenset):
        return sorted(a) == sorted(b)
    if dataclasses.is_dataclass(a) and not hasattr(a, "__dict__"):
        names = [f.name for f in dataclasses.fields(a)]
    else:
        names = list(vars(a))
        if names != list(vars(b)):
            return False
    return all(same_snapshot(getattr(a, name), getattr(b, name)) for name in names)


def assert_same_state(fast: Rack, reference: Rack) -> None:
    """The racks hold the same state; on a difference, the snapshots for pytest to compare."""
    if not same_snapshot((fast.members, fast.bus), (reference.members, reference.bus)):
        assert rack_state(fast) == rack_state(reference)
        raise AssertionError("same_snapshot and snapshot disagree")


def datagram(packet: Request, *, no_forward: bool = True) -> bytes:
    return request_datagram(no_forward, 0, encode_packet(packet))


def query(
    sequence: int, mask: int, *, tlabel: int = 1, offset: int = HUB_QUERY, node: int = 0x3F
) -> bytes:
    return datagram(
        QuadletWriteRequest(
            destination_id=LOCAL_BUS_IDS | node,
            tlabel=tlabel,
            source_id=HOST_ID,
            offset=offset,
            quadlet_data=(sequence << 16 | mask) & 0xFFFFFFFF,
        )
    )


def rt_block(board_id: int, dacs: list[int], control: int) -> list[int]:
    return [board_id << 8 | len(dacs) + 2, *dacs, control]


def rt_write(words: list[int], *, offset: int = 0, tlabel: int = 2) -> bytes:
    return datagram(
        BlockWriteRequest(
            destination_id=EVERY_NODE,
            tlabel=tlabel,
            source_id=HOST_ID,
            offset=offset,
            data=struct.pack(f">{len(words)}I", *words),
        )
    )


def general(rack: Rack, payload: bytes, now: float) -> list[tuple[int, Reply]]:
    """The reference: the datagram for each cabled port in turn."""
    replies: list[tuple[int, Reply]] = []
    for index, _ in rack.ports:
        replies += rack.receive(index, payload, HOST, now)
    return replies


# -- strategies ---------------------------------------------------------------------------------

quadlet = st.integers(0, 0xFFFFFFFF)
#: DAC commands, mostly valid, some asking for an amplifier.
dac = st.one_of(quadlet, st.integers(0, 0xFFFF).map(lambda value: DAC_VALID | value))
#: STATUS commands: relay, power, amplifier enables, now and then a reboot.
control = st.one_of(
    st.sampled_from([0, 0x000A_0000, 0x000F_0F0F, 0x0003_0000, 0x000C_0000, 0x0000_0F00]),
    quadlet,
)


@st.composite
def racks(draw: st.DrawFn) -> tuple[list[int], int]:
    ids = draw(st.lists(st.integers(0, 15), min_size=1, max_size=8, unique=True))
    return ids, draw(st.sampled_from([8, 9, 10]))


@st.composite
def cycle_write(draw: st.DrawFn, ids: list[int]) -> list[int]:
    """The host's block write: a block per board, in some order, maybe for strangers."""
    order = draw(st.permutations(ids))
    words: list[int] = []
    for board_id in order:
        dacs = draw(st.lists(dac, min_size=4, max_size=4))
        words += rt_block(board_id, dacs, draw(control))
    if draw(st.booleans()):
        stranger = draw(st.integers(0, 15))
        words += rt_block(stranger, draw(st.lists(dac, max_size=6)), draw(control))
    return words


def mask_of(ids: list[int]) -> st.SearchStrategy[int]:
    every = sum(1 << board_id for board_id in ids)
    return st.one_of(st.just(every), st.integers(0, 0xFFFF))


def events(ids: list[int]) -> st.SearchStrategy[tuple[str, Any]]:
    """What the rack gets: mostly the host's cycle, sometimes anything else."""
    mask = sum(1 << board_id for board_id in ids)
    sequence = st.integers(0, 0xFFFF)
    register = st.tuples(st.sampled_from(ids), st.integers(0, 0x4F), quadlet)
    unusual = st.one_of(
        st.builds(query, sequence, st.integers(0, 0xFFFF)),  # any mask
        st.builds(lambda s: query(s, mask, offset=0xFFFF_0000_1800), sequence),  # an alias
        st.builds(lambda s: query(s, mask)[:-1], sequence),  # short
        st.builds(lambda s: query(s, mask) + b"\0\0\0\0", sequence),  # long
        st.builds(lambda w: rt_write(w, offset=4), st.lists(quadlet, min_size=1, max_size=12)),
        st.builds(rt_write, st.lists(quadlet, max_size=20)),  # any block chain
        st.builds(lambda w: rt_write(w)[:-3], st.lists(quadlet, max_size=8)),  # cut short
        st.builds(
            lambda s: datagram(
                BlockReadRequest(
                    destination_id=EVERY_NODE,
                    tlabel=3,
                    source_id=HOST_ID,
                    offset=0x1000,
                    data_length=4 * s,
                )
            ),
            st.integers(1, 64),
        ),
        st.builds(
            lambda s: datagram(
                QuadletWriteRequest(
                    destination_id=EVERY_NODE,
                    tlabel=4,
                    source_id=HOST_ID,
                    offset=HUB_QUERY,
                    quadlet_data=s << 16 | mask,
                ),
                no_forward=False,
            ),
            sequence,
        ),
        st.binary(max_size=40),
    )
    return st.one_of(
        st.tuples(st.just("cycle"), st.tuples(sequence, cycle_write(ids).map(rt_write))),
        st.tuples(st.just("cycle"), st.tuples(sequence, cycle_write(ids).map(rt_write))),
        st.tuples(st.just("datagram"), cycle_write(ids).map(rt_write)),
        st.tuples(st.just("datagram"), unusual),
        st.tuples(st.just("register"), register),
        # A query for one board only: the others keep its broadcast for a later round.
        st.tuples(st.just("unicast"), st.tuples(st.sampled_from(ids), sequence, mask_of(ids))),
        st.tuples(st.just("wait"), st.sampled_from([0.0, 1e-6, 2e-4, 0.05, 0.5])),
    )


@st.composite
def scenarios(draw: st.DrawFn) -> tuple[list[int], int, list[tuple[str, Any]]]:
    ids, firmware = draw(racks())
    return ids, firmware, draw(st.lists(events(ids), min_size=1, max_size=25))


# -- the proof ----------------------------------------------------------------------------------


@settings(max_examples=120, deadline=None)
@given(scenarios())
def test_one_pass_equals_port_by_port(scenario: tuple[list[int], int, list[Any]]) -> None:
    ids, firmware, script = scenario
    fast, reference = Rack(ids, firmware=firmware), Rack(ids, firmware=firmware)
    reference.fast_path = None
    mask = sum(1 << board_id for board_id in ids)
    now, sequence = 0.001, 0
    for kind, detail in script:
        if kind == "wait":
            now += detail
            continue
        if kind == "register":
            board_id, index, value = detail
            for rack in (fast, reference):
                member = next(m for m in rack.members if m.board.board_id == board_id)
                member.responder.advance_clock(now)
                member.board.write_quadlet(index, value)
            continue
        if kind == "unicast":
            board_id, drawn, board_mask = detail
            payload = query(drawn, board_mask, node=board_id)
            for rack in (fast, reference):
                index = next(n for n, m in enumerate(rack.members) if m.board.board_id == board_id)
                if rack.members[index].port is not None:
                    rack.receive(index, payload, HOST, now)
            continue
        if kind == "cycle":
            # The host's sequence moves on each cycle; sometimes it is drawn (repeats too).
            drawn, write = detail
            sequence = drawn if drawn % 3 == 0 else sequence % 0xFFFF + 1
            payloads = [query(sequence, mask, tlabel=sequence & 0x3F), write]
        else:
            payloads = [detail]
        for payload in payloads:
            replies = fast.receive_everywhere(payload, HOST, now)
            assert replies == general(reference, payload, now)
            assert_same_state(fast, reference)


@settings(max_examples=200, deadline=None)
@given(st.lists(quadlet, max_size=70), st.integers(0, 0xFF))
def test_split_write_gives_each_board_its_decode(words: list[int], start: int) -> None:
    shares = split_rev8_write(words, start)
    for board_id in range(16):
        own = decode_rev8_write(words, start, board_id)
        assert shares.get(board_id, own) == own
        if board_id not in shares:
            assert not own.dac_commands and not own.control


@st.composite
def block_chains(draw: st.DrawFn) -> tuple[list[int], int]:
    """Block writes as the host makes them, but with boards named more than once, blocks
    of any length (0: the whole address span) and a chain cut anywhere; starting at
    address 0 or just before it comes round."""
    words: list[int] = []
    for _ in range(draw(st.integers(0, 10))):
        length = draw(st.sampled_from([0, 1, 2, 3, 6, 6, 6, 9]))
        owner = draw(st.integers(0, 3))
        words.append(draw(quadlet) & ~0xFFF | owner << 8 | length)
        words += draw(st.lists(quadlet, min_size=max(length - 1, 0), max_size=8))
    cut = draw(st.integers(0, len(words)))
    return words[:cut], draw(st.one_of(st.just(0), st.integers(0xF8, 0xFF)))


@settings(max_examples=200, deadline=None)
@given(block_chains())
def test_split_write_of_block_chains_gives_each_board_its_decode(
    chain: tuple[list[int], int],
) -> None:
    words, start = chain
    shares = split_rev8_write(words, start)
    for board_id in range(16):
        assert shares.get(board_id, NO_SHARE) == decode_rev8_write(words, start, board_id)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.integers(0, 15), min_size=2, max_size=8, unique=True),
    st.integers(1, 0xFFFF),
    st.lists(st.integers(0, 10**6), min_size=2, max_size=2),
)
def test_shared_blocks_are_stored_as_their_broadcasts(
    ids: list[int], sequence: int, delays: list[int]
) -> None:
    boards = [Qla1Board(board_id=board_id, firmware=9) for board_id in ids]
    value = sequence << 16 | sum(1 << board_id for board_id in ids)
    for board in boards:
        board.set_time(delays[0])
        board.write_quadlet(HUB_QUERY, value)
    hub, *others = boards
    twin = copy.deepcopy(hub)
    for board in (hub, twin):
        board.set_time(delays[0] + delays[1])  # blocks may come later than the query
    for other in others:
        broadcast = hub_broadcast(other, 0)
        assert broadcast is not None
        hub.store_hub_broadcast(struct.unpack(f">{len(broadcast.data) // 4}I", broadcast.data))
    twin.store_hub_blocks([other.hub.blocks[other.board_id] for other in others])
    assert snapshot(twin) == snapshot(hub)


# -- what it takes and what it leaves -----------------------------------------------------------


def fast_path(ids: list[int], firmware: int = 9) -> tuple[Rack, RackFastPath]:
    rack = Rack(ids, firmware=firmware)
    return rack, RackFastPath(rack.members, firmware)


def test_the_hosts_cycle_goes_the_fast_way_and_answers_from_the_hub() -> None:
    rack, fast = fast_path([0, 1, 2, 3])
    replies = fast.receive(query(1, 0b1111), HOST, 0.001)
    assert replies is not None
    [(index, reply)] = replies
    assert index == 0 and reply.address == HOST
    words = rt_block(2, [DAC_VALID | 0x1234] * 4, 0)
    assert fast.receive(rt_write(words), HOST, 0.002) == []
    assert rack.members[2].board.channels[0].dac_command == 0x1234
    assert rack.members[1].board.channels[0].dac_command != 0x1234


def test_anything_unusual_is_left_to_the_general_path() -> None:
    rack, fast = fast_path([0, 1, 2])
    before = rack_state(rack)
    declined = [
        query(1, 0b011),  # not every board of the rack
        query(1, 0b111, offset=0xFFFF_0000_1800),  # an alias of 0x1800
        query(1, 0b111)[:-2],  # bad length
        rt_write(rt_block(0, [0] * 4, 0), offset=4),  # another address
        datagram(
            QuadletWriteRequest(
                destination_id=EVERY_NODE,
                tlabel=1,
                source_id=HOST_ID,
                offset=HUB_QUERY,
                quadlet_data=1 << 16 | 0b111,
            ),
            no_forward=False,
        ),
        b"\x01",
    ]
    for payload in declined:
        assert fast.receive(payload, HOST, 0.001) is None
    assert rack_state(rack) == before
    rack.members[1].board.defects = frozenset({DEFECT_RT_WRITE_ANY_BOARD})
    before = rack_state(rack)
    assert fast.receive(query(1, 0b111), HOST, 0.001) is None
    assert rack_state(rack) == before


def test_a_repeated_sequence_is_left_to_the_general_path() -> None:
    _, fast = fast_path([0, 1])
    assert fast.receive(query(7, 0b11), HOST, 0.001) is not None
    assert fast.receive(query(7, 0b11), HOST, 0.002) is None


def test_bridge_mode_is_never_taken_by_the_multicast_path() -> None:
    _, fast = fast_path([0, 1], firmware=8)
    assert fast.receive(query(1, 0b11), HOST, 0.001) is None


# -- bridge mode (firmware 8 and before): the hub's broadcasts in one pass ----------------------


def bridge_write(ids: list[int], firmware: int, draw: st.DrawFn) -> list[int]:
    """The host's broadcast write for ``firmware`` (§4.6), boards in some order."""
    words: list[int] = []
    for board_id in draw(st.permutations(ids)):
        dacs = draw(st.lists(dac, min_size=4, max_size=4))
        if firmware >= 8:
            words += rt_block(board_id, dacs, draw(control))
            continue
        tagged = [value & ~(0xF << 24) | board_id << 24 for value in dacs]
        words += tagged + ([draw(control)] if firmware == 7 else [])
    return words


@st.composite
def bridge_scenarios(draw: st.DrawFn) -> tuple[list[int], int, list[tuple[str, Any]]]:
    ids = draw(st.lists(st.integers(0, 15), min_size=1, max_size=8, unique=True))
    firmware = draw(st.sampled_from([4, 5, 6, 7, 8]))
    mask = sum(1 << board_id for board_id in ids)
    sequence = st.integers(0, 0xFFFF)

    def bridge(packet: Request) -> bytes:
        return datagram(packet, no_forward=False)

    def to_everyone(value: int, offset: int = HUB_QUERY) -> bytes:
        return bridge(
            QuadletWriteRequest(
                destination_id=EVERY_NODE,
                tlabel=5,
                source_id=HOST_ID,
                offset=offset,
                quadlet_data=value,
            )
        )

    def write(words: list[int], offset: int = 0) -> bytes:
        data = struct.pack(f">{len(words)}I", *words)
        return bridge(
            BlockWriteRequest(
                destination_id=EVERY_NODE, tlabel=6, source_id=HOST_ID, offset=offset, data=data
            )
        )

    def read(node: int, offset: int, count: int) -> bytes:
        return bridge(
            BlockReadRequest(
                destination_id=LOCAL_BUS_IDS | node,
                tlabel=7,
                source_id=HOST_ID,
                offset=offset,
                data_length=4 * count,
            )
        )

    cycle = st.builds(
        lambda s, w: [to_everyone(s << 16 | mask), write(w)],
        sequence,
        st.builds(lambda: bridge_write(ids, firmware, draw)),
    )
    single = st.one_of(
        st.builds(lambda s, m: to_everyone(s << 16 | m), sequence, st.integers(0, 0xFFFF)),
        st.builds(lambda s: to_everyone(s << 16 | mask, 0xFFFF_0000_1800), sequence),
        st.builds(lambda s: query(s, mask), sequence),  # no-forward set
        st.builds(lambda w: write(w), st.lists(quadlet, max_size=24)),
        st.builds(lambda w: write(w, offset=4), st.lists(quadlet, min_size=1, max_size=8)),
        st.builds(lambda w: write(w)[:-3], st.lists(quadlet, max_size=8)),
        st.builds(
            read, st.integers(0, len(ids) - 1), st.sampled_from([0, 0x1000]), st.integers(1, 40)
        ),
        st.binary(max_size=40),
    )
    events = st.one_of(
        st.tuples(st.just("datagrams"), cycle),
        st.tuples(st.just("datagrams"), cycle),
        st.tuples(st.just("datagrams"), single.map(lambda one: [one])),
        st.tuples(
            st.just("register"), st.tuples(st.sampled_from(ids), st.integers(0, 0x4F), quadlet)
        ),
        st.tuples(st.just("wait"), st.sampled_from([0.0, 1e-6, 2e-4, 0.05])),
        st.tuples(st.just("bus"), st.sampled_from(["reset", "resetting", "settled"])),
    )
    return ids, firmware, draw(st.lists(events, min_size=1, max_size=20))


@settings(max_examples=120, deadline=None)
@given(bridge_scenarios())
def test_bridge_one_pass_equals_the_general_path(
    scenario: tuple[list[int], int, list[Any]],
) -> None:
    ids, firmware, script = scenario
    fast, reference = Rack(ids, firmware=firmware), Rack(ids, firmware=firmware)
    reference.fast_path = None
    now = 0.001
    for kind, detail in script:
        if kind == "wait":
            now += detail
        elif kind == "bus":
            for rack in (fast, reference):
                if detail == "reset":
                    rack.bus_reset()
                rack.bus.resetting = detail == "resetting"
        elif kind == "register":
            board_id, index, value = detail
            for rack in (fast, reference):
                member = next(m for m in rack.members if m.board.board_id == board_id)
                member.responder.advance_clock(now)
                member.board.write_quadlet(index, value)
        else:
            for payload in detail:
                replies = fast.receive(0, payload, HOST, now)
                assert replies == reference.receive(0, payload, HOST, now)
                assert_same_state(fast, reference)


def test_the_bridge_cycle_goes_the_fast_way() -> None:
    rack = Rack([0, 1, 2], firmware=7)
    assert rack.fast_path is not None
    query_bridge = datagram(
        QuadletWriteRequest(
            destination_id=EVERY_NODE, tlabel=1, source_id=HOST_ID, offset=HUB_QUERY,
            quadlet_data=0x0123_0007,
        ),
        no_forward=False,
    )  # fmt: skip
    assert rack.fast_path.bridge(query_bridge, HOST, 0.001, resetting=False) == []
    hub = rack.members[0].board.hub
    assert sorted(hub.blocks) == [0, 1, 2] and hub.complete
    assert rack.fast_path.bridge(query_bridge, HOST, 0.002, resetting=False) is None
    assert rack.fast_path.bridge(query(9, 0b111), HOST, 0.003, resetting=False) is None
