"""Codec speed: decode and encode rates, construct path and fast path.

Every rate is printed with its ratio to a plain ``struct.unpack`` of the same
packet's header quadlets, measured in the same run (the machines are noisy, so
only ratios compare across runs). Targets: the construct path decodes a quadlet
read request in <= 5 us; the fast path reaches >= 1,000,000 decodes/s and stays
within 3x of the struct baseline.

    python bench/codec.py [--seconds 0.5]
"""

from __future__ import annotations

import argparse
import struct
import timeit
from collections.abc import Callable

from fw1394.packets import (
    LAYOUTS,
    AsyncPacket,
    BlockReadResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    decode,
    encode,
)
from fw1394.packets.fast import decode_header

SAMPLES = {
    "quadlet read request": QuadletReadRequest(destination_id=0xFFC0, tlabel=5, offset=0x4),
    "quadlet read response": QuadletReadResponse(
        destination_id=0xFFC1, source_id=0xFFC0, tlabel=5, quadlet_data=0x514C4131
    ),
    "512-quadlet block read response": BlockReadResponse(
        destination_id=0xFFC1, source_id=0xFFC0, tlabel=5, data=bytes(range(256)) * 8
    ),
}


def per_call(function: Callable[[], object], seconds: float) -> float:
    """Best-of-5 seconds per call, each repeat running about ``seconds``."""
    timer = timeit.Timer(function)
    number, _ = timer.autorange()
    number = max(1, int(number * seconds / 0.2))
    return min(timer.repeat(repeat=5, number=number)) / number


def measure(packet: AsyncPacket, seconds: float) -> dict[str, float]:
    wire = encode(packet)
    count = LAYOUTS[packet.tcode].sealed_header.count
    # The baseline unpacks the same header quadlets and nothing more: the floor
    # any Python decoder of this packet sits on.
    unpack = struct.Struct(f">{count}I").unpack_from
    return {
        "struct.unpack baseline": per_call(lambda: unpack(wire), seconds),
        "decode (construct)": per_call(lambda: decode(wire), seconds),
        "decode_header (fast)": per_call(lambda: decode_header(wire), seconds),
        "encode (construct)": per_call(lambda: encode(packet), seconds),
    }


def bulk_per_packet(seconds: float, verify_crc: bool, count: int = 100_000) -> float:
    """Seconds per packet of the vectorised header decoder over a batch of packets."""
    from fw1394.capture.analysis import columns
    from fw1394.capture.formats import batch
    from fw1394.capture.formats.record import BusRecord, RecordType

    kinds = list(SAMPLES.values())[:2]
    records = [BusRecord(i, RecordType.async_packet, encode(kinds[i % 2])) for i in range(count)]
    packed = batch.from_records(records, range(count))
    return per_call(lambda: columns.decode(packed, verify_crc=verify_crc), seconds) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=0.3, help="time per measurement")
    args = parser.parse_args()
    print(f"{'packet':34} {'operation':22} {'us/op':>8} {'ops/s':>12} {'x struct':>9}")
    for name, packet in SAMPLES.items():
        rows = measure(packet, args.seconds)
        baseline = rows["struct.unpack baseline"]
        for operation, seconds in rows.items():
            print(
                f"{name:34} {operation:22} {seconds * 1e6:8.2f} {1 / seconds:12,.0f} "
                f"{seconds / baseline:9.2f}"
            )
    print()
    print(f"{'bulk (numpy, capture.analysis.columns)':57} {'us/packet':>8} {'packets/s':>12}")
    bulk: dict[bool, float] = {}
    for verify in (False, True):
        bulk[verify] = bulk_per_packet(args.seconds, verify)
        label = f"decode 100,000 packets{' + CRC check' if verify else ''}"
        print(f"{label:57} {bulk[verify] * 1e6:8.3f} {1 / bulk[verify]:12,.0f}")
    qread = encode(SAMPLES["quadlet read request"])
    baseline = measure(SAMPLES["quadlet read request"], args.seconds)["struct.unpack baseline"]
    construct_us = per_call(lambda: decode(qread), args.seconds) * 1e6
    fast_rate = 1 / per_call(lambda: decode_header(qread), args.seconds)
    print()
    print(
        f"target construct decode <= 5 us: {construct_us:.2f} us "
        f"({'met' if construct_us <= 5 else 'NOT met'})"
    )
    print(
        f"target fast path >= 1,000,000/s: {fast_rate:,.0f}/s "
        f"({'met' if fast_rate >= 1e6 else 'NOT met'})"
    )
    for name, seconds in (("one call per packet", 1 / fast_rate), ("bulk", bulk[False])):
        ratio = seconds / baseline
        print(
            f"target fast path within 3x of struct.unpack ({name}): {ratio:.2f}x "
            f"({'met' if ratio <= 3 else 'NOT met'})"
        )


if __name__ == "__main__":
    main()
