"""fw1394's own decoders, fuzzed: any bytes end in a packet or in the documented error.

Documented errors: :class:`~fw1394.packets.PacketError` for the packet codec,
:class:`~fw1394.packets.eth1394.Eth1394Error` for the Eth1394 framing,
:class:`~fw1394.transport.sansio.wire.FrameError` for the tunnel's frames. Inputs are
random bytes and, more to the point, the fuzzer's own malformed packets.
"""

from __future__ import annotations

import contextlib

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fw1394.fuzz.strategies import fuzz_cases, malformed_packets
from fw1394.packets import PacketError, decode, encode, to_json
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.eth1394 import (
    Eth1394Error,
    HostReadRequest,
    host_verdict,
    parse_request,
    parse_response,
)
from fw1394.packets.fast import decode_packet, decode_sound
from fw1394.transport.sansio.wire import (
    FrameError,
    parse_ack,
    parse_header,
    parse_join,
    parse_table,
)

MANY = settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
anything = st.one_of(st.binary(max_size=96), fuzz_cases(max_data=64), malformed_packets())


@MANY
@given(anything, st.booleans(), st.sampled_from(["auto", "async", "phy", "ack"]))
def test_decode_raises_only_packet_errors(raw: bytes, crc: bool, kind: str) -> None:
    try:
        packet = decode(raw, crc=crc, strict=False, kind=kind)  # type: ignore[arg-type]
    except PacketError:
        return
    to_json(packet)  # whatever decodes can be shown


@MANY
@given(anything, st.booleans(), st.booleans())
def test_async_decoders_agree_and_raise_only_packet_errors(
    raw: bytes, crc: bool, strict: bool
) -> None:
    try:
        packet = decode_async(raw, crc=crc, strict=strict)
    except PacketError:
        packet = None
    sound = decode_sound(raw)
    if sound is not None:
        assert sound == decode_async(raw, strict=True)
    with contextlib.suppress(PacketError):
        assert decode_packet(raw) == decode_async(raw)
    if packet is not None and not packet.problems and crc:
        # A field the encoder refuses (kept only by a lenient decode) may raise.
        with contextlib.suppress(PacketError):
            assert decode_async(encode(packet)) == packet


@MANY
@given(anything, st.one_of(st.none(), st.integers(-4, 4096)))
def test_eth1394_parsers_raise_only_their_errors(raw: bytes, expected: int | None) -> None:
    for parse in (lambda: parse_request(raw), lambda: parse_response(raw, expected)):
        with contextlib.suppress(Eth1394Error):
            parse()


@MANY
@given(anything, st.integers(0, 63), st.integers(0, 63), st.one_of(st.none(), st.integers(0, 4096)))
def test_the_host_verdict_never_raises(raw: bytes, node: int, tl: int, length: int | None) -> None:
    host_verdict(HostReadRequest(node, tl, length), raw)


@MANY
@given(st.binary(max_size=128))
def test_tunnel_frames_raise_only_frame_errors(raw: bytes) -> None:
    for parse in (parse_header, parse_ack, parse_table, parse_join):
        with contextlib.suppress(FrameError):
            parse(raw)
