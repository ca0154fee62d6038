"""Each oracle on a packet chosen by hand, the reference model and reply attribution."""

from __future__ import annotations

from fw1394.engine import Reply
from fw1394.fuzz import malform
from fw1394.fuzz.clock import SimulatedClock
from fw1394.fuzz.contract import CONTRACTS, silence_reason
from fw1394.fuzz.inproc import InprocTarget
from fw1394.fuzz.judge import Violation, difference, visible, wire_size
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.reference import Certainty, Reference
from fw1394.fuzz.target import Observation, Visibility
from fw1394.fuzz.trial import Trial, wire_of
from fw1394.fuzz.tunnel import Replies
from fw1394.fuzz.udptarget import ETH1394_VISIBILITY
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    WriteResponse,
    encode,
)
from fw1394.transport.sansio.wire import AckPayload, ack_byte

NODE = 0xFFC0


def trial(kind: str = "memory", *defects: str, contract: str = "thesis") -> Trial:
    policy = CONTRACTS[contract]
    target = InprocTarget(kind, board_id=0, node_id=NODE, policy=policy, defects=frozenset(defects))
    reference = Reference(kind, 0, NODE, policy)
    return Trial(target, reference, offset_model(kind), SimulatedClock(0), state_every=4)


def keys(violations: list[Violation]) -> set[tuple[str, str]]:
    return {(v.oracle, v.signature) for v in violations}


def read(offset: int = 0, node: int = NODE, tlabel: int = 1) -> bytes:
    return encode(QuadletReadRequest(destination_id=node, tlabel=tlabel, offset=offset))


def test_a_clean_node_passes_every_oracle() -> None:
    s = trial()
    assert s.case(read(8)) == []
    assert s.case(encode(QuadletWriteRequest(destination_id=NODE, offset=8, quadlet_data=5))) == []
    assert s.case(malform.flip_header_crc(read(8), 1)) == []
    # Two cases answered and three probes; one read-back of the write.
    assert s.checks["silence"] == 1 and s.checks["reply"] == 5 and s.checks["state"] == 1


def test_silence_other_node() -> None:
    s = trial("memory", "answers-other-node")
    assert ("silence", "other-node:read:ack_pending") in keys(s.case(read(node=0xFFC5)))


def test_silence_bad_crc() -> None:
    s = trial("memory", "bad-crc-read-answered")
    found = keys(s.case(malform.flip_header_crc(read(4), 1 << 7)))
    assert ("silence", "bad-header-crc:read:ack_pending") in found


def test_reply_fields() -> None:
    s = trial("memory", "stale-tlabel")
    s.case(read(tlabel=3))
    assert ("reply", "read:tlabel") in keys(s.case(read(tlabel=4)))


def test_liveness_after_a_wedge() -> None:
    s = trial("memory", "wedge-after-long-block-write")
    long_write = encode(BlockWriteRequest(destination_id=NODE, offset=0, data=bytes(2052)))
    found = keys(s.case(long_write))
    assert ("liveness", "valid-read-unanswered") in found
    assert s.broken


def test_state_after_a_damaged_write() -> None:
    s = trial("memory", "bad-crc-write-performed")
    write = encode(QuadletWriteRequest(destination_id=NODE, offset=0x40, quadlet_data=7))
    found = keys(s.case(malform.flip_header_crc(write, 1)))
    assert ("state", "dropped-write:quadlet_data") in found


def test_process_crash() -> None:
    s = trial("memory", "crash-on-empty-block-write")
    empty = encode(BlockWriteRequest(destination_id=NODE, offset=0, data=b""))
    assert ("process", "crash:raised PlantedCrash") in keys(s.case(empty))
    assert s.broken


def test_state_read_back_and_sweep_see_a_stored_status_write() -> None:
    s = trial("qla1", "status-write-stored", contract="jhu")
    assert s.sweep() == []  # the baseline: every register reads right
    write = encode(QuadletWriteRequest(destination_id=0xFFFF, offset=0, quadlet_data=0x0F0F))
    assert keys(s.case(write)) == {("state", "accepted-write@STATUS:data")}
    found = set()
    for _ in range(3):  # the sweep comes every 4 cases here
        found |= keys(s.case(read(4)))
    assert found == {("state", "sweep-changed@STATUS:data")}


def test_silence_reasons_follow_the_screens() -> None:
    thesis, ieee = CONTRACTS["thesis"], CONTRACTS["ieee1394"]
    packet, damaged = wire_of(read(node=0x0040))[1:]
    assert silence_reason(packet, damaged, NODE, ieee) == "other-bus"
    assert silence_reason(packet, damaged, NODE, thesis) == "contract"
    packet, damaged = wire_of(malform.flip_header_crc(read(), 1))[1:]
    assert silence_reason(packet, damaged, NODE, thesis) == "bad-header-crc"
    assert silence_reason(None, True, NODE, thesis) == "undecodable"


