"""One observed bus event, as a capture tap sees it and a trace file stores it."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from fw1394.packets import Speed


class RecordType(IntEnum):
    """What a trace record holds."""

    async_packet = 0  # an asynchronous packet, wire quadlets (with CRCs if present)
    ack = 1  # one ack byte
    phy_packet = 2  # a PHY packet quadlet and its check quadlet (self-IDs included)
    bus_reset = 3  # no data: the bus reset; ``generation`` is the new generation


class Direction(IntEnum):
    """Whose point of view a record has."""

    bus = 0  # seen on the wire by a passive tap: nobody's in particular
    outbound = 1  # transmitted by the observing node (kernel "AT", host-to-board)
    inbound = 2  # received by the observing node (kernel "AR", board-to-host)


#: ``BusRecord.speed`` when the source does not say (nosy, UDP tunnels).
SPEED_UNKNOWN = 0xFF


@dataclass(frozen=True, slots=True)
class BusRecord:
    """A packet (or a bus reset) seen on the bus at ``timestamp_ns``.

    ``sender`` is the physical ID of the node that transmitted it when known;
    ``ack`` is the ack code that followed an asynchronous packet when the tap
    joined them (``None`` otherwise); ``crc_present`` is False for packets taken
    from sources that strip CRCs (kernel logs).

    The remaining fields describe sources other than a passive tap:
    ``direction`` and ``observer`` (physical ID of the observing node) for
    logs kept by one node; ``crc_placeholder`` when CRC quadlets are present
    but were never computed by the sender (the JHU FPGA's Ethernet responses
    carry zeros); ``partial`` when the packet was rebuilt from a log that
    printed only some header fields (retry, priority, rcode and the data block
    are then unknown and zero); ``time_known`` False when the source has no
    clock and ``timestamp_ns`` is only an ordering.
    """

    timestamp_ns: int
    record_type: RecordType
    data: bytes
    generation: int = 0
    sender: int | None = None
    speed: int = Speed.S400
    ack: int | None = None
    crc_present: bool = True
    direction: Direction = Direction.bus
    observer: int | None = None
    crc_placeholder: bool = False
    partial: bool = False
    time_known: bool = True
