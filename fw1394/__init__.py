"""fw1394: a wire-level IEEE 1394 (FireWire) protocol toolkit.

The names here are the library's public face; everything else is reachable
through the subpackages named below, whose ``__all__`` lists their own.

Packets (:mod:`fw1394.packets`), described once as data and decoded and
encoded from the description::

    >>> import fw1394
    >>> raw = fw1394.encode(fw1394.QuadletReadRequest(destination_id=0xFFC0, tlabel=2, offset=4))
    >>> fw1394.decode(raw).offset
    4

The transaction engine (:mod:`fw1394.engine`): sans-IO :class:`Requester` and
:class:`Responder`. The virtual bus (:mod:`fw1394.transport`): a
:class:`LaunchedBus` starts one; :func:`open_bus` (of the host library,
:mod:`fw1394.host`) joins a running bus as a host and returns a :class:`BusPort`.
Boards (:mod:`fw1394.boards`): :func:`make_board` builds an emulated board of a
registered kind. Traces (:mod:`fw1394.capture`):
:class:`PcapngReader`, :class:`PcapReader`, :func:`write_trace`. Fuzzing
(:mod:`fw1394.fuzz`): :func:`fw1394.fuzz.run` with :class:`fw1394.fuzz.Settings`.

Errors (:mod:`fw1394.errors`): every exception the library raises on purpose
derives from :class:`Error`.

Names are imported when first used, so ``import fw1394`` stays cheap for the
node processes of a bus.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports
from fw1394.errors import BusUnreachable, Error, PacketError, Timeout, TransactionError, UsageError
from fw1394.version import __version__

# Public name -> the module that defines it; loaded on first use.
_HOMES = {
    # packets and their codec
    "Ack": "fw1394.packets",
    "AckCode": "fw1394.packets",
    "AsyncPacket": "fw1394.packets",
    "BlockReadRequest": "fw1394.packets",
    "BlockReadResponse": "fw1394.packets",
    "BlockWriteRequest": "fw1394.packets",
    "ExtendedTCode": "fw1394.packets",
    "LockRequest": "fw1394.packets",
    "LockResponse": "fw1394.packets",
    "Packet": "fw1394.packets",
    "PhyPacket": "fw1394.packets",
    "QuadletReadRequest": "fw1394.packets",
    "QuadletReadResponse": "fw1394.packets",
    "QuadletWriteRequest": "fw1394.packets",
    "RCode": "fw1394.packets",
    "SelfIdPacket": "fw1394.packets",
    "TCode": "fw1394.packets",
    "WriteResponse": "fw1394.packets",
    "decode": "fw1394.packets",
    "encode": "fw1394.packets",
    # the transaction engine
    "Requester": "fw1394.engine",
    "Responder": "fw1394.engine",
    "ResponderPolicy": "fw1394.engine",
    # the virtual bus
    "BusConfig": "fw1394.transport",
    "BusPort": "fw1394.host.bus_port",
    "LaunchedBus": "fw1394.transport",
    "open_bus": "fw1394.host.bus_port",
    # boards
    "BOARDS": "fw1394.boards",
    "BoardKind": "fw1394.boards",
    "board_kind": "fw1394.boards",
    "make_board": "fw1394.boards",
    # traces
    "BusRecord": "fw1394.capture",
    "PcapReader": "fw1394.capture",
    "PcapngReader": "fw1394.capture",
    "PcapWriter": "fw1394.capture",
    "PcapngWriter": "fw1394.capture",
    "write_trace": "fw1394.capture",
}

__all__ = [
    "BOARDS",
    "Ack",
    "AckCode",
    "AsyncPacket",
    "BlockReadRequest",
    "BlockReadResponse",
    "BlockWriteRequest",
    "BoardKind",
    "BusConfig",
    "BusPort",
    "BusRecord",
    "BusUnreachable",
    "Error",
    "ExtendedTCode",
    "LaunchedBus",
    "LockRequest",
    "LockResponse",
    "Packet",
    "PacketError",
    "PcapReader",
    "PcapWriter",
    "PcapngReader",
    "PcapngWriter",
    "PhyPacket",
    "QuadletReadRequest",
    "QuadletReadResponse",
    "QuadletWriteRequest",
    "RCode",
    "Requester",
    "Responder",
    "ResponderPolicy",
    "SelfIdPacket",
    "TCode",
    "Timeout",
    "TransactionError",
    "UsageError",
    "WriteResponse",
    "__version__",
    "board_kind",
    "decode",
    "encode",
    "make_board",
    "open_bus",
    "write_trace",
]


__getattr__, __dir__ = exports(__name__, globals(), _HOMES)


if TYPE_CHECKING:
    from fw1394.boards import BOARDS, BoardKind, board_kind, make_board
    from fw1394.capture import (
        BusRecord,
        PcapngReader,
        PcapngWriter,
        PcapReader,
        PcapWriter,
        write_trace,
    )
    from fw1394.engine import Requester, Responder, ResponderPolicy
    from fw1394.host.bus_port import BusPort, open_bus
    from fw1394.packets import (
        Ack,
        AckCode,
        AsyncPacket,
        BlockReadRequest,
        BlockReadResponse,
        BlockWriteRequest,
        ExtendedTCode,
        LockRequest,
        LockResponse,
        Packet,
        PhyPacket,
        QuadletReadRequest,
        QuadletReadResponse,
        QuadletWriteRequest,
        RCode,
        SelfIdPacket,
        TCode,
        WriteResponse,
        decode,
        encode,
    )
    from fw1394.transport import BusConfig, LaunchedBus
