"""A ROS 2 peer the project did not write: Cyclone DDS from Python, speaking ROS 2's
names and types on DDS, against `station ros2 --arm` and a virtual robot.

1. Waits for rt/odom (the bridge is up and the robot streams).
2. Publishes rt/cmd_vel (geometry_msgs/Twist, or TwistStamped with --stamped, for a bridge
   with use_stamped_vel) at 20 Hz for --drive-s seconds and checks
   that the robot moved the way it was told (forward, turning left).
3. Stops publishing and measures how long after the last command the robot's odometry
   says it stands still: the robot's cmd_vel_timeout, then its deceleration ramp.
4. Resets the pose on rt/set_pose to the origin, publishes an L-shaped nav_msgs/Path of
   a few hundred poses on rt/path, and waits for rt/diagnostics to report the end of the
   run; checks that odom ends at the path's end.

Prints one line:
  ros2 (Cyclone DDS peer): cmd_vel N, odom M at F Hz, stopped S s after the last command, path followed
then `path: settle_s=X final_error_m=Y` for the caller to compare with the station's run.
Exits 1, saying why, when a step fails.
"""

import argparse
import math
import sys
import time

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_types import (
    DiagnosticArray,
    Time,
    Header,
    Odometry,
    Path,
    Point,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Twist,
    TwistStamped,
    Vector3,
)

CMD_HZ = 20.0
STILL_M_S = 0.005  # |v| below this, and |ω| below 10× this in rad/s, is standing still
L_FIRST_M = 0.8
L_SECOND_M = 0.5


def fail(why):
    print(f"ros2 peer FAILED: {why}", flush=True)
    sys.exit(1)


