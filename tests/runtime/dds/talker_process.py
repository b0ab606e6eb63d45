"""Our side of the foreign-client test: ``python -m tests.runtime.dds.talker_process DOMAIN``.

A node on the DDS transport (wall clock) that publishes ``std_msgs/String`` "hello N" on
``/foreign/chatter`` at 20 Hz and answers ``/foreign/arm`` (quadmission_interfaces/Arm:
success = force, message names the timeout), until SIGINT/SIGTERM.
"""

from __future__ import annotations

import signal
import sys
from typing import Any

import interfaces
from interfaces.qos import qos_profile_default
from runtime import Node
from runtime.dds.config import DdsConfig
from runtime.dds.transport import DdsTransport
from runtime.processes.executor import ClockedExecutor


class Talker(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("foreign_talker", **kwargs)
        self.count = 0
        self.pub = self.create_publisher("std_msgs/msg/String", "/foreign/chatter",
                                         qos_profile_default)
        self.create_timer(0.05, self.tick)
        self.create_service("quadmission_interfaces/srv/Arm", "/foreign/arm", self.answer)

    def tick(self) -> None:
        self.pub.publish(interfaces.new("std_msgs/msg/String", data=f"hello {self.count}"))
        self.count += 1

    def answer(self, request: Any, response: Any) -> Any:
        response.success = bool(request.force)
        response.message = f"armed with timeout {request.timeout:g}"
        return response


def main() -> int:
    ex = ClockedExecutor(DdsTransport(DdsConfig(int(sys.argv[1]))), use_sim_time=False,
                         config_dir=None)
    Talker(context=ex.context)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: ex.stop())
    print("ready", flush=True)
    ex.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
