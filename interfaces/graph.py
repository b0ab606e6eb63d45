"""The companion graph contract: every topic, service and action, written once.

Each name has its type, its QoS and the nodes at its ends (who publishes and subscribes,
serves and calls), so the graph can be listed (``quadmission interfaces --graph``,
``docs/graph.md``) and no other module writes a graph name or chooses a QoS again. The
simulator's sensor topics, which stand where a real vehicle's drivers would, are here too.
The /fmu side of the link is :mod:`interfaces.px4.topics`.

A topic holds its publishers' QoS and its subscribers' separately (as the PX4 contract
does); where one end of a topic differs from the others it says so in ``note``. A
monitor (the ground station's page) reads any topic with :data:`MONITOR_QOS`, which
matches every writer. An action's internal topics and services are named after it, as
ROS 2 does (:meth:`Action.internal`). Each entry's ``interface()`` is its type's class
(a message class, a :class:`~interfaces.api.ServiceType`, an
:class:`~interfaces.api.ActionType`). Each module's health is ``/<module>/health``
(:data:`HEALTH`), and the mission watches all of them. A topic made once per instance of
something (a launch's lockstep report, one per node process) is a :class:`TopicPattern`:
its name and its ends' node names hold a ``{field}`` that :meth:`TopicPattern.name_for`
fills.

Nodes are named by their node names (``fcu_bridge``, ``navigator``...); names ending in
``_pilot`` or ``_status`` are the scenarios' mission scripts.
"""

from __future__ import annotations

import builtins
import string
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal

from interfaces.api import ActionType, ServiceType, get_action, get_message, get_service
from interfaces.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_default,
    qos_profile_latched,
    qos_profile_sensor_data,
)

__all__ = [
    "ACTIONS",
    "ACTION_SERVICES",
    "ACTION_TOPICS",
    "ARM",
    "CAMERA_DEPTH_POINTS",
    "CAMERA_DOWN_INFO",
    "CAMERA_DOWN_RAW",
    "CLOCK",
    "CLOCK_QOS",
    "CLOCK_WRITER_QOS",
    "DISARM",
    "ENTRIES",
    "EVENTS_QOS",
    "EXPLORE",
    "FCU_BATTERY",
    "FCU_COMMAND",
    "FCU_COMMAND_ACK",
    "FCU_IMU",
    "FCU_ODOMETRY",
    "FCU_SETPOINT",
    "FCU_STATUS",
    "FCU_TIMESYNC_STATUS",
    "FCU_VISION",
    "FLIGHT_CONTROL_ACTIONS",
    "HEALTH",
    "LAND",
    "LAUNCH_CLOCK_REPORT",
    "MAP_POINTS",
    "MISSION_COMMAND",
    "MISSION_EVENTS",
    "MISSION_ROBOT",
    "MISSION_STATE",
    "MONITOR_QOS",
    "NAVIGATE",
    "NAVIGATION_PATH",
    "NAVIGATION_TAKEOFF",
    "PERCEPTION_MARKERS",
    "PERCEPTION_ROBOT_FOUND",
    "PLAN_PATH",
    "POSE_AT",
    "PRECISION_LAND",
    "REACH",
    "SCANNER_ANNOTATED",
    "SCANNER_ENABLE",
    "SEQUENCE_PROPOSAL",
    "SERVICES",
    "SIM_VISION_POSE",
    "TAKEOFF",
    "TOPICS",
    "TURN",
    "Action",
    "Entry",
    "Row",
    "Service",
    "Topic",
    "TopicPattern",
    "describe_qos",
    "health",
    "markdown",
    "nodes",
    "rows",
    "text",
]

QM = "quadmission_interfaces"

#: A monitor's reader (the ground station's page): best effort, volatile, keep last 10,
#: which matches reliable and best-effort, latched and volatile writers alike.
MONITOR_QOS = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
#: The mission's events: every one counts, so a deeper queue than the default.
EVENTS_QOS = QoSProfile(depth=100)
#: /clock as rclcpp's TimeSource reads it: best effort, keep last 1.
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
#: /clock as the simulator writes it: reliable, keep last 1 (a launch's lockstep must not
#: lose a step; a reliable writer matches the best-effort readers).
CLOCK_WRITER_QOS = QoSProfile(depth=1)


