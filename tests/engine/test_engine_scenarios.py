"""One scenario per path of docs/engine.md, checking the exact packets exchanged."""

from __future__ import annotations

from dataclasses import replace

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import (
    IEEE1394_NODE,
    JHU_FIRMWARE,
    THESIS_FPGA,
    FailureReason,
    LockCompleted,
    ReadCompleted,
    Requester,
    Responder,
    ResponderPolicy,
    TransactionFailed,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.engine.loopback import Link
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    ExtendedTCode,
    LockRequest,
    LockResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    RCode,
    Retry,
    RoutedPacket,
    WriteResponse,
)

HOST, NODE = 0xFFC1, 0xFFC0
CONTENTS = bytes(range(256)) * 4
PENDING, COMPLETE = AckCode.ack_pending, AckCode.ack_complete

Wire = list[tuple[str, AsyncPacket | int | None, bool]]


def make_link(
    policy: ResponderPolicy, *, requester: Requester | None = None, **options: object
) -> tuple[Link, MemorySpace]:
    space = MemorySpace(len(CONTENTS), contents=CONTENTS)
    link = Link(requester or Requester(node_id=HOST), [Responder(NODE, space, policy)], **options)  # type: ignore[arg-type]
    return link, space


def wire(link: Link) -> Wire:
    """(kind, packet or ack, concatenated) per exchange."""
    return [
        (e.kind, e.packet if e.packet is not None else e.ack, e.concatenated) for e in link.trace
    ]


def quadlet_at(offset: int) -> int:
    return int.from_bytes(CONTENTS[offset : offset + 4], "big")


def qread(label: int = 0, offset: int = 8, retry: int = Retry.retry_1) -> QuadletReadRequest:
    return QuadletReadRequest(
        destination_id=NODE, tlabel=label, source_id=HOST, offset=offset, retry=retry
    )


def qread_response(label: int = 0, offset: int = 8, rcode: int = 0) -> QuadletReadResponse:
    value = quadlet_at(offset) if rcode == 0 else 0
    return QuadletReadResponse(
        destination_id=HOST, tlabel=label, source_id=NODE, quadlet_data=value, rcode=rcode
    )


def qwrite(label: int = 0, offset: int = 8, value: int = 0xCAFEF00D) -> QuadletWriteRequest:
    return QuadletWriteRequest(
        destination_id=NODE, tlabel=label, source_id=HOST, offset=offset, quadlet_data=value
    )


def break_header_crc(packet: RoutedPacket, raw: bytes) -> bytes:
    # Byte 4 holds the source ID: a flipped bit there fails the header CRC.
    return raw[:4] + bytes([raw[4] ^ 0x01]) + raw[5:]


def break_data_crc(packet: RoutedPacket, raw: bytes) -> bytes:
    # The last byte is part of the data CRC (the header CRC of a quadlet write).
    return raw[:-1] + bytes([raw[-1] ^ 0x01])


# -- concatenated, split, unified -------------------------------------------------------
def test_concatenated_read_thesis_fpga() -> None:
    link, _ = make_link(THESIS_FPGA)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert wire(link) == [
        ("request", qread(), False),
        ("ack", PENDING, False),
        ("response", qread_response(), True),
        ("ack", COMPLETE, False),
    ]
    assert {e.time for e in link.trace} == {0.0}  # one bus tenure
    assert link.requester.events() == [ReadCompleted(tid, CONTENTS[8:12])]


def test_concatenated_block_read_jhu_firmware() -> None:
    link, _ = make_link(JHU_FIRMWARE)
    tid = link.requester.read_block(NODE, 16, 32, link.now)
    link.run()
    request = BlockReadRequest(
        destination_id=NODE, tlabel=0, source_id=HOST, offset=16, data_length=32
    )
    response = BlockReadResponse(
        destination_id=HOST, tlabel=0, source_id=NODE, data=CONTENTS[16:48]
    )
    assert wire(link) == [
        ("request", request, False),
        ("ack", PENDING, False),
        ("response", response, True),
        ("ack", COMPLETE, False),
    ]
    assert link.requester.events() == [ReadCompleted(tid, CONTENTS[16:48])]


def test_split_read_ieee_node() -> None:
    link, _ = make_link(IEEE1394_NODE, split_delay=0.005)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert wire(link) == [
        ("request", qread(), False),
        ("ack", PENDING, False),
        ("response", qread_response(), False),
        ("ack", COMPLETE, False),
    ]
    assert [e.time for e in link.trace] == [0.0, 0.0, 0.005, 0.005]
    assert link.requester.events() == [ReadCompleted(tid, CONTENTS[8:12])]


