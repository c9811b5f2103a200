"""OpenCV's RGB-D odometry (`cv2.rgbd.RgbdOdometry`, the photometric dense alignment of
Steinbruecker et al. 2011, default options), frame to frame, chained over a TUM-layout
dataset: a peer for the frame-to-frame error. Not part of the product; run through
opencv.sh (the rgbd module is in the contrib build of OpenCV 4).

usage: opencv_odometry.py DATASET CONFIG.toml OUT.txt
CONFIG is a gfsvo camera config ([camera] fx fy cx cy, [depth] scale min_m max_m);
distortion is ignored, as in open3d_odometry.py.
"""

import os
import sys
import tomllib

import cv2
import numpy as np
from scipy.spatial.transform import Rotation


def main(dataset, config_path, out_path):
    with open(config_path, "rb") as f:
        config = tomllib.load(f)
    cam, depth = config["camera"], config.get("depth", {})
    camera = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1]],
                      dtype=np.float32)
    scale = depth.get("scale", 5000.0)
    min_m, max_m = depth.get("min_m", 0.1), depth.get("max_m", 10.0)
    with open(os.path.join(dataset, "associations.txt")) as f:
        frames = [l.split() for l in f if l.strip() and not l.startswith("#")]

    def load(frame):
        gray = cv2.imread(os.path.join(dataset, frame[1]), cv2.IMREAD_GRAYSCALE)
        raw = cv2.imread(os.path.join(dataset, frame[3]), cv2.IMREAD_UNCHANGED)
        metres = raw.astype(np.float32) / scale
        metres[(metres < min_m) | (metres > max_m)] = np.nan
        return gray, metres

    odometry = cv2.rgbd.RgbdOdometry_create(camera, min_m, max_m)
    world_from_camera = np.eye(4)
    lines, failures = [], 0

    def write(timestamp):
        q = Rotation.from_matrix(world_from_camera[:3, :3]).as_quat()
        t = world_from_camera[:3, 3]
        lines.append(f"{timestamp} {t[0]:.6f} {t[1]:.6f} {t[2]:.6f} "
                     f"{q[0]:.6f} {q[1]:.6f} {q[2]:.6f} {q[3]:.6f}\n")

    previous = load(frames[0])
    write(frames[0][0])
    for frame in frames[1:]:
        current = load(frame)
        # Rt maps points of the source (previous) frame into the destination (current).
        ok, current_from_previous = odometry.compute(
            previous[0], previous[1], None, current[0], current[1], None)
        if not ok:
            failures += 1
            current_from_previous = np.eye(4)
        world_from_camera = world_from_camera @ np.linalg.inv(current_from_previous)
        previous = current
        write(frame[0])
    with open(out_path, "w") as f:
        f.writelines(lines)
    print(f"{len(frames)} frames, {failures} failed (kept the last pose)")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
