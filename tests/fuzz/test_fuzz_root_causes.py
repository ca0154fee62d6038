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
    assert "read:tenure" in signatures and "read@VERSION:data" in signatures


#: Quadlet indices of two QLA board registers (JHU Eth1394 register table, §4.2).
HARDWARE_VERSION, TEMP, FIRMWARE_VERSION = 4, 5, 7


class TwoWrongRegisters:
    """An in-process QLA whose quadlet reads of two registers come back one bit off:
    two defects of the same kind in two places."""

    def __init__(self, inner: InprocTarget, wrong: set[int]) -> None:
        self.inner = inner
        self.wrong = wrong

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        out: list[Observed] = []
        for wire, reply in zip(batch, self.inner.exchange(batch, now), strict=True):
            response = reply.response
            packet = wire.packet
            if (
                isinstance(packet, QuadletReadRequest)
                and packet.offset in self.wrong
                and isinstance(response, QuadletReadResponse)
            ):
                response = replace(response, quadlet_data=response.quadlet_data ^ 1)
                out.append(Observation(reply.ack, response, reply.concatenated))
            else:
                out.append(reply)
        return out


def test_model_mismatches_are_one_finding_per_register_and_kind() -> None:
    settings = Settings("inproc:qla1", contract="jhu")
    inner = open_target(settings)
    assert isinstance(inner, InprocTarget)
    wrong = TwoWrongRegisters(inner, {HARDWARE_VERSION, FIRMWARE_VERSION})
    trial = open_trial(settings, wrong)  # type: ignore[arg-type]
    keys: list[tuple[str, str]] = []
    for tlabel, index in enumerate([HARDWARE_VERSION, TEMP, FIRMWARE_VERSION] * 3):
        read = QuadletReadRequest(
            destination_id=0xFFC0, tlabel=tlabel, source_id=0xFFC1, offset=index
        )
        keys += [(v.oracle, v.signature) for v in trial.case(encode_async(read))]
    # Two defects, two findings; each repeated three times, still one each; the
    # register that reads right, none.
    assert set(keys) == {
        ("reply", "read@HARDWARE_VERSION:data"),
        ("reply", "read@FIRMWARE_VERSION:data"),
    }
