"""Running the node a :class:`~fw1394.node.description.NodeDescription` describes."""

from __future__ import annotations

import sys
from typing import Any

from fw1394.boards.config_rom import with_config_rom
from fw1394.boards.registry import BOARDS, board_defects, make_board
from fw1394.engine.policy import POLICIES
from fw1394.errors import Error
from fw1394.node.description import RTL_PREFIX, NodeDescription
from fw1394.node.process import BusRefusedError, NodeOptions, run_node
from fw1394.transport.sansio.membership import BusReset
from fw1394.transport.supervision.procs import die_with_parent

#: A memory node's size unless the description names another.
DEFAULT_MEMORY_SIZE = NodeDescription().memory_size


class NodeStartError(Error, RuntimeError):
    """The node could not start or was turned away (one line for the user)."""


def run(node: NodeDescription) -> None:
    """Run ``node`` in the foreground until SIGINT or SIGTERM.

    A kind with a node program of its own (an Ethernet side) runs that; every
    other kind is a board behind the generic node process.
    """
    if node.parent_pid is not None:
        die_with_parent(node.parent_pid)
    name = node.bus.name
    if node.board.startswith(RTL_PREFIX):
        _run_rtl(node)
        return
    kind = BOARDS[node.board]
    try:
        if kind.node_program is not None:
            kind.node_program.run(
                config=node.bus,
                board_id=node.board_id,
                rank=node.rank,
                timing=node.timing,
                faults=node.faults,
                defects=node.defects,
                eth1394=node.eth1394,
                firmware=node.firmware,
                quiet=node.quiet,
            )
            return
        # Every node has a configuration ROM with a GUID of its own (fw1394.boards.config_rom).
        space = with_config_rom(
            _board(node), bus=name, board_id=node.board_id, rank=node.rank, model=node.board
        )
        options = NodeOptions(
            config=node.bus,
            board_id=node.board_id,
            rank=node.rank,
            timing=node.timing,
            faults=node.faults,
            policy=POLICIES[node.policy_name],
            defects=node.defects,
        )
        run_node(space, options, on_reset=None if node.quiet else _log, on_warning=_warn)
    except BusRefusedError as error:
        raise NodeStartError(f"bus {name!r} refused this node: {error}") from None
    except ValueError as error:
        raise NodeStartError(str(error)) from None
    except OSError as error:
        raise NodeStartError(f"cannot join bus {name!r}: {error}") from None


def _run_rtl(node: NodeDescription) -> None:
    # A link design in simulation (fw1394.rtl): its answers come from the RTL.
    from fw1394.node.rtl import run_rtl_node

    options = NodeOptions(
        config=node.bus,
        board_id=node.board_id,
        rank=node.rank,
        timing=node.timing,
        faults=node.faults,
        defects=node.defects,
    )
    name = node.bus.name
    try:
        run_rtl_node(node.board, options, on_reset=None if node.quiet else _log, on_warning=_warn)
    except BusRefusedError as error:
        raise NodeStartError(f"bus {name!r} refused this node: {error}") from None
    except (ValueError, OSError) as error:
        raise NodeStartError(f"cannot run the RTL node on bus {name!r}: {error}") from None


def _board(node: NodeDescription) -> Any:
    # The size is a memory node's option: a kind that has no such thing says so.
    size = {} if node.memory_size == DEFAULT_MEMORY_SIZE else {"size": node.memory_size}
    defects = board_defects(node.board, node.defects)
    try:
        return make_board(node.board, board_id=node.board_id, defects=defects, **size)
    except (ValueError, TypeError) as error:
        raise ValueError(f"board {node.board!r}: {error}") from None


def _log(change: BusReset) -> None:
    print(
        f"fw1394 node: generation {change.generation}: physical ID {change.phy_id} "
        f"of {len(change.members)}",
        file=sys.stderr,
    )


def _warn(text: str) -> None:
    print(f"fw1394 node: warning: {text}", file=sys.stderr)
