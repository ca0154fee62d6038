"""One case, several root causes: a response in the wrong tenure with the wrong data
is two findings, not one (the tenure mismatch must not hide the data)."""

from __future__ import annotations

from dataclasses import replace

from fw1394.fuzz.inproc import InprocTarget
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.target import Observation, Observed, Wire
from fw1394.fuzz.targets import open_target, open_trial
from fw1394.packets import QuadletReadRequest, QuadletReadResponse
from fw1394.packets.asynchronous import encode_async


class SplitAndWrong:
    """An in-process node whose quadlet read responses come split and one bit off."""

    def __init__(self, inner: InprocTarget) -> None:
        self.inner = inner

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        replies = self.inner.exchange(batch, now)
        out: list[Observed] = []
        for wire, reply in zip(batch, replies, strict=True):
            response = reply.response
            if isinstance(wire.packet, QuadletReadRequest) and isinstance(
                response, QuadletReadResponse
            ):
                wrong = replace(response, quadlet_data=response.quadlet_data ^ 1)
                out.append(Observation(reply.ack, wrong, False))
            else:
                out.append(reply)
        return out


def test_a_wrong_tenure_does_not_hide_wrong_data() -> None:
    settings = Settings("inproc:snake2010")
    inner = open_target(settings)
    assert isinstance(inner, InprocTarget)
    trial = open_trial(settings, SplitAndWrong(inner))  # type: ignore[arg-type]
    read = QuadletReadRequest(destination_id=0xFFC0, tlabel=1, source_id=0xFFC1, offset=4)
    found = trial.case(encode_async(read))
    signatures = sorted(v.signature for v in found if v.oracle == "reply")
    assert "read:tenure" in signatures and "read:quadlet_data" in signatures
