"""Every decoder, fed mutated input: only the library's own errors may come out.

Each decoder is named with the errors it documents: the packet codec raises
:class:`~fw1394.packets.PacketError`, the Eth1394 datagram parsers
:class:`~fw1394.packets.eth1394.Eth1394Error`, and the capture readers (pcap,
pcapng, nosy, kernel text, through :mod:`fw1394.capture.formats.sources`, the
entry point every command uses) :class:`~fw1394.capture.formats.sources.SourceError`
or issues in their batches. Anything else escaping (``OverflowError``,
``struct.error``, ``IndexError``, ...) is a bug. Seeds are good inputs of each
kind; :func:`fw1394.fuzz.mutate.havoc` damages them, as the packet fuzzer
damages packets, plus truncation, splices and numbers that overflow.

``bench/decoder_mutations.py`` runs a million inputs; the capture tests run a
few thousand.
"""

from __future__ import annotations

import io
import random
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from fw1394.capture.analysis.sample_traces import eth1394_frames
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats import nosy, sources
from fw1394.capture.formats.pcap_writer import LINKTYPE_ETHERNET, open_writer
from fw1394.capture.formats.record import BusRecord
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.fuzz.mutate import havoc
from fw1394.packets import PacketError, decode
from fw1394.packets.eth1394 import Eth1394Error, parse_request, parse_response


def _read_capture(fmt: str) -> Callable[[bytes], object]:
    def read(data: bytes) -> object:
        return sum(len(job()) for job in sources.stream_jobs(io.BytesIO(data), fmt))

    return read


def _packet(data: bytes) -> object:
    decode(data, strict=False)
    decode(data, crc=False, strict=False)
    return decode(data)