def test_unified_write_thesis_fpga() -> None:
    link, space = make_link(THESIS_FPGA)
    tid = link.requester.write_quadlet(NODE, 8, 0xCAFEF00D, link.now)
    link.run()
    assert wire(link) == [("request", qwrite(), False), ("ack", COMPLETE, False)]
    assert link.requester.events() == [WriteCompleted(tid)]
    assert space.read_quadlet(8) == 0xCAFEF00D


def test_split_write_ieee_node() -> None:
    link, space = make_link(IEEE1394_NODE, split_delay=0.002)
    tid = link.requester.write_block(NODE, 32, b"\x11" * 8, link.now)
    link.run()
    request = BlockWriteRequest(
        destination_id=NODE, tlabel=0, source_id=HOST, offset=32, data=b"\x11" * 8
    )
    assert wire(link) == [
        ("request", request, False),
        ("ack", PENDING, False),
        ("response", WriteResponse(destination_id=HOST, tlabel=0, source_id=NODE), False),
        ("ack", COMPLETE, False),
    ]
    assert link.requester.events() == [WriteCompleted(tid)]
    assert space.read_block(32, 8) == b"\x11" * 8


def test_split_lock_ieee_node() -> None:
    link, space = make_link(IEEE1394_NODE)
    old = CONTENTS[64:68]
    tid = link.requester.lock(
        NODE, 64, ExtendedTCode.compare_swap, old, b"\xaa\xbb\xcc\xdd", link.now
    )
    link.run()
    request = LockRequest(
        destination_id=NODE,
        tlabel=0,
        source_id=HOST,
        offset=64,
        extended_tcode=ExtendedTCode.compare_swap,
        data=old + b"\xaa\xbb\xcc\xdd",
    )
    response = LockResponse(
        destination_id=HOST,
        tlabel=0,
        source_id=NODE,
        extended_tcode=ExtendedTCode.compare_swap,
        data=old,
    )
    assert wire(link) == [
        ("request", request, False),
        ("ack", PENDING, False),
        ("response", response, False),
        ("ack", COMPLETE, False),
    ]
    assert link.requester.events() == [LockCompleted(tid, old)]
    assert space.read_block(64, 4) == b"\xaa\xbb\xcc\xdd"


# -- damaged packets --------------------------------------------------------------------
def test_bad_crc_dropped_by_thesis_fpga() -> None:
    link, space = make_link(THESIS_FPGA, tamper=break_data_crc)
    tid = link.requester.write_quadlet(NODE, 8, 0xCAFEF00D, link.now)
    link.run()
    assert wire(link) == [("request", qwrite(), False), ("no_ack", None, False)]
    assert link.trace[0].faults == ("tampered",)
    # Silence leaves open whether the write was performed (here it was not).
    assert link.requester.events() == [
        TransactionFailed(
            tid,
            FailureReason.no_ack,
            detail="no ack; outcome unknown: the write may have been performed",
            outcome_unknown=True,
        )
    ]
    assert space.read_quadlet(8) == quadlet_at(8)


def test_bad_data_crc_acked_by_ieee_node() -> None:
    link, space = make_link(IEEE1394_NODE, tamper=break_data_crc)
    tid = link.requester.write_block(NODE, 32, b"\x11" * 8, link.now)
    link.run()
    assert [(kind, item) for kind, item, _ in wire(link)][1:] == [("ack", AckCode.ack_data_error)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.ack_data_error, detail="ack_data_error")
    ]
    assert space.read_block(32, 8) == CONTENTS[32:40]


def test_bad_header_crc_ignored_by_ieee_node() -> None:
    link, _ = make_link(IEEE1394_NODE, tamper=break_header_crc)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert wire(link) == [("request", qread(), False), ("no_ack", None, False)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.no_ack, detail="no ack")
    ]


def test_jhu_firmware_performs_damaged_write_and_acks_data_error() -> None:
    link, space = make_link(JHU_FIRMWARE, tamper=break_data_crc)
    tid = link.requester.write_quadlet(NODE, 8, 0xCAFEF00D, link.now)
    link.run()
    assert wire(link) == [("request", qwrite(), False), ("ack", AckCode.ack_data_error, False)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.ack_data_error, detail="ack_data_error")
    ]
    assert space.read_quadlet(8) == 0xCAFEF00D