@dataclass(frozen=True)
class Topic:
    """One topic: its name, its type, the QoS its publishers offer and its subscribers
    request, and the nodes at each end (``monitors`` read it with :data:`MONITOR_QOS`)."""

    name: str
    type: str
    qos: QoSProfile
    subscriber_qos: QoSProfile
    publishers: tuple[str, ...]
    subscribers: tuple[str, ...] = ()
    monitors: tuple[str, ...] = ()
    note: str = ""
    kind: Literal["topic"] = field(default="topic", init=False)

    def __post_init__(self) -> None:
        _check_name(self.name)
        reason = self.subscriber_qos.incompatibility(self.qos)
        if reason is not None:
            raise ValueError(f"topic {self.name}: its subscribers cannot match its "
                             f"publishers: {reason}")

    def interface(self) -> builtins.type:  # the field ``type`` shadows the builtin here
        """The message class of :attr:`type`."""
        return get_message(self.type)


@dataclass(frozen=True)
class TopicPattern(Topic):
    """Topics made once per instance of something: ``name`` (and node names at its ends)
    hold one ``{field}``, e.g. ``/launch/{process}/clock``; :meth:`name_for` gives one
    instance's name."""

    def __post_init__(self) -> None:
        super().__post_init__()
        fields = {f for _, f, _, _ in string.Formatter().parse(self.name) if f}
        if len(fields) != 1:
            raise ValueError(f"topic pattern {self.name}: expected one {{field}}, "
                             f"found {sorted(fields)}")

    @property
    def field(self) -> str:
        """The name of the pattern's one field (``process``)."""
        return next(f for _, f, _, _ in string.Formatter().parse(self.name) if f)

    def name_for(self, value: str) -> str:
        """The topic of one instance: ``name_for("companion")`` is
        ``/launch/companion/clock``."""
        return self.name.format_map({self.field: value})


@dataclass(frozen=True)
class Service:
    """One service: its name, its type, the node that serves it and those that call it
    (services use ROS 2's services QoS)."""

    name: str
    type: str
    servers: tuple[str, ...]
    clients: tuple[str, ...] = ()
    note: str = ""
    kind: Literal["service"] = field(default="service", init=False)

    def __post_init__(self) -> None:
        _check_name(self.name)

    def interface(self) -> ServiceType:
        """The service type of :attr:`type` (its request and response classes)."""
        return get_service(self.type)


#: An action's parts on the wire, as ROS 2 names them (``<action>/_action/<part>``).
ACTION_TOPICS = ("feedback", "status")
ACTION_SERVICES = ("send_goal", "cancel_goal", "get_result")


@dataclass(frozen=True)
class Action:
    """One action: its name, its type, the node that serves it and those that send goals."""

    name: str
    type: str
    servers: tuple[str, ...]
    clients: tuple[str, ...] = ()
    note: str = ""
    kind: Literal["action"] = field(default="action", init=False)

    def __post_init__(self) -> None:
        _check_name(self.name)

    def interface(self) -> ActionType:
        """The action type of :attr:`type` (goal, result, feedback and the composed types)."""
        return get_action(self.type)

    def internal(self, part: str) -> str:
        """The name of one of the action's topics or services (``feedback``, ``status``,
        ``send_goal``, ``cancel_goal``, ``get_result``)."""
        if part not in ACTION_TOPICS + ACTION_SERVICES:
            raise ValueError(f"action {self.name}: no part {part!r}; the parts are "
                             f"{', '.join(ACTION_TOPICS + ACTION_SERVICES)}")
        return f"{self.name}/_action/{part}"

    @property
    def feedback_topic(self) -> str:
        return self.internal("feedback")

    @property
    def feedback_type(self) -> str:
        """The type of the feedback topic's messages (goal id + feedback)."""
        return f"{self.type}_FeedbackMessage"


