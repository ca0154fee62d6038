"""The responder alone, fed wire bytes: every screen and outcome of its table."""

from __future__ import annotations

import pytest

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import (
    IEEE1394_NODE,
    JHU_FIRMWARE,
    THESIS_FPGA,
    Reply,
    Responder,
    ResponderPolicy,
)
from fw1394.engine.space import (
    AddressError,
    BusyError,
    DataError,
    SpaceError,
    TypeError1394,
)
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    CycleStart,
    ExtendedTCode,
    LockRequest,
    LockResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    RCode,
    StreamPacket,
    WriteResponse,
    encode,
)

HOST, NODE = 0xFFC1, 0xFFC0
SILENCE = Reply(None, None, False)
PENDING = AckCode.ack_pending


def flip(raw: bytes, index: int) -> bytes:
    return raw[:index] + bytes([raw[index] ^ 0x01]) + raw[index + 1 :]


def responder(policy: ResponderPolicy, space: object | None = None) -> Responder:
    return Responder(NODE, space or MemorySpace(256), policy)  # type: ignore[arg-type]


class FailingSpace(MemorySpace):
    """Memory whose every access raises ``error``."""

    def __init__(self, error: SpaceError) -> None:
        super().__init__(64)
        self.error = error

    def read_quadlet(self, offset: int) -> int:
        raise self.error

    def write_quadlet(self, offset: int, value: int) -> None:
        raise self.error


# -- packets a responder does not serve -------------------------------------------------
@pytest.mark.parametrize("policy", [THESIS_FPGA, IEEE1394_NODE, JHU_FIRMWARE])
@pytest.mark.parametrize(
    "raw",
    [
        b"\xff\xc0\x00",  # shorter than a quadlet
        b"\xff\xc0\x00\xe0" + bytes(12),  # reserved tcode 0xE
        encode(QuadletReadRequest(destination_id=NODE))[:8],  # header cut short
        encode(QuadletReadResponse(destination_id=NODE, source_id=HOST)),
        encode(WriteResponse(destination_id=NODE, source_id=HOST)),
        encode(CycleStart(quadlet_data=5)),
        encode(StreamPacket(channel=3, data=b"abcd")),
        encode(QuadletReadRequest(destination_id=0xFFC3, source_id=HOST)),
    ],
)
def test_silence_for_what_is_not_a_request_to_this_node(
    policy: ResponderPolicy, raw: bytes
) -> None:
    assert responder(policy).receive(raw, 0.0) == SILENCE


def test_bus_id_compared_only_by_standard_nodes() -> None:
    raw = encode(QuadletReadRequest(destination_id=0x0140, source_id=HOST))  # bus 5
    assert responder(IEEE1394_NODE).receive(raw, 0.0) == SILENCE
    assert responder(THESIS_FPGA).receive(raw, 0.0).ack == PENDING


def test_own_bus_number_is_accepted() -> None:
    node = Responder(0x0140, MemorySpace(64), IEEE1394_NODE)
    raw = encode(QuadletReadRequest(destination_id=0x0140, source_id=0x0141))
    assert node.receive(raw, 0.0).ack == PENDING


def test_bus_reset_gives_a_new_physical_id() -> None:
    node = responder(IEEE1394_NODE)
    node.bus_reset(node_id=0xFFC4, generation=3)
    assert (node.node_id, node.generation) == (0xFFC4, 3)
    old = encode(QuadletReadRequest(destination_id=NODE, source_id=HOST))
    new = encode(QuadletReadRequest(destination_id=0xFFC4, source_id=HOST))
    assert node.receive(old, 0.0) == SILENCE
    reply = node.receive(new, 0.0)
    assert reply.response is not None and reply.response.source_id == 0xFFC4  # type: ignore[attr-defined]


# -- damaged packets --------------------------------------------------------------------
WRITE = encode(QuadletWriteRequest(destination_id=NODE, source_id=HOST, offset=8, quadlet_data=9))
BLOCK_WRITE = encode(
    BlockWriteRequest(destination_id=NODE, source_id=HOST, offset=8, data=b"\x07" * 8)
)
READ = encode(QuadletReadRequest(destination_id=NODE, source_id=HOST, offset=8))


@pytest.mark.parametrize(
    ("policy", "raw", "ack", "written"),
    [
        (THESIS_FPGA, flip(WRITE, 4), None, False),
        (THESIS_FPGA, flip(BLOCK_WRITE, 21), None, False),
        # IEEE: a bad header CRC is ignored, a bad data CRC acked.
        (IEEE1394_NODE, flip(WRITE, 4), None, False),
        (IEEE1394_NODE, flip(BLOCK_WRITE, 4), None, False),
        (IEEE1394_NODE, flip(BLOCK_WRITE, 21), AckCode.ack_data_error, False),
        (IEEE1394_NODE, BLOCK_WRITE + b"\0\0\0\0", AckCode.ack_data_error, False),
        (IEEE1394_NODE, BLOCK_WRITE[:-4], AckCode.ack_data_error, False),
        # JHU: acked ack_data_error and written all the same...
        (JHU_FIRMWARE, flip(WRITE, 4), AckCode.ack_data_error, True),
        (JHU_FIRMWARE, flip(BLOCK_WRITE, 21), AckCode.ack_data_error, True),
        # ...but a block write's header CRC is never compared.
        (JHU_FIRMWARE, flip(BLOCK_WRITE, 5), AckCode.ack_complete, True),
    ],
)
def test_damaged_writes(
    policy: ResponderPolicy, raw: bytes, ack: int | None, written: bool
) -> None:
    space = MemorySpace(64)
    assert responder(policy, space).receive(raw, 0.0) == Reply(ack, None, False)
    assert (space.contents() != bytes(64)) == written


