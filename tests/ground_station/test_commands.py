"""ground_station/commands.py: what the page may send, and the reason when it may not."""

from __future__ import annotations

import pytest

from ground_station.commands import OperatorCommand, Verb, parse_command
from ground_station.errors import CommandError

PADS = frozenset(range(1, 11))


def test_each_verb_parses_and_maps_to_a_mission_command_constant() -> None:
    import interfaces

    msg = interfaces.get_message("quadmission_interfaces/msg/MissionCommand")
    for verb in Verb:
        assert isinstance(getattr(msg, verb.constant), int)
        if verb is not Verb.SEQUENCE:
            assert parse_command({"command": verb.value}) == OperatorCommand(verb)


def test_a_sequence_keeps_its_order() -> None:
    command = parse_command({"command": "sequence", "sequence": [7, 2, 9], "reason": "x"},
                            PADS)
    assert command == OperatorCommand(Verb.SEQUENCE, (7, 2, 9), "x")


@pytest.mark.parametrize(("payload", "message"), [
    ([1], "JSON object"),
    ({"command": "fly"}, "unknown command 'fly'"),
    ({"command": "start", "token": "x"}, "unknown key 'token'"),
    ({"command": "sequence", "sequence": []}, "non-empty"),
    ({"command": "sequence", "sequence": [1, 1]}, "visits a pad twice"),
    ({"command": "sequence", "sequence": [1, 11]}, "no pad 11"),
    ({"command": "sequence", "sequence": [1, "2"]}, "integer pad ids"),
    ({"command": "sequence", "sequence": [True]}, "integer pad ids"),
    ({"command": "pause", "sequence": [1]}, "takes no sequence"),
    ({"command": "abort", "reason": "y" * 201}, "at most 200"),
])
def test_bad_commands_say_what_is_wrong(payload: object, message: str) -> None:
    with pytest.raises(CommandError, match=message):
        parse_command(payload, PADS)
