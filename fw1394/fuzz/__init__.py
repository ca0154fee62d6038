"""Fuzzing a 1394 node's packet parser against its contract (``docs/fuzzing.md``).

:mod:`fw1394.fuzz.strategies` holds the hypothesis strategies; ``fw1394 fuzz``
(:mod:`fw1394.cli.fuzz`) runs campaigns, replays and the tunnel node.
"""
