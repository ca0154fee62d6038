"""``fw1394 fuzz run|replay|defects``: fuzz a node's packet parser against its contract."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from fw1394.cli.common import CliError, integer, print_json
from fw1394.packets.nodeid import LOCAL_BASE

EXAMPLES = """\
examples:
  fw1394 fuzz run inproc:qla1 --max-cases 20000          QLA emulator vs the thesis contract
  fw1394 fuzz run inproc:qla1 --oracle jhu --seed 7      ... vs what the JHU firmware does
  fw1394 fuzz run inproc:memory --defect wedge-after-long-block-write --max-cases 2000
  fw1394 fuzz run bus:default/0 --model memory --duration 60
  fw1394 fuzz run udp:127.0.0.1:1394 --eth1394 --model qla1 --duration 60
  fw1394 fuzz run udp:127.0.0.1:11394 --model memory --restart ./start-node.sh --duration 60
  fw1394 fuzz run inproc:memory --jobs 2 --max-cases 100000 --seed 3
  fw1394 fuzz run inproc:qla1 --oracle jhu --defect hw-version-swapped --plot run.png
  fw1394 fuzz replay fuzz-findings                       do the saved findings still happen?
  fw1394 fuzz replay fuzz-findings --restart ./start-node.sh
  fw1394 fuzz defects qla1                               the bugs --defect can plant
  fw1394 fuzz serve memory --listen 127.0.0.1:11394 --defect answers-other-node
