#!/usr/bin/env python3
"""Reads a run's MCAP file with readers nobody in this project wrote (PyPI's `mcap` and
`mcap-protobuf-support`) and checks it against the run's trace.csv.

    mcap_check.py RUN.mcap TRACE.csv [RUN.mcap TRACE.csv ...]

For each pair: every channel of the robot's (docs/foxglove.md) is in the file with its
schema, every message decodes, and at each of trace.csv's timestamps the estimated, the
reference and (where the trace knows it) the true pose equal the trace's within 1e-6 m
and 1e-6 rad. Prints one line per file, then
`mcap: N channels, M messages, poses equal trace.csv` (N and M over all files), and
exits 1 on the first difference.
"""

import csv
import math
import os
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

CHANNELS = [
    "/tf",
    "/pose/estimate",
    "/pose/true",
    "/pose/reference",
    "/path",
    "/errors",
    "/body",
    "/wheels",
    "/supervisor",
    "/events",
]
# Pose topic -> trace.csv's columns (x, y, heading).
POSES = {
    "/pose/estimate": ("x_est_m", "y_est_m", "theta_est_rad"),
    "/pose/reference": ("x_ref_m", "y_ref_m", "theta_ref_rad"),
    "/pose/true": ("x_m", "y_m", "theta_rad"),
}
TOLERANCE = 1e-6
# trace.csv prints its time to 1 ms: a message matches a row within half of that.
TIME_TOLERANCE_NS = 500_000


def fail(message):
    print(f"mcap check FAILED: {message}")
    sys.exit(1)


def wrapped(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


def read_file(path):
    """(channel topics with a schema, message count, {pose topic: [(log_time, x, y, θ)]})."""
    poses = {topic: [] for topic in POSES}
    messages = 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        if summary is None:
            fail(f"{path}: no summary section")
        topics = {}
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if schema is None or not schema.name or not schema.data:
                fail(f"{path}: channel {channel.topic} has no schema")
            if schema.encoding != "protobuf":
                fail(f"{path}: channel {channel.topic} is {schema.encoding}, not protobuf")
            topics[channel.topic] = schema.name
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            messages += 1
            if channel.topic in poses:
                p = decoded.pose
                q = p.orientation
                theta = 2.0 * math.atan2(q.z, q.w)
                poses[channel.topic].append(
                    (message.log_time, p.position.x, p.position.y, theta)
                )
    return topics, messages, poses


def nearest(samples, t_ns):
    """The sample of `samples` (sorted by time) nearest to t_ns."""
    lo, hi = 0, len(samples)
    while lo < hi:
        mid = (lo + hi) // 2
        if samples[mid][0] < t_ns:
            lo = mid + 1
        else:
            hi = mid
    best = None
    for i in (lo - 1, lo):
        if 0 <= i < len(samples):
            if best is None or abs(samples[i][0] - t_ns) < abs(best[0] - t_ns):
                best = samples[i]
    return best


def check_pair(mcap_path, trace_path):
    topics, messages, poses = read_file(mcap_path)
    missing = [t for t in CHANNELS if t not in topics]
    if missing:
        fail(f"{mcap_path}: channels missing: {', '.join(missing)}")
    with open(trace_path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        fail(f"{trace_path}: no rows")
    compared = 0
    for topic, (cx, cy, ct) in POSES.items():
        samples = sorted(poses[topic])
        for row in rows:
            x, y, theta = float(row[cx]), float(row[cy]), float(row[ct])
            if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(theta)):
                continue
            t_ns = round(float(row["t_s"]) * 1e9)
            sample = nearest(samples, t_ns)
            if sample is None or abs(sample[0] - t_ns) > TIME_TOLERANCE_NS:
                fail(f"{mcap_path}: no {topic} message at t = {row['t_s']} s")
            _, mx, my, mt = sample
            dx, dy, dt = abs(mx - x), abs(my - y), abs(wrapped(mt - theta))
            if dx > TOLERANCE or dy > TOLERANCE or dt > TOLERANCE:
                fail(
                    f"{mcap_path}: {topic} at t = {row['t_s']} s is "
                    f"({mx:.7f}, {my:.7f}, {mt:.7f}), trace.csv ({x}, {y}, {theta})"
                )
            compared += 1
    if compared == 0:
        fail(f"{mcap_path}: no pose compared")
    size = os.path.getsize(mcap_path)
    print(
        f"{mcap_path}: {len(topics)} channels, {messages} messages, "
        f"{compared} poses at {len(rows)} trace rows equal, {size / 1e6:.2f} MB"
    )
    return len(topics), messages


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        print(__doc__)
        return 2
    channels = messages = 0
    for i in range(0, len(argv), 2):
        n, m = check_pair(argv[i], argv[i + 1])
        channels += n
        messages += m
    print(f"mcap: {channels} channels, {messages} messages, poses equal trace.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
