"""Node runtime in rclpy's shape: a deterministic in-process executor, or ROS 2 (runtime.ros2)."""

from interfaces.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_action_status_default,
    qos_profile_default,
    qos_profile_latched,
    qos_profile_px4_in,
    qos_profile_px4_out,
    qos_profile_px4_subscriber,
    qos_profile_sensor_data,
    qos_profile_services_default,
)
from runtime.action import (
    ActionClient,
    ActionServer,
    CancelResponse,
    ClientGoalHandle,
    GoalResponse,
    GoalStatus,
    Rejection,
    ServerGoalHandle,
)
from runtime.client import Client
from runtime.clock import Clock, ClockType, Duration, SimClock, Time, WallClock
from runtime.context import Context
from runtime.errors import (
    ClockError,
    FutureError,
    GoalCanceled,
    InvalidNameError,
    LaunchError,
    ParameterError,
    RuntimeApiError,
    TopicTypeError,
)
from runtime.executor import DeterministicExecutor, TraceEntry
from runtime.future import Future, Task
from runtime.launch import LaunchDescription, NodeSpec, launch
from runtime.node import Node
from runtime.parameters import Parameter, ParameterDescriptor, ParameterType, param
from runtime.publisher import Publisher
from runtime.service import Service
from runtime.subscription import Subscription
from runtime.timer import Timer
from runtime.transport import Endpoint, EndpointKind, InProcessTransport, RequestId, Transport

__all__ = [
    "ActionClient",
    "ActionServer",
    "CancelResponse",
    "Client",
    "ClientGoalHandle",
    "Clock",
    "ClockError",
    "ClockType",
    "Context",
    "DeterministicExecutor",
    "DurabilityPolicy",
    "Duration",
    "Endpoint",
    "EndpointKind",
    "Future",
    "FutureError",
    "GoalCanceled",
    "GoalResponse",
    "GoalStatus",
    "HistoryPolicy",
    "InProcessTransport",
    "InvalidNameError",
    "LaunchDescription",
    "LaunchError",
    "Node",
    "NodeSpec",
    "Parameter",
    "ParameterDescriptor",
    "ParameterError",
    "ParameterType",
    "Publisher",
    "QoSProfile",
    "Rejection",
    "ReliabilityPolicy",
    "RequestId",
    "RuntimeApiError",
    "ServerGoalHandle",
    "Service",
    "SimClock",
    "Subscription",
    "Task",
    "Time",
    "Timer",
    "TopicTypeError",
    "TraceEntry",
    "Transport",
    "WallClock",
    "launch",
    "param",
    "qos_profile_action_status_default",
    "qos_profile_default",
    "qos_profile_latched",
    "qos_profile_px4_in",
    "qos_profile_px4_out",
    "qos_profile_px4_subscriber",
    "qos_profile_sensor_data",
    "qos_profile_services_default",
]
