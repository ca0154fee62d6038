"""How much each experiment measures: the full run of the thesis, and ``--quick`` for CI."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from fw1394.experiments import thesis

EXPERIMENTS = ("quadlet", "block", "scale")
#: Boards on the bus for the scale experiment. 62 boards and the host are 63
#: nodes, the most a 1394 bus can address.
SCALE_BOARDS = (1, 2, 4, 8, 16, 32, 62)


@dataclass(frozen=True)
class Settings:
    quadlet_iterations: int = thesis.QUADLET_ITERATIONS
    warmup: int = 500
    block_sizes: tuple[int, ...] = tuple(range(1, thesis.BLOCK_MAX_QUADLETS + 1))
    block_passes: int = 10
    baseline_iterations: int = 5000
    scale_boards: tuple[int, ...] = SCALE_BOARDS
    scale_iterations: int = 2000
    experiments: tuple[str, ...] = EXPERIMENTS

    def runs(self, experiment: str) -> bool:
        return experiment in self.experiments

    def as_dict(self) -> dict[str, object]:
        out = asdict(self)
        sizes = self.block_sizes
        if sizes == tuple(range(sizes[0], sizes[-1] + 1)):
            out["block_sizes"] = f"{sizes[0]}..{sizes[-1]}"
        return out


FULL = Settings()
QUICK = Settings(
    quadlet_iterations=1000,
    warmup=100,
    block_sizes=(1, 2, 4, 8, 16, 32, 64, 128, 256, 512),
    # Twenty samples a size: a size's median stays put when a few of them stall.
    block_passes=20,
    baseline_iterations=1000,
    scale_boards=(1, 2, 4),
    scale_iterations=300,
)


def adjusted(
    base: Settings,
    *,
    quadlet_iterations: int | None = None,
    block_sizes: tuple[int, ...] | None = None,
    block_passes: int | None = None,
    scale_boards: tuple[int, ...] | None = None,
    experiments: tuple[str, ...] | None = None,
) -> Settings:
    """``base`` with the options the user gave (None: keep the preset's value)."""
    return replace(
        base,
        quadlet_iterations=quadlet_iterations or base.quadlet_iterations,
        block_sizes=block_sizes or base.block_sizes,
        block_passes=block_passes or base.block_passes,
        scale_boards=scale_boards or base.scale_boards,
        experiments=base.experiments if experiments is None else experiments,
    )
