"""The bus frame, the ack frame and the seal against known-answer vectors.

``tests/vectors/bus_frames.json`` holds bytes computed from the documented
layouts with ``struct`` and ``hashlib`` alone (its ``derivation`` says how); this
file re-derives them the same way, so the vectors cannot drift from their
description, and then requires fw1394's packers, parsers, sealer and verifier to
produce and accept exactly those bytes. A sealer and verifier changed together
(another hash, another digest size, another byte order of the counter) agree
with each other but not with these bytes.
"""

from __future__ import annotations

import hashlib
import json
import struct
from pathlib import Path
from typing import Any

import pytest

from fw1394.transport.sansio.seal import Sealer, Verifier
from fw1394.transport.sansio.wire import (
    AckPayload,
    FrameError,
    FrameHeader,
    FrameKind,
    MemberInfo,
    pack_table,
    parse_ack,
    parse_header,
    parse_table,
)

VECTORS: dict[str, Any] = json.loads(
    (Path(__file__).parent.parent / "vectors" / "bus_frames.json").read_text()
)
KEY = bytes.fromhex(VECTORS["key_hex"])
HEADER_LAYOUT = ">HBBIIIBBBBI"  # docs/virtual-bus.md: the 24-byte frame header
HEADER_ORDER = ("kind", "tag", "sender", "generation", "sender_phy", "destination", "speed")


def documented_header(fields: dict[str, int]) -> bytes:
    values = [fields[name] for name in HEADER_ORDER]
    return struct.pack(HEADER_LAYOUT, 0x4657, 1, *values, 0, fields["sequence"])


def documented_trailer(frame: bytes, counter: int) -> bytes:
    body = frame + struct.pack(">Q", counter)
    return struct.pack(">Q", counter) + hashlib.blake2s(body, key=KEY, digest_size=16).digest()


@pytest.mark.parametrize("vector", VECTORS["frames"], ids=lambda v: v["name"].split(":")[0])
def test_frames_are_the_documented_bytes(vector: dict[str, Any]) -> None:
    frame = bytes.fromhex(vector["frame_hex"])
    payload = bytes.fromhex(vector["payload_hex"])
    fields = vector["fields"]
    assert documented_header(fields) + payload == frame
    assert FrameHeader(**fields).pack() + payload == frame
    assert parse_header(frame) == FrameHeader(**fields)


def test_ack_payload_is_the_documented_bytes() -> None:
    (vector,) = (v for v in VECTORS["frames"] if "ack" in v)
    payload = bytes.fromhex(vector["payload_hex"])
    ack = vector["ack"]
    assert AckPayload(ack["ack_byte"], ack["tlabel"], ack["acked_sequence"]).pack() == payload
    parsed = parse_ack(payload)
    assert (parsed.ack_byte, parsed.tlabel, parsed.acked_sequence) == tuple(ack.values())
    assert parsed.code == 2 and parsed.concatenated == b""  # ack_pending, alone


@pytest.mark.parametrize("vector", VECTORS["seals"], ids=lambda v: str(v["counter"]))
def test_seal_trailers_are_the_documented_mac(vector: dict[str, Any]) -> None:
    frame = bytes.fromhex(vector["frame_hex"])
    trailer = bytes.fromhex(vector["trailer_hex"])
    assert documented_trailer(frame, vector["counter"]) == trailer
    assert Verifier(KEY).open(frame + trailer) == frame


def test_a_new_sealer_writes_the_vectors_first_trailer() -> None:
    first = VECTORS["seals"][0]
    assert first["counter"] == 1  # a sealer counts from 1
    frame = bytes.fromhex(first["frame_hex"])
    assert Sealer(KEY).seal(frame) == frame + bytes.fromhex(first["trailer_hex"])


@pytest.mark.parametrize(
    "forge",
    [
        lambda body: hashlib.blake2b(body, key=KEY, digest_size=16).digest(),
        lambda body: hashlib.blake2s(body, key=KEY[:16], digest_size=16).digest(),
        lambda body: hashlib.blake2s(body[:-8], key=KEY, digest_size=16).digest(),
    ],
    ids=["blake2b", "short-key", "counter-not-covered"],
)
def test_a_verifier_refuses_other_constructions(forge: Any) -> None:
    vector = VECTORS["seals"][0]
    frame = bytes.fromhex(vector["frame_hex"])
    counter = struct.pack(">Q", vector["counter"])
    verifier = Verifier(KEY)
    assert verifier.open(frame + counter + forge(frame + counter)) is None
    assert verifier.dropped.forged == 1


@pytest.mark.parametrize("size", [16, 24, 32, 47])
def test_a_verifier_refuses_a_validly_keyed_mac_on_less_than_a_frame(size: int) -> None:
    # A sealed frame is at least the 24-byte header and the 24-byte trailer. Bytes
    # ending in a correct MAC over what precedes them are still no frame when shorter.
    body = bytes(range(size - 16))
    raw = body + hashlib.blake2s(body, key=KEY, digest_size=16).digest()
    verifier = Verifier(KEY)
    assert not verifier.authentic(raw)
    assert verifier.open(raw) is None and verifier.dropped.forged == 1


#: docs/virtual-bus.md, "Kinds and payloads": the frame kind numbers on the wire.
DOCUMENTED_KINDS = {
    1: "async_packet",
    2: "ack",
    3: "phy_packet",
    16: "join",
    17: "leave",
    18: "heartbeat",
    19: "beacon",
    20: "bus_reset",
    21: "reset_request",
    22: "refused",
}


def test_frame_kinds_are_the_documented_numbers() -> None:
    assert {int(kind): kind.name for kind in FrameKind} == DOCUMENTED_KINDS


@pytest.mark.parametrize("missing", [1, 24, 47])
def test_a_member_table_cut_short_is_a_frame_error(missing: int) -> None:
    # docs/virtual-bus.md: a table is its header, then one 24-byte entry per member.
    members = tuple(MemberInfo(1000 + n, n) for n in range(3))
    payload = pack_table(members, 1000)
    assert parse_table(payload) == (1000, members)
    with pytest.raises(FrameError):
        parse_table(payload[:-missing])
