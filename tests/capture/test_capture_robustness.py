"""``fw1394 dissect`` never crashes: damaged and random input of every format."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats import nosy
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.cli.main import main

DATA = Path(__file__).parents[1] / "data"
VIEWS = (["-s"], ["--transactions"], ["-v"], ["--rom"], ["--json"], ["--transactions", "--csv"])


def originals(tmp_path: Path) -> dict[str, bytes]:
    records = list(simulate(300, Scenario(separate_acks=True)))
    files = {}
    for name, container in (("trace.pcapng", "pcapng"), ("trace.pcap", "pcap")):
        write_trace(str(tmp_path / name), records, container)
        files[name] = (tmp_path / name).read_bytes()
    write_eth1394_sample(str(tmp_path / "eth.pcap"))
    files["eth.pcap"] = (tmp_path / "eth.pcap").read_bytes()
    with open(tmp_path / "dump.nosy", "wb") as stream:
        nosy.write(stream, simulate(100))
    files["dump.nosy"] = (tmp_path / "dump.nosy").read_bytes()
    for log in DATA.glob("firewire-*.txt"):
        files[log.name] = log.read_bytes()
    return files


def mutate(data: bytes, rng: random.Random) -> bytes:
    blob = bytearray(data)
    choice = rng.random()
    if choice < 0.4:
        for _ in range(rng.randint(1, 20)):
            spot = rng.randrange(len(blob))
            blob[spot] = rng.randrange(256)
    elif choice < 0.6:
        blob = blob[: rng.randrange(len(blob))]
    elif choice < 0.8:
        start = rng.randrange(len(blob))
        del blob[start : start + rng.randint(1, 64)]
    else:
        start = rng.randrange(len(blob))
        blob[start:start] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 64)))
    return bytes(blob)


@pytest.mark.slow
def test_damaged_files_of_every_format(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = random.Random(1394)
    files = originals(tmp_path)
    formats = {"trace": "auto", "eth": "udp", "dump": "nosy", "firewire": "kernel"}
    for round_number in range(120):
        name = rng.choice(sorted(files))
        path = tmp_path / f"damaged-{round_number}"
        path.write_bytes(mutate(files[name], rng))
        fmt = next(value for key, value in formats.items() if name.startswith(key))
        args = ["dissect", str(path), "--format", fmt, "--threads", "1", *rng.choice(VIEWS)]
        assert main(args) in (0, 2), (name, round_number)
        err = capsys.readouterr().err
        assert "Traceback" not in err


@pytest.mark.slow
def test_random_bytes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = random.Random(7)
    for round_number in range(40):
        path = tmp_path / f"random-{round_number}"
        path.write_bytes(bytes(rng.randrange(256) for _ in range(rng.randint(1, 3000))))
        for fmt in ("auto", "fw1394", "nosy", "kernel"):
            argv = ["dissect", str(path), "--format", fmt, "--transactions", "--threads", "1"]
            assert main(argv) in (0, 2)
        capsys.readouterr()
