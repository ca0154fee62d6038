"""Transaction engine speed: transactions per second through requester and responder.

Each transaction runs the way a transport would drive it, in memory: the
requester's request is encoded, the responder receives the bytes (and decodes
them), the ack goes back to the requester, the response (if any) is encoded and
decoded and handed to the requester, and its event is drained. In the same run
the codec alone does the same four encodes/decodes on the same packets; the
difference is the engine's own cost (requester, responder and the memory space
it serves). Target: engine / codec < 1.

    python bench/engine.py [--seconds 0.3]
"""

from __future__ import annotations

import argparse
import time
import timeit
from collections.abc import Callable

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import IEEE1394_NODE, THESIS_FPGA, Requester, Responder, ResponderPolicy
from fw1394.engine.loopback import Link
from fw1394.packets import AsyncPacket, encode
from fw1394.packets.asynchronous import decode_async

HOST, NODE = 0xFFC1, 0xFFC0
BLOCK = 512 * 4
LINK_BATCH = 32


def per_call(function: Callable[[], object], seconds: float) -> float:
    """Best-of-5 CPU seconds per call, each repeat running about ``seconds``.

    CPU time, not wall time: on a shared machine a repeat that loses the CPU to
    another process would otherwise count the other process's work too.
    """
    timer = timeit.Timer(function, timer=time.process_time)
    number, _ = timer.autorange()
    number = max(1, int(number * seconds / 0.2))
    return min(timer.repeat(repeat=5, number=number)) / number


def _starter(requester: Requester, kind: str) -> Callable[[float], int]:
    starts: dict[str, Callable[[float], int]] = {
        "quadlet read": lambda now: requester.read_quadlet(NODE, 16, now),
        "quadlet write": lambda now: requester.write_quadlet(NODE, 16, 0x12345678, now),
        "512-quadlet block read": lambda now: requester.read_block(NODE, 0, BLOCK, now),
    }
    return starts[kind]


def transaction(policy: ResponderPolicy, kind: str) -> Callable[[], object]:
    """One complete transaction of ``kind``, through the engine and the codec."""
    requester = Requester(node_id=HOST, duplicate_window=0.0)  # an in-memory medium: no copies
    responder = Responder(NODE, MemorySpace(8192), policy)
    start = _starter(requester, kind)
    clock = [0.0]

    def run() -> object:
        now = clock[0] = clock[0] + 1e-6
        start(now)
        for request in requester.packets_to_send():
            reply = responder.receive(encode(request), now)
            requester.receive_ack(NODE, request.tlabel, reply.ack, now)  # type: ignore[attr-defined]
            if reply.response is not None:
                requester.receive_response(decode_async(encode(reply.response), strict=True), now)
        return requester.events()

    return run


def engine_only(policy: ResponderPolicy, kind: str) -> Callable[[], object]:
    """The same transaction with the codec taken out: packets are handed over as objects."""
    requester = Requester(node_id=HOST, duplicate_window=0.0)  # an in-memory medium: no copies
    responder = Responder(NODE, MemorySpace(8192), policy)
    start = _starter(requester, kind)
    clock = [0.0]

    def run() -> object:
        now = clock[0] = clock[0] + 1e-6
        start(now)
        for request in requester.packets_to_send():
            reply = responder.receive_packet(request, now)
            requester.receive_ack(NODE, request.tlabel, reply.ack, now)  # type: ignore[attr-defined]
            if reply.response is not None:
                requester.receive_response(reply.response, now)
        return requester.events()

    return run


def codec_only(policy: ResponderPolicy, kind: str) -> Callable[[], object]:
    """The same transaction's encodes and decodes, and nothing else."""
    link = Link(
        Requester(node_id=HOST, duplicate_window=0.0), [Responder(NODE, MemorySpace(8192), policy)]
    )
    _starter(link.requester, kind)(0.0)
    link.run()
    packets: list[AsyncPacket] = [e.packet for e in link.trace if e.packet is not None]

    def run() -> object:
        for packet in packets:
            decode_async(encode(packet), strict=True)
        return None

    return run


def through_link(policy: ResponderPolicy, kind: str) -> Callable[[], object]:
    """``LINK_BATCH`` transactions through :class:`Link` (its own bookkeeping included)."""
    link = Link(
        Requester(node_id=HOST, duplicate_window=0.0),
        [Responder(NODE, MemorySpace(8192), policy)],
        keep_trace=False,
    )
    start = _starter(link.requester, kind)

    def run() -> object:
        for _ in range(LINK_BATCH):
            start(link.now)
        link.run()
        return link.requester.events()

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=0.1, help="time per measurement")
    args = parser.parse_args()
    print(
        f"{'policy':12} {'transaction':23} {'tx/s':>7} {'us/tx':>7} {'codec':>7} "
        f"{'engine':>7} {'engine/codec':>12} {'(tx-codec)/codec':>16} {'via Link':>9}"
    )
    worst = 0.0
    for name, policy in (("thesis FPGA", THESIS_FPGA), ("IEEE 1394", IEEE1394_NODE)):
        for kind in ("quadlet read", "quadlet write", "512-quadlet block read"):
            total = per_call(transaction(policy, kind), args.seconds)
            codec = per_call(codec_only(policy, kind), args.seconds)
            engine = per_call(engine_only(policy, kind), args.seconds)
            linked = per_call(through_link(policy, kind), args.seconds) / LINK_BATCH
            worst = max(worst, engine / codec)
            print(
                f"{name:12} {kind:23} {1 / total:7,.0f} {total * 1e6:7.1f} {codec * 1e6:7.1f} "
                f"{engine * 1e6:7.1f} {engine / codec:12.2f} {(total - codec) / codec:16.2f} "
                f"{linked * 1e6:9.1f}"
            )
    verdict = "met" if worst < 1 else "NOT met"
    print(
        "\nus per transaction. codec: its encodes and decodes alone; engine: requester and"
        "\nresponder alone (packets handed over as objects); (tx-codec)/codec also charges"
        "\nthe engine with the codec running slower when interleaved with other code."
        f"\nworst engine/codec ratio {worst:.2f} (target < 1: {verdict})"
    )


if __name__ == "__main__":
    main()