def _eth1394(data: bytes) -> object:
    parse_request(data)
    return parse_response(data, len(data) // 2)


@dataclass(frozen=True, slots=True)
class Decoder:
    name: str
    decode: Callable[[bytes], object]
    #: What it may raise: the library's errors for bad input.
    errors: tuple[type[Exception], ...]


DECODERS = (
    Decoder("packet", _packet, (PacketError,)),
    Decoder("eth1394", _eth1394, (Eth1394Error,)),
    Decoder("pcap", _read_capture("fw1394"), (sources.SourceError,)),
    Decoder("pcapng", _read_capture("fw1394"), (sources.SourceError,)),
    Decoder("udp", _read_capture("udp"), (sources.SourceError,)),
    Decoder("nosy", _read_capture("nosy"), (sources.SourceError,)),
    Decoder("kernel", _read_capture("kernel"), (sources.SourceError,)),
)
BY_NAME = {decoder.name: decoder for decoder in DECODERS}

#: Kernel text lines: dmesg firewire-ohci lines and ftrace tracepoints, as Linux prints
#: them (timestamps, generations and counts are where overflow goes in).
KERNEL_LINES = (
    b"[ 1234.567890] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 2\n",
    b"[ 1234.567891] firewire_ohci 0000:05:00.0: AT spd 2 tl 05, ffc1 -> ffc0, "
    b"ack_complete, QR req, fffff0000400\n",
    b"[ 1234.567892] firewire_ohci 0000:05:00.0: AR spd 2 tl 05, ffc0 -> ffc1, "
    b"ack_complete, QR resp = 04030201\n",
    b"[ 1234.567893] firewire_ohci 0000:05:00.0: 2 selfIDs, generation 3, local node ID ffc1\n",
    b"[ 1234.567894] firewire_ohci 0000:05:00.0: selfID 0: 807f8c56, phy 0 [-p-] S400 gc=63\n",
    b"   kworker/0:1-42 [000] ....  1234.567895: async_request_outbound_initiate: "
    b"transaction=0xffff8880 generation=4 scode=2 dst_id=0xffc0 tlabel=5 tcode=4 "
    b"src_id=0xffc1 offset=0xfffff0000400 header={0xffc01140,0xffc1ffff,0xf0000400}\n",
    b"   kworker/0:1-42 [000] ....  1234.567896: async_request_outbound_complete: "
    b"transaction=0xffff8880 generation=4 scode=2 status=17 timestamp=0x1234\n",
    b"   kworker/0:1-42 [000] ....  1234.567897: bus_reset_handle: card_index=0 "
    b"generation=5 node_id=0xffc1 bm_node_id=0xffff irm_node_id=0xffc1 self_id_count=1 "
    b"self_ids={0x807f8c56}\n",
)
#: Numbers that overflow whatever holds them: 64-bit nanoseconds, 32-bit fields.
OVERFLOWING = (
    b"9223372037",
    b"18446744073709551616",
    b"99999999999999999999999",
    b"4294967296",
    b"0xffffffffffffffffff",
    b"-1",
)


def seeds(rng: random.Random | None = None) -> dict[str, list[bytes]]:
    """Good inputs of every decoder (files built in memory)."""
    rng = rng or random.Random(1394)
    records = list(simulate(120, Scenario(separate_acks=True)))
    packets = [bytes(record.data) for record in records if record.data][:60]
    out: dict[str, list[bytes]] = {"packet": packets}
    frames = eth1394_frames()
    out["eth1394"] = [frame[42:] for frame in frames if len(frame) > 42]
    for container in ("pcap", "pcapng"):
        out[container] = [_written(partial(_write_records, records=records, container=container))]
    out["udp"] = [_written(partial(_write_frames, frames=frames))]
    stream = io.BytesIO()
    nosy.write(stream, simulate(60))
    out["nosy"] = [stream.getvalue()]
    out["kernel"] = [b"".join(KERNEL_LINES), *KERNEL_LINES]
    return out


def _write_records(path: str, records: list[BusRecord], container: str) -> None:
    write_trace(path, records, container)


def _write_frames(path: str, frames: list[bytes]) -> None:
    with open_writer(path, LINKTYPE_ETHERNET, "pcap") as writer:
        for index, frame in enumerate(frames):
            writer.write(1_700_000_000_000_000_000 + 100_000 * index, frame)


def _written(write: Callable[[str], object]) -> bytes:
    with tempfile.TemporaryDirectory() as directory:
        path = str(Path(directory) / "trace")
        write(path)
        return Path(path).read_bytes()


def mutated(rng: random.Random, seed: bytes, pool: list[bytes]) -> bytes:
    """``seed`` damaged one to several ways."""
    data = seed
    for _ in range(rng.randint(1, 4)):
        roll = rng.random()
        if roll < 0.45 and data:
            data, _ = havoc(rng, data, fix_crc_share=0.3)
        elif roll < 0.6 and data:
            data = data[: rng.randrange(len(data) + 1)]
        elif roll < 0.75:
            other = rng.choice(pool)
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + other[rng.randrange(len(other) + 1) :]
        elif roll < 0.9 and data:
            at = rng.randrange(len(data))
            width = rng.choice((1, 2, 4, 8))
            data = data[:at] + rng.choice((b"\xff", b"\x00", b"\x80", b"\x7f")) * width + data[at:]
        else:
            data = _number_swapped(rng, data)
    return data


def _number_swapped(rng: random.Random, data: bytes) -> bytes:
    """A run of digits (a timestamp, a generation, a count) replaced by one too big."""
    spans = [i for i in range(len(data)) if 0x30 <= data[i] <= 0x39]
    if not spans:
        return data + rng.choice(OVERFLOWING)
    start = rng.choice(spans)
    end = start
    while end < len(data) and 0x30 <= data[end] <= 0x39:
        end += 1
    return data[:start] + rng.choice(OVERFLOWING) + data[end:]


@dataclass(frozen=True, slots=True)
class Escape:
    """An exception a decoder let out that is not one of its documented errors."""

    decoder: str
    error: str
    data: bytes


def check(decoder: Decoder, data: bytes) -> Escape | None:
    try:
        decoder.decode(data)
    except decoder.errors:
        return None
    except Exception as error:  # the point: whatever else escapes is reported
        return Escape(decoder.name, f"{type(error).__name__}: {error}", data)
    return None


def campaign(count: int, seed: int = 1394) -> Iterator[tuple[str, Escape | None]]:
    """``count`` mutated inputs, spread over every decoder; each one's escape or None."""
    rng = random.Random(seed)
    corpus = seeds(rng)
    pool = [data for datas in corpus.values() for data in datas]
    for number in range(count):
        decoder = DECODERS[number % len(DECODERS)]
        data = mutated(rng, rng.choice(corpus[decoder.name]), pool)
        yield decoder.name, check(decoder, data)
