"""The camera side of the image test, in a process of its own (Fast DDS delivers within
one process without its transports): ``python -m tests.runtime.processes.image_publisher
DOMAIN COUNT`` waits for a subscriber on ``/tt/image_raw``, publishes COUNT 640x480
images back to back once both sides have matched (``header.stamp.sec`` numbers them),
lingers 3 s and exits."""

from __future__ import annotations

import sys
import time

import numpy as np

import interfaces
from interfaces.qos import QoSProfile, ReliabilityPolicy
from runtime import Node
from runtime.processes.executor import ClockedExecutor
from tests.runtime.processes.conftest import make_transport

SENSOR_QOS = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def main(domain: int, count: int) -> int:
    ex = ClockedExecutor(make_transport("ros2", domain, "camera_process"), use_sim_time=False,
                         config_dir=None)
    camera = Node("camera", context=ex.context)
    pub = camera.create_publisher("sensor_msgs/msg/Image", "/tt/image_raw", SENSOR_QOS)
    deadline = time.monotonic() + 30.0
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        ex.spin_once_realtime()
    settle = time.monotonic() + 1.0  # the reader matches us too (discovery is two-way)
    while time.monotonic() < settle:
        ex.spin_once_realtime()
    for i in range(count):
        image = interfaces.new("sensor_msgs/msg/Image", height=480, width=640,
                               encoding="rgb8", step=1920, data=np.zeros(921_600, np.uint8))
        image.header.stamp.sec = i
        pub.publish(image)
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        ex.spin_once_realtime()
    ex.process_transport.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]), int(sys.argv[2])))
