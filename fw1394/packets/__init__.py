"""IEEE 1394 packets: layouts, values, decoding and encoding.

>>> from fw1394.packets import QuadletReadRequest, decode, encode
>>> raw = encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=2, offset=4))
>>> decode(raw).offset
4
"""

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
