"""Reads the visualisation topics of a `gfsvo run --mcap` recording with PyPI
mcap-ros2-support: one /gfsvo/landmarks, /gfsvo/structure and /gfsvo/keyframes per
keyframe (the same stamps), hundreds of finite map points within a few metres of the
trajectory, line markers, keyframe poses in `map`, and /gfsvo/path at its rate of the
data's clock whose last message holds one pose per frame of odometry.txt.

Arguments: RECORDING.mcap odometry.txt [PATH_RATE_HZ (default 1)]."""
import json
import struct
import sys
from pathlib import Path

import numpy as np
from mcap_ros2.reader import read_ros2_messages

mcap_path, odometry = sys.argv[1], sys.argv[2]
rate = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
rows = np.array([list(map(float, l.split())) for l in open(odometry)
                 if l.strip() and not l.startswith("#")])
# The camera positions in odom (base frame at the first image: x = optical z,
# y = -optical x, z = -optical y), for the distance of the map points.
positions = np.stack([rows[:, 3], -rows[:, 1], -rows[:, 2]], axis=1)


def stamp(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9


by_topic = {}
for m in read_ros2_messages(mcap_path):
    by_topic.setdefault(m.channel.topic, []).append(m.ros_msg)

clouds = by_topic.get("/gfsvo/landmarks", [])
structures = by_topic.get("/gfsvo/structure", [])
keyframes = by_topic.get("/gfsvo/keyframes", [])
paths = by_topic.get("/gfsvo/path", [])
assert len(clouds) >= 10, f"{len(clouds)} /gfsvo/landmarks: one per keyframe expected"
assert len(clouds) == len(structures) == len(keyframes), \
    f"{len(clouds)} landmarks, {len(structures)} structure, {len(keyframes)} keyframes"
assert [stamp(c.header) for c in clouds] == [stamp(k.header) for k in keyframes]

sizes, farthest = [], 0.0
for c in clouds:
    assert c.header.frame_id == "odom" and c.height == 1
    assert [(f.name, f.offset, f.datatype, f.count) for f in c.fields] == \
        [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("rgb", 12, 7, 1)]
    assert c.point_step == 16 and c.row_step == 16 * c.width == len(c.data)
    xyz = np.array(struct.unpack(f"<{4 * c.width}f", bytes(c.data))).reshape(-1, 4)[:, :3]
    assert np.isfinite(xyz).all(), "every landmark coordinate is finite"
    nearest = np.min(np.linalg.norm(xyz[:, None, :] - positions[None, ::10, :], axis=2), axis=1)
    farthest = max(farthest, float(nearest.max()))
    sizes.append(c.width)
assert min(sizes) >= 100, f"hundreds of points per keyframe, got {min(sizes)}"
assert farthest < 6.0, f"a landmark {farthest:.1f} m from the trajectory"

lines = planes = 0
for s in structures:
    names = {m.ns: m for m in s.markers}
    assert names["lines"].type == 5 and names["planes"].type == 11
    assert len(names["lines"].points) % 2 == 0 and len(names["planes"].points) % 3 == 0
    assert all(m.header.frame_id == "odom" for m in s.markers)
    lines = max(lines, len(names["lines"].points) // 2)
    planes = max(planes, len(names["planes"].points) // 6)
assert lines > 0, "line markers"
assert all(k.header.frame_id == "map" and len(k.poses) > 0 for k in keyframes)

duration = rows[-1, 0] - rows[0, 0]
assert paths, "/gfsvo/path"
assert all(p.header.frame_id == "odom" for p in paths)
assert len(paths[-1].poses) == len(rows), \
    f"the last path has {len(paths[-1].poses)} poses, odometry.txt {len(rows)}"
expected = int(duration * rate) + 2
assert abs(len(paths) - expected) <= 1, f"{len(paths)} paths over {duration:.1f} s at {rate} Hz"
print(f"visualisation: {len(clouds)} keyframes with {min(sizes)}..{max(sizes)} landmarks "
      f"(farthest {farthest:.2f} m from the path), up to {lines} lines and {planes} planes, "
      f"{len(paths)} paths at {rate} Hz, the last with {len(paths[-1].poses)} poses")

# The Foxglove layout is JSON whose 3D panel shows these topics; the RViz config names them.
REPO = Path(__file__).resolve().parent.parent.parent
TOPICS = ["/gfsvo/landmarks", "/gfsvo/structure", "/gfsvo/keyframes", "/gfsvo/path", "/odom"]
layout = json.loads((REPO / "deploy" / "foxglove" / "gfsvo.json").read_text())
shown = layout["configById"]["3D!gfsvo"]["topics"]
assert all(shown[t]["visible"] for t in TOPICS), "the Foxglove layout shows every topic"
rviz = (REPO / "deploy" / "rviz" / "gfsvo.rviz").read_text()
assert all(f"Value: {t}\n" in rviz for t in TOPICS), "the RViz config opens every topic"
print("layouts: deploy/foxglove/gfsvo.json and deploy/rviz/gfsvo.rviz open " + ", ".join(TOPICS))