def test_eth1394_shows_no_acks_and_no_write_responses() -> None:
    reply = Reply(AckCode.ack_pending, WriteResponse(destination_id=1), False)
    assert visible(reply, ETH1394_VISIBILITY) == Reply(None, None, False)
    read_reply = Reply(AckCode.ack_pending, QuadletReadResponse(quadlet_data=1), True)
    shown = visible(read_reply, ETH1394_VISIBILITY)
    assert shown.ack is None and shown.response is not None and not shown.concatenated


def test_difference_respects_certainty() -> None:
    want = Reply(AckCode.ack_pending, QuadletReadResponse(tlabel=1, quadlet_data=1), True)
    got = Observation(AckCode.ack_pending, QuadletReadResponse(tlabel=1, quadlet_data=2), True)
    full = Visibility()
    assert difference(want, got, Certainty.exact, full, node_bits_only=False) == "quadlet_data"
    assert difference(want, got, Certainty.header, full, node_bits_only=False) is None
    wrong_ack = got._replace(ack=AckCode.ack_complete, response=want.response)
    assert difference(want, wrong_ack, Certainty.header, full, node_bits_only=False) == "ack"
    assert difference(want, wrong_ack, Certainty.presence, full, node_bits_only=False) is None


def test_the_twin_model_marks_time_dependent_answers() -> None:
    reference = Reference("qla1", 0, NODE, CONTRACTS["jhu"], twin=True)
    block_read = wire_of(encode(BlockReadRequest(destination_id=NODE, data_length=128)))
    reference.expect(block_read.packet, False, 0.001)
    _, certainty = reference.expect(block_read.packet, False, 0.002)
    assert certainty == Certainty.header  # the timestamp depends on the clock
    version = wire_of(read(4))
    assert reference.expect(version.packet, False, 0.003)[1] == Certainty.exact
    assert (
        Reference(None, 0, NODE, CONTRACTS["thesis"]).expect(version.packet, False, 0.0)[1]
        == Certainty.presence
    )


def test_replies_are_matched_by_sequence_and_label() -> None:
    batch = [wire_of(read(tlabel=5)), wire_of(read(tlabel=6))]
    replies = Replies(batch, [10, 11])
    response = encode(QuadletReadResponse(destination_id=0xFFFE, tlabel=6, quadlet_data=9))
    replies.on_ack(AckPayload(ack_byte(AckCode.ack_pending), 6, 99).pack())  # stale
    assert not replies.complete()
    replies.on_ack(AckPayload(ack_byte(AckCode.ack_pending), 6, 11).pack())
    assert not replies.complete()  # ack_pending promises a response
    replies.on_response(response)
    assert replies.complete()
    assert replies.observations()[1] == Observation(AckCode.ack_pending, response, False)
    assert replies.observations()[0] == Observation(None, None, False)


def test_without_acks_a_response_needs_its_label() -> None:
    batch = [wire_of(read(tlabel=5)), wire_of(read(tlabel=6))]
    replies = Replies(batch)
    late = encode(QuadletReadResponse(tlabel=33))
    replies.on_response(late, acked=False)
    assert replies.observations()[0].response is None
    # The requests come from 0xFFC1 (the default source): so must their answers.
    replies.on_response(encode(QuadletReadResponse(destination_id=0xFFC1, tlabel=6)), acked=False)
    assert replies.complete(acks=False)


def test_difference_at_exact_certainty_still_compares_acks_and_tenure() -> None:
    want = Reply(AckCode.ack_pending, QuadletReadResponse(tlabel=1, quadlet_data=1), True)
    full = Visibility()
    wrong_ack = Observation(AckCode.ack_complete, want.response, True)
    assert difference(want, wrong_ack, Certainty.exact, full, node_bits_only=False) == "ack"
    split = Observation(AckCode.ack_pending, want.response, False)
    assert difference(want, split, Certainty.exact, full, node_bits_only=False) == "tenure"
    # Without a header model the tenure is not vouched for.
    assert difference(want, split, Certainty.presence, full, node_bits_only=False) is None


def test_difference_with_node_bits_only_ignores_the_bus_id_of_the_source() -> None:
    # IEEE 1394 node ID: bus ID in bits 15..6, physical ID in 5..0.
    want = Reply(AckCode.ack_pending, QuadletReadResponse(tlabel=1, source_id=0xFFC0), True)
    local_bus = Observation(
        AckCode.ack_pending, QuadletReadResponse(tlabel=1, source_id=0x0000), True
    )
    full = Visibility()
    assert difference(want, local_bus, Certainty.header, full, node_bits_only=True) is None
    assert difference(want, local_bus, Certainty.header, full, node_bits_only=False) == "source_id"


def test_wire_size_counts_header_crcs_and_padded_data() -> None:
    # IEEE 1394: a quadlet read request is 3 header quadlets and the header CRC; a
    # block write adds its data padded to quadlets and the data CRC.
    assert wire_size(QuadletReadRequest(destination_id=NODE)) == 16
    assert wire_size(QuadletWriteRequest(destination_id=NODE)) == 20
    block = BlockWriteRequest(destination_id=NODE, data=b"\x01\x02\x03\x04\x05")
    assert wire_size(block) == 20 + 8 + 4
