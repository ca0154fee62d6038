"""A node process of the virtual bus: its description, its loop, its entry point.

* :mod:`~fw1394.node.description`: what a node is (bus, board kind, policy,
  defects, timing, faults), as options and as :class:`NodeDescription`.
* :mod:`~fw1394.node.process`: the generic node: a board behind a responder link.
* :mod:`~fw1394.node.run`: runs a description (kinds with a node program of
  their own, from the board registry, run that).
* ``python -m fw1394.node``: the entry point supervisors start.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "NodeDescription": "fw1394.node.description",
    "NodeDescriptionError": "fw1394.node.description",
    "NodeStartError": "fw1394.node.run",
    "run": "fw1394.node.run",
}

__all__ = [
    "NodeDescription",
    "NodeDescriptionError",
    "NodeStartError",
    "run",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.node.description import NodeDescription, NodeDescriptionError
    from fw1394.node.run import NodeStartError, run
