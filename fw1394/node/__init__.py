"""A node process of the virtual bus: its description, its loop, its entry point.

* :mod:`~fw1394.node.description`: what a node is (bus, board kind, policy,
  defects, timing, faults), as options and as :class:`NodeDescription`.
* :mod:`~fw1394.node.process`: the generic node: a board behind a responder link.
* :mod:`~fw1394.node.run`: runs a description (kinds with a node program of
  their own, from the board registry, run that).
* ``python -m fw1394.node``: the entry point supervisors start.
"""
