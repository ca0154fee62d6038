"""The numpy bulk path over a trace's columns (:class:`~fw1394.capture.formats.Batch`).

Header fields and CRCs by column, transactions paired from requests, acks and
responses (:class:`Transactions`), statistics (:class:`Stats`), configuration
ROMs. It reads what :mod:`fw1394.capture.formats` produces and imports nothing
of the views.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Stats": "fw1394.capture.analysis.stats",
    "Transactions": "fw1394.capture.analysis.transactions",
}

__all__ = [
    "Stats",
    "Transactions",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.capture.analysis.stats import Stats
    from fw1394.capture.analysis.transactions import Transactions
