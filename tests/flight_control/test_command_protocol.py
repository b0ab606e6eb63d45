"""The FCU command/ack/retry protocol, alone: every way a command can end."""

from __future__ import annotations

import pytest

from flight_control.command_protocol import CommandProtocol, Phase
from interfaces.px4 import CommandResult, VehicleCmd

TIMEOUT_NS = 500_000_000  # 0.5 s


def _protocol(attempts: int = 3) -> CommandProtocol:
    return CommandProtocol(VehicleCmd.DO_SET_MODE, attempts=attempts, timeout_ns=TIMEOUT_NS)


def test_first_poll_sends_and_an_accepting_ack_ends_it() -> None:
    p = _protocol()
    assert p.poll(0) is True
    assert (p.phase, p.sent, p.deadline_ns) == (Phase.WAITING, 1, TIMEOUT_NS)
    assert p.poll(1) is False  # waiting: nothing to send
    p.on_ack(CommandResult.ACCEPTED, 100)
    assert p.done and p.accepted and not p.timed_out
    assert p.result == CommandResult.ACCEPTED
    assert p.poll(10 * TIMEOUT_NS) is False  # done: never sends again
    assert p.describe() == "DO_SET_MODE accepted"


def test_a_lost_ack_is_followed_by_a_resend_at_the_deadline() -> None:
    p = _protocol()
    p.poll(0)
    assert p.poll(TIMEOUT_NS - 1) is False  # not yet
    assert p.poll(TIMEOUT_NS) is True  # exactly at the deadline: send again
    assert (p.sent, p.deadline_ns, p.phase) == (2, 2 * TIMEOUT_NS, Phase.WAITING)
    p.on_ack(CommandResult.ACCEPTED, TIMEOUT_NS + 10)
    assert p.accepted and p.sent == 2


def test_a_temporary_rejection_is_retried_when_the_wait_is_over() -> None:
    p = _protocol()
    p.poll(0)
    p.on_ack(CommandResult.TEMPORARILY_REJECTED, 1000)
    assert p.phase is Phase.BACKING_OFF and not p.done
    assert p.result == CommandResult.TEMPORARILY_REJECTED
    assert p.poll(TIMEOUT_NS - 1) is False  # no resend before the wait is over
    assert p.poll(TIMEOUT_NS) is True
    assert p.sent == 2
    p.on_ack(CommandResult.ACCEPTED, TIMEOUT_NS + 1)
    assert p.accepted


def test_gives_up_after_command_attempts_sends_without_an_ack() -> None:
    p = _protocol(attempts=3)
    sends = [t for t in range(0, 10 * TIMEOUT_NS, TIMEOUT_NS // 5) if p.poll(t)]
    assert sends == [0, TIMEOUT_NS, 2 * TIMEOUT_NS]
    assert p.done and not p.accepted and p.timed_out and p.result is None
    assert p.phase is Phase.FAILED
    assert p.describe() == "DO_SET_MODE: no ack from the FCU after 3 attempt(s)"


def test_one_attempt_fails_at_the_first_deadline() -> None:
    p = _protocol(attempts=1)
    p.poll(0)
    assert p.poll(TIMEOUT_NS - 1) is False and not p.done
    assert p.poll(TIMEOUT_NS) is False
    assert p.done and p.timed_out


def test_a_temporary_rejection_on_the_last_attempt_is_final() -> None:
    p = _protocol(attempts=2)
    p.poll(0)
    p.on_ack(CommandResult.TEMPORARILY_REJECTED, 1)
    p.poll(TIMEOUT_NS)
    p.on_ack(CommandResult.TEMPORARILY_REJECTED, TIMEOUT_NS + 1)
    assert p.done and not p.accepted and not p.timed_out
    assert p.sent == 2
    assert p.describe() == ("DO_SET_MODE refused by the FCU: TEMPORARILY_REJECTED "
                            "(attempt 2/2)")


@pytest.mark.parametrize("result", [CommandResult.DENIED, CommandResult.UNSUPPORTED,
                                    CommandResult.FAILED, CommandResult.CANCELLED])
def test_a_refusal_is_final_and_never_resent(result: CommandResult) -> None:
    p = _protocol()
    p.poll(0)
    p.on_ack(result, 5)
    assert p.done and not p.accepted and not p.timed_out
    assert p.result == result
    assert p.poll(5 * TIMEOUT_NS) is False and p.sent == 1
    assert p.describe() == f"DO_SET_MODE refused by the FCU: {result.name} (attempt 1/3)"


def test_in_progress_keeps_waiting_for_the_final_ack() -> None:
    p = _protocol()
    p.poll(0)
    p.on_ack(CommandResult.IN_PROGRESS, 1)
    assert p.phase is Phase.WAITING and p.result is None
    p.on_ack(CommandResult.ACCEPTED, 2)
    assert p.accepted


def test_acks_outside_a_wait_are_ignored() -> None:
    p = _protocol()
    p.on_ack(CommandResult.ACCEPTED, 0)  # before the first send: someone else's
    assert p.phase is Phase.IDLE and p.result is None
    p.poll(0)
    p.on_ack(CommandResult.TEMPORARILY_REJECTED, 1)
    p.on_ack(CommandResult.ACCEPTED, 2)  # a late ack of the rejected send
    assert p.phase is Phase.BACKING_OFF
    p.poll(TIMEOUT_NS)
    p.on_ack(CommandResult.DENIED, TIMEOUT_NS + 1)
    p.on_ack(CommandResult.ACCEPTED, TIMEOUT_NS + 2)  # after the end
    assert p.phase is Phase.FAILED and p.result == CommandResult.DENIED


def test_describe_while_waiting_and_for_unknown_numbers() -> None:
    p = _protocol()
    assert p.describe() == "DO_SET_MODE: waiting for the ack (attempt 0/3)"
    p.poll(0)
    assert p.describe() == "DO_SET_MODE: waiting for the ack (attempt 1/3)"
    q = CommandProtocol(99999, attempts=1, timeout_ns=1)
    q.poll(0)
    q.on_ack(77, 0)
    assert q.describe() == "99999 refused by the FCU: 77 (attempt 1/1)"


@pytest.mark.parametrize(("attempts", "timeout_ns", "message"), [
    (0, TIMEOUT_NS, "attempts: 0 must be >= 1"),
    (1, 0, "timeout_ns: 0 must be > 0"),
])
def test_bad_settings_are_refused(attempts: int, timeout_ns: int, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        CommandProtocol(VehicleCmd.NAV_LAND, attempts=attempts, timeout_ns=timeout_ns)
