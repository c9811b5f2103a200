#!/usr/bin/env bash
# Open3D's RGB-D odometry on a TUM-layout dataset, then its ATE with `gfsvo eval`: the
# peer of the low-texture ablation (docs/results.md). Sets up its own venv from PyPI in
# target/open3d-venv (about 500 MB); not run by CI.
# usage: bash tests/peers/open3d.sh DATASET CONFIG.toml OUT.txt
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 DATASET CONFIG.toml OUT.txt" >&2; exit 2; }
root=$(cd "$(dirname "$0")/../.." && pwd)
venv=$root/target/open3d-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet open3d==0.19.0 scipy
fi
"$venv/bin/python" "$root/tests/peers/open3d_odometry.py" "$1" "$2" "$3"
gfsvo=$root/target/release/gfsvo
[ -x "$gfsvo" ] || cargo build --release -p gfsvo --manifest-path "$root/Cargo.toml"
"$gfsvo" eval --gt "$1/groundtruth.txt" --est "$3"
