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
@given(st.sampled_from([decoder.name for decoder in DECODERS]), st.randoms(use_true_random=False))
def test_mutated_input_raises_only_the_library_errors(name: str, rng: random.Random) -> None:
    decoder = BY_NAME[name]
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
