"""Reads a `gfsvo run --mcap` recording with PyPI mcap-ros2-support and checks every
/odom against odometry.txt (the poses as published; trajectory.txt, the map poses,
differs once a loop correction or a relocalisation went into map -> odom), matched by
the integer stamp (sec, nanosec) exactly: the base
pose in odom turned back into the camera pose with the default camera-in-base
extrinsic (REP 103 optical frame); and /diagnostics once a second of the camera's clock,
whatever the playback speed."""
import sys

import numpy as np
from mcap_ros2.reader import read_ros2_messages

import tum


def rot(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def matrix(t, q):
    m = np.eye(4)
    m[:3, :3] = rot(q)
    m[:3, 3] = t
    return m


mcap_path, trajectory = sys.argv[1], sys.argv[2]
lines = [l.split() for l in open(trajectory) if l.strip() and not l.startswith("#")]
rows = [list(map(float, l)) for l in lines]
# Keyed by the integer stamp: each /odom must carry its frame's stamp bit for bit.
by_stamp = {tum.stamp(l[0]): r for l, r in zip(lines, rows)}
base = matrix([0, 0, 0], [-0.5, 0.5, -0.5, 0.5])
odoms, statuses, worst = 0, 0, 0.0
diagnostics = []
for m in read_ros2_messages(mcap_path):
    if m.channel.topic == "/gfsvo/status":
        statuses += 1
    if m.channel.topic == "/diagnostics":
        st = m.ros_msg.status[0]
        diagnostics.append((m.ros_msg.header.stamp.sec, {kv.key for kv in st.values}, st.level))
    if m.channel.topic != "/odom":
        continue
    o = m.ros_msg
    p, q = o.pose.pose.position, o.pose.pose.orientation
    key = (o.header.stamp.sec, o.header.stamp.nanosec)
    assert key in by_stamp, f"/odom stamped {key[0]}.{key[1]:09d}: no such frame in {trajectory}"
    row = by_stamp[key]
    camera = np.linalg.inv(base) @ matrix([p.x, p.y, p.z], [q.x, q.y, q.z, q.w]) @ base
    want = matrix(row[1:4], row[4:8])
    worst = max(worst, float(np.abs(camera - want).max()))
    assert o.header.frame_id == "odom" and o.child_frame_id == "base_link"
    odoms += 1
print(f"mcap: {odoms} /odom, {statuses} status messages; odometry.txt has {len(rows)} poses; "
      f"largest difference {worst:.2e}")
assert odoms == len(rows) == statuses, "one /odom per pose"
span_s = rows[-1][0] - rows[0][0]
print(f"mcap: {len(diagnostics)} /diagnostics over {span_s:.1f} s of camera clock, levels "
      f"{sorted({d[2] for d in diagnostics})}")
assert abs(len(diagnostics) - span_s) <= 1.5, "/diagnostics once a second of the data"
assert all({"tracking state", "input rate (Hz)", "frames tracked (%)"} <= d[1] for d in diagnostics)
assert worst < 1e-6, "every /odom equals odometry.txt"
