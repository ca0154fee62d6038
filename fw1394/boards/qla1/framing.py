"""The Eth1394 framing on the hot path: the control word and the extra bytes, by hand.

:mod:`fw1394.packets.eth1394` describes both as construct structs, the reference;
a real-time loop frames every request and every reply, where construct costs
more than the rest of the work. These produce the same values and bytes (the
tests check it against the structs).
"""

from __future__ import annotations

import struct

from fw1394.packets.eth1394 import (
    CONTROL_WORD_SIZE,
    ControlWord,
    DatagramTooShortError,
    Eth1394Request,
    ExtraBytes,
)

_EXTRA = struct.Struct(">BBBBHH")
_NO_FORWARD = 0x01


def split_request(payload: bytes) -> Eth1394Request:
    """Control word and 1394 packet of a request datagram (as ``parse_request``)."""
    if len(payload) < CONTROL_WORD_SIZE:
        raise DatagramTooShortError(
            "control_word", f"needs {CONTROL_WORD_SIZE} bytes, datagram has {len(payload)}"
        )
    flags = payload[0]
    control = ControlWord(
        no_forward=bool(flags & _NO_FORWARD), bus_generation=payload[1], reserved_flags=flags >> 1
    )
    return Eth1394Request(control, payload[CONTROL_WORD_SIZE:])


def request_datagram(no_forward: bool, bus_generation: int, packet: bytes) -> bytes:
    """A request's UDP payload (as ``build_request`` with no reserved flag bits)."""
    return bytes((_NO_FORWARD if no_forward else 0, bus_generation & 0xFF)) + packet


def extra_bytes(extra: ExtraBytes, receive_ticks: int, total_ticks: int) -> bytes:
    """The 8 extra bytes of ``extra`` with its two timers replaced."""
    flags = (
        extra.reserved << 7
        | extra.switch_source_port << 5
        | extra.no_forward_echo << 4
        | extra.summary_error << 3
        | extra.internal_error << 2
        | extra.packet_dropped << 1
        | extra.bus_reset
    )
    return _EXTRA.pack(
        flags,
        extra.fpga_bus_generation,
        extra.state_glitch_count,
        extra.packet_error_count,
        receive_ticks,
        total_ticks,
    )


def extra_generation_and_echo(datagram: bytes) -> tuple[int, bool]:
    """FPGA bus generation and no-forward echo from a response's last 8 bytes."""
    return datagram[-7], bool(datagram[-8] & 0x10)
