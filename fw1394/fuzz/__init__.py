"""Fuzzing a 1394 node's packet parser against its contract (``docs/fuzzing.md``).

:mod:`fw1394.fuzz.strategies` holds the hypothesis strategies; ``fw1394 fuzz``
(:mod:`fw1394.cli.fuzz`) runs campaigns, replays and the tunnel node.

Entry points: :func:`run` fuzzes the target of a :class:`Settings` and returns a
:class:`Report` of shrunk :class:`Finding` objects; :func:`replay_all` replays
saved findings (:func:`load_findings`) on the same or another target.
:data:`CONTRACTS` names the behaviours a node can be held to.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "CONTRACTS": "fw1394.fuzz.contract",
    "Finding": "fw1394.fuzz.findings",
    "load_findings": "fw1394.fuzz.findings:load",
    "replay_all": "fw1394.fuzz.replay",
    "ReplayResult": "fw1394.fuzz.replay",
    "Report": "fw1394.fuzz.report",
    "run": "fw1394.fuzz.campaign",
    "save_findings": "fw1394.fuzz.findings:save",
    "Settings": "fw1394.fuzz.settings",
}

__all__ = [
    "CONTRACTS",
    "Finding",
    "ReplayResult",
    "Report",
    "Settings",
    "load_findings",
    "replay_all",
    "run",
    "save_findings",
    "strategies",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.fuzz import strategies
    from fw1394.fuzz.campaign import run
    from fw1394.fuzz.contract import CONTRACTS
    from fw1394.fuzz.findings import Finding
    from fw1394.fuzz.findings import load as load_findings
    from fw1394.fuzz.findings import save as save_findings
    from fw1394.fuzz.replay import ReplayResult, replay_all
    from fw1394.fuzz.report import Report
    from fw1394.fuzz.settings import Settings
