"""Which fault kinds each scenario takes, and the app's own faults resolved for a run."""

from __future__ import annotations

import pytest

from quadmission.assembly.faults import SCENARIO_KINDS, check_faults, resolve_faults
from quadmission.errors import OptionsError
from quadmission.evaluation.faults import EXPECTED, Handler
from sim.arena import default_arena
from sim.fault_spec import FaultKind, parse_fault, parse_faults


def test_the_mission_takes_every_kind_and_the_others_none_the_mission_must_notice() -> None:
    """Except the square's vio_stop: a run that no mission can handle, on purpose (the
    campaign's unhandled case; lost for good, the FCU's descent on its own)."""
    assert SCENARIO_KINDS["mission"] == frozenset(FaultKind)
    for scenario, kinds in SCENARIO_KINDS.items():
        if scenario != "mission":
            noticed = {k for k in kinds if EXPECTED[k].handler is Handler.MISSION}
            assert noticed == ({FaultKind.VIO_STOP} if scenario == "square" else set()), scenario


def test_a_kind_a_scenario_cannot_take_is_refused_naming_both_and_why() -> None:
    check_faults("navigate", parse_faults(["link_lost@10:3", "depth_dark@5:2"]))
    with pytest.raises(OptionsError, match=r"the navigate scenario cannot take pad_occluded "
                                           r"\(it lands on no pad\); it takes: .*clock_jump"):
        check_faults("navigate", parse_faults(["pad_occluded@0,pad=3"]))
    with pytest.raises(OptionsError, match=r"precision-landing scenario cannot take "
                                           r"battery_low .*mission's RETURN_AND_LAND"):
        check_faults("precision-landing", parse_faults(["battery_low@3"]))
    with pytest.raises(OptionsError, match="the arena-tour scenario takes no faults"):
        check_faults("arena-tour", parse_faults(["light_drop@1"]))
    check_faults("arena-tour", ())


def test_robot_absent_takes_the_target_and_node_stop_a_node_of_the_run() -> None:
    arena = default_arena()
    (f,) = resolve_faults(parse_faults(["robot_absent@0"]), arena, 19, ["mapping"])
    assert f.value("robot") == 19
    with pytest.raises(OptionsError, match=r"no node 'mapper' in this run .*mapping"):
        resolve_faults([parse_fault("node_stop@3,name=mapper")], arena, 19, ["mapping"])
    with pytest.raises(OptionsError, match="no expected reaction for node 'mission'"):
        resolve_faults([parse_fault("node_stop@3,name=mission")], arena, 19, ["mission"])
    with pytest.raises(OptionsError, match="has pads"):
        resolve_faults([parse_fault("pad_occluded@0,pad=77")], arena, 19, [])
