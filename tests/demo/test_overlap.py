"""The demo's overlapped cycle: a board's block write does not wait for the other's ack.

Two memory nodes on a real bus. What went out in which order is read off a
tap's records with the packet layout of IEEE 1394-1995 written out here: the
first quadlet is destination ID (16 bits), tlabel (6), retry (2), tcode (4),
priority (4).
"""

from __future__ import annotations

import os
import signal

import pytest
from bus_support import LaunchBus

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.demo.overlap import OverlappingPort
from fw1394.host.bus_port import BusPort
from fw1394.transport.bus_host import TransactionError

WRITE_BLOCK_REQUEST = 0x1
ACK_COMPLETE = 0x1
#: Every node's configuration ROM (IEEE 1212), which refuses writes.
ROM = 0xFFFF_F000_0400


def _tcode(record: BusRecord) -> int:
    return record.data[3] >> 4


def _destination_phy(record: BusRecord) -> int:
    return record.data[1] & 0x3F


def _records(tap: BusTap, packets: int) -> list[BusRecord]:
    """Records up to and including the ``packets``-th asynchronous packet."""
    found: list[BusRecord] = []
    while packets and (record := tap.receive(5.0)) is not None:
        found.append(record)
        packets -= record.record_type == RecordType.async_packet
    return found


@pytest.mark.process
def test_a_cycle_sends_the_next_boards_write_before_the_first_is_acked(
    launch_bus: LaunchBus,
) -> None:
    bus = launch_bus(2, tag="overlap")
    with BusPort(bus.config) as port, BusTap(bus.config.name) as tap:
        (first, stopped), (second, _) = [(p, m) for p, m in port.nodes() if not m.host]
        overlapping = OverlappingPort(port)
        # The first board cannot ack while it is stopped: a write that waited for
        # its ack would hold the second board's write back until it is resumed.
        os.kill(stopped.pid, signal.SIGSTOP)
        try:
            with overlapping.cycle():
                overlapping.write_block(first, 0x100, b"\x11" * 8)
                overlapping.write_block(second, 0x100, b"\x22" * 8)
                os.kill(stopped.pid, signal.SIGCONT)
        finally:
            os.kill(stopped.pid, signal.SIGCONT)
        # Ended with the cycle: both writes are on their boards.
        assert overlapping.read_block(first, 0x100, 8) == b"\x11" * 8
        assert overlapping.read_block(second, 0x100, 8) == b"\x22" * 8
        records = _records(tap, 4)  # the two writes, then the first read and its response
    writes = [
        i
        for i, r in enumerate(records)
        if r.record_type == RecordType.async_packet and _tcode(r) == WRITE_BLOCK_REQUEST
    ]
    assert [_destination_phy(records[i]) for i in writes] == [first, second]
    # Both carry their acks (the tap joins them), and the first board's ack came
    # only after the second board's write was on the bus.
    assert all(records[i].ack == ACK_COMPLETE for i in writes)
    first_ack = next(
        i for i, r in enumerate(records) if r.record_type == RecordType.ack and r.sender == first
    )
    assert writes[1] < first_ack


@pytest.mark.process
def test_a_write_that_fails_raises_when_the_cycle_ends(launch_bus: LaunchBus) -> None:
    bus = launch_bus(1, tag="overlapfail")
    with BusPort(bus.config) as port:
        (node,) = (phy for phy, member in port.nodes() if not member.host)
        overlapping = OverlappingPort(port)
        reached_the_end = False
        with pytest.raises(TransactionError), overlapping.cycle():
            overlapping.write_block(node, ROM, b"\x33" * 8)  # a configuration ROM is read-only
            overlapping.write_block(node, 0x200, b"\x44" * 8)
            reached_the_end = True  # posted: neither write waited for its ack
        assert reached_the_end
        # The failure ended the cycle, not the bus: the next cycle runs.
        assert port.read_block(node, 0x200, 8) == b"\x44" * 8
        with overlapping.cycle():
            assert overlapping.read_block(node, 0x200, 8) == b"\x44" * 8
