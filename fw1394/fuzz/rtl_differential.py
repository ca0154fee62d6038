"""Differential check: the same seeded cases to a board emulator and to a link design.

Every case of the fuzzer's generator goes to ``inproc:KIND`` (the emulator
behind fw1394's responder, answering as the thesis FPGA) and to the RTL at the
same time on the same clock; both answers are put in wire form (ack code,
response bytes with their CRCs, tenure) and must be identical. A disagreement
names the case and both answers.

    python -m fw1394.fuzz.rtl_differential [--cases 5000] [--seed 0] [--portmap thesis]
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass

from fw1394.fuzz.contract import CONTRACTS
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.inproc import InprocTarget
from fw1394.fuzz.judge import describe
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.rtl_target import RtlTarget
from fw1394.fuzz.target import Observation, Observed, TargetGone
from fw1394.fuzz.trial import wire_of
from fw1394.packets import AsyncPacket
from fw1394.packets.asynchronous import encode_async
from fw1394.packets.nodeid import node_id
from fw1394.rtl.portmap import PortMapError, load

NODE_ID = node_id(0)
#: Cases per exchange with the simulator (fewer round trips; the same answers).
BATCH = 32
#: Simulated time between cases, seconds.
SPACING = 20e-6


@dataclass(frozen=True)
class Disagreement:
    case: int
    packet: bytes
    emulator: str
    rtl: str

    def line(self) -> str:
        return (
            f"case {self.case}: {self.packet.hex()[:48]}: emulator {self.emulator}; RTL {self.rtl}"
        )


def wire_form(observed: Observed) -> tuple[int | None, bytes | None, bool]:
    """(ack, response wire bytes, tenure) whatever the target's kind."""
    response = observed.response
    if isinstance(response, AsyncPacket):
        response = encode_async(response)
    return observed.ack, response, bool(observed.concatenated and response is not None)


def compare(
    cases: int,
    *,
    seed: int = 0,
    portmap: str = "thesis",
    kind: str | None = None,
    defects: frozenset[str] = frozenset(),
) -> Iterator[Disagreement]:
    """The disagreements over ``cases`` generated cases (a generator: stop early at will)."""
    design = load(portmap)
    kind = kind or design.model
    if kind is None:
        raise PortMapError(f"port map {design.path.name} names no board model to compare with")
    emulator = InprocTarget(kind, board_id=0, node_id=NODE_ID, policy=CONTRACTS["thesis"])
    rtl = RtlTarget(design, node_id=NODE_ID, defects=defects)
    generator = Generator(NODE_ID, offset_model(kind), random.Random(seed))
    try:
        done = 0
        while done < cases:
            count = min(BATCH, cases - done)
            batch = [wire_of(generator.case()[0]) for _ in range(count)]
            now = done * SPACING
            expected = emulator.exchange(batch, now)
            observed = rtl.exchange(batch, now)
            for offset, (wire, want, got) in enumerate(zip(batch, expected, observed, strict=True)):
                if wire_form(want) != wire_form(got):
                    yield Disagreement(done + offset + 1, wire.raw, describe(want), _describe(got))
            for line in rtl.interface_violations():
                yield Disagreement(done + count, b"", "no interface violation", line)
            done += count
    finally:
        rtl.close()


def _describe(observed: Observed) -> str:
    text = describe(observed)
    if isinstance(observed, Observation) and observed.concatenated:
        text += " (concatenated)"
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m fw1394.fuzz.rtl_differential",
        description="Send the same seeded cases to a board emulator and to a link design; "
        "every answer must agree (exit 1 on a disagreement).",
    )
    parser.add_argument("--cases", type=int, default=5000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--portmap", default="thesis", help="port map file or shipped name")
    parser.add_argument("--kind", default=None, help="emulator kind (default: the map's model)")
    parser.add_argument("--json", action="store_true", help="one JSON summary line")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    try:
        found = list(compare(args.cases, seed=args.seed, portmap=args.portmap, kind=args.kind))
    except (PortMapError, TargetGone, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    seconds = time.perf_counter() - start
    if args.json:
        print(
            json.dumps(
                {
                    "cases": args.cases,
                    "seed": args.seed,
                    "seconds": round(seconds, 1),
                    "disagreements": [d.line() for d in found],
                }
            )
        )
    else:
        for disagreement in found[:20]:
            print(disagreement.line())
        print(
            f"{args.cases} cases (seed {args.seed}) in {seconds:.1f} s: {len(found)} disagreements"
        )
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
