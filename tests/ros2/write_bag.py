"""Writes a TUM folder as a ROS 2 bag (MCAP) with PyPI rosbags, not with this project:
rgb8 colour, 32FC1 depth in metres (REP 118; raw / 5000 in float64, then float32, as the
folder reader computes it) or with --depth-mm 16UC1 millimetres, CameraInfo with the
fr1 calibration.

Usage: write_bag.py FOLDER OUT_BAG [--depth-mm]"""
import sys

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

import tum

folder, out = sys.argv[1], sys.argv[2]
millimetres = "--depth-mm" in sys.argv[3:]
ts = get_typestore(Stores.ROS2_HUMBLE)
Image = ts.types["sensor_msgs/msg/Image"]
CameraInfo = ts.types["sensor_msgs/msg/CameraInfo"]
Header = ts.types["std_msgs/msg/Header"]
Time = ts.types["builtin_interfaces/msg/Time"]
Roi = ts.types["sensor_msgs/msg/RegionOfInterest"]
c = tum.FR1
with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
    topics = {
        "c": bag.add_connection("/camera/color/image_raw", Image.__msgtype__, typestore=ts),
        "d": bag.add_connection("/camera/aligned_depth_to_color/image_raw", Image.__msgtype__, typestore=ts),
        "i": bag.add_connection("/camera/color/camera_info", CameraInfo.__msgtype__, typestore=ts),
    }
    for t_rgb, t_depth, rgb_path, depth_path in tum.frames(folder):
        rgb = tum.rgb8(rgb_path)
        raw = tum.depth_raw(depth_path).astype(np.float64)
        metres = (raw / tum.TUM_DEPTH_SCALE).astype("<f4")
        mm = np.round(raw / tum.TUM_DEPTH_SCALE * 1000.0).astype("<u2")
        h, w = rgb.shape[:2]
        hc = Header(stamp=Time(*tum.stamp(t_rgb)), frame_id="camera_color_optical_frame")
        hd = Header(stamp=Time(*tum.stamp(t_depth)), frame_id="camera_color_optical_frame")
        colour = Image(header=hc, height=h, width=w, encoding="rgb8", is_bigendian=0,
                       step=3 * w, data=rgb.reshape(-1))
        if millimetres:
            depth = Image(header=hd, height=h, width=w, encoding="16UC1", is_bigendian=0,
                          step=2 * w, data=mm.view(np.uint8).reshape(-1))
        else:
            depth = Image(header=hd, height=h, width=w, encoding="32FC1", is_bigendian=0,
                          step=4 * w, data=metres.view(np.uint8).reshape(-1))
        k = np.array([c["fx"], 0, c["cx"], 0, c["fy"], c["cy"], 0, 0, 1], dtype=np.float64)
        p = np.array([c["fx"], 0, c["cx"], 0, 0, c["fy"], c["cy"], 0, 0, 0, 1, 0], dtype=np.float64)
        info = CameraInfo(header=hc, height=h, width=w, distortion_model="plumb_bob",
                          d=np.array(c["d"], dtype=np.float64), k=k, r=np.eye(3).reshape(-1), p=p,
                          binning_x=0, binning_y=0,
                          roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
        sec, nanosec = tum.stamp(t_rgb)
        ns = sec * 1_000_000_000 + nanosec
        bag.write(topics["i"], ns, ts.serialize_cdr(info, CameraInfo.__msgtype__))
        bag.write(topics["c"], ns, ts.serialize_cdr(colour, Image.__msgtype__))
        dsec, dnanosec = tum.stamp(t_depth)
        bag.write(topics["d"], dsec * 1_000_000_000 + dnanosec, ts.serialize_cdr(depth, Image.__msgtype__))
print(f"bag written: {out}")
