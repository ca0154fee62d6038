"""``dissect -Y``: the parser, the columnar evaluation against a per-row reference, and the CLI."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views import display_filter as df
from fw1394.cli.main import main
from fw1394.packets import AckCode, QuadletWriteRequest, RCode, TCode, WriteResponse, encode

#: Numeric fields of every kind (the text and byte fields kind and data have tests of
#: their own; the pseudo-header's and the CRCs' are more of the same).
FIELD_NAMES = sorted(
    name
    for name, info in df.FIELDS.items()
    if info.text is None and not name.startswith(("ph.", "phy.", "data_crc"))
)


def literal_for(name: str) -> st.SearchStrategy[df.Literal]:
    info = df.FIELDS[name]
    if info.duration:
        return st.builds(
            lambda n, unit: df.Literal(n * df.UNITS[unit], f"{n}{unit}"),
            st.integers(0, 30),
            st.sampled_from(sorted(df.UNITS)),
        )
    plain = st.integers(0, 20).flatmap(
        lambda n: st.sampled_from([df.Literal(n, str(n)), df.Literal(n, hex(n))])
    )
    if info.enum is None:
        return plain
    named = st.sampled_from([df.Literal(int(m), m.name) for m in info.enum])
    return st.one_of(plain, named)


@st.composite
def comparisons(draw: st.DrawFn) -> df.Node:
    name = draw(st.sampled_from(FIELD_NAMES))
    op = draw(st.sampled_from(sorted(df.RELOPS)))
    if draw(st.booleans()):
        same_kind = [n for n in FIELD_NAMES if df.FIELDS[n].duration == df.FIELDS[name].duration]
        other: df.Operand = df.Field(draw(st.sampled_from(same_kind)))
    else:
        other = draw(literal_for(name))
    if isinstance(other, df.Literal) and draw(st.booleans()):
        return df.Compare(op, other, df.Field(name))
    return df.Compare(op, df.Field(name), other)


leaves = st.one_of(
    comparisons(), st.builds(df.Present, st.builds(df.Field, st.sampled_from(FIELD_NAMES)))
)
trees = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.builds(df.Not, inner),
        st.builds(df.And, st.lists(inner, min_size=2, max_size=3).map(tuple)),
        st.builds(df.Or, st.lists(inner, min_size=2, max_size=3).map(tuple)),
    ),
    max_leaves=8,
)


def _scaled(scale: int) -> Callable[[int], int]:
    """Durations are drawn in microseconds; counts as they are (negative: absent)."""
    return lambda v: v * scale if v > 0 else v


@st.composite
def filters_and_rows(
    draw: st.DrawFn,
) -> tuple[df.Node, dict[str, tuple[np.ndarray, ...]], int]:
    """A filter and rows of the fields it names: both evaluations read no other
    column (a missing one would raise KeyError), so drawing the other fields'
    values would only cost time."""
    tree = draw(trees)
    rows = draw(st.integers(0, 40))
    columns = {}
    for name in sorted(df.fields_of(tree)):
        width = draw(st.integers(1, 2))
        values = st.integers(-1, 20).map(_scaled(1000 if df.FIELDS[name].duration else 1))
        columns[name] = tuple(
            np.array(draw(st.lists(values, min_size=rows, max_size=rows)), np.int64)
            for _ in range(width)
        )
    return tree, columns, rows


@settings(max_examples=150, deadline=None)
@given(filters_and_rows())
def test_columnar_evaluation_equals_the_per_row_reference(
    case: tuple[df.Node, dict[str, tuple[np.ndarray, ...]], int],
) -> None:
    tree, columns, rows = case
    fast = df.evaluate(tree, columns, rows)
    for row in range(rows):
        values = {name: tuple(int(c[row]) for c in cols) for name, cols in columns.items()}
        assert bool(fast[row]) == df.evaluate_row(tree, values), (df.to_text(tree), values)


@settings(max_examples=150, deadline=None)
@given(trees)
def test_text_parses_back_to_the_same_tree(tree: df.Node) -> None:
    text = df.to_text(tree)
    assert df.parse(text) == tree
    assert df.to_text(df.parse(text)) == text


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("fw1394.tcode == 4 and rcode != 0", "tcode == 4 && rcode != 0"),
        ("not (src eq 0xffc0) or dst_id", "!(src == 0xffc0) || dst"),
        ("latency >= 1.5ms", "latency >= 1.5ms"),
        # "ack" also names a record type, so it is written in full to stay a field
        (
            "tcode == read_quadlet_request || ack == ack_pending",
            "tcode == read_quadlet_request || fw1394.ack == ack_pending",
        ),
        (
            "record_type != ack && fw1394.record_type == bus_reset",
            "record_type != ack && record_type == bus_reset",
        ),
        ("tlabel>=0x3f&&length<8", "tlabel >= 0x3f && data_length < 8"),
    ],
)
def test_spellings(text: str, expected: str | None) -> None:
    assert df.to_text(df.parse(text)) == (expected or text)


def test_values_of_names_and_units() -> None:
    tree = df.parse("tcode == read_quadlet_request && rcode != resp_address_error")
    assert isinstance(tree, df.And)
    first, second = tree.items
    assert isinstance(first, df.Compare) and first.right == df.Literal(
        int(TCode.read_quadlet_request), "read_quadlet_request"
    )
    assert isinstance(second, df.Compare) and second.right.value == int(RCode.resp_address_error)  # type: ignore[union-attr]
    latency = df.parse("latency > 100us")
    assert isinstance(latency, df.Compare) and latency.right.value == 100_000  # type: ignore[union-attr]
    ack = df.parse("ack == ack_busy_X")
    assert isinstance(ack, df.Compare) and ack.right.value == int(AckCode.ack_busy_X)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("text", "token", "words"),
    [
        ("tcod == 4", "tcod", "unknown field"),
        ("tcode == 4 &&", "", "ends too early"),
        ("tcode = 4", "=", "compare with =="),
        ("(tcode == 4", "", "missing )"),
        ("tcode == 4 5", "5", "expected && or ||"),
        ("rcode != resp_bogus", "resp_bogus", "not a rcode name"),
        ("latency > 100parsecs", "100parsecs", "needs a time"),
        ("tcode contains 4", "contains", "works on text and byte fields"),
        ("kind > 3", ">", "kind is text"),
        ('kind matches "("', '"("', "not a regular expression"),
        ("tcode in {4, 5", "", "missing }"),
        ("tcode in {}", "}", "empty set"),
        ("tlabel == 0xzz", "0", "not an integer"),
        ("4 == 5", "4", "compare a field"),
        ("tcode == $", "$", "unexpected character"),
        ("", "", "empty"),
    ],
)
def test_errors_point_at_the_token(text: str, token: str, words: str) -> None:
    with pytest.raises(df.FilterError) as caught:
        df.parse(text)
    error = caught.value
    assert words in str(error)
    assert text[error.position :].startswith(token)
    assert "\n" not in str(error)


def test_times_are_seconds_as_tshark_writes_them_or_carry_a_unit() -> None:
    for text, nanoseconds in (("100", 100_000_000_000), ("0.0002", 200_000), ("1.5ms", 1_500_000)):
        tree = df.parse(f"fw1394.response_time > {text}")
        assert isinstance(tree, df.Compare) and tree.right == df.Literal(nanoseconds, text)


def test_sets_ranges_and_text_tests() -> None:
    assert df.parse("tcode in {4, 5 6..8}") == df.parse(
        "tcode == 4 || tcode == 5 || (tcode >= 6 && tcode <= 8)"
    )
    kind = df.parse('fw1394.kind contains "quadlet"')
    assert kind == df.TextTest("contains", df.Field("kind"), "quadlet")
    data = df.parse("fw1394.data contains 0a:0b")
    assert data == df.TextTest("contains", df.Field("data"), b"\x0a\x0b")
    names = np.array(["read_quadlet_request", None, "write_response"], dtype=object)
    blocks = np.array([None, b"\x00\x0a\x0b", b"\x0a"], dtype=object)
    columns = {"kind": (names,), "data": (blocks,)}
    assert df.evaluate(kind, columns, 3).tolist() == [True, False, False]
    assert df.evaluate(data, columns, 3).tolist() == [False, True, False]
    regex = df.parse('kind matches "response$"')
    assert df.evaluate(regex, columns, 3).tolist() == [False, False, True]
    assert df.evaluate(df.parse("!data"), columns, 3).tolist() == [True, False, False]


def test_view_checks() -> None:
    with pytest.raises(df.FilterError, match="packet view"):
        df.DisplayFilter('kind contains "read"', "transactions")
    with pytest.raises(df.FilterError, match="packet view"):
        df.DisplayFilter("channel == 3", "transactions")


# -- end to end --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("filter") / "sim.pcapng"
    scenario = Scenario(lost_every=97, busy_every=89, corrupt_every=61, unsolicited_every=113)
    records = list(simulate(3000, scenario))
    write_trace(
        str(path), records + failed_writes(records[-1].timestamp_ns + 1000, records[-1].generation)
    )
    return path


def failed_writes(start_ns: int, generation: int) -> list[BusRecord]:
    """Quadlet writes answered with error rcodes (the simulation has none)."""
    records = []
    for index, rcode in enumerate(
        (RCode.resp_address_error, RCode.resp_complete, RCode.resp_type_error)
    ):
        request = QuadletWriteRequest(
            destination_id=0xFFC1, source_id=0xFFC4, tlabel=50 + index, offset=0x10
        )
        response = WriteResponse(
            destination_id=0xFFC4, source_id=0xFFC1, tlabel=50 + index, rcode=rcode
        )
        at = start_ns + 10_000 * index
        records.append(
            BusRecord(
                at,
                RecordType.async_packet,
                encode(request),
                generation,
                sender=4,
                ack=AckCode.ack_pending,
            )
        )
        records.append(
            BusRecord(
                at + 3_000,
                RecordType.async_packet,
                encode(response),
                generation,
                sender=1,
                ack=AckCode.ack_complete,
            )
        )
    return records


@pytest.fixture(scope="module")
def eth1394(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("filter") / "eth1394.pcap"
    write_eth1394_sample(str(path))
    return path


def json_rows(capsys: pytest.CaptureFixture[str], *args: str) -> list[dict[str, object]]:
    status = main(["dissect", *args, "--json"])
    out = capsys.readouterr().out
    assert status == 0
    return [json.loads(line) for line in out.splitlines()]


def get(obj: dict[str, object], key: str) -> int:
    value = obj.get(key, -1)
    return value if isinstance(value, int) else -1


PACKET_FILTERS = [
    (
        "tcode == read_block_response && data_length > 64",
        lambda o: get(o, "tcode") == 7 and get(o, "data_length") > 64,
    ),
    (
        "src == 0xffc4 && !(tcode == 1)",
        lambda o: get(o, "source_id") == 0xFFC4 and get(o, "tcode") != 1,
    ),
    (
        "rcode == resp_complete && tlabel != 5",
        lambda o: get(o, "rcode") == 0 and get(o, "tlabel") != 5,
    ),
    ("ack == ack_busy_X || ack == ack_pending", lambda o: get(o, "ack") in (4, 2)),
    (
        "(tlabel < 3 or tlabel > 60) and dst == 0xffc0",
        lambda o: (
            (0 <= get(o, "tlabel") < 3 or get(o, "tlabel") > 60)
            and get(o, "destination_id") == 0xFFC0
        ),
    ),
    (
        "offset >= 0xfffff0000400 && offset < 0xfffff0000800",
        lambda o: 0xFFFFF0000400 <= get(o, "offset") < 0xFFFFF0000800,
    ),
]


@pytest.mark.parametrize(("expression", "by_hand"), PACKET_FILTERS)
def test_packet_filter_equals_filtering_by_hand(
    simulated: Path, capsys: pytest.CaptureFixture[str], expression: str, by_hand: object
) -> None:
    everything = json_rows(capsys, str(simulated))
    wanted = [o["frame"] for o in everything if by_hand(o)]  # type: ignore[operator]
    shown = [o["frame"] for o in json_rows(capsys, str(simulated), "-Y", expression)]
    assert shown == wanted and wanted


TRANSACTION_FILTERS = [
    ("latency > 20us", lambda o: get(o, "latency_ns") > 20_000),
    (
        "tcode == 0 && rcode != 0",
        lambda o: 0 in (get(o, "tcode"), get(o, "response_tcode")) and get(o, "rcode") > 0,
    ),
    ("!latency || attempts > 1", lambda o: get(o, "latency_ns") < 0 or get(o, "attempts") > 1),
    (
        "tcode == read_quadlet_response && src == 0xffc4",
        lambda o: get(o, "response_tcode") == 6 and get(o, "requester") == 0xFFC4,
    ),
    (
        "latency <= 0.019ms && dst != 0xffc1",
        lambda o: 0 <= get(o, "latency_ns") <= 19_000 and get(o, "responder") not in (-1, 0xFFC1),
    ),
]


@pytest.mark.parametrize(("expression", "by_hand"), TRANSACTION_FILTERS)
def test_transaction_filter_equals_filtering_by_hand(
    simulated: Path, capsys: pytest.CaptureFixture[str], expression: str, by_hand: object
) -> None:
    everything = json_rows(capsys, str(simulated), "--transactions")
    wanted = [(o["frame"], o.get("response_frame")) for o in everything if by_hand(o)]  # type: ignore[operator]
    shown = json_rows(capsys, str(simulated), "--transactions", "-Y", expression)
    assert [(o["frame"], o.get("response_frame")) for o in shown] == wanted and wanted


def test_eth1394_sample_filters(eth1394: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reads = json_rows(capsys, str(eth1394), "-Y", "tcode == read_quadlet_request")
    assert [o["frame"] for o in reads] == [1, 3]
    answered = json_rows(capsys, str(eth1394), "--transactions", "-Y", "latency >= 100us")
    assert [o["frame"] for o in answered] == [1, 3]
    missing = json_rows(capsys, str(eth1394), "--transactions", "-Y", "!latency")
    assert [o["frame"] for o in missing] == [5, 6]


def test_bad_filter_is_one_line_exit_2(eth1394: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["dissect", str(eth1394), "-Y", "tcode == 4 &&& rcode"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and "'&'" in lines[0] and "character 14" in lines[0]
    assert main(["dissect", str(eth1394), "--transactions", "-Y", "sender == 1"]) == 2
    assert "packet view" in capsys.readouterr().err
    assert main(["dissect", str(eth1394), "--stats", "-Y", "tcode == 4"]) == 2
    assert "-Y filters the packet and transaction views" in capsys.readouterr().err
