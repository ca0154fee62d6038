"""The published numbers of the thesis's §8, for the side-by-side tables.

P. Thienphrapa, *A Centralized Processing, Distributed I/O Motor Controller
Based on IEEE 1394 for the Snake Robot*, JHU 2010: one node at 400 Mbit/s,
a 2 GHz Pentium 4 running conventional Linux and libraw1394.
"""

from __future__ import annotations

from typing import Final

#: §8.2: quadlet reads and writes, 9,000 iterations each (Figure 20).
QUADLET_ITERATIONS: Final = 9000
QUADLET_READ_BANDS_US: Final = (30.0, 42.0, 49.0)
QUADLET_WRITE_BANDS_US: Final = (27.0, 42.0)
QUADLET_READ_MEAN_US: Final = 34.5
QUADLET_WRITE_MEAN_US: Final = 30.2

#: §8.3: block transfers of every size up to 512 quadlets (Figure 21).
BLOCK_MAX_QUADLETS: Final = 512
BLOCK_READ_BASE_US: Final = 33.2
BLOCK_WRITE_BASE_US: Final = 30.7
BLOCK_READ_MBIT_S: Final = 360.0
BLOCK_WRITE_MBIT_S: Final = 290.0

#: §8.2 and §8.4: the servo budget of a seven-axis node.
SERVO_AXES: Final = 7
SERVO_RATES_HZ: Final = (1000, 8000, 10000)
QUADLET_LOOP_US: Final = 453.0
BLOCK_LOOP_US: Final = 65.0
#: Control time left per cycle as the thesis states it; a rate it leaves out
#: is one where the loop does not fit ("not even feasible at 8 kHz").
QUADLET_LEFT_US: Final = {1000: 547.0}
BLOCK_LEFT_US: Final = {1000: 935.0, 8000: 60.0, 10000: 35.0}
