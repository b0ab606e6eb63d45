"""Each fault kind's expected reaction and a run's faults judged by it (no flight: the
mission's events, the FCU's failsafe times and the end state as a run gives them)."""

from __future__ import annotations

import pytest

from fsm.mission_machine import EventKind, MissionEvent, Severity
from fsm.mission_table import ErrorCause
from quadmission.evaluation.faults import (
    EXPECTED,
    EndState,
    FaultExpectationError,
    expectation,
    fcu_takes_back_within_s,
    judge_fault,
)
from sim.fault_spec import FaultKind, parse_fault


def _error(cause: str, reaction: str) -> MissionEvent:
    return MissionEvent(EventKind.ERROR, f"{cause} -> {reaction}", Severity.ERROR,
                        values=(("cause", cause), ("reaction", reaction)))


HOLD = _error("localisation_lost", "HOLD")


def test_every_kind_has_one_expected_reaction() -> None:
    assert set(EXPECTED) == set(FaultKind)


def test_vio_lost_for_good_is_hold_then_the_fcu_descent_ending_on_the_ground() -> None:
    fault = parse_fault("vio_stop@25")
    ok = judge_fault(fault, [(25.7, HOLD)], [26.5], EndState.LANDED)
    assert ok["expected"] == ok["observed"] == "localisation_lost: HOLD, then FAILSAFE"
    assert ok["handled"] and ok["reaction_s"] == pytest.approx(0.7)
    no_failsafe = judge_fault(fault, [(25.7, HOLD)], [], EndState.LANDED)
    assert not no_failsafe["handled"] and no_failsafe["observed"] == "localisation_lost: HOLD"
    holding = judge_fault(fault, [(25.7, HOLD)], [26.5], EndState.HOLDING)
    assert not holding["handled"], "no position: holding in the air is not where it may end"
    crashed = judge_fault(fault, [(25.7, HOLD)], [26.5], EndState.CRASHED)
    assert not crashed["handled"]


RESUME = _error("localisation_lost", "RESUME")


def test_a_vio_gap_holds_resumes_and_must_let_the_mission_complete() -> None:
    fault = parse_fault("vio_stop@25:3")
    judged = judge_fault(fault, [(25.7, HOLD), (30.1, RESUME)], [], EndState.LANDED,
                         completed=True)
    assert judged["expected"] == "localisation_lost: HOLD, then RESUME, then completed"
    assert judged["observed"] == judged["expected"] and judged["handled"]
    assert judged["reaction_s"] == pytest.approx(0.7)
    stopped = judge_fault(fault, [(25.7, HOLD), (55.7, _error("localisation_lost", "HOLD"))],
                          [], EndState.HOLDING)
    assert not stopped["handled"] and stopped["observed"] == "localisation_lost: HOLD"
    # too short for the FCU to call its position invalid: nothing to hold, still handled
    quiet = judge_fault(parse_fault("vio_stop@25:0.3"), [], [], EndState.LANDED,
                        completed=True)
    assert quiet["handled"] and quiet["observed"] == "completed"


def test_a_link_loss_that_ends_is_the_missions_offboard_lost_then_completed() -> None:
    fault = parse_fault("link_lost@25:3")
    hold, resume = _error("offboard_lost", "HOLD"), _error("offboard_lost", "RESUME")
    judged = judge_fault(fault, [(26.1, hold), (31.0, resume)], [26.0], EndState.LANDED,
                         completed=True)
    assert judged["expected"] == "offboard_lost: HOLD, then RESUME, then completed"
    assert judged["observed"] == judged["expected"] and judged["handled"]
    assert not judge_fault(fault, [(26.1, hold)], [26.0], EndState.HOLDING)["handled"]


def test_an_fcu_fault_for_good_needs_its_failsafe_within_the_fault() -> None:
    fault = parse_fault("node_stop@25,name=fcu_bridge")
    assert judge_fault(fault, [], [26.0], EndState.HOLDING)["handled"]
    for_good = parse_fault("link_lost@25")
    assert judge_fault(for_good, [], [26.0], EndState.LANDED)["handled"]
    assert not judge_fault(for_good, [], [], EndState.LANDED)["handled"]


def test_a_ridden_out_fault_must_raise_no_error_and_let_the_mission_complete() -> None:
    fault = parse_fault("wind_gust@25:2,force=2")
    judged = judge_fault(fault, [], [], EndState.LANDED_ON_START_PAD, completed=True)
    assert judged["expected"] == "NONE, then completed"
    assert judged["observed"] == "completed" and judged["handled"]
    hit = judge_fault(fault, [(26.0, _error("flight_error", "HOLD"))], [], EndState.HOLDING,
                      completed=True)
    assert not hit["handled"]
    stopped = judge_fault(fault, [], [], EndState.LANDED_ON_START_PAD, completed=False)
    assert not stopped["handled"], "a gust that is over leaves the mission nothing to stop for"
    # a step (no duration) or no mission: no error is all it takes
    jump = judge_fault(parse_fault("vio_jump@25,x=0.5"), [], [], EndState.FLYING)
    assert jump["expected"] == "NONE" and jump["handled"]
    alone = judge_fault(fault, [], [], EndState.HOLDING, mission=False)
    assert alone["expected"] == "NONE" and alone["handled"]


