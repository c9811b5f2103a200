"""Bags as robots record them (run by interop.sh in its venv), on the first 80 frames of
../shared/data/tum_fr1_rpy_head300, each written by write_bag_variant.py with
implementations not of this project and played with `gfsvo run BAG --mcap`:

1. zstd chunks (rosbags) and lz4 chunks (PyPI mcap) of rgb8 + 32FC1: trajectory
   byte-identical to the folder's.
2. image_transport's compressed colour (png) and compressedDepth (png, 16UC1):
   byte-identical to the same frames as raw rgb8 + 16UC1 (PNG is lossless; 16UC1 because
   compressedDepth carries millimetres); jpeg colour (quality 95, 4:2:0): ATE within 10 %
   of the folder's (1.008 measured; see below for how one run's ATE moves).
3. Every `--mcap` recording (zstd chunks, the default) read back by PyPI
   mcap-ros2-support: one /odom per pose, equal to odometry.txt and carrying its frame's
   stamp exactly (integer sec, nanosec).
4. Stamps with nine non-zero nanosecond digits (tum.nine_digit_stamp, zstd chunks): every
   frame posed, odometry.txt and each /odom stamped with its colour image's stamp bit
   for bit.
"""
import sys
import time
from pathlib import Path

import tum

from harness import GFSVO, REPO, sh
from harness import ate as ate_against

HERE = Path(__file__).resolve().parent
DATA = REPO.parent / "shared" / "data" / "tum_fr1_rpy_head300"
WORK = REPO / "target" / "ros2-test" / "bags"
PY = sys.executable
FRAMES = 80


def ate(trajectory):
    return ate_against(DATA / "groundtruth.txt", trajectory)


def play(kind):
    """Writes the bag of `kind`, plays it with --mcap, checks the recording; its run folder."""
    bag = WORK / (f"fr1_{kind}.mcap" if kind == "lz4" else f"fr1_{kind}_bag")
    sh("rm", "-rf", bag)
    sh(PY, HERE / "write_bag_variant.py", DATA, bag, kind, FRAMES)
    out = WORK / kind
    sh(GFSVO, "--log", "warn", "run", bag, "--out", out, "--mcap", out / "odom.mcap")
    print(sh(PY, HERE / "check_mcap.py", out / "odom.mcap", out / "odometry.txt"), end="")
    sh("rm", "-rf", bag)
    return out


def same(a, b):
    return (a / "trajectory.txt").read_bytes() == (b / "trajectory.txt").read_bytes()


def main():
    WORK.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    folder = WORK / "folder"
    sh(GFSVO, "--log", "warn", "run", DATA, "--frames", FRAMES, "--out", folder)
    runs = {kind: play(kind) for kind in ["zstd", "lz4", "nine", "mm", "png", "jpeg"]}
    lines = (folder / "trajectory.txt").read_text().count("\n")
    for kind in ["zstd", "lz4"]:
        identical = same(folder, runs[kind])
        print(f"bag with {kind} chunks: trajectory ({lines} lines) byte-identical to the folder's: "
              f"{identical}", flush=True)
        assert identical, f"the {kind} bag plays to the folder's trajectory"
    written = [tum.nine_digit_stamp(i) for i in range(FRAMES)]
    posed = [tum.stamp(l.split()[0]) for l in
             (runs["nine"] / "odometry.txt").read_text().splitlines() if l and l[0] != "#"]
    print(f"nine-digit stamps: {len(posed)} poses for {FRAMES} frames, "
          f"{sum(a == b for a, b in zip(posed, written))} stamped exactly as their colour image "
          f"(first {posed[0][0]}.{posed[0][1]:09d})", flush=True)
    assert posed == written, "every frame posed, each with its colour image's stamp exactly"
    identical = same(runs["mm"], runs["png"])
    print(f"compressed png + compressedDepth png: byte-identical to raw rgb8 + 16UC1: {identical}")
    assert identical, "lossless compressed images play to the raw images' trajectory"
    ates = {name: ate(runs[name] / "trajectory.txt") for name in ["mm", "png", "jpeg"]}
    ates["folder"] = ate(folder / "trajectory.txt")
    print("ATE RMSE over", FRAMES, "frames:", ", ".join(f"{k} {v:.4f} m" for k, v in ates.items()))
    print(f"jpeg / raw 16UC1: {ates['jpeg'] / ates['mm']:.3f}, jpeg / folder: "
          f"{ates['jpeg'] / ates['folder']:.3f}")
    # One run's ATE follows changes below one grey level chaotically (keyframe choices,
    # RANSAC draws), and JPEG's loss is such a change: over these 80 frames, relative to
    # the raw bag, rgb8 with +-1 grey-level noise gave 0.92, 0.95, 1.03 and 1.11 (four
    # seeds); this jpeg decoded by libjpeg-turbo (PIL) instead of ours and played raw
    # gave 1.19; jpeg through our decoder 1.075 at quality 95 and 0.98 at 80 (4:2:0, as
    # image_transport's OpenCV encodes), 1.19 at 95 with 4:4:4 chroma (more fidelity,
    # worse: not a systematic loss). On all 300 frames: noise 0.91, 1.01, 1.08; jpeg 95
    # 1.01, 80 0.96, 4:4:4 1.14; libjpeg-turbo's decoding 1.16. The run is deterministic
    # (lockstep): this bag gives 1.008 of the folder's ATE, 1.075 of the raw bag's. A
    # change elsewhere that moves it past 10 % deserves that look: the spread above says
    # whether it is JPEG or chance. A transport fault (channels swapped, colour and depth
    # of different frames, a wrong scale) costs far more.
    assert ates["jpeg"] <= 1.10 * ates["folder"], "jpeg colour within 10 % of the folder's ATE"
    print(f"ros2 bags: all checks passed in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