def test_jhu_firmware_damaged_read_gets_ack_data_error_and_no_response() -> None:
    link, _ = make_link(JHU_FIRMWARE, tamper=break_header_crc)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert wire(link) == [("request", qread(), False), ("ack", AckCode.ack_data_error, False)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.ack_data_error, detail="ack_data_error")
    ]


# -- addressing -------------------------------------------------------------------------
def test_request_to_another_node_gets_silence() -> None:
    link, _ = make_link(IEEE1394_NODE)
    tid = link.requester.read_quadlet(0xFFC5, 8, link.now)
    link.run()
    request = QuadletReadRequest(destination_id=0xFFC5, tlabel=0, source_id=HOST, offset=8)
    assert wire(link) == [("request", request, False), ("no_ack", None, False)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.no_ack, detail="no ack")
    ]


def test_broadcast_write_performed_by_every_node_never_acked() -> None:
    spaces = [MemorySpace(64), MemorySpace(64)]
    link = Link(
        Requester(node_id=HOST),
        [Responder(0xFFC0, spaces[0], THESIS_FPGA), Responder(0xFFC2, spaces[1], IEEE1394_NODE)],
    )
    tid = link.requester.write_quadlet(0xFFFF, 4, 0x01020304, link.now)
    assert link.requester.events() == [WriteCompleted(tid)]
    assert link.requester.outstanding == 0
    link.run()
    request = QuadletWriteRequest(
        destination_id=0xFFFF, tlabel=0, source_id=HOST, offset=4, quadlet_data=0x01020304
    )
    assert wire(link) == [("request", request, False)]
    assert [space.read_quadlet(4) for space in spaces] == [0x01020304, 0x01020304]


def test_broadcast_read_ignored() -> None:
    link, _ = make_link(IEEE1394_NODE)
    tid = link.requester.read_quadlet(0xFFFF, 8, link.now)
    link.run()
    request = QuadletReadRequest(destination_id=0xFFFF, tlabel=0, source_id=HOST, offset=8)
    assert wire(link) == [("request", request, False), ("no_ack", None, False)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.no_ack, detail="no ack")
    ]


# -- unsupported tcode and address errors -----------------------------------------------
def test_unsupported_tcode_silent_on_thesis_fpga() -> None:
    link, _ = make_link(THESIS_FPGA)
    tid = link.requester.lock(NODE, 0, ExtendedTCode.fetch_add, b"", b"\0\0\0\1", link.now)
    link.run()
    assert [kind for kind, _, _ in wire(link)] == ["request", "no_ack"]
    assert link.requester.events() == [
        TransactionFailed(
            tid,
            FailureReason.no_ack,
            detail="no ack; outcome unknown: the lock may have been performed",
            outcome_unknown=True,
        )
    ]


def test_unsupported_tcode_acked_type_error_by_standard_node() -> None:
    link, _ = make_link(ResponderPolicy(locks=False))
    tid = link.requester.lock(NODE, 0, ExtendedTCode.fetch_add, b"", b"\0\0\0\1", link.now)
    link.run()
    assert [(kind, item) for kind, item, _ in wire(link)][1:] == [("ack", AckCode.ack_type_error)]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.ack_type_error, detail="ack_type_error")
    ]


def test_address_error_in_the_ack() -> None:
    link, _ = make_link(THESIS_FPGA)
    tid = link.requester.read_quadlet(NODE, 0x10000, link.now)
    link.run()
    assert wire(link) == [
        ("request", qread(offset=0x10000), False),
        ("ack", AckCode.ack_address_error, False),
    ]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.ack_address_error, detail="ack_address_error")
    ]


def test_address_error_in_the_rcode() -> None:
    link, _ = make_link(IEEE1394_NODE)
    tid = link.requester.read_quadlet(NODE, 0x10000, link.now)
    link.run()
    assert wire(link) == [
        ("request", qread(offset=0x10000), False),
        ("ack", PENDING, False),
        ("response", qread_response(offset=0x10000, rcode=RCode.resp_address_error), False),
        ("ack", COMPLETE, False),
    ]
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.rcode_error, rcode=RCode.resp_address_error)
    ]


def test_address_error_rcode_on_a_unified_write_uses_the_ack() -> None:
    link, _ = make_link(ResponderPolicy(write_mode="unified", address_error="rcode"))
    tid = link.requester.write_quadlet(NODE, 0x10000, 1, link.now)
    link.run()
    assert [item for _, item, _ in wire(link)][1:] == [AckCode.ack_address_error]
    assert link.requester.events()[0] == TransactionFailed(
        tid, FailureReason.ack_address_error, detail="ack_address_error"
    )


