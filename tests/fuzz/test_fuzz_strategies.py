"""The fuzzer's inputs: strategies, malformations, mutations and the fast generator."""

from __future__ import annotations

import random

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fw1394.fuzz import malform, mutate
from fw1394.fuzz.generate import MALFORMATION_WEIGHTS, Generator
from fw1394.fuzz.offsets import BOUNDARY_OFFSETS, offset_model
from fw1394.fuzz.strategies import (
    destination_ids,
    fuzz_cases,
    long_blocks,
    malformed_packets,
    offsets,
    requests,
    wire_packets,
)
from fw1394.packets import (
    LAYOUTS,
    AsyncPacket,
    BlockWriteRequest,
    PacketError,
    QuadletReadRequest,
    QuadletWriteRequest,
    Request,
    encode,
)
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.fast import decode_sound

SOME = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))


def sound(raw: bytes) -> bool:
    return decode_sound(raw) is not None


@SOME
@given(wire_packets(0xFFC3, kind="qla1"))
def test_wire_packets_are_sound(raw: bytes) -> None:
    assert sound(raw)


@SOME
@given(st.lists(malformed_packets(0xFFC3, kind="snake2010"), min_size=10, max_size=10))
def test_malformed_packets_are_mostly_unsound(raws: list[bytes]) -> None:
    # Mutations with recomputed CRCs and long blocks may be sound; the rest never are.
    assert sum(not sound(raw) for raw in raws) >= 3
    for raw in raws:
        packet = decode_sound(raw)
        if packet is not None:
            assert decode_async(raw, strict=True) == packet


@SOME
@given(requests(0xFFC0, kind="memory"))
def test_requests_are_requests(packet: AsyncPacket) -> None:
    assert isinstance(packet, Request)
    assert 0 <= packet.offset < 1 << 48


@SOME
@given(destination_ids(0xFFC5), offsets("qla1"))
def test_fields_fit(destination: int, offset: int) -> None:
    assert 0 <= destination <= 0xFFFF
    assert 0 <= offset < 1 << 48


@SOME
@given(long_blocks())
def test_long_blocks_are_past_the_limit(raw: bytes) -> None:
    packet = decode_async(raw)
    assert getattr(packet, "data_length", 0) > 2048


@SOME
@given(fuzz_cases(), st.randoms(use_true_random=False))
def test_mutations_keep_bytes_and_can_recompute_crcs(raw: bytes, rng: random.Random) -> None:
    mutant, fixed = mutate.havoc(rng, raw, fix_crc_share=1.0)
    if fixed:
        packet = decode_async(mutant)
        assert packet.header_crc_ok
        assert packet.data_crc_ok is not False


def test_malformations_do_what_they_say() -> None:
    block = BlockWriteRequest(destination_id=0xFFC0, offset=0x10, data=b"abcdefgh")
    wire = encode(block)
    assert decode_async(malform.flip_header_crc(wire, 1)).header_crc_ok is False
    assert decode_async(malform.flip_data_crc(wire, 1)).data_crc_ok is False
    assert decode_async(malform.without_crcs(wire), crc=False) == block
    assert decode_async(malform.truncated(wire, 20)).problems
    assert decode_async(malform.over_long(wire, b"\1\2")).trailing == b"\1\2"
    relengthed = decode_async(malform.with_data_length(wire, 4, fix_crc=True))
    assert relengthed.header_crc_ok and getattr(relengthed, "data_length", None) == 4
    assert relengthed.problems
    unknown = malform.with_tcode(wire, 0xD)
    try:
        decode_async(unknown)
    except PacketError as error:
        assert error.field == "tcode"
    fixed = malform.recomputed_crcs(malform.flip_header_crc(wire, 0xFF))
    assert fixed == wire


def test_field_edits_go_through_the_layouts() -> None:
    wire = encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=5, offset=0x1234))
    edited = decode_async(malform.with_header(wire, {"tlabel": 9}, fix_crc=True))
    assert getattr(edited, "tlabel", None) == 9 and edited.header_crc_ok
    swapped = decode_async(mutate.swap_fields(wire, "tlabel", "retry"))
    assert getattr(swapped, "retry", None) == 5 & 3 and swapped.header_crc_ok is False
    widths = QuadletReadRequest.LAYOUT.header.widths
    assert set(mutate.editable_fields(wire)) == set(widths) - {"tcode"}
    assert mutate.delete_quadlet(wire, 1) == wire[:4] + wire[8:]
    assert mutate.insert_quadlet(wire, 0, 7)[:4] == bytes([0, 0, 0, 7])
    assert mutate.flip_bit(wire, 0)[0] == wire[0] ^ 0x80


def test_the_generator_covers_every_kind_and_malformation() -> None:
    generator = Generator(0xFFC0, offset_model("qla1"), random.Random(1))
    cases = [generator.case() for _ in range(4000)]
    labels = {label for _, label in cases}
    assert {name for name, _ in MALFORMATION_WEIGHTS} <= labels | {"long-block"}
    assert {"mutation", "mutation+crc", "long-block"} <= labels
    kinds = {type(p) for raw, _ in cases if (p := malform.lenient(raw)) is not None}
    assert len(kinds) == len(LAYOUTS)
    offsets_seen = {getattr(malform.lenient(raw), "offset", None) for raw, _ in cases}
    assert 0xFFFF_FFFF_0000 in offsets_seen and set(BOUNDARY_OFFSETS) & offsets_seen


def test_the_generator_repeats_itself_for_a_seed() -> None:
    def run(seed: int) -> list[bytes]:
        generator = Generator(0xFFC0, offset_model("memory"), random.Random(seed))
        return [generator.case()[0] for _ in range(500)]

    assert run(3) == run(3)
    assert run(3) != run(4)


def test_a_corpus_is_mutated() -> None:
    seed = encode(QuadletWriteRequest(destination_id=0xFFC0, offset=8, quadlet_data=0xDEAD))
    generator = Generator(0xFFC0, offset_model("memory"), random.Random(2), [seed])
    labels = [generator.case()[1] for _ in range(200)]
    assert "corpus-mutation" in labels and "corpus-mutation+crc" in labels
