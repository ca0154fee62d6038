"""Asynchronous packets as immutable values.

One frozen dataclass per transaction code. Field names are those of the Linux
kernel; which bits they occupy is defined only in :mod:`fw1394.packets.layouts`,
and :func:`encode` / :func:`decode_async` go through those construct layouts.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar, Self

from construct import ConstructError

from fw1394.crc import crc32, data_crc, header_crc, padded
from fw1394.packets.enums import ExtendedTCode, RCode, Retry, TCode, name_of
from fw1394.packets.errors import PacketError
from fw1394.packets.fields import FieldRangeError
from fw1394.packets.layouts import LAYOUTS, TCODE_BYTE, TCODE_SHIFT, Layout
from fw1394.packets.nodeid import bus_of, node_id, phy_of

_QUADLET = struct.Struct(">I")


@dataclass(frozen=True, slots=True, kw_only=True)
class AsyncPacket:
    """Common part of every asynchronous packet.

    ``header_crc`` and ``data_crc`` hold the CRC quadlets as received; ``None``
    means the packet carries none (a kernel header dump) or, when encoding,
    that the correct value is to be computed. ``trailing`` keeps any bytes that
    followed the packet, so nothing is silently lost.
    """

    LAYOUT: ClassVar[Layout]
    header_crc: int | None = None
    trailing: bytes = b""

    # -- identity ----------------------------------------------------------------------
    @property
    def tcode(self) -> TCode:
        return self.LAYOUT.tcode

    @property
    def kind(self) -> str:
        return self.LAYOUT.name

    def header_fields(self) -> dict[str, int]:
        """The header fields, including implied ones, keyed as in the layout."""
        values = {name: getattr(self, name) for name in self.LAYOUT.fields}
        values["tcode"] = int(self.LAYOUT.tcode)
        return values

    # -- CRCs --------------------------------------------------------------------------
    def computed_header_crc(self) -> int:
        return header_crc(self.LAYOUT.header.pack(self.header_fields()))

    def computed_data_crc(self) -> int | None:
        data: bytes | None = getattr(self, "data", None)
        return None if data is None else data_crc(data)

    @property
    def header_crc_ok(self) -> bool | None:
        """``None`` when the packet carries no header CRC."""
        if self.header_crc is None:
            return None
        return self.header_crc == self.computed_header_crc()

    @property
    def data_crc_ok(self) -> bool | None:
        """``None`` when the kind has no data block or the packet carries no data CRC."""
        received: int | None = getattr(self, "data_crc", None)
        if received is None:
            return None
        return received == self.computed_data_crc()

    def with_crcs(self) -> Self:
        """The same packet with correct CRC quadlets filled in."""
        changes: dict[str, Any] = {"header_crc": self.computed_header_crc()}
        if self.LAYOUT.has_data:
            changes["data_crc"] = self.computed_data_crc()
        return replace(self, **changes)

    @property
    def problems(self) -> tuple[PacketError, ...]:
        """Everything wrong with the packet as received; empty for a sound packet."""
        found: list[PacketError] = []
        if self.header_crc is not None and not self.header_crc_ok:
            found.append(
                PacketError(
                    "header_crc",
                    f"{self.header_crc:#010x} does not match computed "
                    f"{self.computed_header_crc():#010x}",
                )
            )
        if self.LAYOUT.has_data:
            data: bytes = getattr(self, "data")  # noqa: B009
            length: int = getattr(self, "data_length")  # noqa: B009
            if len(data) != length:
                found.append(
                    PacketError("data", f"{len(data)} bytes present, data_length says {length}")
                )
            received: int | None = getattr(self, "data_crc")  # noqa: B009
            if self.header_crc is not None and received is None:
                found.append(PacketError("data_crc", "missing (packet truncated)"))
            elif received is not None and received != self.computed_data_crc():
                found.append(
                    PacketError(
                        "data_crc",
                        f"{received:#010x} does not match computed "
                        f"{self.computed_data_crc():#010x}",
                    )
                )
        if self.trailing:
            found.append(
                PacketError("length", f"{len(self.trailing)} bytes follow the end of the packet")
            )
        return tuple(found)


@dataclass(frozen=True, slots=True, kw_only=True)
class RoutedPacket(AsyncPacket):
    """Packets sent to one node (or broadcast): every tcode but stream data."""

    destination_id: int = node_id(0)
    tlabel: int = 0
    retry: int = Retry.retry_1
    priority: int = 0
    source_id: int = node_id(1)

    @property
    def destination_bus(self) -> int:
        return bus_of(self.destination_id)

    @property
    def destination_node(self) -> int:
        return phy_of(self.destination_id)

    @property
    def source_bus(self) -> int:
        return bus_of(self.source_id)

    @property
    def source_node(self) -> int:
        return phy_of(self.source_id)


@dataclass(frozen=True, slots=True, kw_only=True)
class Request(RoutedPacket):
    """A request: ``offset`` is the 48-bit address it reads, writes or locks."""

    offset: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class Response(RoutedPacket):
    """A response: ``rcode`` says how the request ended (``RCode``)."""

    rcode: int = RCode.resp_complete
    #: Bits the standard reserves (quadlet 1 bits 11..0 and quadlet 2); normally zero.
    reserved: int = 0


def _fill_length(packet: Any) -> None:
    if packet.data_length < 0:
        object.__setattr__(packet, "data_length", len(packet.data))


@dataclass(frozen=True, slots=True, kw_only=True)
class QuadletWriteRequest(Request):
    """Write request for one quadlet (tcode 0): ``quadlet_data`` goes to ``offset``."""

    LAYOUT = LAYOUTS[TCode.write_quadlet_request]
    quadlet_data: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class BlockWriteRequest(Request):
    """Write request for a block (tcode 1): ``data`` goes to ``offset``."""

    LAYOUT = LAYOUTS[TCode.write_block_request]
    #: Negative means "the length of ``data``".
    data_length: int = -1
    extended_tcode: int = 0
    data: bytes = b""
    data_crc: int | None = None

    def __post_init__(self) -> None:
        _fill_length(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class WriteResponse(Response):
    """Response to a write request (tcode 2): only the rcode."""

    LAYOUT = LAYOUTS[TCode.write_response]


@dataclass(frozen=True, slots=True, kw_only=True)
class QuadletReadRequest(Request):
    """Read request for one quadlet (tcode 4) at ``offset``."""

    LAYOUT = LAYOUTS[TCode.read_quadlet_request]


@dataclass(frozen=True, slots=True, kw_only=True)
class BlockReadRequest(Request):
    """Read request for ``data_length`` bytes (tcode 5) at ``offset``."""

    LAYOUT = LAYOUTS[TCode.read_block_request]
    data_length: int = 4
    extended_tcode: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class QuadletReadResponse(Response):
    """Response to a quadlet read (tcode 6): the quadlet is ``quadlet_data``."""

    LAYOUT = LAYOUTS[TCode.read_quadlet_response]
    quadlet_data: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class BlockReadResponse(Response):
    """Response to a block read (tcode 7): the bytes read are ``data``."""

    LAYOUT = LAYOUTS[TCode.read_block_response]
    data_length: int = -1
    extended_tcode: int = 0
    data: bytes = b""
    data_crc: int | None = None

    def __post_init__(self) -> None:
        _fill_length(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class CycleStart(Request):
    """Cycle start: a broadcast write of the cycle master's CYCLE_TIME register."""

    LAYOUT = LAYOUTS[TCode.cycle_start]
    destination_id: int = 0xFFFF
    offset: int = 0xFFFFF0000200
    quadlet_data: int = 0

    @property
    def cycle_time(self) -> int:
        return self.quadlet_data