# -- busy -------------------------------------------------------------------------------
def test_busy_single_phase_retries_with_retry_x() -> None:
    link, _ = make_link(THESIS_FPGA)
    link.responders[0].inject_busy(2)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run()
    busy = AckCode.ack_busy_X
    assert wire(link) == [
        ("request", qread(), False),
        ("ack", busy, False),
        ("request", qread(retry=Retry.retry_X), False),
        ("ack", busy, False),
        ("request", qread(retry=Retry.retry_X), False),
        ("ack", PENDING, False),
        ("response", qread_response(), True),
        ("ack", COMPLETE, False),
    ]
    assert [e.time for e in link.trace if e.kind == "request"] == [0.0, 0.001, 0.002]
    assert link.requester.events() == [ReadCompleted(tid, CONTENTS[8:12])]


def test_busy_dual_phase_echoes_the_phase() -> None:
    requester = Requester(node_id=HOST, retry_protocol="dual")
    link, _ = make_link(THESIS_FPGA, requester=requester)
    responder = link.responders[0]
    responder.inject_busy(1, AckCode.ack_busy_A)
    first = requester.write_quadlet(NODE, 8, 0xCAFEF00D, link.now)
    link.run()
    responder.inject_busy(1, AckCode.ack_busy_B)
    second = requester.write_quadlet(NODE, 8, 0xCAFEF00D, link.now)
    link.run()
    assert wire(link) == [
        ("request", qwrite(), False),
        ("ack", AckCode.ack_busy_A, False),
        ("request", replace(qwrite(), retry=Retry.retry_A), False),
        ("ack", COMPLETE, False),
        ("request", qwrite(label=1), False),
        ("ack", AckCode.ack_busy_B, False),
        ("request", replace(qwrite(label=1), retry=Retry.retry_B), False),
        ("ack", COMPLETE, False),
    ]
    assert requester.events() == [WriteCompleted(first), WriteCompleted(second)]


def test_busy_retries_exhausted() -> None:
    requester = Requester(node_id=HOST, max_busy_retries=2)
    link, _ = make_link(THESIS_FPGA, requester=requester)
    link.responders[0].inject_busy(10)
    tid = requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert [kind for kind, _, _ in wire(link)] == ["request", "ack"] * 3
    assert requester.events() == [
        TransactionFailed(
            tid, FailureReason.busy_retries_exhausted, detail="2 retries, then ack_busy_X"
        )
    ]


# -- the requester's clocks and bus resets ----------------------------------------------
def test_split_timeout_then_late_response() -> None:
    link, _ = make_link(IEEE1394_NODE, split_delay=0.150)
    tid = link.requester.read_quadlet(NODE, 8, link.now)
    link.run(0.120)
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.response_timeout, detail="split timeout")
    ]
    link.run()
    assert wire(link)[2:] == [("response", qread_response(), False), ("ack", COMPLETE, False)]
    (late,) = link.requester.events()
    assert isinstance(late, UnexpectedResponse)
    assert late.ended_transaction == tid


def test_no_ack_by_ack_timeout_when_the_transport_does_not_report() -> None:
    link, _ = make_link(IEEE1394_NODE, report_missing_acks=False)
    tid = link.requester.read_quadlet(0xFFC9, 8, link.now)
    link.run()
    assert link.now == 0.050
    assert link.requester.events() == [
        TransactionFailed(tid, FailureReason.no_ack, detail="ack timeout")
    ]


def test_bus_reset_fails_outstanding_and_loses_packets_in_flight() -> None:
    link, _ = make_link(IEEE1394_NODE, split_delay=0.050)
    requester = link.requester
    tid = requester.read_quadlet(NODE, 8, link.now)
    link.run(0.010)
    assert requester.outstanding == 1 and link.in_flight == 1
    link.bus_reset(1)
    assert requester.events() == [
        TransactionFailed(tid, FailureReason.bus_reset, detail="bus generation 0 -> 1")
    ]
    assert link.in_flight == 0
    after = requester.read_quadlet(NODE, 8, link.now)
    link.run()
    assert requester.generation == 1
    assert requester.events() == [ReadCompleted(after, CONTENTS[8:12])]
    assert [kind for kind, _, _ in wire(link)] == [
        "request",
        "ack",
        "bus_reset",
        "request",
        "ack",
        "response",
        "ack",
    ]
