"""Reads the visualisation topics of a `gfsvo run --mcap` recording with PyPI
mcap-ros2-support: one /gfsvo/landmarks, /gfsvo/structure and /gfsvo/keyframes per
keyframe (the same stamps), hundreds of finite map points within a few metres of the
trajectory, line markers, keyframe poses in `map`, /gfsvo/path at its rate of the
data's clock whose last message holds one pose per frame of odometry.txt,
/gfsvo/frame_points for every frame (finite points in front of the camera, in its
optical frame, most of them inliers), and /gfsvo/tracking_image (rgb8, the camera's size) at
its rate of the data's clock, with the matches drawn in the inlier green.

Arguments: RECORDING.mcap odometry.txt [PATH_RATE_HZ (default 1)
[TRACKING_IMAGE_RATE_HZ (default 1) [WIDTH HEIGHT (default 640 480)]]] [--keyframes N]
(the keyframes the run made, `gfsvo run --json`'s `keyframes`: one /gfsvo/landmarks each)."""
import json
import struct
import sys
from pathlib import Path

import numpy as np
from mcap_ros2.reader import read_ros2_messages

args = sys.argv[1:]
made = None
if "--keyframes" in args:
    at = args.index("--keyframes")
    made = int(args[at + 1])
    del args[at:at + 2]
sys.argv[1:] = args
mcap_path, odometry = sys.argv[1], sys.argv[2]
rate = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
image_rate = float(sys.argv[4]) if len(sys.argv) > 4 else 1.0
size = (int(sys.argv[5]), int(sys.argv[6])) if len(sys.argv) > 6 else (640, 480)
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
assert made is None or len(clouds) == made, f"{len(clouds)} /gfsvo/landmarks, {made} keyframes made"
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
assert lines > 0 and planes > 0, f"line and plane markers: {lines} lines, {planes} planes"
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

# Each frame's matched points with depth, in the camera's optical frame (z forward).
frame_points = by_topic.get("/gfsvo/frame_points", [])
assert len(frame_points) >= len(rows) - 1, \
    f"{len(frame_points)} /gfsvo/frame_points for {len(rows)} frames"
counts, inliers, depths = [], 0, []
for c in frame_points:
    assert c.header.frame_id == "camera_color_optical_frame" and c.point_step == 16
    cloud = np.array(struct.unpack(f"<{4 * c.width}f", bytes(c.data))).reshape(-1, 4)
    assert np.isfinite(cloud[:, :3]).all(), "every frame point is finite"
    assert (cloud[:, 2] > 0.1).all() and (cloud[:, 2] < 10).all(), "in front of the camera"
    packed = cloud[:, 3].astype("<f4").view("<u4")
    inliers += int(np.sum(packed == 0x00E600))
    counts.append(c.width)
    depths.extend(cloud[:, 2].tolist())
median_points = int(np.median(counts))
assert median_points >= 100, f"a median of {median_points} matched points with depth per frame"
assert inliers > 0.5 * sum(counts), f"{inliers} of {sum(counts)} frame points are inliers"

# The tracking image: rgb8 of the camera's size, at its rate, the matches drawn in green.
images = by_topic.get("/gfsvo/tracking_image", [])
expected_images = int(duration * image_rate) + 1
assert abs(len(images) - expected_images) <= 1, \
    f"{len(images)} tracking images over {duration:.1f} s at {image_rate} Hz"
green = []
for im in images:
    assert (im.width, im.height, im.encoding, im.step) == (*size, "rgb8", 3 * size[0])
    assert im.header.frame_id == "camera_color_optical_frame"
    pixels = np.frombuffer(bytes(im.data), dtype=np.uint8).reshape(size[1], size[0], 3)
    green.append(int(np.sum(np.all(pixels == [0, 230, 0], axis=2))))
# The first frame starts the map: nothing matched yet.
assert min(green[1:]) > 100, f"the matches drawn in green: {min(green[1:])} pixels at least"
print(f"frame points: {len(frame_points)} clouds, a median of {median_points} points "
      f"({100 * inliers / max(1, sum(counts)):.0f} % inliers, depth {min(depths):.2f}.."
      f"{max(depths):.2f} m); {len(images)} tracking images {size[0]}x{size[1]} at "
      f"{image_rate} Hz, {min(green[1:])}..{max(green)} green pixels after the first")

# The Foxglove layout is JSON whose 3D panel shows these topics; the RViz config names them.
REPO = Path(__file__).resolve().parent.parent.parent
TOPICS = ["/gfsvo/landmarks", "/gfsvo/structure", "/gfsvo/keyframes", "/gfsvo/path", "/odom",
          "/gfsvo/frame_points"]
layout = json.loads((REPO / "deploy" / "foxglove" / "gfsvo.json").read_text())
shown = layout["configById"]["3D!gfsvo"]["topics"]
assert all(shown[t]["visible"] for t in TOPICS), "the Foxglove layout shows every topic"
assert layout["configById"]["Image!tracking"]["imageMode"]["imageTopic"] == "/gfsvo/tracking_image"
rviz = (REPO / "deploy" / "rviz" / "gfsvo.rviz").read_text()
assert all(f"Value: {t}\n" in rviz for t in TOPICS + ["/gfsvo/tracking_image"]), \
    "the RViz config opens every topic"
print("layouts: deploy/foxglove/gfsvo.json and deploy/rviz/gfsvo.rviz open "
      + ", ".join(TOPICS + ["/gfsvo/tracking_image"]))
