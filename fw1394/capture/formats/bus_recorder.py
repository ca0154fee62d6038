"""Recording a virtual bus into a trace file, as a library call or a process of its own.

``python -m fw1394.capture.formats.bus_recorder BUS FILE`` records bus BUS into
FILE until SIGINT or SIGTERM, writing the file header as soon as its tap
listens; programs that must not share a core with the capture (the demo's
servo loop) run it that way.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from types import FrameType

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.live import Limits, capture_records
from fw1394.capture.formats.pcap_writer import PcapngWriter, PcapWriter
from fw1394.capture.formats.pseudo_header import LINKTYPE_FW1394


def open_writer(path: Path, bus: str, *, pcap: bool = False) -> PcapngWriter | PcapWriter:
    """A trace writer of fw1394's link type on ``path`` (classic pcap when asked)."""
    stream = path.open("wb")
    if pcap:
        return PcapWriter(stream, LINKTYPE_FW1394)
    return PcapngWriter(
        stream, LINKTYPE_FW1394, interface_name="fw1394", description=f"fw1394 virtual bus {bus}"
    )


def record_bus(
    bus: str,
    path: Path,
    stop: threading.Event,
    *,
    duration: float | None = None,
    count: int | None = None,
    pcap: bool = False,
    show: Callable[[str], None] | None = None,
) -> int:
    """Record bus ``bus`` into ``path`` until ``stop``, a duration or a count; how many records."""
    with BusTap(bus) as tap:
        writer = open_writer(path, bus, pcap=pcap)
        writer.flush()  # the header on disk tells whoever waits for it that the tap listens
        try:
            return capture_records(tap, writer, Limits(stop, duration, count), show)
        finally:
            writer.close()


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python -m fw1394.capture.formats.bus_recorder BUS FILE", file=sys.stderr)
        return 2
    stop = threading.Event()

    def on_signal(number: int, frame: FrameType | None) -> None:
        stop.set()

    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, on_signal)
    try:
        record_bus(argv[0], Path(argv[1]), stop)
    except (OSError, ValueError) as error:
        print(f"fw1394 capture: {argv[1]}: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
