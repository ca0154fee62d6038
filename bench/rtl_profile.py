"""Where an RTL case's time goes: simulated cycles per case, and the cost of each.

Sends generated cases (the fuzzer's generator, snake2010 offsets) straight to
the thesis link's simulation in batches, as the ``rtl:`` target does, and
reports: cases/s; SCLK cycles simulated per case (the PHY model steps each
one from Python); CPU seconds of the simulator process (vvp with cocotb: the
PHY model and Icarus together) and of this process (generator, JSON,
waiting), per case and per cycle. Run it beside ``bench/fuzz.py --rtl-only``
on the same machine; the load average is printed (the machine may be shared).

    python bench/rtl_profile.py [--cases 1000] [--batch 32] [--speed S400]
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import time

from fw1394.fuzz.generate import Generator
from fw1394.fuzz.offsets import offset_model
from fw1394.rtl.portmap import SPEED_NAMES, load
from fw1394.rtl.simulation import Simulation, missing_tools


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--speed", choices=SPEED_NAMES, default="S400")
    args = parser.parse_args()
    problem = missing_tools()
    if problem:
        print(f"skipped: {problem}")
        return
    generator = Generator(0xFFC0, offset_model("snake2010"), random.Random(0))
    cases = [generator.case()[0] for _ in range(args.cases)]
    speed = SPEED_NAMES.index(args.speed)
    own_before = time.process_time()
    sim = Simulation(load("thesis"), physical_id=0)
    start_cycles = sim.exchange([], 0.0)["cycles"]
    started = time.perf_counter()
    own_start = time.process_time()
    cycles = start_cycles
    for first in range(0, len(cases), args.batch):
        batch = cases[first : first + args.batch]
        cycles = sim.exchange(batch, first * 20e-6, speeds=[speed] * len(batch))["cycles"]
    elapsed = time.perf_counter() - started
    own = time.process_time() - own_start
    sim.close()
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    simulator = child.ru_utime + child.ru_stime  # start-up included (a second or so)
    simulated = cycles - start_cycles
    n = len(cases)
    print(f"{n} cases at {args.speed} in {elapsed:.1f} s: {n / elapsed:.0f} cases/s")
    print(f"cycles per case      {simulated / n:8.0f}")
    per_cycle = simulator / simulated * 1e6
    print(f"simulator CPU/case   {simulator / n * 1e3:8.2f} ms  ({per_cycle:.1f} us/cycle)")
    print(f"parent CPU/case      {own / n * 1e3:8.2f} ms  (setup {own_start - own_before:.2f} s)")
    print(f"wall/case            {elapsed / n * 1e3:8.2f} ms")
    print(f"load average {os.getloadavg()[0]:.1f} (shared machine)")


if __name__ == "__main__":
    main()
