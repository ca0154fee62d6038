"""Mutated input to every decoder raises only that decoder's documented errors.

The packet codec may raise PacketError, the Eth1394 datagram parsers
Eth1394Error, the capture readers (pcap, pcapng, Eth1394 in pcap, nosy, kernel
text) SourceError or put issues in their batches; an OverflowError, struct
error or IndexError escaping is a bug. ``bench/decoder_mutations.py`` runs a
million of these; here a few thousand, plus the inputs that once escaped.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numpy")

from fw1394.cli.main import main
from fw1394.fuzz.decoders import BY_NAME, DECODERS, check, mutated, seeds

SEEDS = seeds()
POOL = [data for datas in SEEDS.values() for data in datas]


@settings(
    max_examples=2_000,
    deadline=None,
    suppress_health_check=list(HealthCheck),
    database=None,
)
# The mutations come from a seeded Random: a failure prints its seed, which replays it.
# (st.randoms() records every call instead, which cost four times the decoding.)
@given(st.sampled_from([decoder.name for decoder in DECODERS]), st.integers(0, 2**64 - 1))
def test_mutated_input_raises_only_the_library_errors(name: str, seed: int) -> None:
    decoder = BY_NAME[name]
    rng = random.Random(seed)
    data = mutated(rng, rng.choice(SEEDS[name]), POOL)
    assert check(decoder, data) is None


# Kernel lines as Linux prints them, with numbers no 64-bit clock or 32-bit field holds.
OVERFLOWING = [
    b"[9223372037.000000] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 2\n",
    b"[ 12.000001] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 18446744073709551616\n",
    b"[ 12.000001] firewire_ohci 0000:05:00.0: 2 selfIDs, generation 4294967296, "
    b"local node ID ffc1\n",
    b"[ 12.000001] firewire_ohci 0000:05:00.0: AT spd 99999999999999999999 tl 05, "
    b"ffc1 -> ffc0, ack_complete, QR req, fffff0000400\n",
    b"   kworker/0:1-42 [000] ....  99999999999.000000: bus_reset_handle: card_index=0 "
    b"generation=5 node_id=0xffc1 bm_node_id=0xffff irm_node_id=0xffc1 self_id_count=1 "
    b"self_ids={0x807f8c56}\n",
]


@pytest.mark.parametrize("line", OVERFLOWING, ids=range(len(OVERFLOWING)))
def test_numbers_beyond_their_fields_are_a_one_line_error(
    line: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "k.txt"
    path.write_bytes(line)
    assert check(BY_NAME["kernel"], line) is None
    assert main(["dissect", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err and all(line.startswith("fw1394: ") for line in err.splitlines())


def test_the_same_line_in_range_decodes() -> None:
    line = b"[ 12.000001] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 2\n"
    assert BY_NAME["kernel"].decode(line) == 1


@pytest.mark.parametrize(
    ("option", "value"),
    [(9, bytes([127])), (9, bytes([28])), (14, (2**62).to_bytes(8, "little"))],
    ids=["if_tsresol 10^-127", "if_tsresol 10^-28", "if_tsoffset 2^62 s"],
)
def test_pcapng_time_options_beyond_int64_nanoseconds_decode(option: int, value: bytes) -> None:
    # An interface whose time resolution or offset no int64 nanosecond count can
    # hold (pcapng: if_tsresol is option 9, if_tsoffset option 14) is read, not fatal.
    options = option.to_bytes(2, "little") + len(value).to_bytes(2, "little")
    options += value + bytes(-len(value) % 4) + bytes(4)
    idb_body = (147).to_bytes(2, "little") + bytes(2) + bytes(4) + options
    shb_body = (0x1A2B3C4D).to_bytes(4, "little") + (1).to_bytes(2, "little") + bytes(2)
    shb_body += (2**64 - 1).to_bytes(8, "little")
    packet = bytes.fromhex("010c0002000b020501ff0000ffc00c40ffc1fffff000040011ab9b77")
    epb_body = bytes(4) + (5).to_bytes(4, "little") + (7).to_bytes(4, "little")
    epb_body += len(packet).to_bytes(4, "little") * 2 + packet

    def block(kind: int, body: bytes) -> bytes:
        size = (12 + len(body)).to_bytes(4, "little")
        return kind.to_bytes(4, "little") + size + body + size

    data = block(0x0A0D0D0A, shb_body) + block(1, idb_body) + block(6, epb_body)
    assert BY_NAME["pcapng"].decode(data) == 1
