"""The mission machine: the tables' shape, a whole mission, the pad-search branch, the error
policy per cause, and pause/resume/abort reaching the active action."""

from __future__ import annotations

from collections import deque
from typing import Any

import pytest

from fsm.mission_machine import EventKind, Mission, MissionConfig, MissionEvent
from fsm.mission_table import (
    ERROR_POLICY,
    INITIAL,
    RESUMABLE,
    SEPARATOR,
    TRANSITIONS,
    ErrorCause,
    Phase,
    Reaction,
    leaves,
    phase_of,
    terminal_states,
    walk,
)

PADS = {1: (1.5, 1.5), 2: (3.0, 7.5), 3: (7.0, 10.5), 5: (11.5, 7.5)}


class Recorder:
    """The world as the machine sees it: every request it made, in order."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []
        self.states: list[str] = []
        self.events: list[MissionEvent] = []

    def check_health(self) -> None:
        self.calls.append(("check_health",))

    def takeoff(self) -> None:
        self.calls.append(("takeoff",))

    def explore(self, target_robot: int) -> None:
        self.calls.append(("explore", target_robot))

    def send_pictures(self) -> None:
        self.calls.append(("send_pictures",))

    def navigate(self, target: tuple[float, float]) -> None:
        self.calls.append(("navigate", target))

    def precision_land(self, pad: int, position: tuple[float, float],
                       search_radius: float) -> None:
        self.calls.append(("precision_land", pad, position, search_radius))

    def land(self) -> None:
        self.calls.append(("land",))

    def hold(self) -> None:
        self.calls.append(("hold",))

    def cancel(self) -> None:
        self.calls.append(("cancel",))

    def state_changed(self, state: str) -> None:
        self.states.append(state)

    def emit(self, event: MissionEvent) -> None:
        self.events.append(event)

    def last(self, name: str) -> tuple[Any, ...]:
        return next(c for c in reversed(self.calls) if c[0] == name)


def make_mission() -> tuple[Mission, Recorder]:
    driver = Recorder()
    config = MissionConfig(target_robot=19, start_pad=1, pads=PADS,
                           search_radius_near=0.5, search_radius_wide=2.0)
    return Mission(config, driver), driver


def to_await_sequence(m: Mission) -> None:
    assert m.start().accepted
    assert m.preflight_result(True)
    assert m.took_off()
    assert m.robot_found(19)
    assert m.pictures_sent()
    assert m.state == "mission.await_sequence"


# -- the tables --------------------------------------------------------------------------------
def _graph() -> dict[str, set[str]]:
    """Leaf -> leaves reachable in one transition (a parent source covers its children,
    a parent destination enters its initial child)."""
    specs = dict(walk())

    def enter(name: str) -> str:
        while specs[name].children:
            name = name + SEPARATOR + str(specs[name].initial)
        return name

    def under(leaf: str, source: str) -> bool:
        return leaf == source or leaf.startswith(source + SEPARATOR)

    edges: dict[str, set[str]] = {leaf: set() for leaf in leaves()}
    for leaf in edges:
        for t in TRANSITIONS:
            if under(leaf, t.source):
                edges[leaf].add(enter(t.dest))
    for dest in RESUMABLE:
        edges["paused"].add(dest)
    return edges


def test_every_state_is_reachable_from_idle() -> None:
    edges = _graph()
    seen, todo = {INITIAL}, deque([INITIAL])
    while todo:
        for nxt in edges[todo.popleft()]:
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    assert seen == set(edges), f"unreachable: {sorted(set(edges) - seen)}"


def test_every_state_leads_to_a_termination_state_and_terminals_are_final() -> None:
    edges = _graph()
    terminal = set(terminal_states())
    assert terminal == {"completed", "stopped", "landed"}
    for t in TRANSITIONS:
        assert t.source not in terminal, f"{t.trigger} leaves terminal state {t.source}"
    for leaf in set(edges) - terminal:
        seen, todo = {leaf}, deque([leaf])
        while todo:
            for nxt in edges[todo.popleft()]:
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        assert seen & terminal, f"{leaf} cannot end"


def test_every_non_terminal_state_has_the_stop_way_out() -> None:
    m, _ = make_mission()
    terminal = set(terminal_states())
    for leaf in leaves():
        if leaf in terminal:
            assert m.machine.get_triggers(leaf) == [], leaf
        else:
            assert Reaction.HOLD.value in m.machine.get_triggers(leaf), leaf


def test_every_state_has_a_phase_for_mission_state() -> None:
    assert phase_of("mission.pad.search") is Phase.LANDING_SEQUENCE
    assert phase_of("returning.land") is Phase.RETURN_HOME
    for name in leaves():
        phase_of(name)  # raises on a state without a phase
    with pytest.raises(KeyError):
        phase_of("missionary")


def test_every_cause_has_a_policy_and_localisation_loss_never_lands() -> None:
    assert set(ERROR_POLICY) == set(ErrorCause)
    assert ERROR_POLICY[ErrorCause.LOCALISATION_LOST].reaction is Reaction.HOLD
    assert ERROR_POLICY[ErrorCause.BATTERY_LOW].reaction is Reaction.RETURN_AND_LAND
    assert ERROR_POLICY[ErrorCause.BATTERY_CRITICAL].reaction is Reaction.LAND_NOW
    assert ERROR_POLICY[ErrorCause.MODULE_SILENT].reaction is Reaction.HOLD


# -- a whole mission ---------------------------------------------------------------------------
def test_a_whole_mission_lands_the_sequence_in_order_and_sums_the_points() -> None:
    m, d = make_mission()
    to_await_sequence(m)
    requests = [c for c in d.calls if c != ("cancel",)]
    assert requests == [("check_health",), ("takeoff",), ("explore", 19), ("send_pictures",),
                        ("hold",)]
    assert m.receive_sequence([3, 5], [40, 30]).accepted
    assert d.last("navigate") == ("navigate", PADS[3])
    assert m.target_pad == 3
    assert m.arrived()
    assert d.last("precision_land") == ("precision_land", 3, PADS[3], 0.5)
    assert m.landed(0.04)
    assert m.state == "mission.pad.takeoff" and m.score == 40
    assert m.took_off()
    assert d.last("navigate") == ("navigate", PADS[5]) and m.target_pad == 5
    assert m.arrived() and m.landed()
    assert m.state == "completed" and m.finished
    assert (m.score, m.landed_pads, m.skipped, m.stop) == (70, [3, 5], [], None)
    assert d.events[-1].kind is EventKind.COMPLETED
    assert d.states[-1] == "completed"


def test_a_late_result_from_an_earlier_state_is_ignored() -> None:
    m, _ = make_mission()
    to_await_sequence(m)
    assert not m.took_off()
    assert not m.robot_found(19)
    assert not m.landed()
    assert m.state == "mission.await_sequence"


def test_another_robot_does_not_end_the_exploration() -> None:
    m, _ = make_mission()
    m.start()
    m.preflight_result(True)
    m.took_off()
    assert not m.robot_found(14)
    assert m.state == "mission.explore"


@pytest.mark.parametrize(("pads", "points", "problem"), [
    ([], [], "empty"), ([3, 4], [], "unknown pads [4]"), ([3, 3], [], "twice"),
    ([3, 5], [1], "1 points for 2 pads"), ([3], [-1], "negative")])
def test_a_bad_sequence_is_rejected_with_the_reason(pads: list[int], points: list[int],
                                                    problem: str) -> None:
    m, d = make_mission()
    to_await_sequence(m)
    reply = m.receive_sequence(pads, points)
    assert not reply.accepted and problem in reply.reason
    assert m.state == "mission.await_sequence"
    assert d.events[-1].kind is EventKind.COMMAND_REJECTED


def test_a_sequence_is_only_taken_while_waiting_for_it() -> None:
    m, _ = make_mission()
    m.start()
    reply = m.receive_sequence([3])
    assert not reply.accepted and "not waiting" in reply.reason


# -- the pad-search branch (seed 003, 4.2) ----------------------------------------------------
def test_a_missing_pad_is_searched_for_wider_then_skipped_with_the_reason() -> None:
    m, d = make_mission()
    to_await_sequence(m)
    m.receive_sequence([3, 5], [40, 30])
    m.arrived()
    assert m.marker_not_found("not in view")
    assert m.state == "mission.pad.search"
    assert d.last("precision_land") == ("precision_land", 3, PADS[3], 2.0)
    assert m.marker_not_found("searched 8 points")
    assert m.state == "mission.pad.navigate" and m.target_pad == 5
    assert [s.pad for s in m.skipped] == [3]
    assert "within 2 m" in m.skipped[0].reason and "searched 8 points" in m.skipped[0].reason
    m.arrived()
    m.landed()
    assert m.state == "completed" and m.score == 30


def test_a_pad_found_by_the_search_is_landed_on() -> None:
    m, _ = make_mission()
    to_await_sequence(m)
    m.receive_sequence([3], [40])
    m.arrived()
    m.marker_not_found("not in view")
    assert m.landed()
    assert (m.state, m.score, m.skipped) == ("completed", 40, [])


def test_skipping_the_last_pad_flies_home_lands_and_completes() -> None:
    m, d = make_mission()
    to_await_sequence(m)
    m.receive_sequence([3], [40])
    m.arrived()
    m.marker_not_found("a")
    m.marker_not_found("b")
    assert m.state == "returning.navigate"
    assert d.last("navigate") == ("navigate", PADS[1])
    m.arrived()
    assert d.last("precision_land")[1] == 1
    m.landed()
    assert m.state == "completed" and m.stop is None and m.score == 0


def test_no_path_to_a_pad_skips_it() -> None:
    m, _ = make_mission()
    to_await_sequence(m)
    m.receive_sequence([3, 5])
    assert m.unreachable("goal occupied")
    assert m.skipped[0].pad == 3 and "no path: goal occupied" in m.skipped[0].reason
    assert m.state == "mission.pad.navigate" and m.target_pad == 5


# -- the error policy ---------------------------------------------------------------------------
def to_pad_land(m: Mission) -> None:
    to_await_sequence(m)
    m.receive_sequence([3, 5], [40, 30])
    m.arrived()
    assert m.state == "mission.pad.land"


@pytest.mark.parametrize("cause", [ErrorCause.LOCALISATION_LOST, ErrorCause.MODULE_SILENT,
                                   ErrorCause.MODULE_ERROR, ErrorCause.FLIGHT_ERROR])
def test_a_stop_cause_cancels_the_action_and_holds_without_landing(cause: ErrorCause) -> None:
    m, d = make_mission()
    to_pad_land(m)
    before = len(d.calls)
    assert m.error(cause, "vision pose stale for 0.5 s")
    assert m.state == "stopped" and m.finished
    assert d.calls[before:] == [("cancel",), ("hold",)]  # no land, no navigate
    assert m.stop is not None
    assert (m.stop.cause, m.stop.reaction, m.stop.state) == (cause, Reaction.HOLD,
                                                             "mission.pad.land")
    assert not m.landed()  # nothing moves a stopped mission
    assert m.state == "stopped"


def test_battery_low_returns_home_and_lands_there() -> None:
    m, d = make_mission()
    to_pad_land(m)
    assert m.error(ErrorCause.BATTERY_LOW, "25 %")
    assert m.state == "returning.navigate" and d.calls[-2:] == [("cancel",),
                                                               ("navigate", PADS[1])]
    assert not m.error(ErrorCause.BATTERY_LOW, "24 %")  # already on the way home
    m.arrived()
    assert d.last("precision_land")[:2] == ("precision_land", 1)
    m.landed()
    assert m.state == "landed"
    assert m.stop is not None and m.stop.cause is ErrorCause.BATTERY_LOW
    assert m.landed_pads == []  # the home landing is not a sequence pad


def test_battery_critical_lands_now_even_on_the_way_home() -> None:
    m, d = make_mission()
    to_pad_land(m)
    m.error(ErrorCause.BATTERY_LOW, "25 %")
    assert m.error(ErrorCause.BATTERY_CRITICAL, "9 %")
    assert m.state == "landing_now" and d.calls[-1] == ("land",)
    assert not m.error(ErrorCause.BATTERY_LOW, "8 %")
    m.landed()
    assert m.state == "landed"
    assert m.stop is not None and m.stop.cause is ErrorCause.BATTERY_CRITICAL


def test_localisation_loss_on_the_way_home_still_stops() -> None:
    m, _ = make_mission()
    to_pad_land(m)
    m.error(ErrorCause.BATTERY_LOW, "25 %")
    assert m.error(ErrorCause.LOCALISATION_LOST, "no vision")
    assert m.state == "stopped"


def test_a_preflight_failure_stops_on_the_ground_whatever_the_cause() -> None:
    for cause in (ErrorCause.BATTERY_LOW, ErrorCause.BATTERY_CRITICAL):
        m, d = make_mission()
        m.start()
        assert m.error(cause, "on the ground")
        assert m.state == "stopped" and ("land",) not in d.calls
    m, _ = make_mission()
    m.start()
    assert m.preflight_result(False, "navigator did not answer")
    assert m.state == "stopped"
    assert m.stop is not None and m.stop.cause is ErrorCause.PREFLIGHT_FAILED
    assert "navigator" in m.stop.detail


def test_errors_before_start_change_nothing() -> None:
    m, _ = make_mission()
    assert not m.error(ErrorCause.MODULE_SILENT, "not up yet")
    assert m.state == INITIAL


def test_robot_not_found_and_no_sequence_return_home() -> None:
    m, _ = make_mission()
    m.start()
    m.preflight_result(True)
    m.took_off()
    assert m.explore_ended("field covered")
    assert m.state == "returning.navigate"
    m2, _ = make_mission()
    to_await_sequence(m2)
    assert m2.error(ErrorCause.SEQUENCE_TIMEOUT, "120 s")
    assert m2.state == "returning.navigate"


# -- pause, resume, abort -----------------------------------------------------------------------
def test_pause_cancels_the_active_landing_and_resume_restarts_it() -> None:
    m, d = make_mission()
    to_pad_land(m)
    before = len(d.calls)
    assert m.pause().accepted
    assert m.state == "paused" and d.calls[before:] == [("cancel",), ("hold",)]
    assert not m.landed()  # the canceled landing's result changes nothing
    assert not m.pause().accepted
    assert m.resume().accepted
    assert m.state == "mission.pad.land"
    assert d.calls[-1] == ("precision_land", 3, PADS[3], 0.5)
    assert m.landed() and m.score == 40


@pytest.mark.parametrize("state", RESUMABLE)
def test_resume_returns_to_the_state_paused_in(state: str) -> None:
    m, _ = make_mission()
    m.start()
    m.preflight_result(True)
    steps = {"mission.explore": [m.took_off],
             "mission.report_robot": [m.took_off, lambda: m.robot_found(19)],
             "mission.await_sequence": [m.took_off, lambda: m.robot_found(19), m.pictures_sent]}
    pad_steps = [m.took_off, lambda: m.robot_found(19), m.pictures_sent,
                 lambda: m.receive_sequence([3, 5]).accepted]
    steps |= {"mission.pad.navigate": pad_steps, "mission.pad.land": [*pad_steps, m.arrived],
              "mission.pad.search": [*pad_steps, m.arrived, lambda: m.marker_not_found("x")],
              "mission.pad.takeoff": [*pad_steps, m.arrived, m.landed]}
    for step in steps.get(state, []):
        assert step()
    assert m.state == state
    m.pause()
    m.resume()
    assert m.state == state


def test_abort_stops_from_paused_and_commands_outside_their_states_are_rejected() -> None:
    m, d = make_mission()
    assert not m.pause().accepted
    assert not m.resume().accepted
    assert not m.abort("x").accepted
    to_pad_land(m)
    m.pause()
    assert m.abort("operator saw smoke").accepted
    assert m.state == "stopped"
    assert m.stop is not None and m.stop.cause is ErrorCause.OPERATOR_ABORT
    assert "smoke" in m.stop.detail
    assert not m.start().accepted
    assert not m.abort("again").accepted
    assert ("land",) not in d.calls


def test_return_home_on_the_operators_command_lands_home_and_is_not_a_completion() -> None:
    m, d = make_mission()
    assert not m.return_home("x").accepted  # idle: nowhere to return from
    to_pad_land(m)
    assert m.return_home("wind").accepted
    assert m.state == "returning.navigate" and d.last("navigate") == ("navigate", PADS[1])
    assert not m.return_home("again").accepted
    m.arrived()
    m.landed()
    assert m.state == "landed"
    assert m.stop is not None and m.stop.cause is ErrorCause.OPERATOR_RETURN


def test_the_scanner_is_on_where_a_state_reads_markers_and_off_where_it_flies_between():
    """The states that explore or land on a pad (precision landing, its searches, the
    start pad on the way home) have the ArUco scanner on; those that take off, navigate,
    hold or land blind have it off, so the down camera renders nothing there."""
    from fsm.mission_machine import ACTIONS
    from fsm.mission_table import scans

    reads = {"_do_explore", "_do_report_robot", "_do_pad_land", "_do_pad_search",
             "_do_return_land", "_do_preflight"}
    blind = {"_do_takeoff", "_do_pad_navigate", "_do_return_navigate", "_do_land_now",
             "_do_hold", "_do_await_sequence", "_do_stopped"}
    for state, action in ACTIONS.items():
        if action in reads:
            assert scans(state), state
        elif action in blind:
            assert not scans(state), state
    assert {a for a in ACTIONS.values()} <= reads | blind | {"_do_completed", "_do_landed"}
