"""The capture readers, fuzzed: damaged traces end in records, issues or SourceError.

Each example writes a good trace in one of the formats, damages it the way
the packet fuzzer damages packets (bit flips, quadlets inserted and deleted,
truncation), and reads it back through ``fw1394.capture.formats.sources``, the entry
point every command uses. ``SourceError`` (a ``ValueError``) is the one
documented error; anything else escaping is a bug.
"""

from __future__ import annotations

import io
import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numpy")

from fw1394.capture.formats import nosy, sources
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.fuzz.mutate import havoc
from fw1394.fuzz.strategies import fuzz_cases

DATA = Path(__file__).parents[1] / "data"
SOME = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))


def read_all(path: Path, fmt: str | None = None) -> int:
    """Records read from ``path`` (detected format unless named); SourceError allowed."""
    try:
        kind = fmt or sources.detect(str(path))
        return sum(len(job()) for job in sources.jobs(str(path), kind))
    except sources.SourceError:
        return -1


def records(packets: list[bytes]) -> list[BusRecord]:
    return [
        BusRecord(timestamp_ns=1_000 * i, record_type=RecordType.async_packet, data=raw)
        for i, raw in enumerate(packets)
    ]


def damaged(data: bytes, rng: random.Random, cuts: int) -> bytes:
    for _ in range(cuts):
        data, _ = havoc(rng, data, fix_crc_share=0.0)
    if rng.random() < 0.3:
        data = data[: rng.randrange(len(data) + 1)]
    return data


@SOME
@given(
    st.lists(fuzz_cases(max_data=32), min_size=1, max_size=6),
    st.sampled_from(["pcapng", "pcap"]),
    st.randoms(use_true_random=False),
    st.integers(0, 4),
)
def test_damaged_fw1394_traces(
    tmp_path_factory: pytest.TempPathFactory,
    packets: list[bytes],
    container: str,
    rng: random.Random,
    cuts: int,
) -> None:
    path = tmp_path_factory.mktemp("trace") / f"t.{container}"
    write_trace(str(path), records(packets), container)
    path.write_bytes(damaged(path.read_bytes(), rng, cuts))
    read_all(path)
    read_all(path, "fw1394")


@SOME
@given(
    st.lists(fuzz_cases(max_data=32), min_size=1, max_size=6),
    st.randoms(use_true_random=False),
    st.integers(0, 4),
)
def test_damaged_nosy_dumps(
    tmp_path_factory: pytest.TempPathFactory, packets: list[bytes], rng: random.Random, cuts: int
) -> None:
    stream = io.BytesIO()
    nosy.write(stream, records(packets))
    path = tmp_path_factory.mktemp("nosy") / "dump.nosy"
    path.write_bytes(damaged(stream.getvalue(), rng, cuts))
    read_all(path, "nosy")


@SOME
@given(st.randoms(use_true_random=False), st.integers(1, 40))
def test_damaged_kernel_logs(
    tmp_path_factory: pytest.TempPathFactory, rng: random.Random, edits: int
) -> None:
    lines = (DATA / "firewire-tracepoints.txt").read_text().splitlines()
    lines += (DATA / "firewire-ohci-dmesg.txt").read_text().splitlines()
    for _ in range(edits):
        index = rng.randrange(len(lines))
        line = lines[index]
        if line and rng.random() < 0.7:
            at = rng.randrange(len(line))
            line = line[:at] + rng.choice("0123456789abcdefx :=[]-") + line[at + 1 :]
        else:
            line = line[: rng.randrange(len(line) + 1)]
        lines[index] = line
    path = tmp_path_factory.mktemp("kernel") / "log.txt"
    path.write_text("\n".join(lines))
    read_all(path, "kernel")


@SOME
@given(st.binary(max_size=512), st.sampled_from(["fw1394", "udp", "nosy", "kernel"]))
def test_arbitrary_bytes_in_every_format(
    tmp_path_factory: pytest.TempPathFactory, raw: bytes, fmt: str
) -> None:
    path = tmp_path_factory.mktemp("raw") / "file"
    path.write_bytes(raw)
    read_all(path)
    read_all(path, fmt)


def test_undamaged_traces_read_whole(tmp_path: Path) -> None:
    from fw1394.packets import QuadletReadRequest, encode

    packets = [encode(QuadletReadRequest(tlabel=i, offset=4 * i)) for i in range(5)]
    write_trace(str(tmp_path / "t.pcapng"), records(packets))
    stream = io.BytesIO()
    nosy.write(stream, records(packets))
    (tmp_path / "d.nosy").write_bytes(stream.getvalue())
    assert read_all(tmp_path / "t.pcapng") == 5
    assert read_all(tmp_path / "d.nosy", "nosy") == 5
    assert read_all(DATA / "firewire-tracepoints.txt") > 0
