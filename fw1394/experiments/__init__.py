"""``fw1394 bench``: the thesis's §8 experiments, against a bus node or a tunnelled board.

Modules: :mod:`~fw1394.experiments.run` (one run), :mod:`~fw1394.experiments.measurements`
(the measurements), :mod:`~fw1394.experiments.baseline` (raw UDP floor),
:mod:`~fw1394.experiments.connect` and :mod:`~fw1394.experiments.bench_targets` (what is
measured), :mod:`~fw1394.experiments.bands`, :mod:`~fw1394.experiments.fit`,
:mod:`~fw1394.experiments.servo` and :mod:`~fw1394.experiments.summary` (the statistics),
:mod:`~fw1394.experiments.results`, :mod:`~fw1394.experiments.report_text` and
:mod:`~fw1394.experiments.figures` (output), :mod:`~fw1394.experiments.thesis` (the
published numbers). ``docs/performance.md`` describes the method.

Used through ``fw1394 bench``; no names of its own here.
"""

__all__: list[str] = []
