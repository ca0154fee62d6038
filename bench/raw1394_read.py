"""A blocking raw1394_read of a quadlet through fw1394's libraw1394, next to AdapterPort.

    python bench/raw1394_read.py               # 8 rounds of 2000 reads each way
    python bench/raw1394_read.py --rounds 4 --reads 500 --json
    python bench/raw1394_read.py --rt          # the JHU-style loop, 4 boards


Starts a bus of one memory board with its host adapter (in a private runtime
directory), builds the library, and times quadlet reads of the board in
interleaved rounds: AdapterPort.read_quadlet from this process, then a small C
program (built here against the system's libraw1394 headers, run with the
library in place) calling raw1394_read in a loop, then AdapterPort again...
Each side times only its loop (the C program reports its own clock), so
process start-up is not counted. The ratio library / AdapterPort per round and
their median are printed; the issue's goal is <= 1.3x. ``--rt`` instead runs the
JHU host library's real-time loop shape through the library (per cycle, one
64-byte block read and one 16-byte block write per board, four boards) and
prints cycles per second (goal >= 1 kHz). Nothing is asserted.
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
from fw1394.transport.host_adapter.server import wait_adapter
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

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


RT_PROGRAM = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <libraw1394/raw1394.h>
int main(int argc, char **argv)
{
	int cycles = atoi(argv[1]), boards = atoi(argv[2]), i, b;
	quadlet_t in[16], out[4] = { 0 };
	struct timespec a, z;
	raw1394handle_t h = raw1394_new_handle_on_port(0);
	if (!h) { perror("raw1394_new_handle_on_port"); return 1; }
	clock_gettime(CLOCK_MONOTONIC, &a);
	for (i = 0; i < cycles; i++)
		for (b = 0; b < boards; b++) {
			out[0] = i;
			if (raw1394_read(h, 0xFFC0 | b, 0, sizeof in, in) < 0 ||
				raw1394_write(h, 0xFFC0 | b, 0x100, sizeof out, out) < 0) {
				perror("transaction"); return 1;
			}
		}
	clock_gettime(CLOCK_MONOTONIC, &z);
	printf("%.1f\n", cycles / ((z.tv_sec - a.tv_sec) + (z.tv_nsec - a.tv_nsec) / 1e9));
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
    parser.add_argument("--rt", action="store_true", help="the real-time loop, 4 boards")
    args = parser.parse_args()
    if shutil.which("gcc") is None:
        print("raw1394_read bench: gcc is needed", file=sys.stderr)
        return 2
    work = Path(tempfile.mkdtemp(prefix="fwbench"))
    os.environ["XDG_RUNTIME_DIR"] = str(work)
    program = work / "loop"
    (work / "loop.c").write_text(RT_PROGRAM if args.rt else PROGRAM)
    subprocess.run(
        ["gcc", "-O2", "-o", str(program), str(work / "loop.c"), "-lraw1394"], check=True
    )
    config = BusConfig(f"bench-raw1394-{os.getpid()}")
    boards = 4 if args.rt else 1
    bus = LaunchedBus(
        config, boards, board="memory", root=work / "fw1394", node_arguments=("--adapter",)
    )
    rows = []
    try:
        with bus:
            bus.wait_members()
            if wait_adapter(config, bus.directory, 30.0) is None:
                print("raw1394_read bench: the adapter did not come up", file=sys.stderr)
                return 1
            env = environment(config.name, work / "fw1394")
            if args.rt:
                for _ in range(args.rounds):
                    out = subprocess.run(
                        [str(program), str(args.reads // 4), str(boards)],
                        env=env,
                        capture_output=True,
                        text=True,
                        check=True,
                    )
                    rows.append((0.0, 0.0, float(out.stdout)))
            with AdapterPort(config.name, root=work / "fw1394") as port:
                port.members()
                for _ in range(0 if args.rt else args.rounds):
                    python_ns = adapter_port_round(port, args.reads)
                    library_ns = library_round(program, env, args.reads)
                    rows.append((python_ns, library_ns, library_ns / python_ns))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if args.rt:
        rates = [r for _, _, r in rows]
        if args.json:
            print(json.dumps({"boards": boards, "cycles_per_second": rates, "goal": 1000}))
        else:
            print("real-time loop through libraw1394: per cycle one 64-byte block read and one")
            print(f"16-byte block write to each of {boards} boards (shared machine)")
            print("cycles/s per round: " + ", ".join(f"{r:.0f}" for r in rates))
            print(f"median: {statistics.median(rates):.0f} cycles/s (goal >= 1000)")
        return 0
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