@pytest.mark.parametrize(
    ("policy", "ack"),
    [(THESIS_FPGA, None), (IEEE1394_NODE, None), (JHU_FIRMWARE, AckCode.ack_data_error)],
)
def test_damaged_read_header(policy: ResponderPolicy, ack: int | None) -> None:
    assert responder(policy).receive(flip(READ, 10), 0.0) == Reply(ack, None, False)


def test_damaged_broadcast_write_is_never_acked() -> None:
    raw = flip(encode(QuadletWriteRequest(destination_id=0xFFFF, offset=8, quadlet_data=9)), 4)
    space = MemorySpace(64)
    assert responder(JHU_FIRMWARE, space).receive(raw, 0.0) == SILENCE
    assert space.read_quadlet(8) == 9


def test_unsupported_tcode_before_the_crc_on_silent_nodes() -> None:
    lock = encode(LockRequest(destination_id=NODE, source_id=HOST, data=b"\0" * 8))
    assert responder(JHU_FIRMWARE).receive(flip(lock, 20), 0.0) == SILENCE
    standard = responder(ResponderPolicy(locks=False))
    assert standard.receive(flip(lock, 20), 0.0).ack == AckCode.ack_data_error
    assert standard.receive(lock, 0.0).ack == AckCode.ack_type_error


# -- broadcast --------------------------------------------------------------------------
def test_broadcast_write_performed_even_when_refused() -> None:
    space = MemorySpace(16)
    node = responder(IEEE1394_NODE, space)
    inside = encode(QuadletWriteRequest(destination_id=0xFFFF, offset=4, quadlet_data=3))
    outside = encode(QuadletWriteRequest(destination_id=0xFFFF, offset=64, quadlet_data=3))
    assert node.receive(inside, 0.0) == SILENCE
    assert node.receive(outside, 0.0) == SILENCE
    assert space.read_quadlet(4) == 3


def test_broadcast_block_write_and_read() -> None:
    space = MemorySpace(16)
    node = responder(THESIS_FPGA, space)
    write = encode(BlockWriteRequest(destination_id=0xFFFF, offset=0, data=b"\x05" * 8))
    read = encode(BlockReadRequest(destination_id=0xFFFF, offset=0, data_length=8))
    assert node.receive(write, 0.0) == SILENCE
    assert node.receive(read, 0.0) == SILENCE
    assert space.read_block(0, 8) == b"\x05" * 8


# -- outcomes of the space --------------------------------------------------------------
@pytest.mark.parametrize(
    ("error", "policy", "ack", "rcode"),
    [
        (AddressError(), IEEE1394_NODE, PENDING, RCode.resp_address_error),
        (AddressError(), THESIS_FPGA, AckCode.ack_address_error, None),
        (DataError(), IEEE1394_NODE, PENDING, RCode.resp_data_error),
        (DataError(), THESIS_FPGA, PENDING, RCode.resp_data_error),
        (TypeError1394(), IEEE1394_NODE, PENDING, RCode.resp_type_error),
        (SpaceError(), IEEE1394_NODE, PENDING, RCode.resp_conflict_error),
        (BusyError(), IEEE1394_NODE, AckCode.ack_busy_X, None),
    ],
)
def test_read_outcomes(
    error: SpaceError, policy: ResponderPolicy, ack: int, rcode: int | None
) -> None:
    reply = responder(policy, FailingSpace(error)).receive(READ, 0.0)
    assert reply.ack == ack
    if rcode is None:
        assert reply.response is None
    else:
        assert reply.response == QuadletReadResponse(
            destination_id=HOST, tlabel=0, source_id=NODE, rcode=rcode
        )
        assert reply.concatenated == (policy.read_mode == "concatenated")


@pytest.mark.parametrize(
    ("error", "ack"),
    [
        (AddressError(), AckCode.ack_address_error),
        (DataError(), AckCode.ack_data_error),
        (TypeError1394(), AckCode.ack_type_error),
        (SpaceError(), AckCode.ack_conflict_error),
        (BusyError(), AckCode.ack_busy_X),
    ],
)
def test_unified_write_outcomes_are_acks(error: SpaceError, ack: int) -> None:
    assert responder(THESIS_FPGA, FailingSpace(error)).receive(WRITE, 0.0) == Reply(
        ack, None, False
    )