Entry = Topic | Service | Action


def _check_name(name: str) -> None:
    tokens = name.split("/")
    if not name.startswith("/") or any(not t for t in tokens[1:]):
        raise ValueError(f"graph name {name!r}: names in the contract are absolute "
                         "('/a/b'), with no empty token")


_SENSOR = qos_profile_sensor_data
_DEFAULT = qos_profile_default
_LATCHED = qos_profile_latched


def _topic(name: str, type_name: str, qos: QoSProfile, publishers: tuple[str, ...],
           subscribers: tuple[str, ...] = (), monitors: tuple[str, ...] = (),
           subscriber_qos: QoSProfile | None = None, note: str = "") -> Topic:
    return Topic(name, type_name, qos, qos if subscriber_qos is None else subscriber_qos,
                 publishers, subscribers, monitors, note)


_GCS = ("ground_station",)

# -- the simulator's sensors (a real vehicle's drivers and VIO stand here) -------------------
CLOCK = _topic("/clock", "rosgraph_msgs/msg/Clock", CLOCK_WRITER_QOS,
               ("sim_sensors", "simulator_clock"), subscriber_qos=CLOCK_QOS,
               note="read by every process's time source under use_sim_time "
                    "(runtime.processes.executor); simulator_clock is a process launch's "
                    "lockstep (runtime.processes.child)")
CAMERA_DOWN_RAW = _topic("/camera/down/image_raw", "sensor_msgs/msg/Image", _SENSOR,
                         ("sim_sensors",), ("aruco_scanner", "frame_grabber"), _GCS,
                         note="rendered only while it has subscribers")
CAMERA_DOWN_INFO = _topic("/camera/down/camera_info", "sensor_msgs/msg/CameraInfo", _SENSOR,
                          ("sim_sensors",), ("aruco_scanner",))
CAMERA_DEPTH_POINTS = _topic("/camera/depth/points", "sensor_msgs/msg/PointCloud2", _SENSOR,
                             ("sim_sensors",), ("mapping",))
SIM_VISION_POSE = _topic("/sim/vision/pose", "geometry_msgs/msg/PoseWithCovarianceStamped",
                         _SENSOR, ("sim_vision",),
                         ("vio", "latency_test", "offboard_harness"),
                         note="the visual odometry, map frame, sample time in the stamp")

# -- a launch over processes ----------------------------------------------------------------
LAUNCH_CLOCK_REPORT = TopicPattern(
    "/launch/{process}/clock", CLOCK.type, CLOCK_WRITER_QOS, CLOCK_WRITER_QOS,
    ("launch_{process}_clock",), ("simulator_clock",),
    note="the lockstep: each node process reports the simulated time it has reached; the "
         "simulator never runs more than max_lead_s ahead of the slowest "
         "(runtime.processes.child)")

# -- the bridge: the FCU on the companion's frames and clock ---------------------------------
FCU_ODOMETRY = _topic("/fcu/odometry", "nav_msgs/msg/Odometry", _SENSOR, ("fcu_bridge",),
                      ("flight_control", "aruco_scanner", "precision_land", "navigator",
                       "mission", "navigate_pilot", "square_pilot"), _GCS)
FCU_IMU = _topic("/fcu/imu", "sensor_msgs/msg/Imu", _SENSOR, ("fcu_bridge",),
                 note="built only while it has subscribers")
FCU_BATTERY = _topic("/fcu/battery", "sensor_msgs/msg/BatteryState", _DEFAULT, ("fcu_bridge",))
FCU_STATUS = _topic("/fcu/status", f"{QM}/msg/FcuStatus", _DEFAULT, ("fcu_bridge",),
                    ("flight_control", "mapping", "mission", "operator"), _GCS)
FCU_COMMAND_ACK = _topic("/fcu/command_ack", f"{QM}/msg/FcuCommandAck", _DEFAULT,
                         ("fcu_bridge",), ("flight_control",))
