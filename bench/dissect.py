"""Dissection speed and memory: ``fw1394 dissect`` end to end, against scapy's PcapReader.

Generates a trace of simulated bus traffic (a host polling four boards, with
busy retries, bus resets, lost and corrupted responses), then measures, each
in a fresh child process so its peak memory is its own:

* the whole pipeline of ``fw1394 dissect --stats``: read, decode, pair, count;
  once trusting the CRC verdicts recorded in the trace (the default) and once
  recomputing every CRC (``--verify-crc``);
* the same on a trace a quarter as long, to show memory does not grow with length;
* scapy's ``PcapReader`` over the first ``--sample`` packets (with fw1394's
  scapy layers loaded, so it builds one object per packet, as scapy does).

Targets: >= 1,000,000 packets/s, >= 100x scapy, memory flat in trace length.

    python bench/dissect.py [--packets 1000000] [--sample 20000] [--keep DIR] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_RATE = 1_000_000
TARGET_RATIO = 100

_DISSECT = """
import io, json, resource, sys, time
begin = time.perf_counter()
from fw1394.capture.formats import sources
from fw1394.capture.views.dissection import Dissection, Options
imported = time.perf_counter() - begin
path, threads, verify = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
start, cpu = time.perf_counter(), time.process_time()
options = Options(view="stats", workers=threads, verify_crc=True if verify else None)
outcome = Dissection(options, io.StringIO()).run(sources.jobs(path, "fw1394"))
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"records": outcome.records, "wall_s": wall, "cpu_s": cpu,
                  "import_s": imported, "peak_bytes": peak}))
"""

_SCAPY = """
import json, resource, sys, time
from scapy.utils import PcapReader
import fw1394.capture.views.scapy_layers
start = time.perf_counter()
count = sum(1 for _ in PcapReader(sys.argv[1]))
wall = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"records": count, "wall_s": wall, "peak_bytes": peak}))
"""


def child(code: str, *args: str) -> dict[str, float]:
    result = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, check=True
    )
    return dict(json.loads(result.stdout.splitlines()[-1]))


def make_trace(path: Path, packets: int) -> float:
    from fw1394.capture.analysis.traffic_sim import simulate
    from fw1394.capture.formats.trace_writer import write_trace

    start = time.perf_counter()
    write_trace(str(path), simulate(packets))
    return time.perf_counter() - start


def best(code: str, repeats: int, *args: str) -> dict[str, float]:
    runs = [child(code, *args) for _ in range(repeats)]
    return min(runs, key=lambda run: run["wall_s"])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--packets", type=int, default=1_000_000)
    parser.add_argument("--sample", type=int, default=20_000)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3, help="best of N runs")
    parser.add_argument("--keep", help="directory to keep (and reuse) the traces in")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()

    directory = Path(args.keep or tempfile.mkdtemp(prefix="fw1394-bench-"))
    directory.mkdir(parents=True, exist_ok=True)
    big = directory / f"sim-{args.packets}.pcapng"
    quarter = directory / f"sim-{args.packets // 4}.pcapng"
    small = directory / f"sim-{args.sample}.pcapng"
    generated = {}
    for path, count in ((big, args.packets), (quarter, args.packets // 4), (small, args.sample)):
        if not path.exists():
            generated[path.name] = make_trace(path, count)

    threads = str(args.threads)
    trusted = best(_DISSECT, args.repeats, str(big), threads, "0")
    verified = best(_DISSECT, args.repeats, str(big), threads, "1")
    short = best(_DISSECT, 1, str(quarter), threads, "0")
    scapy = child(_SCAPY, str(small))
    ours = trusted["records"] / trusted["wall_s"]
    scapy_rate = scapy["records"] / scapy["wall_s"]
    report = {
        "packets": int(trusted["records"]),
        "trace_bytes": big.stat().st_size,
        "threads": args.threads,
        "cpus": os.cpu_count(),
        "generation_s": generated,
        "rate_per_s": ours,
        "rate_with_imports_per_s": trusted["records"] / (trusted["wall_s"] + trusted["import_s"]),
        "import_s": trusted["import_s"],
        "cpu_rate_per_s": trusted["records"] / trusted["cpu_s"],
        "rate_verify_crc_per_s": verified["records"] / verified["wall_s"],
        "peak_mb": trusted["peak_bytes"] / 1e6,
        "peak_mb_short_trace": short["peak_bytes"] / 1e6,
        "short_trace_packets": int(short["records"]),
        "scapy_rate_per_s": scapy_rate,
        "scapy_peak_mb": scapy["peak_bytes"] / 1e6,
        "ratio_to_scapy": ours / scapy_rate,
    }
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"trace: {report['packets']} packets, {report['trace_bytes'] / 1e6:.0f} MB, in {big}")
    print(
        f"machine: {report['cpus']} CPUs, {args.threads} decoding threads, best of {args.repeats}"
    )
    print(
        f"fw1394 dissect --stats: {ours:,.0f} packets/s wall "
        f"({report['cpu_rate_per_s']:,.0f} per CPU-second); target {TARGET_RATE:,}"
    )
    print(
        f"  counting Python's imports ({report['import_s']:.2f} s) too: "
        f"{report['rate_with_imports_per_s']:,.0f}/s"
    )
    print(f"  with --verify-crc (every CRC recomputed): {report['rate_verify_crc_per_s']:,.0f}/s")
    print(
        f"  peak memory {report['peak_mb']:.0f} MB for {report['packets']:,} packets, "
        f"{report['peak_mb_short_trace']:.0f} MB for {report['short_trace_packets']:,}"
    )
    print(
        f"scapy PcapReader: {scapy_rate:,.0f} packets/s on {int(scapy['records']):,} packets "
        f"(peak {report['scapy_peak_mb']:.0f} MB)"
    )
    print(f"ratio: {report['ratio_to_scapy']:.0f}x scapy; target {TARGET_RATIO}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
