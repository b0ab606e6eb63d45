"""The square pilot's progress as the mission's topics, for the ground station and the bag.

The square is a mission script, not the contest's state machine (issue 12), but the
operator page and Foxglove speak the mission's topics. :class:`SquareStatusNode`
publishes ``/mission/state`` from the pilot's step (waiting and arming are ``preflight``,
the square is flown as ``mission.explore``, the landing as ``returning.land``) and the
square it flies as ``/navigation/path``, the planned path. It only reads the pilot;
the flight is unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import interfaces
from fsm.mission_table import phase_of
from interfaces import graph
from quadmission.scenarios.square.pilot import PilotPhase, SquarePilot
from runtime import Node

STATUS_PERIOD_S = 0.2  # s between /mission/state messages
#: The mission machine's state (fsm/mission_table.py) each pilot step stands for.
STATE_OF_STEP = {
    PilotPhase.WAIT_READY: "preflight", PilotPhase.ARM: "preflight",
    PilotPhase.TAKEOFF: "mission.takeoff", PilotPhase.SQUARE: "mission.explore",
    PilotPhase.LAND: "returning.land", PilotPhase.DONE: "completed",
    PilotPhase.FAILED: "stopped"}


class SquareStatusNode(Node):
    def __init__(self, pilot: SquarePilot, outline: Sequence[tuple[float, float]],
                 **kwargs: Any) -> None:
        super().__init__("square_status", **kwargs)
        self.pilot = pilot
        self._state = graph.MISSION_STATE.interface()
        self.state_pub, self.path_pub = (self.create_publisher(t.type, t.name, t.qos) for t in
                                         (graph.MISSION_STATE, graph.NAVIGATION_PATH))
        self._poses = [
            interfaces.new("geometry_msgs/msg/PoseStamped", pose=interfaces.new(
                "geometry_msgs/msg/Pose", position=interfaces.new(
                    "geometry_msgs/msg/Point", x=float(x), y=float(y), z=pilot.altitude)))
            for x, y in outline]
        self._previous = self._phase()
        self._current = self._previous
        self.create_timer(STATUS_PERIOD_S, self._tick)

    def _phase(self) -> int:
        return phase_of(STATE_OF_STEP[self.pilot.phase]).value

    def _tick(self) -> None:
        phase = self._phase()
        if phase != self._current:
            self._previous, self._current = self._current, phase
        sub = self.pilot.phase.value
        if self.pilot.phase is PilotPhase.SQUARE:
            sub += f" (corner {self.pilot.corner_index + 1}/{len(self.pilot.corners)})"
        stamp = self.now().nanoseconds
        state = STATE_OF_STEP[self.pilot.phase]
        msg = interfaces.new(self._state, phase=phase, previous_phase=self._previous,
                             state=state, sub_state=sub)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10**9)
        self.state_pub.publish(msg)
        # a new Path each time: in one process subscribers keep the object published
        # (the poses never change, so they are shared)
        path = interfaces.new("nav_msgs/msg/Path", poses=self._poses)
        path.header.frame_id = "map"
        path.header.stamp.sec, path.header.stamp.nanosec = divmod(stamp, 10**9)
        self.path_pub.publish(path)


__all__ = ["STATE_OF_STEP", "SquareStatusNode"]
