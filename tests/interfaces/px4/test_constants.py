"""PX4 enums come from the .msg files: the committed module is what the generator writes."""

from __future__ import annotations

from interfaces.api import typestore
from interfaces.generate_px4 import GROUPS, TARGET, render
from interfaces.px4 import ArmingState, BatteryWarning, CommandResult, NavigationState, VehicleCmd


def test_committed_constants_match_the_msg_files() -> None:
    assert TARGET.read_text() == render(), (
        "interfaces/px4/constants.py is stale: run python -m interfaces.generate_px4")


def test_every_group_member_is_the_msg_constant() -> None:
    import interfaces.px4.constants as generated

    for group in GROUPS:
        consts = {name: value for name, _t, value in
                  typestore().fielddefs[f"px4_msgs/msg/{group.message}"][0]}
        enum = getattr(generated, group.enum)
        for member in enum:
            sources = [p + member.name for p in group.prefixes if p + member.name in consts]
            assert sources, f"{group.enum}.{member.name} is in no {group.message} constant"
            assert int(member) == consts[sources[0]]


def test_the_numbers_the_stack_relies_on() -> None:
    # spot checks against PX4's published values, independent of the generator
    assert ArmingState.ARMED == 2
    assert NavigationState.OFFBOARD == 14
    assert VehicleCmd.COMPONENT_ARM_DISARM == 400
    assert VehicleCmd.DO_SET_MODE == 176
    assert CommandResult.TEMPORARILY_REJECTED == 1
    assert BatteryWarning.CRITICAL == 2
