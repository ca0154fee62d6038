"""The CLI's parsing, fuzzed: any arguments end in an exit status, never a traceback.

Only commands that cannot block or touch the network are drawn (decode,
encode, the in-process fuzzer); argparse's own exits (status 2 for a usage
error, 0 for --help) are part of the contract.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fw1394.cli.main import main
from fw1394.fuzz.strategies import fuzz_cases
from fw1394.packets import LAYOUTS

SOME = settings(max_examples=80, deadline=None, suppress_health_check=list(HealthCheck))

hex_words = fuzz_cases(max_data=16).map(lambda raw: raw.hex())
numbers = st.one_of(
    st.integers(-5, 1 << 50).map(str),
    st.integers(0, 1 << 48).map(hex),
    st.sampled_from(["0x", "1_0", "0b101", "-0x1", "9" * 30, "nan", ""]),
)
junk = st.text(alphabet="0123456789abcdefxXg _-:,./", max_size=12)
words = st.one_of(hex_words, numbers, junk)
decode_flags = st.sampled_from(["--json", "--no-crc", "--lenient", "--jhu", "--phy", "--help"])
kinds = st.sampled_from([layout.name for layout in LAYOUTS.values()] + ["self_id", "nonsense"])
encode_flags = st.sampled_from(
    ["--destination-id", "--tlabel", "--offset", "--data", "--quadlet-data", "--rcode", "--json"]
)
fuzz_flags = st.sampled_from(
    ["--oracle", "--defect", "--seed", "--probe-every", "--state-every", "--policy", "--node-id",
     "--probe-offset", "--history", "--shrink-budget", "--engine", "--model"]
)  # fmt: skip


def call(argv: list[str], stdin: str = "") -> int:
    saved = sys.stdin
    sys.stdin = io.StringIO(stdin)  # decode reads packets from stdin when given none
    try:
        return main(argv)
    except SystemExit as leaving:  # argparse: usage errors and --help
        assert leaving.code in (0, 2), argv
        return int(leaving.code or 0)
    finally:
        sys.stdin = saved


@SOME
@given(st.lists(st.one_of(words, decode_flags), max_size=6), st.lists(words, max_size=3))
def test_decode_arguments(argv: list[str], lines: list[str]) -> None:
    assert call(["decode", *argv], "\n".join(lines)) in (0, 1, 2)


@SOME
@given(kinds, st.lists(st.one_of(encode_flags, words), max_size=6))
def test_encode_arguments(kind: str, argv: list[str]) -> None:
    assert call(["encode", kind, *argv]) in (0, 1, 2)


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    st.sampled_from(["inproc:memory", "inproc:qla1", "inproc:", "inproc:snake2010", "x"]),
    st.lists(st.one_of(fuzz_flags, words), max_size=4),
)
def test_fuzz_run_arguments(
    tmp_path_factory: pytest.TempPathFactory, target: str, argv: list[str]
) -> None:
    findings = tmp_path_factory.mktemp("findings")
    base = ["fuzz", "run", target, "--max-cases", "5", "--findings", str(findings)]
    assert call([*base, *argv, "--shrink-budget", "2"]) in (0, 1, 2)


@settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(words, max_size=3))
def test_fuzz_replay_of_anything(
    tmp_path_factory: pytest.TempPathFactory, names: list[str]
) -> None:
    directory: Path = tmp_path_factory.mktemp("replay")
    for number, text in enumerate(names):
        (directory / f"{number:03d}-x.json").write_text(text)
    assert call(["fuzz", "replay", str(directory)]) in (0, 1, 2)
