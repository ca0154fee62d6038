"""The decision tables: complete, and described row by row in docs/engine.md."""

from __future__ import annotations

from pathlib import Path

from fw1394.engine.events import FailureReason
from fw1394.engine.table import (
    ANSWERS,
    ON_ACK,
    RETRY_CODES,
    SCREENS,
    Delivery,
    Outcome,
    Screen,
    Step,
)
from fw1394.packets import AckCode, Retry

DOC = (Path(__file__).parents[2] / "docs" / "engine.md").read_text()


def test_every_screen_has_an_answer_and_a_row_in_the_docs() -> None:
    assert set(SCREENS) == set(Screen)
    for screen in Screen:
        assert f"`{screen.value}`" in DOC


def test_every_delivery_answers_every_outcome() -> None:
    assert set(ANSWERS) == set(Delivery)
    for answers in ANSWERS.values():
        assert set(answers) == set(Outcome)


def test_only_unified_answers_go_without_a_response_on_success() -> None:
    for delivery, answers in ANSWERS.items():
        done = answers[Outcome.done]
        assert (done.rcode is None) == (delivery is Delivery.unified)
        assert done.concatenated == (delivery is Delivery.concatenated)


def test_every_ack_code_has_a_reaction() -> None:
    for expects_response in (False, True):
        for ack in AckCode:
            assert (expects_response, ack) in ON_ACK
    reasons = {reaction.reason for reaction in ON_ACK.values() if reaction.step is Step.fail}
    assert reasons <= set(FailureReason)


def test_retry_codes_cover_every_busy_ack_in_both_protocols() -> None:
    retried = [ack for (expects, ack), r in ON_ACK.items() if r.step is Step.retry and expects]
    for protocol in ("single", "dual"):
        for ack in retried:
            assert RETRY_CODES[(protocol, ack)] in (Retry.retry_X, Retry.retry_A, Retry.retry_B)
    assert {RETRY_CODES[("single", ack)] for ack in retried} == {Retry.retry_X}


def test_every_failure_reason_is_documented() -> None:
    for reason in FailureReason:
        assert reason.value in DOC