FCU_TIMESYNC_STATUS = _topic("/fcu/timesync_status", f"{QM}/msg/TimesyncDiagnostics",
                             _DEFAULT, ("fcu_bridge",), (), _GCS)
FCU_SETPOINT = _topic("/fcu/setpoint", f"{QM}/msg/FcuSetpoint", _SENSOR, ("flight_control",),
                      ("fcu_bridge", "setpoint_recorder"),
                      note="the offboard heartbeat: each one becomes OffboardControlMode + "
                           "TrajectorySetpoint")
FCU_COMMAND = _topic("/fcu/command", f"{QM}/msg/FcuCommand", _DEFAULT, ("flight_control",),
                     ("fcu_bridge",))
FCU_VISION = _topic("/fcu/vision", "geometry_msgs/msg/PoseWithCovarianceStamped", _SENSOR,
                    ("vio",), ("fcu_bridge",))
POSE_AT = Service("/fcu/pose_at", f"{QM}/srv/PoseAt", ("fcu_bridge",),
                  ("mapping", "aruco_scanner", "precision_land"),
                  note="the pose at a past companion time")

# -- flight control ---------------------------------------------------------------------------
ARM = Service("/flight_control/arm", f"{QM}/srv/Arm", ("flight_control",),
              ("mission", "square_pilot", "landing_pilot", "navigate_pilot"))
DISARM = Service("/flight_control/disarm", f"{QM}/srv/Disarm", ("flight_control",))
TAKEOFF = Action("/flight_control/takeoff", f"{QM}/action/Takeoff", ("flight_control",),
                 ("navigator", "mission", "square_pilot", "landing_pilot"))
LAND = Action("/flight_control/land", f"{QM}/action/Land", ("flight_control",),
              ("precision_land", "mission", "square_pilot", "navigate_pilot"))
REACH = Action("/flight_control/reach", f"{QM}/action/Reach", ("flight_control",),
               ("navigator", "precision_land", "mission", "square_pilot"))
TURN = Action("/flight_control/turn", f"{QM}/action/Turn", ("flight_control",),
              ("navigator",))
#: The flight-control layer's motion actions by short name (the node serves each).
FLIGHT_CONTROL_ACTIONS: Mapping[str, Action] = MappingProxyType({
    "takeoff": TAKEOFF, "land": LAND, "reach": REACH, "turn": TURN})

# -- perception -------------------------------------------------------------------------------
PERCEPTION_MARKERS = _topic("/perception/markers", f"{QM}/msg/MarkerDetectionArray", _DEFAULT,
                            ("aruco_scanner",), ("navigator", "precision_land"),
                            note="stamped with the image's capture time; empty when none")
PERCEPTION_ROBOT_FOUND = _topic("/perception/robot_found", f"{QM}/msg/RobotFound", _DEFAULT,
                                ("aruco_scanner",), ("mission",), _GCS,
                                note="with JPEG pictures")
SCANNER_ANNOTATED = _topic("/aruco_scanner/annotated", "sensor_msgs/msg/Image", _SENSOR,
                           ("aruco_scanner",), note="for people; built only when read")
SCANNER_ENABLE = Service("/aruco_scanner/enable", "std_srvs/srv/SetBool", ("aruco_scanner",),
                         ("mission", "precision_land"),
                         note="scanning on or off (off, it also leaves the image topic)")

# -- navigation -------------------------------------------------------------------------------
MAP_POINTS = _topic("/map/points", "sensor_msgs/msg/PointCloud2", _DEFAULT, ("mapping",),
                    ("path_finder",), _GCS)
PLAN_PATH = Service("/navigation/plan_path", f"{QM}/srv/PlanPath", ("path_finder",),
                    ("navigator", "precision_land", "operator", "navigate_pilot"))
NAVIGATE = Action("/navigation/navigate", f"{QM}/action/Navigate", ("navigator",),
                  ("mission", "navigate_pilot"),
                  note="the ground station reads its feedback topic (the planned path)")
