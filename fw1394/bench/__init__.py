"""``fw1394 bench``: the thesis's §8 experiments, against a bus node or a tunnelled board.

Modules: :mod:`~fw1394.bench.run` (one run), :mod:`~fw1394.bench.experiments`
(the measurements), :mod:`~fw1394.bench.baseline` (raw UDP floor),
:mod:`~fw1394.bench.connect` and :mod:`~fw1394.bench.targets` (what is
measured), :mod:`~fw1394.bench.bands`, :mod:`~fw1394.bench.fit`,
:mod:`~fw1394.bench.servo` and :mod:`~fw1394.bench.summary` (the statistics),
:mod:`~fw1394.bench.results`, :mod:`~fw1394.bench.report` and
:mod:`~fw1394.bench.plots` (output), :mod:`~fw1394.bench.thesis` (the
published numbers). ``docs/performance.md`` describes the method.
"""
