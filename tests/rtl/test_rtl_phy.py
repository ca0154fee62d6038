"""The PHY model's LREQ decoder: every request type, and malformed streams."""

from __future__ import annotations

import pytest

pytest.importorskip("cocotb", reason="cocotb is not installed (pip install 'fw1394[rtl]')")

from fw1394.rtl.phy import Limits, Phy, Request


def _decoded(*streams: str) -> tuple[list[Request], list[str]]:
    phy = Phy(None, physical_id=0, limits=Limits(ack_gap=40), registers=None)
    for stream in streams:
        for bit in "0" + stream + "000":  # idle low before and after
            phy._lreq(int(bit))
    return list(phy.requests), phy.violations


@pytest.mark.parametrize(
    ("stream", "wanted"),
    [
        ("10001000", Request(0, 0b100, 3)),  # ImmReq at S400 (an ack)
        ("10110100", Request(3, 0b010, 3)),  # FairReq at S200
        ("110001010", Request(4, 5, 4)),  # RdReg of register 5
        ("11010001010000000", Request(5, 0x140, 12)),  # WrReg IBR
        ("111010", Request(6, 1, 1)),  # AccelCtl
    ],
)
def test_each_request_type_is_decoded(stream: str, wanted: Request) -> None:
    assert _decoded(stream) == ([wanted], [])


def test_back_to_back_requests() -> None:
    requests, violations = _decoded("11000000010001000")
    assert requests == [Request(4, 0, 4), Request(0, 0b100, 3)] and violations == []


def test_malformed_streams_are_interface_violations() -> None:
    requests, violations = _decoded("11110000")
    assert requests == [] and violations[0].startswith("lreq-reserved:")
    requests, violations = _decoded("10001001")
    assert requests == [] and violations[0].startswith("lreq-stop:")
