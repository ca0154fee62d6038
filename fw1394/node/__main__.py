"""``python -m fw1394.node [OPTIONS]``: one node process of a virtual 1394 bus.

What supervisors start for every node of a bus (``fw1394 bus up``); by hand
``fw1394 node run`` takes the same options. Bad options are one line on
stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from fw1394.node.description import (
    NodeDescriptionError,
    add_node_options,
    description_from_arguments,
)
from fw1394.node.run import NodeStartError, run

EXAMPLES = """\
examples:
  python -m fw1394.node --name arm --board snake2010 --board-id 3 --rank 0
  python -m fw1394.node --board qla1 --eth1394 127.0.0.1:1394 --quiet
"""


def parser() -> argparse.ArgumentParser:
    out = argparse.ArgumentParser(
        prog="python -m fw1394.node",
        description="Run one node (an emulated board) on a virtual 1394 bus until "
        "SIGINT or SIGTERM.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_node_options(out)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        run(description_from_arguments(args))
    except (NodeDescriptionError, NodeStartError) as error:
        print(f"fw1394 node: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
