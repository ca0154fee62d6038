"""fw1394.Error is the one base of every exception the library defines.

The walk imports every module of the package and checks every exception class
defined there, so a new module cannot add one outside the hierarchy. The kinds
are checked against failures the library really produces: bytes the codec
rejects, a transaction the engine fails, and the command-line tool's one place
that turns any of them into a line on stderr and exit status 2.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import fw1394
from fw1394 import errors
from fw1394.cli import main as cli_main
from fw1394.engine import FailureReason, TransactionFailed
from fw1394.packets import AckCode, RCode, decode
from fw1394.transport.bus_host import (
    StaleGenerationError,
    TransactionError,
    TransactionTimeout,
)


def _library_exception_classes() -> list[type[BaseException]]:
    found: list[type[BaseException]] = []
    for info in pkgutil.walk_packages(fw1394.__path__, "fw1394."):
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if (
                inspect.isclass(value)
                and issubclass(value, BaseException)
                and value.__module__ == module.__name__
            ):
                found.append(value)
    return found


def test_every_exception_class_of_the_library_derives_from_fw1394_error() -> None:
    classes = _library_exception_classes()
    # The walk must reach the whole package, not stop at the top (57 when written).
    assert len(classes) > 50
    # A request to end the process (SIGTERM raised as an interrupt) is not an error.
    errors = [c for c in classes if not issubclass(c, KeyboardInterrupt)]
    outside = sorted(
        f"{c.__module__}.{c.__qualname__}" for c in errors if not issubclass(c, fw1394.Error)
    )
    assert outside == []


def test_each_exception_class_has_one_name() -> None:
    classes = set(_library_exception_classes())
    names = [c.__name__ for c in classes if not c.__name__.startswith("_")]
    assert sorted({n for n in names if names.count(n) > 1}) == []


def test_bytes_the_codec_rejects_raise_a_packet_error() -> None:
    # A quadlet write request (tcode 0) cut after its first quadlet: IEEE 1394-1995
    # 6.2.2 gives it four header quadlets and a header CRC.
    with pytest.raises(fw1394.PacketError) as caught:
        decode(bytes([0xFF, 0xC0, 0x04, 0x00]))
    assert isinstance(caught.value, fw1394.Error)
    assert isinstance(caught.value, ValueError)


@pytest.mark.parametrize(
    ("reason", "rcode", "ack", "timeout"),
    [
        (FailureReason.ack_address_error, None, AckCode.ack_address_error, False),
        (FailureReason.ack_type_error, None, AckCode.ack_type_error, False),
        (FailureReason.rcode_error, RCode.resp_data_error, None, False),
        (FailureReason.no_ack, None, None, True),
        (FailureReason.response_timeout, None, None, True),
        (FailureReason.bus_reset, None, None, False),
    ],
)
def test_a_failed_transaction_carries_its_ack_and_rcode(
    reason: FailureReason, rcode: int | None, ack: int | None, timeout: bool
) -> None:
    error = TransactionError(TransactionFailed(7, reason, rcode))
    assert isinstance(error, fw1394.TransactionError)
    assert (error.ack, error.rcode) == (ack, rcode)
    assert isinstance(error, fw1394.Timeout) is timeout
    assert isinstance(error, TransactionTimeout) is timeout


def test_a_subclass_keeps_its_own_constructor() -> None:
    # The base picks TransactionTimeout from the failure; a subclass built from
    # other arguments must still construct (a stale generation is not a timeout).
    stale = StaleGenerationError(3, 4)
    assert (stale.addressed, stale.current, stale.ack, stale.rcode) == (3, 4, None, None)
    assert isinstance(stale, fw1394.TransactionError)
    assert not isinstance(stale, fw1394.Timeout)


def test_a_packet_error_names_its_field_or_only_the_problem() -> None:
    assert str(errors.PacketError("tcode", "reserved value 0xc")) == "tcode: reserved value 0xc"
    whole = errors.PacketError("truncated record")
    assert (whole.field, whole.problem, str(whole)) == ("", "truncated record", "truncated record")


@pytest.mark.parametrize(
    "error",
    [
        errors.UsageError("--count -1: must be positive"),
        errors.BusUnreachable("bus 'x': no coordinator"),
        errors.Timeout("no answer\nwithin 1 s"),
        errors.TransactionError("rcode_error", rcode=RCode.resp_address_error),
    ],
)
def test_the_cli_turns_any_library_error_into_one_line_and_status_2(
    error: fw1394.Error, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = cli_main.build_parser()
    args = parser.parse_args(["decode", "00"])

    def failing(_args: object) -> int:
        raise error

    args.handler = failing
    monkeypatch.setattr(cli_main, "build_parser", lambda _command=None: _Fixed(parser, args))
    assert cli_main.main(["decode", "00"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("fw1394: error: ")
    assert " ".join(str(error).split()) in lines[0]


class _Fixed:
    """A parser stand-in that returns namespace ``args`` whatever it is given."""

    def __init__(self, parser: object, args: object) -> None:
        self._parser = parser
        self._args = args

    def parse_args(self, _argv: object) -> object:
        return self._args
