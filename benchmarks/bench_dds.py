"""One-way latency over Cyclone DDS between two processes: our transport vs bare cyclonedds.

    python benchmarks/bench_dds.py --out benchmarks/results/dds.json [--duration 10]

The seed's stream (seed 000: 115-byte messages at 200 Hz) as a ping-pong between two
processes on a loopback-only domain: the pinger sends at 200 Hz, the echoer sends each
message straight back, the pinger takes half the round trip as the one-way latency
(p50, p99, max [us]) and counts what came back (throughput [msg/s]).

- **ours**: two node processes (:class:`~runtime.processes.executor.ClockedExecutor` on the
  wall clock, :class:`~runtime.dds.transport.DdsTransport`): a timer publishes, a
  subscription callback receives the deserialised message and publishes the echo; node
  code as any node writes it (rosbags CDR in, rosbags CDR out).
- **bare**: the same wire type with the plain ``cyclonedds`` API (DataWriter.write of an
  IdlStruct, WaitSet + take), no runtime: the baseline, measured in the same run;
  ``overhead_ratio`` = ours / bare at p50 and p99.
- **in-process** for scale: the in-process transport and the deterministic executor, one
  process, publish to callback.

The message is ``std_msgs/UInt8MultiArray`` with 99 data bytes: 115 bytes of CDR. The send
time (CLOCK_MONOTONIC, the same in every process) travels in its first 8 data bytes.
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import interfaces  # noqa: E402
from interfaces.qos import QoSProfile  # noqa: E402

TYPE = "std_msgs/msg/UInt8MultiArray"
DATA_BYTES = 99  # 4 header + 8 layout + 4 length + 99 = 115 bytes of CDR
RATE_HZ = 200.0
QOS = QoSProfile(depth=10)  # reliable, volatile, keep last 10
PING, PONG = "/bench/ping", "/bench/pong"


def _message(stamp_ns: int) -> Any:
    data = np.zeros(DATA_BYTES, dtype=np.uint8)
    data[:8] = np.frombuffer(struct.pack("<Q", stamp_ns), dtype=np.uint8)
    return interfaces.new(TYPE, data=data)


def _stamp(data: Any) -> int:
    return int(struct.unpack("<Q", bytes(np.asarray(data[:8], dtype=np.uint8)))[0])


def _stats(latencies_ns: list[int], sent: int, duration_s: float) -> dict[str, Any]:
    us = np.asarray(latencies_ns, dtype=np.float64) / 1e3
    return {"samples": len(us), "sent": sent,
            "throughput_msg_s": round(len(us) / duration_s, 1),
            "p50_us": round(float(np.percentile(us, 50)), 1),
            "p99_us": round(float(np.percentile(us, 99)), 1),
            "max_us": round(float(us.max()), 1)}


# -- ours -----------------------------------------------------------------------------------
def ours_echo(domain: int) -> None:
    from runtime import Node
    from runtime.dds.config import DdsConfig
    from runtime.dds.transport import DdsTransport
    from runtime.processes.executor import ClockedExecutor

    ex = ClockedExecutor(DdsTransport(DdsConfig(domain)), use_sim_time=False, config_dir=None)
    node = Node("bench_echo", context=ex.context)
    pub = node.create_publisher(TYPE, PONG, QOS)
    node.create_subscription(TYPE, PING, pub.publish, QOS)
    print("ready", flush=True)
    ex.spin(until=lambda: sys.stdin.closed)


def ours_ping(domain: int, duration_s: float) -> dict[str, Any]:
    from runtime import Node
    from runtime.dds.config import DdsConfig
    from runtime.dds.transport import DdsTransport
    from runtime.processes.executor import ClockedExecutor

    ex = ClockedExecutor(DdsTransport(DdsConfig(domain)), use_sim_time=False, config_dir=None)
    node = Node("bench_ping", context=ex.context)
    pub = node.create_publisher(TYPE, PING, QOS)
    rtts: list[int] = []
    node.create_subscription(TYPE, PONG,
                             lambda m: rtts.append(time.monotonic_ns() - _stamp(m.data)), QOS)
    sent = [0]

    def tick() -> None:
        pub.publish(_message(time.monotonic_ns()))
        sent[0] += 1

    deadline = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        ex.spin_once_realtime()
    ex.spin_until(time.time_ns())
    timer = node.create_timer(1.0 / RATE_HZ, tick)
    end = time.monotonic() + duration_s
    ex.spin(until=lambda: time.monotonic() > end)
    timer.cancel()  # then only collect the echoes still on their way
    settle = time.monotonic() + 0.2
    ex.spin(until=lambda: time.monotonic() > settle)
    return _stats([r // 2 for r in rtts], sent[0], duration_s)


# -- bare cyclonedds ------------------------------------------------------------------------
def _bare_endpoints(domain: int, out_topic: str, in_topic: str) -> Any:
    from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
    from cyclonedds.domain import Domain, DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    from runtime.dds.config import DdsConfig
    from runtime.dds.qos import dds_qos
    from runtime.dds.types import dds_topic_name, idl_struct
    from runtime.transport import EndpointKind

    config = DdsConfig(domain)
    domain_entity = Domain(domain, config.xml())
    dp = DomainParticipant(domain)
    cls = idl_struct(TYPE)
    qos = dds_qos(QOS)
    writer = DataWriter(dp, Topic(dp, dds_topic_name(out_topic, EndpointKind.TOPIC), cls), qos)
    reader = DataReader(dp, Topic(dp, dds_topic_name(in_topic, EndpointKind.TOPIC), cls), qos)
    ws = WaitSet(dp)
    ws.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
    return domain_entity, dp, cls, writer, reader, ws


def bare_echo(domain: int) -> None:
    from cyclonedds.util import duration

    _d, _dp, cls, writer, reader, ws = _bare_endpoints(domain, PONG, PING)
    print("ready", flush=True)
    while not sys.stdin.closed:
        ws.wait(duration(milliseconds=50))
        for sample in reader.take(64):
            if isinstance(sample, cls):  # not the no-writers notice at the end
                writer.write(sample)


def bare_ping(domain: int, duration_s: float) -> dict[str, Any]:
    from cyclonedds.util import duration

    _d, _dp, cls, writer, reader, ws = _bare_endpoints(domain, PING, PONG)
    deadline = time.monotonic() + 20
    while not writer.get_matched_subscriptions() and time.monotonic() < deadline:
        time.sleep(0.01)
    rtts: list[int] = []
    sent = 0
    period_ns = round(1e9 / RATE_HZ)
    start = time.monotonic_ns()
    end = start + round(duration_s * 1e9)
    next_ns = start + period_ns
    while True:
        now = time.monotonic_ns()
        if now >= next_ns:
            if next_ns >= end:
                break
            data = np.zeros(DATA_BYTES, dtype=np.uint8)
            data[:8] = np.frombuffer(struct.pack("<Q", time.monotonic_ns()), dtype=np.uint8)
            writer.write(cls(layout=cls.__annotations__["layout"](dim=[], data_offset=0),
                             data=data.tolist()))
            sent += 1
            next_ns += period_ns
        ws.wait(duration(nanoseconds=max(1000, next_ns - time.monotonic_ns())))
        for sample in reader.take(64):
            rtts.append(time.monotonic_ns() - struct.unpack("<Q", bytes(sample.data[:8]))[0])
    settle = time.monotonic() + 0.2
    while time.monotonic() < settle:
        ws.wait(duration(milliseconds=20))
        for sample in reader.take(64):
            rtts.append(time.monotonic_ns() - struct.unpack("<Q", bytes(sample.data[:8]))[0])
    return _stats([r // 2 for r in rtts], sent, duration_s)


# -- in-process ------------------------------------------------------------------------------
def in_process(samples: int) -> dict[str, Any]:
    from runtime import DeterministicExecutor, Node

    ex = DeterministicExecutor(config_dir=None)
    talker, listener = Node("talker", context=ex.context), Node("listener", context=ex.context)
    pub = talker.create_publisher(TYPE, PING, QOS)
    got: list[int] = []
    listener.create_subscription(TYPE, PING, lambda m: got.append(time.perf_counter_ns()), QOS)
    latencies = []
    for _ in range(samples):
        t0 = time.perf_counter_ns()
        pub.publish(_message(0))
        ex.spin_once()
        latencies.append(got[-1] - t0)
    return _stats(latencies, samples, samples / RATE_HZ) | {"throughput_msg_s": None}


# -- driver ----------------------------------------------------------------------------------
def _run_pair(kind: str, domain: int, duration_s: float) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    echo = subprocess.Popen([sys.executable, __file__, "--role", f"{kind}-echo",
                             "--domain", str(domain)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)
    assert echo.stdout is not None and echo.stdout.readline().strip() == "ready"
    try:
        ping = subprocess.run([sys.executable, __file__, "--role", f"{kind}-ping", "--domain",
                               str(domain), "--duration", str(duration_s)],
                              capture_output=True, text=True, env=env, timeout=120)
        if ping.returncode != 0:
            raise RuntimeError(f"{kind} pinger failed: {ping.stderr}")
        return dict(json.loads(ping.stdout))
    finally:
        echo.terminate()
        echo.wait(10)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--duration", type=float, default=10.0, help="seconds per stream")
    parser.add_argument("--domain", type=int, default=200 + os.getpid() % 30)
    parser.add_argument("--role", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    roles = {"ours-echo": lambda: ours_echo(args.domain),
             "bare-echo": lambda: bare_echo(args.domain)}
    if args.role in roles:
        roles[args.role]()
        return 0
    if args.role == "ours-ping":
        print(json.dumps(ours_ping(args.domain, args.duration)))
        return 0
    if args.role == "bare-ping":
        print(json.dumps(bare_ping(args.domain, args.duration)))
        return 0
    bare = _run_pair("bare", args.domain, args.duration)
    ours = _run_pair("ours", args.domain, args.duration)
    inproc = in_process(int(args.duration * RATE_HZ))
    result = {
        "message": {"type": TYPE, "cdr_bytes": len(interfaces.serialize(_message(0), TYPE)),
                    "rate_hz": RATE_HZ, "qos": "reliable, volatile, keep last 10"},
        "method": "ping-pong between two processes, one-way = round trip / 2, loopback",
        "dds_ours": ours, "dds_bare_cyclonedds": bare, "in_process": inproc,
        "overhead_ratio": {"p50": round(ours["p50_us"] / bare["p50_us"], 2),
                           "p99": round(ours["p99_us"] / bare["p99_us"], 2)},
        "targets": {"p50_us": 200, "p99_us": 1000, "overhead_ratio": 1.5},
    }
    text = json.dumps(result, indent=2)
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