EXPLORE = Action("/navigation/explore", f"{QM}/action/Explore", ("navigator",), ("mission",))
NAVIGATION_TAKEOFF = Action("/navigation/takeoff", f"{QM}/action/Takeoff", ("navigator",),
                            ("mission", "navigate_pilot"),
                            note="climb, then survey turns so the depth camera maps around")
PRECISION_LAND = Action("/navigation/precision_land", f"{QM}/action/PrecisionLand",
                        ("precision_land",), ("mission", "landing_pilot"))
NAVIGATION_PATH = _topic("/navigation/path", "nav_msgs/msg/Path", _DEFAULT, ("square_status",),
                         (), _GCS, note="the square scenario's outline, as a planned path")

# -- the mission and the operator -------------------------------------------------------------
MISSION_STATE = _topic("/mission/state", f"{QM}/msg/MissionState", _LATCHED,
                       ("mission", "square_status"), ("operator",), _GCS,
                       note="on every change and at state_rate_hz; latched for late joiners")
MISSION_EVENTS = _topic("/mission/events", f"{QM}/msg/MissionEvent", EVENTS_QOS, ("mission",),
                        (), _GCS, note="answers to commands, alerts, what happened")
MISSION_COMMAND = _topic("/mission/command", f"{QM}/msg/MissionCommand", _DEFAULT,
                         ("operator", "ground_station", "scripted_operator"), ("mission",))
MISSION_ROBOT = _topic("/mission/robot", f"{QM}/msg/RobotFound", _LATCHED, ("mission",),
                       ("operator",), note="the target robot's pictures, for the operator")
SEQUENCE_PROPOSAL = _topic("/mission/sequence_proposal", f"{QM}/msg/LandingSequence", _LATCHED,
                           ("operator",), (), _GCS,
                           note="the operator's best sequence, before it sends it")

# -- health -----------------------------------------------------------------------------------
_HEALTH_OF = ("flight_control", "aruco_scanner", "mapping", "path_finder", "navigator",
              "precision_land")


def health(module: str) -> str:
    """The HealthReport topic of ``module`` (its node name)."""
    return f"/{module}/health"


def _health_topic(module: str) -> Topic:
    readers = ("mission",) + (("square_pilot", "landing_pilot", "navigate_pilot")
                              if module == "flight_control" else ())
    return _topic(health(module), f"{QM}/msg/HealthReport", _DEFAULT, (module,), readers,
                  _GCS if module == "flight_control" else ())


#: Each module's HealthReport topic, by module (node) name; the mission watches them all.
HEALTH: Mapping[str, Topic] = MappingProxyType({m: _health_topic(m) for m in _HEALTH_OF})


def _by_name(entries: tuple[Entry, ...]) -> Mapping[str, Entry]:
    out: dict[str, Entry] = {}
    for entry in entries:
        if entry.name in out:
            raise ValueError(f"{entry.name} is in the contract twice")
        out[entry.name] = entry
    return MappingProxyType(out)


TOPICS: tuple[Topic, ...] = (
    CLOCK, LAUNCH_CLOCK_REPORT, CAMERA_DOWN_RAW, CAMERA_DOWN_INFO, CAMERA_DEPTH_POINTS,
    SIM_VISION_POSE, FCU_ODOMETRY, FCU_IMU, FCU_BATTERY, FCU_STATUS, FCU_COMMAND_ACK,
    FCU_TIMESYNC_STATUS, FCU_SETPOINT, FCU_COMMAND, FCU_VISION, PERCEPTION_MARKERS,
    PERCEPTION_ROBOT_FOUND, SCANNER_ANNOTATED, MAP_POINTS, NAVIGATION_PATH, MISSION_STATE,
    MISSION_EVENTS, MISSION_COMMAND, MISSION_ROBOT, SEQUENCE_PROPOSAL, *HEALTH.values())
SERVICES: tuple[Service, ...] = (POSE_AT, ARM, DISARM, SCANNER_ENABLE, PLAN_PATH)
ACTIONS: tuple[Action, ...] = (TAKEOFF, LAND, REACH, TURN, NAVIGATE, EXPLORE,
                               NAVIGATION_TAKEOFF, PRECISION_LAND)
