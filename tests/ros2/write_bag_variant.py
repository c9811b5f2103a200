"""Writes the first FRAMES frames of a TUM folder as a ROS 2 bag the way robots record
them, with implementations not of this project:

- zstd: rosbags, MCAP chunks zstd-compressed (rosbags' storage compression, what
  `ros2 bag record -s mcap` writes by default); rgb8 + 32FC1 metres.
- lz4: the PyPI mcap writer (rosbags writes no lz4 chunks), lz4 chunks; the payloads
  serialised by rosbags; a bare .mcap file; rgb8 + 32FC1 metres.
- nine: as zstd, on a clock whose every stamp has nine non-zero nanosecond digits
  (tum.nine_digit_stamp; each depth stamp as far from its colour stamp as in the folder).
- mm: rosbags, uncompressed; rgb8 + 16UC1 millimetres (the reference of the next two).
- png / jpeg: rosbags, zstd chunks; colour as image_transport's `compressed` plugin
  sends it on <colour>/compressed (PNG, or JPEG quality 95, its default; format
  `rgb8; png compressed bgr8`), depth as the `compressedDepth` plugin sends 16UC1 on
  <depth>/compressedDepth (`16UC1; compressedDepth png`: 12-byte ConfigHeader, then a
  16-bit PNG of the millimetres).

Usage: write_bag_variant.py FOLDER OUT KIND FRAMES"""
import io
import os
import struct
import sys
from itertools import islice

import numpy as np
from PIL import Image as PilImage
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.typesys import Stores, get_typestore

import tum

folder, out, kind, count = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
ts = get_typestore(Stores.ROS2_HUMBLE)
T = {name: ts.types[f"{pkg}/msg/{name}"] for pkg, name in [
    ("sensor_msgs", "Image"), ("sensor_msgs", "CompressedImage"), ("sensor_msgs", "CameraInfo"),
    ("sensor_msgs", "RegionOfInterest"), ("std_msgs", "Header"), ("builtin_interfaces", "Time")]}
COLOUR, DEPTH = "/camera/color/image_raw", "/camera/aligned_depth_to_color/image_raw"
INFO = "/camera/color/camera_info"
c = tum.FR1


def encoded(array, fmt, **options):
    buffer = io.BytesIO()
    PilImage.fromarray(array).save(buffer, format=fmt, **options)
    return np.frombuffer(buffer.getvalue(), dtype=np.uint8)


def messages():
    """(topic, type name, log time ns, message) of each frame, colour stamp first."""
    for i, (t_rgb, t_depth, rgb_path, depth_path) in enumerate(islice(tum.frames(folder), count)):
        rgb = tum.rgb8(rgb_path)
        raw = tum.depth_raw(depth_path).astype(np.float64)
        h, w = rgb.shape[:2]
        (sec_c, nsec_c), (sec_d, nsec_d) = tum.stamp(t_rgb), tum.stamp(t_depth)
        ns_c, ns_d = sec_c * 1_000_000_000 + nsec_c, sec_d * 1_000_000_000 + nsec_d
        if kind == "nine":
            sec_c, nsec_c = tum.nine_digit_stamp(i)
            ns_c, ns_d = sec_c * 1_000_000_000 + nsec_c, sec_c * 1_000_000_000 + nsec_c + ns_d - ns_c
            sec_d, nsec_d = divmod(ns_d, 1_000_000_000)
        hc = T["Header"](stamp=T["Time"](sec_c, nsec_c), frame_id="camera_color_optical_frame")
        hd = T["Header"](stamp=T["Time"](sec_d, nsec_d), frame_id="camera_color_optical_frame")
        k = np.array([c["fx"], 0, c["cx"], 0, c["fy"], c["cy"], 0, 0, 1], dtype=np.float64)
        p = np.array([c["fx"], 0, c["cx"], 0, 0, c["fy"], c["cy"], 0, 0, 0, 1, 0], dtype=np.float64)
        info = T["CameraInfo"](header=hc, height=h, width=w, distortion_model="plumb_bob",
                               d=np.array(c["d"], dtype=np.float64), k=k, r=np.eye(3).reshape(-1), p=p,
                               binning_x=0, binning_y=0,
                               roi=T["RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                         do_rectify=False))
        yield INFO, "CameraInfo", ns_c, info
        mm = np.round(raw / tum.TUM_DEPTH_SCALE * 1000.0).astype("<u2")
        if kind in ("png", "jpeg"):
            data = encoded(rgb, "PNG") if kind == "png" else encoded(rgb, "JPEG", quality=int(os.environ.get("JPEG_QUALITY", "95")))
            yield COLOUR + "/compressed", "CompressedImage", ns_c, T["CompressedImage"](
                header=hc, format=f"rgb8; {kind} compressed bgr8", data=data)
            config = np.frombuffer(struct.pack("<iff", 0, 0.0, 0.0), dtype=np.uint8)
            png = encoded(mm.astype(np.uint16), "PNG")
            yield DEPTH + "/compressedDepth", "CompressedImage", ns_d, T["CompressedImage"](
                header=hd, format="16UC1; compressedDepth png", data=np.concatenate([config, png]))
            continue
        yield COLOUR, "Image", ns_c, T["Image"](header=hc, height=h, width=w, encoding="rgb8",
                                                 is_bigendian=0, step=3 * w, data=rgb.reshape(-1))
        if kind == "mm":
            depth = T["Image"](header=hd, height=h, width=w, encoding="16UC1", is_bigendian=0,
                               step=2 * w, data=mm.view(np.uint8).reshape(-1))
        else:
            metres = (raw / tum.TUM_DEPTH_SCALE).astype("<f4")
            depth = T["Image"](header=hd, height=h, width=w, encoding="32FC1", is_bigendian=0,
                               step=4 * w, data=metres.view(np.uint8).reshape(-1))
        yield DEPTH, "Image", ns_d, depth


def write_rosbags():
    bag = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    if kind != "mm":
        bag.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with bag:
        connections = {}
        for topic, name, ns, message in messages():
            msgtype = T[name].__msgtype__
            if topic not in connections:
                connections[topic] = bag.add_connection(topic, msgtype, typestore=ts)
            bag.write(connections[topic], ns, ts.serialize_cdr(message, msgtype))


def write_mcap_lz4():
    from mcap.writer import CompressionType
    from mcap.writer import Writer as McapWriter
    with open(out, "wb") as stream:
        writer = McapWriter(stream, compression=CompressionType.LZ4)
        writer.start(profile="ros2", library="mcap (PyPI)")
        schemas, channels = {}, {}
        for topic, name, ns, message in messages():
            msgtype = T[name].__msgtype__
            if msgtype not in schemas:
                text, _ = ts.generate_msgdef(msgtype, ros_version=2)
                schemas[msgtype] = writer.register_schema(msgtype, "ros2msg", text.encode())
            if topic not in channels:
                channels[topic] = writer.register_channel(topic, "cdr", schemas[msgtype])
            writer.add_message(channels[topic], log_time=ns, publish_time=ns,
                               data=ts.serialize_cdr(message, msgtype))
        writer.finish()


if kind == "lz4":
    write_mcap_lz4()
elif kind in ("zstd", "nine", "mm", "png", "jpeg"):
    write_rosbags()
else:
    raise SystemExit(f"unknown kind {kind}")
print(f"{kind} bag written: {out}")
