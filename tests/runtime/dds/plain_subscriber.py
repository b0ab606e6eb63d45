"""A plain Cyclone DDS client that knows nothing of quadmission: only the IDL.

``python plain_subscriber.py DOMAIN`` (CYCLONEDDS_URI set by the caller). The types are
what ``idlc -l py`` generates from the ROS 2 IDL (``rosidl`` output)::

    module std_msgs { module msg { module dds_ {
      @final struct String_ { string data; };
    }; }; };
    module quadmission_interfaces { module srv { module dds_ {
      @final struct Arm_Request_ { boolean force; double timeout; };
      @final struct Arm_Response_ { octet result; octet fcu_result; boolean success;
                                    string message; };
    }; }; };

A service sample on the wire is rmw_cyclonedds' request header (uint64 client id, int64
sequence) followed by the request, so the client's structs start with those two fields,
named as our endpoints announce them in their type information (``request_guid_``,
``request_seq_``; XTypes matches final structs member by member, names included).
It prints one line per received String and the service's reply, then exits.
"""

import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import float64, int64, uint8, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic


@final
@dataclass
class String_(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@final
@dataclass
class Arm_Request_(IdlStruct, typename="quadmission_interfaces::srv::dds_::Arm_Request_"):
    request_guid_: uint64
    request_seq_: int64
    force: bool
    timeout: float64


@final
@dataclass
class Arm_Response_(IdlStruct, typename="quadmission_interfaces::srv::dds_::Arm_Response_"):
    request_guid_: uint64
    request_seq_: int64
    result: uint8
    fcu_result: uint8
    success: bool
    message: str


def main() -> int:
    dp = DomainParticipant(int(sys.argv[1]))
    qos = Qos(Policy.Reliability.Reliable(100_000_000), Policy.History.KeepLast(10),
              Policy.DataRepresentation(use_cdrv0_representation=True))
    reader = DataReader(dp, Topic(dp, "rt/foreign/chatter", String_), qos=qos)
    got = []
    deadline = time.monotonic() + 20
    while len(got) < 3 and time.monotonic() < deadline:
        for sample in reader.take(10):
            got.append(sample.data)
            print(f"String: {sample.data}", flush=True)
        time.sleep(0.02)
    requests = DataWriter(dp, Topic(dp, "rq/foreign/armRequest", Arm_Request_), qos=qos)
    replies = DataReader(dp, Topic(dp, "rr/foreign/armReply", Arm_Response_), qos=qos)
    while not (requests.get_matched_subscriptions() and replies.get_matched_publications()):
        if time.monotonic() > deadline:
            return 1
        time.sleep(0.02)
    requests.write(Arm_Request_(request_guid_=0xABCDEF, request_seq_=7, force=True,
                                timeout=2.5))
    while time.monotonic() < deadline:
        for reply in replies.take(10):
            if reply.request_guid_ == 0xABCDEF and reply.request_seq_ == 7:
                print(f"reply: success={reply.success} message={reply.message}", flush=True)
                return 0
        time.sleep(0.02)
    return 1


if __name__ == "__main__":
    sys.exit(main())
