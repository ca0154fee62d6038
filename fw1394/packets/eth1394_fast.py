"""The Eth1394 framing on the hot path: the control word and the extra bytes.

:mod:`fw1394.packets.eth1394` describes both as construct structs, the
reference; a real-time loop frames every request and every reply, where
construct costs more than the rest of the work. The bit positions, byte
offsets and struct format used here are read off those structs once, at
import, so there is still one description (the tests check bytes and values
against the structs).
"""

from __future__ import annotations

import struct

from fw1394.packets.bitfields import BitField, flatten, struct_format
from fw1394.packets.eth1394 import (
    CONTROL_WORD,
    CONTROL_WORD_SIZE,
    EXTRA_BYTES,
    EXTRA_SIZE,
    ControlWord,
    DatagramTooShortError,
    Eth1394Request,
    ExtraBytes,
)

_CONTROL = {field.name: field for field in flatten(CONTROL_WORD)}
_EXTRA_FIELDS = {field.name: field for field in flatten(EXTRA_BYTES)}
_EXTRA = struct.Struct(struct_format(EXTRA_BYTES))
_NO_FORWARD = _CONTROL["flags.no_forward"]
_RESERVED_FLAGS = _CONTROL["flags.reserved"]
_BUS_GENERATION = _CONTROL["bus_generation"].byte_offset
#: (attribute of ExtraBytes, bit position) of every flag in the extra bytes' flag byte.
_EXTRA_FLAGS = tuple(
    (field.name.removeprefix("flags."), field.lsb)
    for field in _EXTRA_FIELDS.values()
    if field.name.startswith("flags.")
)
_ECHO = _EXTRA_FIELDS["flags.no_forward_echo"]
#: Where a response's extra bytes put them, counted from the datagram's end.
_ECHO_BYTE = _ECHO.byte_offset - EXTRA_SIZE
_GENERATION_BYTE = _EXTRA_FIELDS["fpga_bus_generation"].byte_offset - EXTRA_SIZE


def _bits(field: BitField, unit: int) -> int:
    return unit >> field.lsb & field.mask


def split_request(payload: bytes) -> Eth1394Request:
    """Control word and 1394 packet of a request datagram (as ``parse_request``)."""
    if len(payload) < CONTROL_WORD_SIZE:
        raise DatagramTooShortError(
            "control_word", f"needs {CONTROL_WORD_SIZE} bytes, datagram has {len(payload)}"
        )
    flags = payload[_NO_FORWARD.byte_offset]
    control = ControlWord(
        no_forward=bool(_bits(_NO_FORWARD, flags)),
        bus_generation=payload[_BUS_GENERATION],
        reserved_flags=_bits(_RESERVED_FLAGS, flags),
    )
    return Eth1394Request(control, payload[CONTROL_WORD_SIZE:])


def request_datagram(no_forward: bool, bus_generation: int, packet: bytes) -> bytes:
    """A request's UDP payload (as ``build_request`` with no reserved flag bits)."""
    flags = int(no_forward) << _NO_FORWARD.lsb
    return bytes((flags, bus_generation & 0xFF)) + packet


def extra_bytes(extra: ExtraBytes, receive_ticks: int, total_ticks: int) -> bytes:
    """The 8 extra bytes of ``extra`` with its two timers replaced."""
    flags = 0
    for name, lsb in _EXTRA_FLAGS:
        flags |= int(getattr(extra, name)) << lsb
    return _EXTRA.pack(
        flags,
        extra.fpga_bus_generation,
        extra.state_glitch_count,
        extra.packet_error_count,
        receive_ticks,
        total_ticks,
    )


def extra_generation_and_echo(datagram: bytes) -> tuple[int, bool]:
    """FPGA bus generation and no-forward echo from a response's extra bytes."""
    return datagram[_GENERATION_BYTE], bool(_bits(_ECHO, datagram[_ECHO_BYTE]))