#: Every entry by name, topics then services then actions.
ENTRIES: Mapping[str, Entry] = _by_name((*TOPICS, *SERVICES, *ACTIONS))


def nodes() -> tuple[str, ...]:
    """Every node the contract names, sorted."""
    return tuple(sorted({n for e in ENTRIES.values() for n in _ends(e)}))


def _ends(entry: Entry) -> Iterator[str]:
    if isinstance(entry, Topic):
        yield from (*entry.publishers, *entry.subscribers, *entry.monitors)
    else:
        yield from (*entry.servers, *entry.clients)


def describe_qos(qos: QoSProfile) -> str:
    """``reliable, volatile, keep last 10``: a profile in words."""
    history = (f"keep last {qos.depth}" if qos.history is HistoryPolicy.KEEP_LAST
               else "keep all")
    reliability = "reliable" if qos.reliability is ReliabilityPolicy.RELIABLE else "best effort"
    durability = ("transient local" if qos.durability is DurabilityPolicy.TRANSIENT_LOCAL
                  else "volatile")
    return f"{reliability}, {durability}, {history}"


# -- the listing ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Row:
    """One entry of the listing, in words."""

    name: str
    kind: str
    type: str
    qos: str  # topics: the publishers' (then the subscribers' when they differ)
    writers: str  # publishers or servers
    readers: str  # subscribers (and monitors) or clients
    note: str


def rows() -> tuple[Row, ...]:
    """Every entry, by name, in words: what ``quadmission interfaces --graph`` prints."""
    out = []
    for entry in sorted(ENTRIES.values(), key=lambda e: e.name):
        if isinstance(entry, Topic):
            qos = describe_qos(entry.qos)
            if entry.subscriber_qos != entry.qos:
                qos += f"; subscribers: {describe_qos(entry.subscriber_qos)}"
            readers = [*entry.subscribers, *(f"{m} (monitor)" for m in entry.monitors)]
            out.append(Row(entry.name, entry.kind, entry.type, qos,
                           ", ".join(entry.publishers), ", ".join(readers), entry.note))
        else:
            qos = "services default" if isinstance(entry, Service) else "actions default"
            out.append(Row(entry.name, entry.kind, entry.type, qos, ", ".join(entry.servers),
                           ", ".join(entry.clients), entry.note))
    return tuple(out)


def text() -> str:
    """The listing as a plain-text table (one entry per block)."""
    lines = []
    for r in rows():
        ends = ("publishers", "subscribers") if r.kind == "topic" else ("servers", "clients")
        lines += [f"{r.name}  [{r.kind}]  {r.type}", f"  qos: {r.qos}",
                  f"  {ends[0]}: {r.writers or '-'}", f"  {ends[1]}: {r.readers or '-'}"]
        lines += [f"  note: {r.note}"] if r.note else []
    return "\n".join(lines) + "\n"


def markdown() -> str:
    """``docs/graph.md``: the listing as a page (generated; see tests/interfaces)."""
    head = [
        "# The companion graph",
        "",
        "Generated from the graph contract, `interfaces/graph.py` (`interfaces.graph.markdown()`;",
        "`quadmission interfaces --graph` prints the same): do not edit by hand. Every topic,",
        "service and action of the companion, with the simulator's sensor topics, its type,",
        "its QoS and the nodes at each end. The /fmu side of the link is",
        "`interfaces/px4/topics.py`. A monitor (the ground station) reads with",
        f"{describe_qos(MONITOR_QOS)}, which matches every writer. An action `A` is also its",
        "topics `A/_action/feedback`, `A/_action/status` and services `A/_action/send_goal`,",
        "`.../cancel_goal`, `.../get_result`.",
        "",
        "| name | kind | type | QoS | publishers / servers | subscribers / clients | note |",
        "|---|---|---|---|---|---|---|",
    ]
    body = [f"| `{r.name}` | {r.kind} | `{r.type}` | {r.qos} | {r.writers} | {r.readers} "
            f"| {r.note} |" for r in rows()]
    return "\n".join(head + body) + "\n"
