"""A blocking raw1394_read of a quadlet through fw1394's libraw1394, next to AdapterPort.

    python bench/raw1394_read.py               # 8 rounds of 2000 reads each way
    python bench/raw1394_read.py --rounds 4 --reads 500 --json

Starts a bus of one memory board with its host adapter (in a private runtime
directory), builds the library, and times quadlet reads of the board in
interleaved rounds: AdapterPort.read_quadlet from this process, then a small C
program (built here against the system's libraw1394 headers, run with the
library in place) calling raw1394_read in a loop, then AdapterPort again...
Each side times only its loop (the C program reports its own clock), so
process start-up is not counted. The ratio library / AdapterPort per round and
their median are printed; the issue's goal is <= 1.3x. Nothing is asserted.
The machine this runs on may be shared: compare ratios of one run, not
absolute times across runs.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fw1394.host.adapter_port import AdapterPort
from fw1394.raw1394.launch import environment
from fw1394.transport.adapter import wait_adapter
from fw1394.transport.config import BusConfig
from fw1394.transport.launch import LaunchedBus

PROGRAM = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <libraw1394/raw1394.h>
int main(int argc, char **argv)
{
	int reads = atoi(argv[1]), i;
	quadlet_t value;
	struct timespec a, b;
	raw1394handle_t h = raw1394_new_handle_on_port(0);
	if (!h) { perror("raw1394_new_handle_on_port"); return 1; }
	for (i = 0; i < 20; i++) raw1394_read(h, 0xFFC0, 0, 4, &value); /* warm up */
	clock_gettime(CLOCK_MONOTONIC, &a);
	for (i = 0; i < reads; i++)
		if (raw1394_read(h, 0xFFC0, 0, 4, &value) < 0) { perror("raw1394_read"); return 1; }
	clock_gettime(CLOCK_MONOTONIC, &b);
	printf("%.0f\n", ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / reads);
	raw1394_destroy_handle(h);
	return 0;
}
"""


def adapter_port_round(port: AdapterPort, reads: int) -> float:
    for _ in range(20):
        port.read_quadlet(0, 0)
    start = time.perf_counter_ns()
    for _ in range(reads):
        port.read_quadlet(0, 0)
    return (time.perf_counter_ns() - start) / reads


def library_round(program: Path, env: dict[str, str], reads: int) -> float:
    out = subprocess.run(
        [str(program), str(reads)], env=env, capture_output=True, text=True, check=True
    )
    return float(out.stdout)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--reads", type=int, default=2000)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if shutil.which("gcc") is None:
        print("raw1394_read bench: gcc is needed", file=sys.stderr)
        return 2
    work = Path(tempfile.mkdtemp(prefix="fwbench"))
    os.environ["XDG_RUNTIME_DIR"] = str(work)
    program = work / "read_loop"
    (work / "read_loop.c").write_text(PROGRAM)
    subprocess.run(
        ["gcc", "-O2", "-o", str(program), str(work / "read_loop.c"), "-lraw1394"], check=True
    )
    config = BusConfig(f"bench-raw1394-{os.getpid()}")
    bus = LaunchedBus(
        config, 1, board="memory", root=work / "fw1394", node_arguments=("--adapter",)
    )
    rows = []
    try:
        with bus:
            bus.wait_members()
            if wait_adapter(config, bus.directory, 30.0) is None:
                print("raw1394_read bench: the adapter did not come up", file=sys.stderr)
                return 1
            env = environment(config.name, work / "fw1394")
            with AdapterPort(config.name, root=work / "fw1394") as port:
                port.members()
                for _ in range(args.rounds):
                    python_ns = adapter_port_round(port, args.reads)
                    library_ns = library_round(program, env, args.reads)
                    rows.append((python_ns, library_ns, library_ns / python_ns))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    ratios = [r for _, _, r in rows]
    summary = {
        "reads_per_round": args.reads,
        "rounds": [
            {"adapter_port_us": p / 1e3, "raw1394_read_us": lib / 1e3, "ratio": r}
            for p, lib, r in rows
        ],
        "median_ratio": statistics.median(ratios),
        "goal": 1.3,
    }
    if args.json:
        print(json.dumps(summary))
        return 0
    print("quadlet read of one memory board, per read (interleaved rounds; shared machine)")
    print(f"{'round':>5}  {'AdapterPort':>12}  {'raw1394_read':>12}  {'ratio':>6}")
    for i, (p, lib, r) in enumerate(rows):
        print(f"{i:>5}  {p / 1e3:>10.1f}us  {lib / 1e3:>10.1f}us  {r:>6.2f}")
    print(f"median ratio raw1394_read / AdapterPort: {summary['median_ratio']:.2f} (goal <= 1.3)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
