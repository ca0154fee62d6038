"""A campaign's picture (``fw1394 fuzz run --plot FILE``): findings and coverage as it ran.

Two panels over the cases sent (a log axis), from the report's timeline:
distinct findings (each step a new root cause) and coverage bins hit (kind x
outcome x speed x length x address, out of those the campaign could reach).
A coverage line flat long before the end says more cases of the same kind
will not find more; findings that keep coming say the opposite.
"""

from __future__ import annotations

from pathlib import Path

from fw1394.capture.views.trace_plots import PlotError, require_matplotlib, save_figure
from fw1394.fuzz.coverage import space
from fw1394.fuzz.report import Report

__all__ = ["plot_campaign"]

DPI = 100
FINDINGS_COLOUR, BINS_COLOUR = "#c0504d", "#3b6ea8"


def plot_campaign(report: Report, path: Path) -> Path:
    """Draw ``report``'s timeline into ``path`` (any format matplotlib writes)."""
    if len(report.timeline) < 2:
        raise PlotError("nothing to draw: the campaign ran no cases (or ran on several workers)")
    pyplot = require_matplotlib()
    cases = [point[0] for point in report.timeline]
    findings = [point[2] for point in report.timeline]
    bins = [point[3] for point in report.timeline]
    reachable = len(space(report.speeds))
    figure, (top, bottom) = pyplot.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    top.step(cases, findings, where="post", color=FINDINGS_COLOUR)
    top.set_ylabel("distinct findings")
    top.set_ylim(0, max(findings) * 1.15 + 1)
    bottom.step(cases, bins, where="post", color=BINS_COLOUR)
    bottom.axhline(reachable, color="grey", linestyle=":", linewidth=1)
    bottom.annotate(
        f"{reachable} bins in all", (cases[-1], reachable), ha="right", va="bottom",
        fontsize=8, color="grey",
    )  # fmt: skip
    bottom.set_ylim(0, reachable * 1.1)
    bottom.set_ylabel("coverage bins hit")
    bottom.set_xlabel("cases sent (log scale)")
    s = report.settings
    figure.suptitle(
        f"fw1394 fuzz run {s.target} ({s.contract} contract, seed {s.seed}): "
        f"{report.cases} cases in {report.elapsed:.1f} s",
        fontsize=10,
    )
    for axis in (top, bottom):
        axis.grid(True, alpha=0.3)
        # Most findings come early: a log axis shows the first hundred cases and
        # the last ten thousand alike.
        axis.set_xscale("log")
        axis.set_xlim(1, max(cases[-1], 10))
    save_figure(pyplot, figure, path, dpi=DPI)
    return path
