"""The thesis link in Icarus Verilog, driven by the PHY model, against fw1394's engine.

Truth: fw1394's responder with the thesis policy and the snake2010 emulator
answers every packet; the RTL must send the same ack and the very same response
bytes (CRCs included), with the response concatenated to the ack.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from fw1394.crc import header_crc
from fw1394.engine import THESIS_FPGA, Responder
from fw1394.fuzz.reference import board
from fw1394.fuzz.rtl_target import NeverAcks, RtlTarget
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
)
from fw1394.packets.asynchronous import decode_async, encode_async
from fw1394.rtl.portmap import load
from fw1394.rtl.simulation import Simulation, missing_tools

HERE = Path(__file__).parent
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
ME, HOST, OTHER = 0xFFC2, 0xFFC0, 0xFFC5


@pytest.fixture(scope="module")
def thesis() -> Iterator[Simulation]:
    sim = Simulation(load("thesis"), physical_id=ME & 0x3F)
    yield sim
    sim.close()


def _expected(responder: Responder, raw: bytes, now: float) -> list[object]:
    reply = responder.receive(raw, now)
    response = None if reply.response is None else encode_async(reply.response).hex()
    return [reply.ack, response, reply.concatenated]


def test_answers_like_the_engine_byte_for_byte(thesis: Simulation) -> None:
    responder = Responder(ME, board("snake2010", 0), THESIS_FPGA)
    packets = [
        QuadletReadRequest(destination_id=ME, tlabel=1, source_id=HOST, offset=0),
        QuadletReadRequest(destination_id=ME, tlabel=2, source_id=HOST, offset=4),
        QuadletWriteRequest(
            destination_id=ME, tlabel=3, source_id=HOST, offset=3, quadlet_data=0x1234
        ),
        QuadletReadRequest(destination_id=ME, tlabel=4, source_id=HOST, offset=3),
        BlockReadRequest(destination_id=ME, tlabel=5, source_id=HOST, offset=0, data_length=10),
        BlockWriteRequest(
            destination_id=ME, tlabel=6, source_id=HOST, offset=0x11, data=bytes.fromhex("80001234")
        ),
        BlockReadRequest(destination_id=ME, tlabel=7, source_id=HOST, offset=0x10, data_length=8),
        # odd lengths: the bytes past the length are sent as zeros
        BlockReadRequest(destination_id=ME, tlabel=7, source_id=HOST, offset=0x11, data_length=3),
        BlockReadRequest(destination_id=ME, tlabel=7, source_id=HOST, offset=0x11, data_length=2),
        BlockReadRequest(destination_id=ME, tlabel=7, source_id=HOST, offset=0x10, data_length=5),
        BlockReadRequest(destination_id=ME, tlabel=8, source_id=HOST, offset=0, data_length=4096),
        BlockWriteRequest(destination_id=ME, tlabel=9, source_id=HOST, offset=3, data=bytes(3000)),
        BlockReadRequest(destination_id=ME, tlabel=10, source_id=HOST, offset=0, data_length=0),
        # broadcast write: performed, never acked; then read back
        QuadletWriteRequest(
            destination_id=0xFFFF, tlabel=11, source_id=HOST, offset=3, quadlet_data=0x77
        ),
        QuadletReadRequest(destination_id=ME, tlabel=12, source_id=HOST, offset=3),
        QuadletReadRequest(destination_id=OTHER, tlabel=13, source_id=HOST, offset=0),
        LockRequest(
            destination_id=ME, tlabel=14, source_id=HOST, offset=0, extended_tcode=2, data=bytes(8)
        ),
    ]
    raws = [encode_async(p) for p in packets]
    good_read = raws[0]
    raws.append(good_read[:-1] + bytes([good_read[-1] ^ 1]))  # bad header CRC: dropped
    raws.append(good_read + b"\0\0\0\0")  # trailing bytes: dropped
    raws.append(b"")  # a null packet
    answer = thesis.exchange(raws, 0.002)
    assert answer["violations"] == []
    for raw, got in zip(raws, answer["replies"], strict=True):
        assert got == _expected(responder, raw, 0.002), raw.hex()
    replies = answer["replies"]
    assert replies[0][0] == AckCode.ack_pending and replies[0][2] is True
    assert replies[2][0] == AckCode.ack_complete and replies[2][1] is None
    assert replies[14][1] is not None
    read_back = decode_async(bytes.fromhex(replies[14][1]))
    assert isinstance(read_back, QuadletReadResponse) and read_back.quadlet_data == 0x77


def test_response_crcs_are_right(thesis: Simulation) -> None:
    raw = encode_async(QuadletReadRequest(destination_id=ME, tlabel=1, source_id=HOST, offset=4))
    [[_, response, _]] = thesis.exchange([raw], 0.003)["replies"]
    wire = bytes.fromhex(response)
    assert int.from_bytes(wire[16:20], "big") == header_crc(wire[:16])
    assert decode_async(wire).problems == ()


def _own_with_board_id(tmp_path: Path, board_id: int) -> Path:
    own = load("thesis-own")
    text = own.path.read_text().replace(
        'busy = "busy"', f'busy = "busy"\nparameters = {{ BOARD_ID = {board_id} }}'
    )
    path = tmp_path / "own.toml"
    path.write_text(text.replace("@hdl/", str(own.sources[0].parent) + "/"))
    return path


@pytest.mark.parametrize(
    ("spec", "board_id"),
    [("thesis-own", 9), (str(HERE / "split_lsb.toml"), 5), (str(HERE / "flag.toml"), 5)],
    ids=["inout-msb-high", "split-oe-lsb-low", "split-flag"],
)
def test_every_pin_style_reads_and_writes(spec: str, board_id: int, tmp_path: Path) -> None:
    if spec == "thesis-own":  # and a port map parameter reaches the design
        spec = str(_own_with_board_id(tmp_path, board_id))
    # inout/msb/active-high, split with enables/lsb/active-low, split with a PHY-drives flag
    sim = Simulation(load(spec), physical_id=3)
    try:
        assert sim.acked
        me = 0xFFC3
        write = QuadletWriteRequest(
            destination_id=me, tlabel=1, source_id=HOST, offset=0x20, quadlet_data=0xCAFE0001
        )
        read = QuadletReadRequest(destination_id=me, tlabel=2, source_id=HOST, offset=0x20)
        block = BlockWriteRequest(
            destination_id=me, tlabel=3, source_id=HOST, offset=0x30, data=bytes(range(8))
        )
        block_read = BlockReadRequest(
            destination_id=me, tlabel=4, source_id=HOST, offset=0x30, data_length=8
        )
        odd_read = BlockReadRequest(
            destination_id=me, tlabel=5, source_id=HOST, offset=0x30, data_length=7
        )
        status = QuadletReadRequest(destination_id=me, tlabel=6, source_id=HOST, offset=0)
        packets = (write, read, block, block_read, odd_read, status)
        answer = sim.exchange([encode_async(p) for p in packets], 0.0)
        assert answer["violations"] == []
        replies = answer["replies"]
        (w_ack, _, _), (r_ack, r_raw, r_cat), (b_ack, _, _), (br_ack, br_raw, _) = replies[:4]
        assert (w_ack, r_ack, b_ack, br_ack) == (1, 2, 1, 2) and r_cat
        quadlet = decode_async(bytes.fromhex(r_raw))
        assert isinstance(quadlet, QuadletReadResponse) and quadlet.quadlet_data == 0xCAFE0001
        block_answer = decode_async(bytes.fromhex(br_raw))
        assert isinstance(block_answer, BlockReadResponse) and block_answer.data == bytes(range(8))
        # an odd length: the byte past it goes out as zero, under a data CRC over zeros
        odd = bytes.fromhex(replies[4][1])
        assert odd[20:28] == bytes(range(7)) + b"\0"
        assert decode_async(odd).problems == ()
        status_answer = decode_async(bytes.fromhex(replies[5][1]))
        assert isinstance(status_answer, QuadletReadResponse)
        assert status_answer.quadlet_data == board_id << 24
    finally:
        sim.close()


@pytest.mark.parametrize(
    "change",
    [
        ('reset_active = "high"', 'reset_active = "low"'),
        ('ctl = "ctl"', 'ctl = "ctl"\nctl0 = "lsb"'),
    ],
    ids=["reset-polarity", "ctl-bit-order"],
)
def test_a_map_under_which_the_design_never_acks_is_refused(
    tmp_path: Path, change: tuple[str, str]
) -> None:
    text = load("thesis-own").path.read_text().replace(*change)
    text = text.replace("@hdl/", str(load("thesis-own").sources[0].parent) + "/")
    path = tmp_path / "wrong.toml"
    path.write_text(text)
    with pytest.raises(NeverAcks, match="never acknowledged a valid quadlet read"):
        RtlTarget(load(path), node_id=0xFFC0)


def test_a_waveform_of_the_run_is_written(tmp_path: Path) -> None:
    waves = tmp_path / "repro.vcd"
    target = RtlTarget(load("thesis"), node_id=0xFFC0, waves=waves)
    raw = encode_async(QuadletReadRequest(destination_id=0xFFC0, tlabel=1, source_id=HOST))
    from fw1394.fuzz.trial import wire_of

    [reply] = target.exchange([wire_of(raw)], 0.0)
    target.close()
    assert reply.ack == AckCode.ack_pending
    text = waves.read_text()
    assert "$scope module fw1394_harness" in text and "$enddefinitions" in text
    assert " lreq " in text and "#" in text.split("$enddefinitions")[1]


def test_driving_on_the_phys_turn_is_caught() -> None:
    sim = Simulation(load(HERE / "late_release.toml"), physical_id=0)
    try:
        raw = encode_async(
            QuadletWriteRequest(
                destination_id=0xFFC0, tlabel=1, source_id=HOST, offset=0x20, quadlet_data=5
            )
        )
        answer = sim.exchange([raw], 0.0)
        assert answer["replies"][0][0] == AckCode.ack_complete
        assert {v.split(":")[0] for v in answer["violations"]} == {"release", "contention"}
    finally:
        sim.close()


@pytest.mark.parametrize("cut", [1, 3, 7])
def test_a_receive_may_cut_a_status_transfer_short(thesis: Simulation, cut: int) -> None:
    # The link must take the packet, and not a half-sent register 0 for its node ID.
    read = encode_async(QuadletReadRequest(destination_id=ME, tlabel=1, source_id=HOST, offset=4))
    answer = thesis.exchange([read], 0.004, interrupting=cut)
    assert answer["violations"] == []
    assert answer["replies"][0][0] == AckCode.ack_pending
    again = thesis.exchange([read], 0.004)["replies"][0]
    assert again[0] == AckCode.ack_pending


def test_a_register_bus_without_read_strobes_is_served_by_address() -> None:
    # An 8-bit address, no read strobe, no block signals: the board still answers.
    responder = Responder(0xFFC0, board("snake2010", 0), THESIS_FPGA)
    sim = Simulation(load(HERE / "no_rd.toml"), physical_id=0)
    try:
        packets = [
            QuadletReadRequest(destination_id=0xFFC0, tlabel=1, source_id=HOST, offset=4),
            QuadletWriteRequest(
                destination_id=0xFFC0,
                tlabel=2,
                source_id=HOST,
                offset=0x11,
                quadlet_data=0x80004321,
            ),
            QuadletReadRequest(destination_id=0xFFC0, tlabel=3, source_id=HOST, offset=0x11),
            BlockReadRequest(
                destination_id=0xFFC0, tlabel=4, source_id=HOST, offset=0x10, data_length=12
            ),
        ]
        raws = [encode_async(p) for p in packets]
        answer = sim.exchange(raws, 0.001)
        assert answer["violations"] == []
        for raw, got in zip(raws, answer["replies"], strict=True):
            assert got == _expected(responder, raw, 0.001), raw.hex()
    finally:
        sim.close()


@pytest.mark.parametrize(
    ("delay", "ack", "violation"),
    [(20, AckCode.ack_pending, "ack-gap"), (40, None, "unsolicited")],
)
def test_late_acks_break_the_ack_gap(
    tmp_path: Path, delay: int, ack: int | None, violation: str
) -> None:
    # LREQ delayed 20 cycles: the ack comes 33 cycles after the packet (gap 32);
    # delayed 40: LREQ is quiet for the whole gap (silence), and the ack comes anyway.
    text = (HERE / "slow_lreq.toml").read_text().replace("DELAY = 20", f"DELAY = {delay}")
    path = tmp_path / "slow.toml"
    path.write_text(text.replace('"variant_slow_lreq.v"', f'"{HERE / "variant_slow_lreq.v"}"'))
    sim = Simulation(load(path), physical_id=0)
    try:
        raw = encode_async(QuadletReadRequest(destination_id=0xFFC0, tlabel=1, source_id=HOST))
        answer = sim.exchange([raw], 0.0)
        assert answer["replies"][0][0] == ack
        assert [v.split(":")[0] for v in answer["violations"]] == [violation]
    finally:
        sim.close()
