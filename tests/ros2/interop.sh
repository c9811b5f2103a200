#!/usr/bin/env bash
# The ROS 2 interop tests (tests/ros2/bags.py, imu_bags.py, interop.py, live_checks.py,
# live_reset.py, live_map.py, live_compressed.py and live_visualisation.py say what they cover): sets up its own Python venv from PyPI (cached in target/ros2-venv), builds
# the executables, runs them.
# Skips with a reason when ../shared/data is absent. Loopback only.
set -euo pipefail
cd "$(dirname "$0")/../.."
DATA=../shared/data/tum_fr1_rpy_head300
if [ ! -d "$DATA" ]; then
  echo "ros2 interop: skipped: $DATA is absent"
  exit 0
fi
VENV=target/ros2-venv
PINS="cyclonedds==11.0.1 mcap==1.6.0 mcap-ros2-support==0.6.0 rosbags==0.11.9 numpy==2.4.6 pillow==13.0.0"
if [ "$(cat $VENV/pins 2>/dev/null)" != "$PINS" ]; then
  rm -rf "$VENV"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install --quiet --disable-pip-version-check $PINS
  echo "$PINS" > "$VENV/pins"
fi
cargo build --release --workspace --bins --quiet
"$VENV/bin/python" tests/ros2/bags.py
"$VENV/bin/python" tests/ros2/imu_bags.py
"$VENV/bin/python" tests/ros2/interop.py
"$VENV/bin/python" tests/ros2/live_checks.py
"$VENV/bin/python" tests/ros2/live_reset.py
"$VENV/bin/python" tests/ros2/live_map.py
"$VENV/bin/python" tests/ros2/live_compressed.py
"$VENV/bin/python" tests/ros2/live_visualisation.py
