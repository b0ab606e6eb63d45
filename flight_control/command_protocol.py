"""The FCU command protocol as a pure state machine: send, wait for the ack, send again.

PX4 answers every ``VehicleCommand`` with a ``VehicleCommandAck``. Over a lossy link the
command or its ack can be lost, and PX4 answers ``TEMPORARILY_REJECTED`` when it cannot
take the command yet (e.g. offboard asked for before the setpoint stream is seen). So a
command is sent, then the ack is awaited for ``timeout_ns``; without an ack, or after a
temporary rejection, it is sent again when that wait is over, up to ``attempts`` sends.
``ACCEPTED`` ends it; any other answer (``DENIED``, ``UNSUPPORTED``, ``FAILED``, ...) is
final; ``IN_PROGRESS`` only says the FCU is working on it, so the wait goes on.

Inputs are the time (int nanoseconds, any monotonic clock) and the acks; the machine
tells its driver when to send. The driver (:class:`flight_control.behaviour_server.FcuCommands`)
publishes, feeds acks in and calls :meth:`CommandProtocol.poll` until :attr:`done`.
"""

from __future__ import annotations

from enum import Enum

from interfaces.px4 import CommandResult, VehicleCmd


class Phase(Enum):
    """Where a command is."""

    IDLE = "idle"  # not sent yet
    WAITING = "waiting"  # sent, waiting for the ack until the deadline
    BACKING_OFF = "backing_off"  # temporarily rejected: send again at the deadline
    ACCEPTED = "accepted"
    FAILED = "failed"


def _name(command: int) -> str:
    try:
        return VehicleCmd(command).name
    except ValueError:
        return str(command)


def _result_name(result: int) -> str:
    try:
        return CommandResult(result).name
    except ValueError:
        return str(result)


class CommandProtocol:
    """One FCU command's sends and acks. ``attempts`` >= 1 sends at most, ``timeout_ns``
    > 0 between a send and the next."""

    def __init__(self, command: int, *, attempts: int, timeout_ns: int) -> None:
        if attempts < 1:
            raise ValueError(f"attempts: {attempts} must be >= 1")
        if timeout_ns <= 0:
            raise ValueError(f"timeout_ns: {timeout_ns} must be > 0")
        self.command = int(command)
        self.attempts = attempts
        self.timeout_ns = timeout_ns
        self.phase = Phase.IDLE
        self.sent = 0  # sends so far
        self.deadline_ns = 0  # end of the current wait
        self.result: int | None = None  # the last ack's result, None: no ack yet

    @property
    def done(self) -> bool:
        return self.phase in (Phase.ACCEPTED, Phase.FAILED)

    @property
    def accepted(self) -> bool:
        return self.phase is Phase.ACCEPTED

    @property
    def timed_out(self) -> bool:
        """Failed without any ack."""
        return self.phase is Phase.FAILED and self.result is None

    def poll(self, now_ns: int) -> bool:
        """Advance to ``now_ns``; True when the command must be sent now."""
        if self.phase is Phase.IDLE:
            return self._send(now_ns)
        if self.phase in (Phase.WAITING, Phase.BACKING_OFF) and now_ns >= self.deadline_ns:
            if self.sent < self.attempts:
                return self._send(now_ns)
            self.phase = Phase.FAILED
        return False

    def on_ack(self, result: int, now_ns: int) -> None:
        """An ack for this command arrived at ``now_ns``."""
        if self.phase is not Phase.WAITING or result == CommandResult.IN_PROGRESS:
            return  # not waiting (a late or repeated ack), or still working on it
        self.result = int(result)
        if result == CommandResult.ACCEPTED:
            self.phase = Phase.ACCEPTED
        elif result == CommandResult.TEMPORARILY_REJECTED and self.sent < self.attempts:
            self.phase = Phase.BACKING_OFF
        else:
            self.phase = Phase.FAILED

    def _send(self, now_ns: int) -> bool:
        self.sent += 1
        self.deadline_ns = now_ns + self.timeout_ns
        self.phase = Phase.WAITING
        return True

    def describe(self) -> str:
        """A sentence for messages: ``DO_SET_MODE accepted``, ``... refused by the FCU:
        DENIED``, ``...: no ack from the FCU after 3 attempt(s)``."""
        name = _name(self.command)
        if self.phase is Phase.ACCEPTED:
            return f"{name} accepted"
        if self.phase is not Phase.FAILED:
            return f"{name}: waiting for the ack (attempt {self.sent}/{self.attempts})"
        if self.result is None:
            return f"{name}: no ack from the FCU after {self.sent} attempt(s)"
        return (f"{name} refused by the FCU: {_result_name(self.result)} "
                f"(attempt {self.sent}/{self.attempts})")


__all__ = ["CommandProtocol", "Phase"]
