"""Open3D's RGB-D odometry (hybrid photometric + geometric term, frame to frame,
default options), chained over a TUM-layout dataset: the peer of the
low-texture ablation (docs/results.md). Not part of the product; run through open3d.sh.

usage: open3d_odometry.py DATASET CONFIG.toml OUT.txt
CONFIG is a gfsvo camera config ([camera] fx fy cx cy width height, [depth] scale
max_m); distortion is ignored (the synthetic sequences have none).
"""

import os
import sys
import tomllib

import numpy as np
import open3d as o3d
from scipy.spatial.transform import Rotation


def main(dataset, config_path, out_path):
    with open(config_path, "rb") as f:
        config = tomllib.load(f)
    cam, depth = config["camera"], config.get("depth", {})
    intrinsic = o3d.camera.PinholeCameraIntrinsic(
        cam["width"], cam["height"], cam["fx"], cam["fy"], cam["cx"], cam["cy"]
    )
    scale, trunc = depth.get("scale", 5000.0), depth.get("max_m", 10.0)
    with open(os.path.join(dataset, "associations.txt")) as f:
        frames = [l.split() for l in f if l.strip() and not l.startswith("#")]

    def load(frame):
        color = o3d.io.read_image(os.path.join(dataset, frame[1]))
        depth_image = o3d.io.read_image(os.path.join(dataset, frame[3]))
        return o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth_image, depth_scale=scale, depth_trunc=trunc,
            convert_rgb_to_intensity=True,
        )

    option = o3d.pipelines.odometry.OdometryOption()
    jacobian = o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm()
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
        ok, previous_from_current, _ = o3d.pipelines.odometry.compute_rgbd_odometry(
            current, previous, intrinsic, np.eye(4), jacobian, option)
        if not ok:
            failures += 1
            previous_from_current = np.eye(4)
        world_from_camera = world_from_camera @ previous_from_current
        previous = current
        write(frame[0])
    with open(out_path, "w") as f:
        f.writelines(lines)
    print(f"{len(frames)} frames, {failures} failed (kept the last pose)")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