class Peer:
    def __init__(self, domain, stamped):
        qos = Qos(
            Policy.Reliability.Reliable(duration(milliseconds=100)),
            Policy.Durability.Volatile,
            Policy.History.KeepLast(10),
        )
        self.participant = DomainParticipant(domain)
        p = self.participant
        # cmd_vel as the bridge's use_stamped_vel says: Twist, or TwistStamped.
        self.stamped = stamped
        self.cmd_vel = DataWriter(
            p, Topic(p, "rt/cmd_vel", TwistStamped if stamped else Twist), qos=qos
        )
        self.path = DataWriter(p, Topic(p, "rt/path", Path), qos=qos)
        self.set_pose = DataWriter(
            p, Topic(p, "rt/set_pose", PoseWithCovarianceStamped), qos=qos
        )
        self.odom_reader = DataReader(p, Topic(p, "rt/odom", Odometry), qos=qos)
        self.diagnostics_reader = DataReader(
            p, Topic(p, "rt/diagnostics", DiagnosticArray), qos=qos
        )
        # (receipt time, odometry) of every sample.
        self.odom = []
        self.statuses = []

    def pump(self):
        # A writer that goes away leaves samples that carry no data: skipped.
        now = time.monotonic()
        for sample in self.odom_reader.take(N=1000):
            if isinstance(sample, Odometry):
                self.odom.append((now, sample))
        for sample in self.diagnostics_reader.take(N=100):
            if isinstance(sample, DiagnosticArray):
                self.statuses.append((now, sample))

    def wait(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.pump()
            time.sleep(0.005)

    def send_cmd_vel(self, v, omega):
        twist = Twist(linear=Vector3(x=v), angular=Vector3(z=omega))
        if self.stamped:
            now = time.time()
            stamp = Time(sec=int(now), nanosec=int((now % 1.0) * 1e9))
            self.cmd_vel.write(TwistStamped(header=Header(stamp=stamp, frame_id="base_link"), twist=twist))
        else:
            self.cmd_vel.write(twist)

    def latest(self):
        return self.odom[-1][1] if self.odom else None


def yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def still(odom):
    return abs(odom.twist.twist.linear.x) < STILL_M_S and abs(odom.twist.twist.angular.z) < 10 * STILL_M_S


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--stamped", action="store_true", help="cmd_vel as TwistStamped (the bridge's use_stamped_vel)")
    parser.add_argument("--drive-s", type=float, default=3.0)
    parser.add_argument("--v", type=float, default=0.2)
    parser.add_argument("--omega", type=float, default=0.3)
    parser.add_argument("--timeout-s", type=float, default=0.5, help="the robot's cmd_vel_timeout")
    parser.add_argument("--corner-radius", type=float, default=0.1)
    parser.add_argument("--path-wait-s", type=float, default=30.0)
    args = parser.parse_args()
    peer = Peer(args.domain, args.stamped)

    # 1. The bridge's odometry.
    deadline = time.monotonic() + 30.0
    while not peer.odom and time.monotonic() < deadline:
        peer.wait(0.05)
    if not peer.odom:
        fail("no rt/odom within 30 s (discovery, or the bridge has no robot)")
    start = peer.latest()

    # 2. Drive.
    sent = 0
    period = 1.0 / CMD_HZ
    t_first = time.monotonic()
    next_send = t_first
    while time.monotonic() < t_first + args.drive_s:
        peer.send_cmd_vel(args.v, args.omega)
        sent += 1
        t_last = time.monotonic()
        next_send += period
        while time.monotonic() < next_send:
            peer.pump()
            time.sleep(0.002)
    moving = peer.latest()
    dx = moving.pose.pose.position.x - start.pose.pose.position.x
    dy = moving.pose.pose.position.y - start.pose.pose.position.y
    heading_change = math.remainder(yaw(moving.pose.pose.orientation) - yaw(start.pose.pose.orientation), math.tau)
    along = dx * math.cos(yaw(start.pose.pose.orientation)) + dy * math.sin(yaw(start.pose.pose.orientation))
    if along < 0.3 * args.v * args.drive_s:
        fail(f"the robot moved {along:.3f} m forward in {args.drive_s} s at {args.v} m/s")
    if args.omega > 0 and heading_change < 0.3 * args.omega * args.drive_s:
        fail(f"the robot turned {heading_change:.3f} rad in {args.drive_s} s at {args.omega} rad/s")
    if abs(moving.twist.twist.linear.x - args.v) > 0.05:
        fail(f"odom says v = {moving.twist.twist.linear.x:.3f} m/s while commanded {args.v}")

    # 3. Stop publishing: the robot stands still after its timeout and ramp.
    stopped_at = None
    still_count = 0
    deadline = t_last + 5.0
    seen = len(peer.odom)
    while time.monotonic() < deadline and stopped_at is None:
        peer.wait(0.01)
        for received, odom in peer.odom[seen:]:
            if still(odom):
                still_count += 1
                if still_count == 1:
                    candidate = received
                if still_count >= 10:
                    stopped_at = candidate
                    break
            else:
                still_count = 0
        seen = len(peer.odom)
    if stopped_at is None:
        fail("the robot did not stop within 5 s of the last cmd_vel")
    stopped_s = stopped_at - t_last
    if stopped_s < 0.8 * args.timeout_s:
        fail(f"the robot stopped {stopped_s:.2f} s after the last cmd_vel, before its {args.timeout_s} s timeout")
    if stopped_s > args.timeout_s + 1.0:
        fail(f"the robot stopped {stopped_s:.2f} s after the last cmd_vel (timeout {args.timeout_s} s)")

    # The odometry's rate while driving and stopping.
    window = [t for t, _ in peer.odom if t_first <= t <= stopped_at]
    rate_hz = (len(window) - 1) / (window[-1] - window[0]) if len(window) > 1 else 0.0

    # 4. A path from the origin.
    peer.set_pose.write(
        PoseWithCovarianceStamped(
            header=Header(frame_id="odom"),
            pose=PoseWithCovariance(pose=Pose(position=Point(), orientation=Quaternion())),
        )
    )
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        peer.wait(0.05)
        o = peer.latest()
        p = o.pose.pose.position
        if math.hypot(p.x, p.y) < 1e-3 and abs(yaw(o.pose.pose.orientation)) < 1e-3:
            break
    else:
        fail("rt/set_pose to the origin did not show on rt/odom within 5 s")
    poses = []
    step = 0.005
    for i in range(int(L_FIRST_M / step) + 1):
        poses.append((i * step, 0.0))
    for i in range(1, int(L_SECOND_M / step) + 1):
        poses.append((L_FIRST_M, i * step))
    path = Path(
        header=Header(frame_id="odom"),
        poses=[
            PoseStamped(header=Header(frame_id="odom"), pose=Pose(position=Point(x=x, y=y)))
            for x, y in poses
        ],
    )
    statuses_before = len(peer.statuses)
    peer.path.write(path)
    ended = None
    deadline = time.monotonic() + args.path_wait_s
    while ended is None and time.monotonic() < deadline:
        peer.wait(0.05)
        for _, array in peer.statuses[statuses_before:]:
            for status in array.status:
                if status.name == "station ros2: commands" and "path run ended" in status.message:
                    ended = status.message
                if status.name == "station ros2: commands" and "path" in status.message and "refused" in status.message:
                    fail(f"the bridge refused the path: {status.message}")
    if ended is None:
        fail(f"no end of the path run on rt/diagnostics within {args.path_wait_s} s")
    if "did not settle" in ended:
        fail(f"the path run did not settle: {ended}")
    end = peer.latest().pose.pose.position
    miss = math.hypot(end.x - L_FIRST_M, end.y - L_SECOND_M)
    if miss > 0.05:
        fail(f"odom ends {miss:.3f} m from the path's end ({end.x:.3f}, {end.y:.3f})")
    settle = ended.split("settled at ")[1].split(" s")[0]
    final_error = ended.split("final error ")[1].split(" m")[0]

    print(
        f"ros2 (Cyclone DDS peer): cmd_vel {sent}, odom {len(peer.odom)} at {rate_hz:.1f} Hz, "
        f"stopped {stopped_s:.2f} s after the last command, path followed",
        flush=True,
    )
    print(f"path: settle_s={settle} final_error_m={final_error} waypoints=[[0,0],[{L_FIRST_M},0],[{L_FIRST_M},{L_SECOND_M}]]")


if __name__ == "__main__":
    main()