"""


def register(subparsers: Any) -> None:
    fuzz = subparsers.add_parser(
        "fuzz",
        help="fuzz a node's packet parser against its contract",
        description=(
            "Send a node every kind of packet the wire can carry, valid and malformed, and "
            "check its answers against a contract (thesis FPGA, JHU firmware, IEEE 1394) "
            "and a reference model of its board. See docs/fuzzing.md."
        ),
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = fuzz.add_subparsers(dest="action", metavar="ACTION", required=True)
    run = actions.add_parser("run", help="run a campaign and save its findings")
    add_run_options(run)
    run.set_defaults(handler=run_campaign)
    replay = actions.add_parser("replay", help="replay saved findings on a fresh node")
    replay.add_argument("directory", metavar="DIR", help="findings directory (or one .json)")
    replay.add_argument("--target", default=None, help="replay on this target instead")
    replay.add_argument(
        "--restart",
        default=None,
        metavar="CMD",
        help="remote targets: shell command run before each stream to bring up a fresh node",
    )
    replay.add_argument("--json", action="store_true", help="one JSON line per finding")
    replay.set_defaults(handler=run_replay)
    serve = actions.add_parser(
        "serve",
        help="serve a board over a UDP tunnel (a process to fuzz with udp:)",
        description=(
            "Serve one emulated board over fw1394's tunnel frames or the Eth1394 framing "
            "on a loopback UDP port, with planted defects if asked. Prints the address "
            "it listens on, then serves until interrupted or --duration passes."
        ),
    )
    serve.add_argument("board", metavar="BOARD", help="board kind (memory, qla1, snake2010, ...)")
    serve.add_argument("--listen", default="127.0.0.1:0", help="HOST:PORT (0: any free port)")
    serve.add_argument("--eth1394", action="store_true", help="JHU Eth1394 framing")
    serve.add_argument("--policy", choices=("thesis", "jhu", "ieee1394"), default=None)
    serve.add_argument("--board-id", type=integer, default=0, help="the board's own ID")
    serve.add_argument("--node-id", type=integer, default=LOCAL_BASE, help="16-bit node ID")
    serve.add_argument("--defect", action="append", default=[], metavar="NAME")
    serve.add_argument("--duration", type=float, default=None, help="stop after S seconds")
    serve.add_argument("--parent-pid", type=int, default=None, help=argparse.SUPPRESS)
    serve.set_defaults(handler=run_serve)
    defects = actions.add_parser("defects", help="list the defects --defect can plant")
    defects.add_argument("board", nargs="?", default=None, help="board kind (default: all)")
    defects.set_defaults(handler=list_defects)


def add_run_options(run: argparse.ArgumentParser) -> None:
    run.add_argument(
        "target", metavar="TARGET", help="inproc:BOARD, bus:NAME/NODE, udp:HOST[:PORT], rtl:PORTMAP"
    )
    what = run.add_argument_group("contract and model")
    what.add_argument(
        "--oracle",
        choices=("thesis", "jhu", "ieee1394"),
        default="thesis",
        help="the contract the node is held to (default: thesis)",
    )
    what.add_argument("--model", default=None, help="board kind of the reference model")
    what.add_argument("--board-id", type=integer, default=0, help="the board's own ID (default 0)")
    what.add_argument("--node-id", type=integer, default=LOCAL_BASE, help="16-bit node ID (0xffc0)")
    what.add_argument(
        "--policy",
        choices=("thesis", "jhu", "ieee1394"),
        default=None,
        help="inproc: how the fuzzed node answers (default: its board's own way)",
    )
    what.add_argument(
        "--defect", action="append", default=[], metavar="NAME", help="inproc: plant a bug"
    )
    limits = run.add_argument_group("limits and reproducibility")
    limits.add_argument("--seed", type=integer, default=0, help="makes a run repeatable")
    limits.add_argument("--max-cases", type=integer, default=None, help="stop after N cases")
    limits.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="the whole run, shrinking included, ends within S seconds (but for a replay "
        "begun before): fuzzing stops at S, or at 80%% of S once there are findings to "
        "shrink, and shrinking stops at S, the findings left kept as found",
    )
    limits.add_argument(
        "--engine",
        choices=("fast", "hypothesis"),
        default="fast",
        help="fast: seeded generator, thousands of cases/s; hypothesis (inproc only): "
        "slower, findings shrunk by hypothesis",
    )
    checks = run.add_argument_group("oracles")
    checks.add_argument(
        "--probe-every",
        type=integer,
        default=4,
        help="inproc: liveness probe every N cases (remote targets: every case)",
    )
    checks.add_argument("--state-every", type=integer, default=64, help="register sweep every N")
    checks.add_argument("--probe-offset", type=integer, default=None, help="offset probed")
    checks.add_argument("--pid", type=integer, default=None, help="udp: node process to watch")
    transport = run.add_argument_group("remote targets")
    transport.add_argument("--eth1394", action="store_true", help="udp: JHU Eth1394 framing")
    transport.add_argument("--timeout", type=float, default=0.5, help="reply timeout (s)")
    transport.add_argument(
        "--dead-after",
        type=float,
        default=3.0,
        help="give up when the node stays silent (or does not come back from a restart) S s",
    )
    transport.add_argument(
        "--restart",
        default=None,
        metavar="CMD",
        help="shell command that brings up a fresh node, run after a wedge or a death and "
        "before every replay while shrinking ({worker}: the worker number)",
    )
    transport.add_argument(
        "--jobs",
        type=integer,
        default=1,
        metavar="N",
        help="N worker processes, seeds derived from --seed; remote targets need {worker} "
        "in TARGET (one node each)",
    )
    rtl = run.add_argument_group("rtl: targets")
    rtl.add_argument(
        "--speed",
        choices=("S100", "S200", "S400", "mixed"),
        default="S400",
        help="speed packets are delivered at (mixed: each packet its own; default S400)",
    )
    rtl.add_argument(
        "--sclk-mhz", type=float, default=49.152, metavar="MHZ", help="SCLK of the design"
    )
    transport.add_argument(
        "--cluster",
        default=None,
        metavar="ADDRESS",
        help="run the campaign on the Dask distributed scheduler at ADDRESS "
        "(tcp://HOST:8786): one share of the seeds per worker, findings merged",
    )
    out = run.add_argument_group("inputs and findings")
    out.add_argument("--corpus", action="append", default=[], metavar="FILE", help="seeds")
    out.add_argument(
        "--findings",
        default="fuzz-findings",
        metavar="DIR",
        help="reproducers, each written when found (a stopped or killed run keeps them)",
    )
    saved = out.add_mutually_exclusive_group()
    saved.add_argument("--force", action="store_true", help="replace the findings already in DIR")
    saved.add_argument(
        "--merge", action="store_true", help="keep the findings in DIR, add new signatures"
    )
    out.add_argument(
        "--shrink-budget",
        type=integer,
        default=300,
        help="replays per finding when shrinking (default 300; 0: no shrinking); with "
        "--duration, shrinking also stops when the duration is over",
    )
    out.add_argument("--history", type=integer, default=512, help="packets kept per finding")
    out.add_argument("--json", action="store_true", help="print the report as JSON")
    out.add_argument(
        "--plot",
        default=None,
        metavar="FILE",
        help="draw findings and coverage over the run into FILE (.png, .svg, .pdf; one job)",
    )
    out.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: when stderr is a terminal)",
    )


def settings_of(args: argparse.Namespace) -> Any:
    from fw1394.fuzz.settings import Settings
    from fw1394.fuzz.targets import check

    settings = Settings(
        target=args.target,
        contract=args.oracle,
        model=args.model,
        board_id=args.board_id,
        node_id=args.node_id,
        policy=args.policy,
        defects=tuple(args.defect),
        seed=args.seed,
        max_cases=args.max_cases,
        duration=args.duration,
        probe_every=args.probe_every,
        state_every=args.state_every,
        timeout=args.timeout,
        dead_after=args.dead_after,
        eth1394=args.eth1394,
        corpus=tuple(args.corpus),
        shrink_budget=args.shrink_budget,
        history=args.history,
        probe_offset=args.probe_offset,
        pid=args.pid,
        speed=args.speed,
        sclk_mhz=args.sclk_mhz,
    )
    check(settings)
    return settings


def run_campaign(args: argparse.Namespace) -> int:
    from fw1394.fuzz import findings, workers
    from fw1394.fuzz.campaign import terminable
    from fw1394.progress import Progress

    settings = settings_of(args)
    directory = Path(args.findings)
    try:
        earlier = findings.prepare(directory, force=args.force, merge=args.merge)
    except findings.FindingsExist:
        raise
    except ValueError as error:  # a file in DIR that is not a finding: its message names it
        raise CliError(str(error)) from None
    if args.jobs < 1:
        raise CliError("--jobs must be at least 1")
    if args.engine == "hypothesis":
        if args.jobs != 1 or args.restart is not None:
            raise CliError("the hypothesis engine runs one in-process job, without --restart")
        if settings.max_cases is None and settings.duration is None:
            raise CliError("the hypothesis engine needs --max-cases or --duration")
        try:
            from fw1394.fuzz import hypo
        except ImportError as error:
            raise CliError(f"the hypothesis engine needs the {error.name} package") from None
    if args.cluster is not None and args.restart is not None:
        raise CliError("--cluster runs without --restart")
    if args.plot is not None:
        from fw1394.capture.views.trace_plots import check_plot_path

        if args.jobs != 1 or args.cluster is not None or args.engine == "hypothesis":
            raise CliError("--plot draws a campaign of one job of the fast engine")
        check_plot_path(args.plot)
    try:
        store = findings.Store(directory, earlier)
    except OSError as error:
        raise CliError(f"cannot save findings in {directory}: {error.strerror or error}") from None
    with terminable():
        if args.engine == "hypothesis":
            report = _guarded(lambda: hypo.run(settings))
        elif args.cluster is not None:
            from fw1394.fuzz import cluster

            jobs = args.jobs if args.jobs > 1 else None
            report = _guarded(lambda: cluster.run(settings, args.cluster, jobs=jobs))
        else:
            show = sys.stderr.isatty() if args.progress is None else args.progress
            show = show and args.jobs == 1
            progress = Progress() if show else None
            report = _guarded(
                lambda: workers.run(
                    settings, args.jobs, restart=args.restart, progress=progress, store=store
                )
            )
    try:
        for finding in report.findings:
            store.put(finding)
        store.report(report.to_json())
    except OSError as error:
        raise CliError(f"cannot save findings in {directory}: {error.strerror or error}") from None
    if args.plot is not None:
        from fw1394.fuzz.plot import plot_campaign

        plot_campaign(report, Path(args.plot))
    if args.json:
        print_json(report.to_json())
    else:
        print("\n".join(report.lines()))
        if report.findings:
            print(f"reproducers in {directory}/ (replay: fw1394 fuzz replay {directory})")
    return 1 if report.findings else 0


def run_replay(args: argparse.Namespace) -> int:
    from fw1394.fuzz.findings import load
    from fw1394.fuzz.replay import replay_all

    try:
        loaded = load(Path(args.directory))
    except ValueError as error:
        raise CliError(str(error)) from None
    if not loaded:
        raise CliError(f"no findings in {args.directory}")
    results = _guarded(lambda: replay_all(loaded, args.target, args.restart))
    for result in results:
        if args.json:
            print_json(result.to_json())
        else:
            print(result.line())
    return 1 if any(r.reproduced for r in results) else 0


def run_serve(args: argparse.Namespace) -> int:
    from fw1394.fuzz.contract import CONTRACTS
    from fw1394.fuzz.serve import TunnelNode, loopback_address
    from fw1394.fuzz.settings import Settings, default_policy
    from fw1394.fuzz.targets import check
    from fw1394.transport.udp_ports import refuse_taken_port

    if args.parent_pid is not None:
        from fw1394.transport.supervision.procs import die_with_parent

        die_with_parent(args.parent_pid)
    address = loopback_address(args.listen)
    check(Settings(f"inproc:{args.board}", board_id=args.board_id, defects=tuple(args.defect)))
    if args.duration is not None and args.duration <= 0:
        raise CliError("--duration must be positive")
    policy = CONTRACTS[args.policy or default_policy(args.board)]
    refuse_taken_port(*address)
    try:
        node = TunnelNode(
            address,
            args.board,
            board_id=args.board_id,
            node_id=args.node_id,
            policy=policy,
            defects=frozenset(args.defect),
            eth1394=args.eth1394,
        )
    except (OSError, ValueError) as error:
        raise CliError(f"cannot serve {args.board} on {args.listen}: {error}") from None
    host, port = node.address
    print(f"listening on {host}:{port}", flush=True)
    try:
        node.serve(args.duration)
    finally:
        node.close()
    return 0


def list_defects(args: argparse.Namespace) -> int:
    from fw1394.boards.registry import known_defects
    from fw1394.fuzz.targets import kinds

    known = kinds()
    if args.board is not None and args.board not in known:
        raise CliError(f"unknown board kind {args.board!r}; known kinds: {', '.join(known)}")
    rows = known_defects(args.board)
    if args.board is None:
        for kind in known:
            rows.update(known_defects(kind))
    width = max(len(name) for name in rows)
    for name, text in rows.items():
        print(f"{name:<{width}}  {text}")
    return 0


# -- planted defects for node processes (used by `fw1394 node run` and `bus up`) ----------
def add_defect_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--defect",
        action="append",
        default=[],
        metavar="NAME",
        help="plant a bug for the fuzzer to find (list: fw1394 fuzz defects)",
    )


def checked_defects(kind: str, names: list[str]) -> frozenset[str]:
    """``names`` if board ``kind`` (or the responder) knows each, else a one-line error."""
    from fw1394.boards.registry import check_defects

    try:
        return check_defects(kind, names)
    except ValueError as error:
        raise CliError(str(error)) from None


def _guarded(action: Any) -> Any:
    """Run ``action``; an error of the target's socket or process says it is the target's."""
    try:
        return action()
    except OSError as error:
        raise CliError(f"target: {error.strerror or error}") from None