def _landing_failed(pad: int) -> MissionEvent:
    return MissionEvent(EventKind.LANDING_FAILED, f"pad {pad} not seen: searching",
                        Severity.WARN, marker_id=pad)


def _landed(pad: int) -> MissionEvent:
    return MissionEvent(EventKind.LANDED, f"landed on pad {pad}", marker_id=pad)


def test_an_occluded_pad_is_searched_then_skipped_with_its_reason() -> None:
    fault = parse_fault("pad_occluded@0,pad=4")
    skipped = [(120.0, 4, "marker not seen within the search radius")]
    judged = judge_fault(fault, [(80.0, _landing_failed(4))], [],
                         EndState.LANDED_ON_START_PAD, skipped)
    assert judged["expected"] == "SEARCH, then SKIP" and judged["handled"]
    assert judged["observed"] == ("SEARCH pad 4, then SKIP pad 4: marker not seen within the "
                                  "search radius")
    assert judged["reaction_s"] == 80.0  # the search is the reaction's start
    alone = judge_fault(fault, [], [], EndState.LANDED_ON_START_PAD, skipped)  # no path there
    assert alone["handled"] and alone["observed"] == ("SKIP pad 4: marker not seen within the "
                                                      "search radius")
    other = judge_fault(fault, [], [], EndState.LANDED_ON_START_PAD, [(120.0, 5, "x")])
    assert not other["handled"], "another pad skipped is not this one"
    err = judge_fault(fault, [(90.0, _error("flight_error", "HOLD"))], [], EndState.HOLDING,
                      skipped)
    assert not err["handled"]


def test_a_dark_camera_s_landing_is_searched_then_landed_when_the_camera_is_back() -> None:
    fault = parse_fault("camera_dark@130:60")
    back = judge_fault(fault, [(176.0, _landing_failed(5)), (232.0, _landed(5))], [],
                       EndState.LANDED_ON_START_PAD, completed=True)
    assert back["expected"] == "SEARCH, then landed or SKIP, then completed"
    assert back["observed"] == "SEARCH pad 5, then landed on it, then completed"
    assert back["handled"] and back["reaction_s"] == 46.0
    still_dark = judge_fault(fault, [(176.0, _landing_failed(5))], [],
                             EndState.LANDED_ON_START_PAD, [(220.0, 5, "marker not seen")],
                             completed=True)
    assert still_dark["handled"]
    assert still_dark["observed"] == ("SEARCH pad 5, then SKIP pad 5: marker not seen, then "
                                      "completed")
    unsettled = judge_fault(fault, [(176.0, _landing_failed(5))], [], EndState.HOLDING)
    assert not unsettled["handled"], "a search that neither landed nor skipped"
    before = judge_fault(fault, [(100.0, _landing_failed(5)), (150.0, _landed(5))], [],
                         EndState.LANDED_ON_START_PAD, completed=True)
    assert before["observed"] == "completed" and before["handled"]  # failed before it
    err = judge_fault(fault, [(140.0, _error("flight_error", "HOLD"))], [], EndState.HOLDING)
    assert not err["handled"]
    for_good = judge_fault(parse_fault("camera_dark@130"), [(176.0, _landing_failed(5))], [],
                           EndState.LANDED_ON_START_PAD, [(220.0, 5, "marker not seen")])
    assert for_good["expected"] == "SEARCH, then SKIP" and for_good["handled"]


def test_node_stop_is_expected_by_the_node_and_unknown_nodes_are_named() -> None:
    fc = judge_fault(parse_fault("node_stop@30,name=flight_control"), [], [31.0],
                     EndState.LANDED)
    assert fc["expected"] == "FAILSAFE" and fc["handled"]
    mapping = judge_fault(parse_fault("node_stop@30,name=mapping"),
                          [(33.2, _error("module_silent", "HOLD"))], [], EndState.HOLDING)
    assert mapping["expected"] == "module_silent: HOLD" and mapping["handled"]
    with pytest.raises(FaultExpectationError, match=r"node 'mission'.*flight_control"):
        expectation(parse_fault("node_stop@30,name=mission"))


