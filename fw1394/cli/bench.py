"""``fw1394 bench``: the thesis's §8 experiments against a target, beside the thesis's numbers.

Quadlet reads and writes (9,000 each, bands, mean and percentiles), block
reads and writes of every size up to 512 quadlets (base latency and
throughput from a linear fit), the seven-axis servo budget at 1, 8 and
10 kHz, quadlet read latency as the bus grows to 63 nodes, and a raw UDP
ping-pong of the same run that every figure is divided by. On a bus target, a
quadlet read's three frames with no work done (the transport's floor) are timed
in the same rounds. Every round starts once the other half has stopped polling,
and each half's wake-ups and preemptions per call are reported: a ratio whose
halves ran in different regimes is flagged (--pin keeps the two ends of a
round trip on different CPUs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from fw1394.cli.common import CliError, print_json

EXAMPLES = """\
examples:
  fw1394 bench                               full run on a fresh virtual bus (a few minutes)
  fw1394 bench --quick --json                the CI run (under 20 s)
  fw1394 bench --quick --pin                 bench on one CPU, its peers on the others
  fw1394 bench --plots docs/performance      PNG figures in the thesis's form
  fw1394 bench --target bus:default/0        node 0 of a bus that is up (fw1394 bus up)
  fw1394 jhu serve --eth1394 127.0.0.1:11394 &
  fw1394 bench --target udp:127.0.0.1:11394 --eth1394     a QLA board behind Eth1394
  fw1394 bench --sizes 1-64,128,256,512 --skip scale

Writes go to offset 0 (status register, real-time block) with every enable
and valid bit clear; do not point the bench at a board with powered amplifiers.
"""


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="thesis §8 latency and throughput experiments, beside the thesis's numbers",
        description=__doc__,
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--target",
        default=None,
        metavar="TARGET",
        help="virtual (default: a fresh bus of one board), bus:NAME/NODE, or udp:HOST[:PORT]",
    )
    parser.add_argument(
        "--eth1394", action="store_true", help="the udp: target speaks JHU Eth1394 (a QLA board)"
    )
    parser.add_argument(
        "--board-id", type=int, default=None, help="Eth1394: board ID to measure (default: first)"
    )
    parser.add_argument(
        "--board", default="snake2010", help="board kind of the fresh bus (default: snake2010)"
    )
    parser.add_argument("--quick", action="store_true", help="a short run for CI (under 20 s)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--plots", type=Path, default=None, metavar="DIR", help="write PNGs here")
    parser.add_argument(
        "--sizes", default=None, help="block sizes in quadlets, e.g. 1-64,128,512 (default 1-512)"
    )
    parser.add_argument("--iterations", type=int, default=None, help="quadlet reads and writes")
    parser.add_argument("--passes", type=int, default=None, help="sweeps over the block sizes")
    parser.add_argument(
        "--scale-boards", default=None, help="bus sizes in boards, e.g. 1,2,4 (default up to 62)"
    )
    parser.add_argument(
        "--skip",
        default="",
        metavar="LIST",
        help="experiments to leave out: quadlet, block, scale (comma-separated)",
    )
    parser.add_argument(
        "--pin", action="store_true", help="bench on one CPU, nodes and echo on the others"
    )
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds for a bus to form")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(handler=run_bench_command)


def size_list(text: str, low: int, high: int, what: str) -> tuple[int, ...]:
    """``1-64,128,512`` as sorted distinct numbers, each in ``low..high``."""
    values: set[int] = set()
    for part in text.replace(" ", "").split(","):
        first, dash, last = part.partition("-")
        try:
            start = int(first)
            stop = int(last) if dash else start
        except ValueError:
            raise CliError(f"{what} {text!r}: {part!r} is not N or N-M") from None
        if not low <= start <= stop <= high:
            raise CliError(f"{what} {text!r}: {part!r} is outside {low}..{high} or reversed")
        values.update(range(start, stop + 1))
    return tuple(sorted(values))


def _settings(args: argparse.Namespace) -> Any:
    from fw1394.experiments.run_settings import EXPERIMENTS, FULL, QUICK, adjusted

    skip = {name for name in args.skip.replace(" ", "").split(",") if name}
    unknown = skip - set(EXPERIMENTS)
    if unknown:
        raise CliError(f"--skip {args.skip!r}: no experiment {', '.join(sorted(unknown))}")
    for name in ("iterations", "passes"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise CliError(f"--{name} {value} must be at least 1")
    sizes = None if args.sizes is None else size_list(args.sizes, 1, 512, "--sizes")
    if sizes is not None and len(sizes) < 2 and "block" not in skip:
        raise CliError("--sizes needs at least two sizes to fit a line")
    boards = (
        None if args.scale_boards is None else size_list(args.scale_boards, 1, 62, "--scale-boards")
    )
    return adjusted(
        QUICK if args.quick else FULL,
        quadlet_iterations=args.iterations,
        block_sizes=sizes,
        block_passes=args.passes,
        scale_boards=boards,
        experiments=tuple(name for name in EXPERIMENTS if name not in skip),
    )


def run_bench_command(args: argparse.Namespace) -> int:
    from fw1394.boards import BOARDS
    from fw1394.experiments.connect import parse_target
    from fw1394.experiments.report_text import render
    from fw1394.experiments.results import digest
    from fw1394.experiments.run import run_bench
    from fw1394.experiments.timing import MeasurementError
    from fw1394.progress import Progress

    settings = _settings(args)
    try:
        spec = parse_target(args.target, eth1394=args.eth1394)
    except ValueError as error:
        raise CliError(f"--target: {error}") from None
    if args.board not in BOARDS:
        # The wording is pinned by tests/experiments/test_bench_cli.py.
        known = ", ".join(sorted(BOARDS))
        raise CliError(f"--board {args.board!r}: not memory or one of {known}")
    progress = Progress(enabled=not args.quiet)
    try:
        result = run_bench(
            spec,
            settings,
            board=args.board,
            board_id=args.board_id,
            pin_cpus=args.pin,
            progress=progress,
            timeout=args.timeout,
        )
    except MeasurementError as error:
        print(f"fw1394: bench failed: {error}", file=sys.stderr)
        return 1
    numbers = digest(result)
    if args.plots is not None:
        # Imported only here: plotting pulls in matplotlib and the capture package's helpers.
        from fw1394.experiments.figures import write_plots

        paths = write_plots(result, numbers, args.plots)
        numbers["plots"] = [str(path) for path in paths]
    if args.json:
        print_json(numbers)
    else:
        print(render(numbers), end="")
    return 0
