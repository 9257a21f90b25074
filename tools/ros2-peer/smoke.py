"""Cyclone DDS peer for the smoke test: publishes 30 rt/cmd_vel at 20 Hz, counts rt/odom."""

import sys
import time

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_types import Odometry, Twist, Vector3

qos = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(10),
)
participant = DomainParticipant(int(sys.argv[1]) if len(sys.argv) > 1 else 0)
writer = DataWriter(participant, Topic(participant, "rt/cmd_vel", Twist), qos=qos)
reader = DataReader(participant, Topic(participant, "rt/odom", Odometry), qos=qos)
odom = 0
last_x = None
for i in range(60):
    if 10 <= i < 40:
        writer.write(Twist(linear=Vector3(x=0.1 * i)))
    for sample in reader.take(N=100):
        odom += 1
        last_x = sample.pose.pose.position.x
    time.sleep(0.05)
print(f"peer: odom {odom}, last x {last_x}")