def test_a_node_restarted_is_held_then_resumed_where_the_mission_survives_it() -> None:
    """The watched modules and the VIO back: HOLD, then RESUME, then completed; flight
    control only when back before the FCU's offboard-loss failsafe acts (seed 0,
    node_stop@60:5 of it: back at the end of the FCU's 5 s hold, too late, the failsafe's
    landing hit a box); the bridge never (its time sync first)."""
    for name, cause in (("navigator", "module_silent"), ("mapping", "module_silent"),
                        ("precision_land", "module_silent"), ("vio", "localisation_lost")):
        restarted = judge_fault(parse_fault(f"node_stop@60:5,name={name}"),
                                [(63.1, _error(cause, "HOLD")), (68.1, _error(cause, "RESUME"))],
                                [], EndState.LANDED_ON_START_PAD, completed=True)
        assert restarted["expected"] == f"{cause}: HOLD, then RESUME, then completed"
        assert restarted["observed"] == f"{cause}: HOLD, then RESUME, then completed"
        assert restarted["handled"]
    within = fcu_takes_back_within_s()
    assert within == 5.0  # COM_OF_LOSS_T 1 s + COM_FAIL_ACT_T 5 s - 1 s of stream
    soon = expectation(parse_fault("node_stop@60:2,name=flight_control"))
    assert soon.recovers and soon.cause is ErrorCause.OFFBOARD_LOST
    for late in ("node_stop@60:5,name=flight_control", "node_stop@60:2,name=fcu_bridge"):
        assert expectation(parse_fault(late)).reaction == "FAILSAFE"
    # for good, as before
    assert expectation(parse_fault("node_stop@60,name=navigator")).reaction == "HOLD"
    assert not expectation(parse_fault("node_stop@60,name=flight_control")).recovers


def test_without_the_mission_a_fault_that_ends_is_judged_as_before() -> None:
    """navigate, precision landing, square: no one to resume, the FCU's failsafe alone."""
    fault = parse_fault("link_lost@25:3")
    assert expectation(fault, mission=False).reaction == "FAILSAFE"
    judged = judge_fault(fault, [], [26.0], EndState.HOLDING, mission=False)
    assert judged["expected"] == "FAILSAFE" and judged["handled"]


def test_a_packet_burst_and_a_camera_blink_are_ridden_out_then_the_mission_completes() -> None:
    burst = parse_fault("packet_burst@40:2,loss=0.4")
    assert expectation(burst).completes and not expectation(burst).recovers
    quiet = judge_fault(burst, [], [], EndState.LANDED_ON_START_PAD, completed=True)
    assert quiet["expected"] == "NONE, then completed" and quiet["handled"]
    assert quiet["observed"] == "completed"
    # five /fcu/status lost in a row: the link lost for a while, held and resumed
    hold, resume = _error("offboard_lost", "HOLD"), _error("offboard_lost", "RESUME")
    held = judge_fault(burst, [(41.3, hold), (44.0, resume)], [], EndState.LANDED_ON_START_PAD,
                       completed=True)
    assert held["handled"] and held["reaction_s"] == pytest.approx(1.3)
    assert held["observed"] == "offboard_lost: HOLD, then RESUME, then completed"
    assert not judge_fault(burst, [(41.3, hold)], [], EndState.HOLDING)["handled"]
    other = judge_fault(burst, [(41.0, _error("flight_error", "HOLD"))], [],
                        EndState.LANDED_ON_START_PAD, completed=True)
    assert not other["handled"], "another cause is an error the burst made"
    blink = parse_fault("camera_dark@150:0.8")
    landed = judge_fault(blink, [(150.5, _landing_failed(3)), (160.0, _landed(3))], [],
                         EndState.LANDED_ON_START_PAD, completed=True)
    assert landed["handled"]
    assert landed["observed"] == "SEARCH pad 3, then landed on it, then completed"
    assert not judge_fault(blink, [], [], EndState.LANDED_ON_START_PAD)["handled"]


def _judge_run(specs: list[str], events: list[tuple[float, MissionEvent]],
               completed: bool) -> list[dict[str, object]]:
    return [judge_fault(parse_fault(s), events, [], EndState.LANDED_ON_START_PAD,
                        completed=completed) for s in specs]


def test_a_run_of_two_transient_faults_is_handled_when_the_mission_completes() -> None:
    """As the transient campaign draws them: apart in time, each judged on its own
    window, both handled when the mission completes with every landing inside."""
    specs = ["camera_dark@60.2:1.1", "node_stop@200:4,name=mapping"]
    silent = [(203.1, _error("module_silent", "HOLD")), (206.5, _error("module_silent",
                                                                       "RESUME"))]
    both = _judge_run(specs, silent, completed=True)
    assert [j["handled"] for j in both] == [True, True], both
    assert both[0]["observed"] == "completed", "the later fault's HOLD is not the blink's"
    assert both[1]["observed"] == "module_silent: HOLD, then RESUME, then completed"
    assert not any(j["handled"] for j in _judge_run(specs, silent, completed=False))
    specs = ["link_lost@30:0.6", "vio_stop@150:3"]
    lost = [(150.7, HOLD), (155.2, RESUME)]
    first, second = _judge_run(specs, lost, completed=True)
    assert first["handled"] and first["observed"] == "completed" and first["reaction_s"] is None
    assert second["handled"] and second["reaction_s"] == pytest.approx(0.7)
