"""Text, JSON and CSV rows for the transaction view."""

from __future__ import annotations

from typing import Any

from fw1394.capture.analysis.csr import csr_name
from fw1394.capture.analysis.transaction_model import Kind, flag_names
from fw1394.capture.analysis.transactions import Transactions
from fw1394.capture.views.packet_view import ack_name
from fw1394.packets import RCode, TCode, name_of

#: Columns of ``--csv`` in the transaction view.
TRANSACTION_CSV = (
    "frame",
    "response_frame",
    "time_s",
    "generation",
    "requester",
    "responder",
    "tlabel",
    "tcode",
    "response_tcode",
    "kind",
    "ack",
    "response_ack",
    "rcode",
    "offset",
    "data_length",
    "response_data_length",
    "quadlet_data",
    "latency_ns",
    "attempts",
    "flags",
)
#: The name a transaction column has in every output (JSON and CSV alike).
OUTPUT_NAMES = {
    "resp_frame": "response_frame",
    "resp_tcode": "response_tcode",
    "resp_ack": "response_ack",
    "resp_data_length": "response_data_length",
    "resp_quadlet": "response_quadlet_data",
}
_SHORT = {
    TCode.write_quadlet_request: "QW",
    TCode.write_block_request: "BW",
    TCode.read_quadlet_request: "QR",
    TCode.read_block_request: "BR",
    TCode.lock_request: "LK",
}


class TransactionFormatter:
    """Renders transactions."""

    def __init__(self, tx: Transactions, origin_ns: int) -> None:
        self.tx = tx
        self.origin_ns = origin_ns
        self.c = tx.as_table()

    def value(self, name: str, row: int) -> int:
        return int(self.c[name][row])

    def time(self, row: int) -> float:
        return (self.value("first_ts", row) - self.origin_ns) / 1e9

    def line(self, row: int) -> str:
        v = self.value
        kind = Kind(v("kind", row))
        tcode = v("tcode", row)
        when = f"{self.time(row):>14.9f}" if v("time_known", row) != 0 else f"{'-':>14}"
        text = f"{v('first_frame', row):>7}  {when}  g{v('generation', row):<3} "
        text += f"{v('requester', row):04x} -> {v('responder', row):04x} tl={v('tlabel', row):<2} "
        if tcode >= 0:
            text += _SHORT.get(TCode(tcode), name_of(TCode, tcode))
            offset = v("offset", row)
            text += f" 0x{offset:012x}"
            name = csr_name(offset)
            if name:
                text += f" [{name}]"
            if v("data_length", row) >= 0:
                text += f" len={v('data_length', row)}"
            if v("quadlet_data", row) >= 0:
                text += f" data={v('quadlet_data', row):08x}"
            text += f"  {ack_name(v('ack', row)) or 'ack ?'}"
        else:
            text += "(no request)"
        if v("resp_tcode", row) >= 0:
            text += f" -> {name_of(RCode, v('rcode', row))}"
            if v("resp_quadlet", row) >= 0:
                text += f" data={v('resp_quadlet', row):08x}"
            if v("resp_data_length", row) >= 0:
                text += f" len={v('resp_data_length', row)}"
        latency = v("latency_ns", row)
        if latency >= 0:
            text += f"  {latency / 1000:.3f} us"
        text += f"  {kind.name}"
        if v("attempts", row) > 1:
            text += f" attempts={v('attempts', row)}"
        flags = [
            f for f in flag_names(v("flags", row)) if f != "unsolicited" or kind != Kind.unsolicited
        ]
        text += "".join(f" [{f}]" for f in flags)
        if v("resp_frame", row) >= 0:
            text += f"  (response frame {v('resp_frame', row)})"
        return text

    def json(self, row: int) -> dict[str, Any]:
        v = self.value
        obj: dict[str, Any] = {
            "frame": v("first_frame", row),
            "time_s": round(self.time(row), 9),
            "kind": Kind(v("kind", row)).name,
        }
        for name in (
            "generation",
            "requester",
            "responder",
            "tlabel",
            "tcode",
            "ack",
            "offset",
            "data_length",
            "quadlet_data",
            "attempts",
            "resp_frame",
            "resp_tcode",
            "resp_ack",
            "rcode",
            "resp_data_length",
            "resp_quadlet",
            "latency_ns",
        ):
            if v(name, row) >= 0:
                obj[OUTPUT_NAMES.get(name, name)] = v(name, row)
        if v("tcode", row) >= 0:
            obj["tcode_name"] = name_of(TCode, v("tcode", row))
            register = csr_name(v("offset", row))
            if register:
                obj["csr"] = register
        obj["flags"] = flag_names(v("flags", row))
        return obj

    def csv(self, row: int) -> list[str]:
        v = self.value

        def text(name: str) -> str:
            value = v(name, row)
            return "" if value < 0 else str(value)

        return [
            text("first_frame"),
            text("resp_frame"),
            f"{self.time(row):.9f}",
            text("generation"),
            text("requester"),
            text("responder"),
            text("tlabel"),
            text("tcode"),
            text("resp_tcode"),
            Kind(v("kind", row)).name,
            text("ack"),
            text("resp_ack"),
            text("rcode"),
            text("offset"),
            text("data_length"),
            text("resp_data_length"),
            text("quadlet_data") if v("tcode", row) >= 0 else text("resp_quadlet"),
            text("latency_ns"),
            text("attempts"),
            ";".join(flag_names(v("flags", row))),
        ]
