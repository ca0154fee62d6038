"""IEEE 1394 packets: layouts, values, decoding and encoding.

>>> from fw1394.packets import QuadletReadRequest, decode, encode
>>> raw = encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=2, offset=4))
>>> decode(raw).offset
4
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "SOURCE_ID": "fw1394.packets.accessors",
    "TCODE": "fw1394.packets.accessors",
    "TLABEL": "fw1394.packets.accessors",
    "layout_reader": "fw1394.packets.accessors",
    "Ack": "fw1394.packets.ack",
    "ASYNC_CLASSES": "fw1394.packets.asynchronous",
    "AsyncPacket": "fw1394.packets.asynchronous",
    "BlockReadRequest": "fw1394.packets.asynchronous",
    "BlockReadResponse": "fw1394.packets.asynchronous",
    "BlockWriteRequest": "fw1394.packets.asynchronous",
    "CycleStart": "fw1394.packets.asynchronous",
    "LockRequest": "fw1394.packets.asynchronous",
    "LockResponse": "fw1394.packets.asynchronous",
    "QuadletReadRequest": "fw1394.packets.asynchronous",
    "QuadletReadResponse": "fw1394.packets.asynchronous",
    "QuadletWriteRequest": "fw1394.packets.asynchronous",
    "Request": "fw1394.packets.asynchronous",
    "Response": "fw1394.packets.asynchronous",
    "RoutedPacket": "fw1394.packets.asynchronous",
    "StreamPacket": "fw1394.packets.asynchronous",
    "WriteResponse": "fw1394.packets.asynchronous",
    "Packet": "fw1394.packets.codec",
    "decode": "fw1394.packets.codec",
    "encode": "fw1394.packets.codec",
    "looks_like_phy": "fw1394.packets.codec",
    "AckCode": "fw1394.packets.enums",
    "ExtendedTCode": "fw1394.packets.enums",
    "PhyPacketType": "fw1394.packets.enums",
    "PortStatus": "fw1394.packets.enums",
    "PowerClass": "fw1394.packets.enums",
    "RCode": "fw1394.packets.enums",
    "Retry": "fw1394.packets.enums",
    "Speed": "fw1394.packets.enums",
    "TCode": "fw1394.packets.enums",
    "name_of": "fw1394.packets.enums",
    "PacketError": "fw1394.packets.errors",
    "LAYOUTS": "fw1394.packets.layouts",
    "Layout": "fw1394.packets.layouts",
    "phy_of": "fw1394.packets.nodeid",
    "PHY_CLASSES": "fw1394.packets.phy",
    "ExtendedSelfIdPacket": "fw1394.packets.phy",
    "LinkOnPacket": "fw1394.packets.phy",
    "PhyConfigPacket": "fw1394.packets.phy",
    "PhyPacket": "fw1394.packets.phy",
    "PingPacket": "fw1394.packets.phy",
    "RemoteAccessPacket": "fw1394.packets.phy",
    "RemoteCommandPacket": "fw1394.packets.phy",
    "RemoteConfirmationPacket": "fw1394.packets.phy",
    "RemoteReplyPacket": "fw1394.packets.phy",
    "ResumePacket": "fw1394.packets.phy",
    "SelfIdPacket": "fw1394.packets.phy",
    "self_id_port_status": "fw1394.packets.phy",
    "field_rows": "fw1394.packets.render",
    "summary": "fw1394.packets.render",
    "to_json": "fw1394.packets.render",
}

__all__ = [
    "ASYNC_CLASSES",
    "LAYOUTS",
    "PHY_CLASSES",
    "SOURCE_ID",
    "TCODE",
    "TLABEL",
    "Ack",
    "AckCode",
    "AsyncPacket",
    "BlockReadRequest",
    "BlockReadResponse",
    "BlockWriteRequest",
    "CycleStart",
    "ExtendedSelfIdPacket",
    "ExtendedTCode",
    "Layout",
    "LinkOnPacket",
    "LockRequest",
    "LockResponse",
    "Packet",
    "PacketError",
    "PhyConfigPacket",
    "PhyPacket",
    "PhyPacketType",
    "PingPacket",
    "PortStatus",
    "PowerClass",
    "QuadletReadRequest",
    "QuadletReadResponse",
    "QuadletWriteRequest",
    "RCode",
    "RemoteAccessPacket",
    "RemoteCommandPacket",
    "RemoteConfirmationPacket",
    "RemoteReplyPacket",
    "Request",
    "Response",
    "ResumePacket",
    "Retry",
    "RoutedPacket",
    "SelfIdPacket",
    "Speed",
    "StreamPacket",
    "TCode",
    "WriteResponse",
    "decode",
    "encode",
    "field_rows",
    "layout_reader",
    "looks_like_phy",
    "name_of",
    "phy_of",
    "self_id_port_status",
    "summary",
    "to_json",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.packets.accessors import SOURCE_ID, TCODE, TLABEL, layout_reader
    from fw1394.packets.ack import Ack
    from fw1394.packets.asynchronous import (
        ASYNC_CLASSES,
        AsyncPacket,
        BlockReadRequest,
        BlockReadResponse,
        BlockWriteRequest,
        CycleStart,
        LockRequest,
        LockResponse,
        QuadletReadRequest,
        QuadletReadResponse,
        QuadletWriteRequest,
        Request,
        Response,
        RoutedPacket,
        StreamPacket,
        WriteResponse,
    )
    from fw1394.packets.codec import Packet, decode, encode, looks_like_phy
    from fw1394.packets.enums import (
        AckCode,
        ExtendedTCode,
        PhyPacketType,
        PortStatus,
        PowerClass,
        RCode,
        Retry,
        Speed,
        TCode,
        name_of,
    )
    from fw1394.packets.errors import PacketError
    from fw1394.packets.layouts import LAYOUTS, Layout
    from fw1394.packets.nodeid import phy_of
    from fw1394.packets.phy import (
        PHY_CLASSES,
        ExtendedSelfIdPacket,
        LinkOnPacket,
        PhyConfigPacket,
        PhyPacket,
        PingPacket,
        RemoteAccessPacket,
        RemoteCommandPacket,
        RemoteConfirmationPacket,
        RemoteReplyPacket,
        ResumePacket,
        SelfIdPacket,
        self_id_port_status,
    )
    from fw1394.packets.render import field_rows, summary, to_json
