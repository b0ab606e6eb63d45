"""Software in the loop: the arena, the flight controller and its link, ready to fly.

:func:`build_sitl` assembles the parts every FCU scenario needs: the scene, the
executor, the FCU agent node behind the serial link, the firmware, the IMU, the motors,
the simulated visual odometry, the moving robots. Scenarios add their companion nodes
and call :meth:`Sitl.run`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from runtime import DeterministicExecutor
from runtime.parameters import load_parameters
from sim.arena import ArenaSpec, default_arena
from sim.fcu.agent import FcuAgentNode
from sim.fcu.firmware import Firmware, FirmwareConfig
from sim.fcu.link import LINK_NODE_NAME, Link, LinkParams
from sim.quadrotor import MotorModel
from sim.vision import VisionNode, VisionNoise, VisionPose
from sim.world import (
    Actuation,
    Imu,
    Part,
    RobotMotion,
    Scene,
    Stop,
    WorldResult,
    run_world,
)


@dataclass
class Sitl:
    """Everything of one simulated flight, wired together."""

    scene: Scene
    executor: DeterministicExecutor
    link: Link
    agent: FcuAgentNode
    firmware: Firmware
    imu: Imu
    vision: VisionPose
    actuation: Actuation
    robots: RobotMotion = field(default_factory=RobotMotion)
    extra_parts: list[Part] = field(default_factory=list)
    first_parts: list[Part] = field(default_factory=list)
    """Parts that run before all others at a tick (fault switches: a fault due at ``t``
    acts on what the other parts do at ``t``)."""

    @property
    def parts(self) -> list[Part]:
        """In order: the first parts, IMU, firmware, motors, vision, robots, then
        scenario extras."""
        return [*self.first_parts, self.imu, self.firmware, self.actuation, self.vision,
                self.robots, *self.extra_parts]

    def run(self, duration_s: float, stop: Stop | None = None) -> WorldResult:
        return run_world(self.scene, self.executor, duration_s=duration_s, parts=self.parts,
                         stop=stop)


def build_sitl(
    arena: ArenaSpec | None = None,
    *,
    seed: int = 0,
    link: LinkParams | None = None,
    firmware: FirmwareConfig | None = None,
    vision_noise: VisionNoise | None = None,
    executor: DeterministicExecutor | None = None,
    physics_hz: int | None = None,
    session_topics: bool = True,
) -> Sitl:
    """A quadrotor on the start pad, FCU booted, vision running; nothing armed yet.
    ``physics_hz`` defaults to ``config/sim_world.yaml``'s; ``session_topics``: the
    agent's modelled XRCE time-sync exchange on the graph (:class:`FcuAgentNode`)."""
    scene = Scene.build(arena or default_arena(), physics_hz=physics_hz)
    scene.place_at_takeoff()
    ex = executor or DeterministicExecutor()
    link_params = link or load_parameters(LinkParams, LINK_NODE_NAME)
    firmware = (firmware or FirmwareConfig()).resolved()
    assert firmware.firmware is not None
    the_link = Link(link_params.__class__(link_params.to_fcu, link_params.to_companion,
                                          seed + link_params.seed, link_params.clock))
    agent = FcuAgentNode(the_link, session_topics=session_topics, context=ex.context)
    imu = Imu.seeded(seed + 1, rate_hz=firmware.firmware.imu_rate_hz)
    fw = Firmware(agent, imu, the_link.clock, firmware)
    vision_node = VisionNode(context=ex.context)
    vision = VisionPose.from_node(vision_node, seed=seed + 2, noise=vision_noise)
    actuation = Actuation(fw, MotorModel(scene.quad), rate_hz=fw.rate_hz)
    for node in (agent, vision_node):
        ex.add_node(node)
    return Sitl(scene, ex, the_link, agent, fw, imu, vision, actuation)


def schedule_report(sitl: Sitl) -> dict[str, Any]:
    """The resolved firmware and what it achieved: module order, per function frequency,
    prescaler, offset and achieved rate; per task group duty (host us) and rate."""
    from sim.fcu.scheduler import call_pattern

    schedule = sitl.firmware.schedule
    report = sitl.firmware.scheduler.report()
    pattern = call_pattern(schedule)
    return {
        "main_freq_hz": schedule.main_freq_hz,
        "offsets": schedule.strategy,
        "module_order": list(schedule.module_order),
        "functions_per_tick": {"peak": pattern.peak, "mean": round(pattern.mean, 3)},
        "periodics": [
            {
                "module": p.module,
                "group": p.group.name.lower(),
                "function": p.fun,
                "freq_hz": schedule.main_freq_hz / p.prescaler,
                "prescaler": p.prescaler,
                "offset": p.offset,
                "achieved_hz": round(report.function_freq[p.fun].freq_hz, 3),
            }
            for p in schedule.periodics
        ],
        "groups": [
            {
                "group": group.name.lower(),
                "duty_avg_us": round(duty.avg_us, 1),
                "duty_min_us": round(duty.min_us, 1),
                "duty_max_us": round(duty.max_us, 1),
                "freq_hz": round(report.group_freq[group].freq_hz, 3),
            }
            for group, duty in report.group_duty.items()
        ],
        "tick_duty_avg_us": round(report.tick_duty.avg_us, 1),
        "tick_duty_max_us": round(report.tick_duty.max_us, 1),
        "ticks": report.ticks,
        "overruns": report.overruns,
    }