@dataclass(frozen=True, slots=True, kw_only=True)
class LockRequest(Request):
    """Lock request; ``data`` is the argument (if the operation has one) then the data."""

    LAYOUT = LAYOUTS[TCode.lock_request]
    data_length: int = -1
    extended_tcode: int = ExtendedTCode.compare_swap
    data: bytes = b""
    data_crc: int | None = None

    def __post_init__(self) -> None:
        _fill_length(self)

    @property
    def has_argument(self) -> bool:
        """fetch_add and little_add carry data only; the others argument then data."""
        return self.extended_tcode not in (ExtendedTCode.fetch_add, ExtendedTCode.little_add)

    @property
    def argument(self) -> bytes:
        return self.data[: len(self.data) // 2] if self.has_argument else b""

    @property
    def lock_data(self) -> bytes:
        return self.data[len(self.data) // 2 :] if self.has_argument else self.data


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamPacket(AsyncPacket):
    """Asynchronous stream packet (tcode 0xA): a channel, not a node, is addressed."""

    LAYOUT = LAYOUTS[TCode.stream_data]
    data_length: int = -1
    tag: int = 0
    channel: int = 0
    sy: int = 0
    data: bytes = b""
    data_crc: int | None = None

    def __post_init__(self) -> None:
        _fill_length(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class LockResponse(Response):
    """Lock response; ``data`` is the old value."""

    LAYOUT = LAYOUTS[TCode.lock_response]
    data_length: int = -1
    extended_tcode: int = ExtendedTCode.compare_swap
    data: bytes = b""
    data_crc: int | None = None

    def __post_init__(self) -> None:
        _fill_length(self)


ASYNC_CLASSES: dict[TCode, type[AsyncPacket]] = {
    cls.LAYOUT.tcode: cls
    for cls in (
        QuadletWriteRequest,
        BlockWriteRequest,
        WriteResponse,
        QuadletReadRequest,
        BlockReadRequest,
        QuadletReadResponse,
        BlockReadResponse,
        CycleStart,
        LockRequest,
        StreamPacket,
        LockResponse,
    )
}

_STORED = frozenset({"header_crc", "trailing", "data", "data_crc"})


def stored_header_fields(cls: type[AsyncPacket]) -> tuple[str, ...]:
    """Header fields a class declares (to check against its layout)."""
    return tuple(f.name for f in fields(cls) if f.name not in _STORED)


# -- encoding ---------------------------------------------------------------------------
def encode_async(packet: AsyncPacket, *, crc: bool = True) -> bytes:
    """Wire bytes of ``packet``; missing CRCs are computed, given ones are kept as they are.

    ``data_length`` is written as given even when it disagrees with ``data`` (the
    fuzzer needs such packets). With ``crc=False`` the result is the header (and
    data) without CRC quadlets, as the Linux kernel prints it.
    """
    layout = packet.LAYOUT
    header: dict[str, Any] = packet.header_fields()
    try:
        if crc:
            header["header_crc"] = (
                packet.header_crc
                if packet.header_crc is not None
                else crc32(layout.header.pack(header))
            )
        if not layout.has_data:
            # Quadlets.pack is what the construct's build calls, minus construct's
            # per-call context setup: this runs for every packet a node sends.
            raw: bytes = (layout.sealed_header if crc else layout.header).pack(header)
        else:
            data: bytes = packet.data  # type: ignore[attr-defined]
            block: dict[str, Any] = {"header": header, "data": data}
            if crc:
                received: int | None = packet.data_crc  # type: ignore[attr-defined]
                block["data_crc"] = data_crc(data) if received is None else received
            raw = layout.parser(crc=crc).build(block)
    except FieldRangeError as error:
        raise PacketError(error.field, error.problem) from None
    except ConstructError as error:
        raise PacketError("packet", str(error)) from None
    return raw + packet.trailing


# -- decoding ---------------------------------------------------------------------------
def tcode_of(raw: bytes) -> int:
    return raw[TCODE_BYTE] >> TCODE_SHIFT


def decode_async(raw: bytes, *, crc: bool = True, strict: bool = False) -> AsyncPacket:
    """Decode one asynchronous packet.

    Leniently (the default), :class:`PacketError` is raised only when no packet
    can be made of the bytes: a header shorter than its layout, or a tcode no
    layout defines; anything else wrong is left for ``problems`` to report.
    ``strict=True`` raises the first problem instead.
    """
    packet = _decode_async(raw, crc)
    if strict and not _sound(packet, raw, crc):
        raise packet.problems[0]
    return packet


def _sound(packet: AsyncPacket, raw: bytes, crc: bool) -> bool:
    # The same verdict as ``not packet.problems``, from the received bytes, without
    # rebuilding the header: this runs for every packet a node or host receives.
    if packet.trailing:
        return False
    layout = packet.LAYOUT
    data: bytes | None = getattr(packet, "data", None)
    if data is not None and len(data) != packet.data_length:  # type: ignore[attr-defined]
        return False
    if not crc:
        return True
    if crc32(raw[: layout.header_size]) != packet.header_crc:
        return False
    if data is None:
        return True
    received: int | None = packet.data_crc  # type: ignore[attr-defined]
    return received is not None and received == data_crc(data)


def _decode_async(raw: bytes, crc: bool) -> AsyncPacket:
    if len(raw) < 4:
        raise PacketError("length", f"{len(raw)} bytes is shorter than one quadlet")
    tcode = tcode_of(raw)
    cls = _CLASS_BY_TCODE.get(tcode)
    if cls is None:
        raise PacketError("tcode", f"{tcode:#x} is not an asynchronous packet type")
    layout = cls.LAYOUT
    head = layout.sealed_header if crc else layout.header
    size = 4 * head.count
    if len(raw) < size:
        raise PacketError(
            "length",
            f"{len(raw)} bytes is too short for a {layout.name} header ({size} bytes"
            f"{' with CRC' if crc else ''})",
        )
    values: dict[str, Any] = head.unpack_fields(raw[:size])
    del values["tcode"]
    if not layout.has_data:
        return cls(**values, trailing=raw[size:])
    return _with_data_block(cls, values, raw, size, crc)


def _with_data_block(
    cls: type[AsyncPacket], values: dict[str, Any], raw: bytes, size: int, crc: bool
) -> AsyncPacket:
    layout = cls.LAYOUT
    length: int = values["data_length"]
    structure = layout.parser(crc=crc)
    expected = size + len(padded(bytes(length))) + (4 if crc else 0)
    if len(raw) >= expected:
        parsed = structure.parse(raw[:expected])
        block: dict[str, Any] = {"data": parsed.data}
        if crc:
            block["data_crc"] = parsed.data_crc
        return cls(**values, **block, trailing=raw[expected:])
    # Truncated packet: keep what arrived; ``problems`` reports the shortfall.
    values["data"] = raw[size : size + length]
    return cls(**values)


_CLASS_BY_TCODE: dict[int, type[AsyncPacket]] = {int(t): c for t, c in ASYNC_CLASSES.items()}


def rcode_name(value: int) -> str:
    return name_of(RCode, value)
