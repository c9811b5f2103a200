#!/usr/bin/env bash
# OpenCV's RGB-D odometry on a TUM-layout dataset, then its ATE and frame-to-frame error
# with `gfsvo eval`. Sets up its own venv from PyPI in target/opencv-venv
# (opencv-contrib-python-headless: the rgbd module is contrib; about 100 MB); not run
# by CI.
# usage: bash tests/peers/opencv.sh DATASET CONFIG.toml OUT.txt
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 DATASET CONFIG.toml OUT.txt" >&2; exit 2; }
root=$(cd "$(dirname "$0")/../.." && pwd)
venv=$root/target/opencv-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import cv2, scipy' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet opencv-contrib-python-headless==4.11.0.86 scipy
fi
"$venv/bin/python" "$root/tests/peers/opencv_odometry.py" "$1" "$2" "$3"
gfsvo=$root/target/release/gfsvo
[ -x "$gfsvo" ] || cargo build --release -p gfsvo --manifest-path "$root/Cargo.toml"
"$gfsvo" eval --gt "$1/groundtruth.txt" --est "$3"