def test_split_write_error_response() -> None:
    reply = responder(IEEE1394_NODE, FailingSpace(DataError())).receive(WRITE, 0.0)
    assert reply == Reply(
        PENDING,
        WriteResponse(destination_id=HOST, source_id=NODE, rcode=RCode.resp_data_error),
        False,
    )


def test_block_read_error_response_carries_no_data() -> None:
    raw = encode(BlockReadRequest(destination_id=NODE, source_id=HOST, offset=0, data_length=512))
    reply = responder(IEEE1394_NODE, MemorySpace(64)).receive(raw, 0.0)
    assert reply.response == BlockReadResponse(
        destination_id=HOST, source_id=NODE, rcode=RCode.resp_address_error
    )
    assert reply.response.data_length == 0


def test_the_space_clock_follows_the_packets() -> None:
    space = MemorySpace(64)
    node = responder(THESIS_FPGA, space)
    node.receive(READ, 0.5)
    assert space.ticks == 24_576_000
    node.receive(READ, 0.25)  # never backwards
    assert space.ticks == 24_576_000


def test_inject_busy_counts_and_checks_its_code() -> None:
    node = responder(IEEE1394_NODE)
    node.inject_busy(2, AckCode.ack_busy_B)
    assert [node.receive(READ, 0.0).ack for _ in range(3)] == [
        AckCode.ack_busy_B,
        AckCode.ack_busy_B,
        PENDING,
    ]
    with pytest.raises(ValueError):
        node.inject_busy(1, AckCode.ack_complete)


def test_policy_values_are_checked() -> None:
    with pytest.raises(ValueError):
        ResponderPolicy(read_mode="unified")  # type: ignore[arg-type]


# -- locks ------------------------------------------------------------------------------
def lock(extended_tcode: int, argument: bytes, data: bytes) -> bytes:
    return encode(
        LockRequest(
            destination_id=NODE,
            source_id=HOST,
            offset=16,
            extended_tcode=extended_tcode,
            data=argument + data,
        )
    )


def q(value: int, size: int = 4) -> bytes:
    return value.to_bytes(size, "big")


@pytest.mark.parametrize("size", [4, 8])
@pytest.mark.parametrize(
    ("extended_tcode", "old", "argument", "data", "new"),
    [
        (ExtendedTCode.mask_swap, 0b1100, 0b1010, 0b0001, 0b0101),
        (ExtendedTCode.compare_swap, 5, 5, 9, 9),
        (ExtendedTCode.compare_swap, 5, 6, 9, 5),
        (ExtendedTCode.fetch_add, 5, None, 9, 14),
        (ExtendedTCode.bounded_add, 5, 7, 9, 14),
        (ExtendedTCode.bounded_add, 7, 7, 9, 7),
        (ExtendedTCode.wrap_add, 5, 7, 9, 14),
        (ExtendedTCode.wrap_add, 7, 7, 9, 9),
    ],
)
def test_lock_arithmetic(
    size: int, extended_tcode: int, old: int, argument: int | None, data: int, new: int
) -> None:
    space = MemorySpace(64)
    space.write_block(16, q(old, size))
    argument_bytes = b"" if argument is None else q(argument, size)
    reply = responder(IEEE1394_NODE, space).receive(
        lock(extended_tcode, argument_bytes, q(data, size)), 0.0
    )
    assert reply.response == LockResponse(
        destination_id=HOST, source_id=NODE, extended_tcode=extended_tcode, data=q(old, size)
    )
    assert space.read_block(16, size) == q(new, size)


def test_fetch_add_wraps_and_little_add_is_little_endian() -> None:
    space = MemorySpace(64)
    node = responder(IEEE1394_NODE, space)
    space.write_quadlet(16, 0xFFFFFFFF)
    node.receive(lock(ExtendedTCode.fetch_add, b"", q(2)), 0.0)
    assert space.read_quadlet(16) == 1
    space.write_block(16, bytes([0xFF, 0, 0, 0]))  # 255 as a little-endian number
    node.receive(lock(ExtendedTCode.little_add, b"", bytes([1, 0, 0, 0])), 0.0)
    assert space.read_block(16, 4) == bytes([0, 1, 0, 0])


@pytest.mark.parametrize(
    ("raw", "rcode"),
    [
        (lock(ExtendedTCode.vendor_dependent, q(0), q(0)), RCode.resp_type_error),
        (lock(ExtendedTCode.compare_swap, q(0, 2), q(0, 2)), RCode.resp_data_error),
        (lock(ExtendedTCode.fetch_add, b"", q(0, 16)), RCode.resp_data_error),
    ],
)
def test_lock_refusals(raw: bytes, rcode: int) -> None:
    reply = responder(IEEE1394_NODE).receive(raw, 0.0)
    assert reply.ack == PENDING
    assert reply.response is not None and reply.response.rcode == rcode  # type: ignore[attr-defined]
    assert reply.response.data == b""  # type: ignore[attr-defined]
