"""Mutated input to every decoder: does anything but the library's own errors come out?

    python bench/decoder_mutations.py                  # 1,000,000 inputs
    python bench/decoder_mutations.py --inputs 20000   # a shorter run
    python bench/decoder_mutations.py --json           # one JSON object

Inputs are spread evenly over the decoders of :mod:`fw1394.fuzz.decoders`
(packets, Eth1394 datagrams, pcap, pcapng, Eth1394 in pcap, nosy, kernel text),
each a good seed damaged by :func:`fw1394.fuzz.decoders.mutated`. Printed: inputs
per decoder, escapes (exceptions that are not the decoder's documented errors)
by decoder and exception type with the first example's bytes, and the rate.
Exit status 1 if anything escaped.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter

from fw1394.fuzz.decoders import campaign


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=1394)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    inputs: Counter[str] = Counter()
    escapes: Counter[str] = Counter()
    examples: dict[str, str] = {}
    began = time.monotonic()
    for name, escape in campaign(args.inputs, args.seed):
        inputs[name] += 1
        if escape is not None:
            kind = f"{name}: {escape.error.partition(':')[0]}"
            escapes[kind] += 1
            examples.setdefault(kind, f"{escape.error[:120]} on {escape.data[:80]!r}")
    seconds = time.monotonic() - began
    if args.json:
        report = {
            "inputs": dict(inputs),
            "escapes": dict(escapes),
            "examples": examples,
            "seconds": round(seconds, 1),
        }
        print(json.dumps(report))
    else:
        total = sum(inputs.values())
        print(f"{total:,} mutated inputs in {seconds:.0f} s ({total / seconds:,.0f}/s)")
        for name, count in sorted(inputs.items()):
            print(f"  {name:8} {count:,}")
        print(f"{sum(escapes.values())} escaped the library's errors")
        for kind, count in escapes.most_common():
            print(f"  {kind}: {count}  e.g. {examples[kind]}")
    return 1 if escapes else 0


if __name__ == "__main__":
    sys.exit(main())
