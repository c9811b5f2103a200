"""The ROS 2 camera driver and navigation stack that no one here wrote: Eclipse Cyclone
DDS (PyPI cyclonedds) publishes a TUM folder at 30 Hz as sensor_msgs/Image (rgb8 and
16UC1 millimetres, REP 118) + CameraInfo on the realsense topics, and subscribes to
/odom. Prints frames received and the latency colour published -> odometry received;
writes the /odom poses as JSON lines.

Usage: cyclone_peer.py FOLDER OUT.jsonl [--rate 30] [--wait-match 60] [--frames N]
       [--stamps tum|nine] [--diagnostics DIAG.jsonl] [--distortion-model NAME]
       [--compressed] [--imu]
       [--start N] [--control FRAME:reset | FRAME:pose:x,y,z,qx,qy,qz,qw | FRAME:save
       | FRAME:hint:x,y,z,qx,qy,qz,qw | FRAME:odomhint:x,y,z,qx,qy,qz,qw ...]

The CameraInfo is the folder's camera: its synthetic.toml `[camera]` (any lens model)
when it has one, else TUM freiburg1's. `--stamps nine` stamps the frames on a clock
whose nanoseconds have nine non-zero digits (tum.nine_digit_stamp).

--compressed publishes as image_transport's plugins do: sensor_msgs/CompressedImage,
png colour on <colour>/compressed (`rgb8; png compressed bgr8`), compressedDepth png of
the millimetres on <depth>/compressedDepth (`16UC1; compressedDepth png`, its 12-byte
header first).

--imu publishes the folder's imu.txt on /camera/imu (sensor_msgs/Imu, RealSense's
unified topic), before each frame the samples up to its stamp and the first past it
(as a driver's IMU arrives ahead of the images); the count goes into the summary.

--control calls the reset service /gfsvo/reset (std_srvs/srv/Empty, as rmw_cyclonedds
maps a service onto DDS: rq/gfsvo/resetRequest and rr/gfsvo/resetReply, the client's id
and the call's number before the request) or publishes a base pose in odom on
/gfsvo/reset_to_pose (geometry_msgs/PoseWithCovarianceStamped) when frame FRAME is
published; `save` calls /gfsvo/save_map (std_srvs/srv/Trigger, mapped the same way),
`hint` publishes a base pose in map on /initialpose (as RViz's "2D Pose Estimate"),
`odomhint` the same in odom (which is refused). The summary lists each call and whether
its reply came (with a Trigger's success and message). `--start N` publishes the
folder from its frame N (FRAME counts from there).

Cyclone's Python writer must use XCDR1 to be read by RustDDS. Images are serialised by
hand (numpy bytes after the CDR header fields), once, before publishing starts: the IDL
serialiser writes a uint8 sequence element by element, too slow for 30 Hz in Python."""
import argparse
import io
import itertools
import json
import tomllib
import os
import struct
import subprocess
import threading
import time
from dataclasses import dataclass

import numpy as np
from PIL import Image as PilImage
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int32, int64, sequence, uint8, uint32, uint64
from pathlib import Path
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

import tum


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


class Cdr:
    """Little-endian CDR (XCDR1) written field by field, aligned from after the header."""

    def __init__(self):
        self.parts = [b"\x00\x01\x00\x00"]
        self.n = 0

    def _put(self, b):
        self.parts.append(b)
        self.n += len(b)

    def align(self, k):
        pad = (-self.n) % k
        if pad:
            self._put(b"\0" * pad)

    def u32(self, v, fmt="<I"):
        self.align(4)
        self._put(struct.pack(fmt, v))

    def u8(self, v):
        self._put(struct.pack("<B", v))

    def string(self, s):
        b = s.encode() + b"\0"
        self.u32(len(b))
        self._put(b)

    def f64s(self, values):
        self.align(8)
        self._put(np.asarray(values, dtype="<f8").tobytes())

    def header(self, sec, nanosec, frame):
        self.u32(sec, "<i")
        self.u32(nanosec)
        self.string(frame)

    def bytes(self):
        return b"".join(self.parts)


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]

    def serialize(self, buffer=None, endianness=None, use_version_2=None):
        return self.data  # the whole payload, built by image_payload


@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header
    format: str
    data: sequence[uint8]

    def serialize(self, buffer=None, endianness=None, use_version_2=None):
        return self.data  # the whole payload, built by compressed_payload


def compressed_payload(sec, nanosec, frame, fmt, data):
    c = Cdr()
    c.header(sec, nanosec, frame)
    c.string(fmt)
    c.u32(len(data))
    c._put(data)
    return c.bytes()


def png(pixels):
    buffer = io.BytesIO()
    PilImage.fromarray(pixels).save(buffer, format="PNG")
    return buffer.getvalue()


def image_payload(sec, nanosec, frame, pixels, encoding, bytes_per_pixel):
    h, w = pixels.shape[:2]
    c = Cdr()
    c.header(sec, nanosec, frame)
    c.u32(h)
    c.u32(w)
    c.string(encoding)
    c.u8(0)
    c.u32(w * bytes_per_pixel)
    raw = np.ascontiguousarray(pixels).tobytes()
    c.u32(len(raw))
    c._put(raw)
    return c.bytes()


@dataclass
class RegionOfInterest(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32
    y_offset: uint32
    height: uint32
    width: uint32
    do_rectify: bool


@dataclass
class CameraInfo(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Header
    height: uint32
    width: uint32
    distortion_model: str
    d: sequence[float64]
    k: array[float64, 9]
    r: array[float64, 9]
    p: array[float64, 12]
    binning_x: uint32
    binning_y: uint32
    roi: RegionOfInterest


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class PoseWithCovarianceStamped(IdlStruct,
                                typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"):
    header: Header
    pose: PoseWithCovariance


@dataclass
class EmptyRequest(IdlStruct, typename="std_srvs::srv::dds_::Empty_Request_"):
    """rmw_cyclonedds's request: the client's id and the call's number, then the request
    (std_srvs/Empty: IDL's one byte of an empty structure)."""
    client: uint64
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class EmptyReply(IdlStruct, typename="std_srvs::srv::dds_::Empty_Response_"):
    client: uint64
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    client: uint64
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class TriggerReply(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    client: uint64
    seq: int64
    success: bool
    message: str


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header
    status: sequence[DiagnosticStatus]


@dataclass
class Imu(IdlStruct, typename="sensor_msgs::msg::dds_::Imu_"):
    header: Header
    orientation: Quaternion
    orientation_covariance: array[float64, 9]
    angular_velocity: Vector3
    angular_velocity_covariance: array[float64, 9]
    linear_acceleration: Vector3
    linear_acceleration_covariance: array[float64, 9]


def imu_samples(folder):
    """((sec, nanosec), gyro, accel) of each line of the folder's imu.txt."""
    out = []
    for line in (Path(folder) / "imu.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            f = line.split()
            sec, _, frac = f[0].partition(".")
            v = [float(x) for x in f[1:]]
            out.append(((int(sec), int((frac + "000000000")[:9])), v[:3], v[3:]))
    return out


def folder_camera(folder, model_override):
    """(width, height, model, D, fx, fy, cx, cy) of the folder's camera."""
    config = Path(folder) / "synthetic.toml"
    if config.is_file():
        cam = tomllib.loads(config.read_text())["camera"]
        model = cam.get("model", "plumb_bob")
        names = {"plumb_bob": ["k1", "k2", "p1", "p2", "k3"],
                 "rational_polynomial": ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
                 "equidistant": ["k1", "k2", "k3", "k4"]}[model]
        d = [float(cam.get(n, 0.0)) for n in names]
        size, k = (cam["width"], cam["height"]), (cam["fx"], cam["fy"], cam["cx"], cam["cy"])
    else:
        c = tum.FR1
        model, d, size, k = "plumb_bob", c["d"], (640, 480), (c["fx"], c["fy"], c["cx"], c["cy"])
    return (*size, model_override or model, d, *k)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("out")
    ap.add_argument("--rate", type=float, default=30.0)
    ap.add_argument("--wait-match", type=float, default=60.0)
    ap.add_argument("--linger", type=float, default=5.0)
    ap.add_argument("--on-frame", type=int, default=-1,
                    help="run --command when this frame is published (fault test)")
    ap.add_argument("--command", default="")
    ap.add_argument("--frames", type=int, default=0, help="publish only the first N frames")
    ap.add_argument("--start", type=int, default=0, help="publish from the folder's frame N")
    ap.add_argument("--stamps", choices=["tum", "nine"], default="tum")
    ap.add_argument("--diagnostics", help="write the /diagnostics received here (JSON lines)")
    ap.add_argument("--distortion-model", help="publish this model name in the CameraInfo")
    ap.add_argument("--compressed", action="store_true")
    ap.add_argument("--imu", action="store_true", help="publish imu.txt on /camera/imu")
    ap.add_argument("--control", action="append", default=[],
                    help="FRAME:reset, FRAME:pose:x,y,z,qx,qy,qz,qw (base in odom), FRAME:save, "
                         "FRAME:hint:x,y,z,qx,qy,qz,qw (base in map) or FRAME:odomhint:...")
    args = ap.parse_args()
    controls = {}
    for spec in args.control:
        frame_text, kind, *rest = spec.split(":")
        controls[int(frame_text)] = (kind, [float(v) for v in rest[0].split(",")] if rest else None)

    frame = "camera_color_optical_frame"
    frames = []
    t0 = time.time()
    for i, (t_rgb, t_depth, rgb_path, depth_path) in enumerate(itertools.islice(tum.frames(args.folder), args.start, None)):
        if args.frames and i >= args.frames:
            break
        sec, ns = tum.stamp(t_rgb)
        dsec, dns = tum.stamp(t_depth)
        if args.stamps == "nine":
            sec, ns = dsec, dns = tum.nine_digit_stamp(i)
        # REP 118: 16UC1 in millimetres (TUM stores 5000 units per metre).
        mm = np.round(tum.depth_raw(depth_path).astype(np.float64) / 5.0).astype("<u2")
        if args.compressed:
            header = struct.pack("<iff", 0, 0.0, 0.0)
            frames.append((t_rgb, sec, ns,
                           compressed_payload(sec, ns, frame, "rgb8; png compressed bgr8",
                                              png(tum.rgb8(rgb_path))),
                           compressed_payload(dsec, dns, frame, "16UC1; compressedDepth png",
                                              header + png(mm.astype(np.uint16)))))
            continue
        frames.append((t_rgb, sec, ns,
                       image_payload(sec, ns, frame, tum.rgb8(rgb_path), "rgb8", 3),
                       image_payload(dsec, dns, frame, mm, "16UC1", 2)))
    print(f"cyclone: {len(frames)} frames loaded in {time.time() - t0:.1f} s", flush=True)

    dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0") or 0))
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    sensor = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(5), xcdr1)
    reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                   Policy.History.KeepLast(50), xcdr1)
    if args.compressed:
        message = lambda payload: CompressedImage(None, "", payload)  # noqa: E731
        colour_w = DataWriter(dp, Topic(dp, "rt/camera/color/image_raw/compressed", CompressedImage),
                              qos=sensor)
        depth_w = DataWriter(dp, Topic(dp, "rt/camera/aligned_depth_to_color/image_raw/compressedDepth",
                                       CompressedImage), qos=sensor)
    else:
        message = lambda payload: Image(None, 0, 0, "", 0, 0, payload)  # noqa: E731
        colour_w = DataWriter(dp, Topic(dp, "rt/camera/color/image_raw", Image), qos=sensor)
        depth_w = DataWriter(dp, Topic(dp, "rt/camera/aligned_depth_to_color/image_raw", Image), qos=sensor)
    info_w = DataWriter(dp, Topic(dp, "rt/camera/color/camera_info", CameraInfo), qos=sensor)
    imu = imu_samples(args.folder) if args.imu else []
    imu_w = DataWriter(dp, Topic(dp, "rt/camera/imu", Imu),
                       qos=Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(100), xcdr1))
    no_orientation = [-1.0] + [0.0] * 8
    imu_sent = 0
    odom_r = DataReader(dp, Topic(dp, "rt/odom", Odometry), qos=reliable)
    diag_r = DataReader(dp, Topic(dp, "rt/diagnostics", DiagnosticArray), qos=reliable)
    control_endpoints = []
    if controls:
        reset_w = DataWriter(dp, Topic(dp, "rq/gfsvo/resetRequest", EmptyRequest), qos=reliable)
        reply_r = DataReader(dp, Topic(dp, "rr/gfsvo/resetReply", EmptyReply), qos=reliable)
        pose_w = DataWriter(dp, Topic(dp, "rt/gfsvo/reset_to_pose", PoseWithCovarianceStamped),
                            qos=reliable)
        save_w = DataWriter(dp, Topic(dp, "rq/gfsvo/save_mapRequest", TriggerRequest), qos=reliable)
        saved_r = DataReader(dp, Topic(dp, "rr/gfsvo/save_mapReply", TriggerReply), qos=reliable)
        hint_w = DataWriter(dp, Topic(dp, "rt/initialpose", PoseWithCovarianceStamped), qos=reliable)
        control_endpoints = [reset_w.get_matched_subscriptions, reply_r.get_matched_publications,
                             pose_w.get_matched_subscriptions, save_w.get_matched_subscriptions,
                             saved_r.get_matched_publications, hint_w.get_matched_subscriptions]
        client_id = 0x5EED0000 + os.getpid()

    w, h, model, d, fx, fy, cx, cy = folder_camera(args.folder, args.distortion_model)

    def camera_info(sec, ns):
        return CameraInfo(Header(Time(sec, ns), frame), h, w, model, d,
                          [fx, 0, cx, 0, fy, cy, 0, 0, 1],
                          [1, 0, 0, 0, 1, 0, 0, 0, 1],
                          [fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0],
                          0, 0, RegionOfInterest(0, 0, 0, 0, False))

    # A driver publishes its CameraInfo from the start (gfsvo ros2 reads the camera
    # from it before it starts the pipeline). /odom is volatile: a pose published before
    # its writer matched this reader never comes, so wait for that match too.
    deadline = time.time() + args.wait_match
    while time.time() < deadline:
        if (colour_w.get_matched_subscriptions() and depth_w.get_matched_subscriptions()
                and odom_r.get_matched_publications() and all(m() for m in control_endpoints)):
            break
        info_w.write(camera_info(frames[0][1], frames[0][2]))
        time.sleep(0.1)
    else:
        raise SystemExit("cyclone: gfsvo-ros2 did not subscribe within the wait")
    time.sleep(1.0)

    published = {}
    received = {}
    order = []
    diagnostics = []
    calls = []
    stop = threading.Event()

    def read_odom():
        while not stop.is_set():
            if controls:
                for r in reply_r.take(N=10) + saved_r.take(N=10):
                    for call in calls:
                        if (r.client, r.seq) == (client_id, call["seq"]):
                            call["replied_s"] = time.time() - call["sent"]
                            if isinstance(r, TriggerReply):
                                call["success"], call["message"] = r.success, r.message
            for a in diag_r.take(N=10):
                for st in a.status:
                    diagnostics.append({"received": time.time(), "level": st.level,
                                        "message": st.message,
                                        "values": {kv.key: kv.value for kv in st.values}})
            for o in odom_r.take(N=100):
                now = time.time()
                key = (o.header.stamp.sec, o.header.stamp.nanosec)
                order.append(key)
                p, q = o.pose.pose.position, o.pose.pose.orientation
                received.setdefault(key, (now, [p.x, p.y, p.z, q.x, q.y, q.z, q.w],
                                          o.header.frame_id, o.child_frame_id,
                                          o.pose.covariance[0]))
            time.sleep(0.002)

    reader = threading.Thread(target=read_odom)
    reader.start()
    start = time.time()
    for i, (t_rgb, sec, ns, colour, depth) in enumerate(frames):
        due = start + i / args.rate
        while (now := time.time()) < due:
            time.sleep(min(0.002, due - now))
        info = camera_info(sec, ns)
        while imu_sent < len(imu) and (imu_sent == 0 or imu[imu_sent - 1][0] <= (sec, ns)):
            (isec, ins), g, a = imu[imu_sent]
            imu_w.write(Imu(Header(Time(isec, ins), "camera_imu_optical_frame"),
                            Quaternion(0.0, 0.0, 0.0, 1.0), no_orientation, Vector3(*g),
                            [0.0] * 9, Vector3(*a), [0.0] * 9))
            imu_sent += 1
        published[(sec, ns)] = time.time()
        colour_w.write(message(colour))
        depth_w.write(message(depth))
        if i % 30 == 0:
            info_w.write(info)
        if i == args.on_frame and args.command:
            subprocess.Popen(args.command, shell=True)
        if i in controls:
            kind, values = controls[i]
            call = {"frame": i, "kind": kind, "values": values, "sent": time.time(),
                    "seq": len(calls) + 1}
            if kind == "reset":
                reset_w.write(EmptyRequest(client_id, call["seq"], 0))
            elif kind == "save":
                save_w.write(TriggerRequest(client_id, call["seq"], 0))
            else:
                x, y, z, qx, qy, qz, qw = values
                writer, in_frame = {"pose": (pose_w, "odom"), "hint": (hint_w, "map"),
                                    "odomhint": (hint_w, "odom")}[kind]
                writer.write(PoseWithCovarianceStamped(
                    Header(Time(sec, ns), in_frame),
                    PoseWithCovariance(Pose(Point(x, y, z), Quaternion(qx, qy, qz, qw)), [0.0] * 36)))
            calls.append(call)
    print(f"cyclone: published {len(frames)} frames in {time.time() - start:.1f} s", flush=True)
    time.sleep(args.linger)
    stop.set()
    reader.join()

    latencies = sorted(1e3 * (received[k][0] - published[k]) for k in received if k in published)
    with open(args.out, "w") as f:
        for (sec, ns), (_, pose, frame_id, child, var_x) in sorted(received.items()):
            f.write(json.dumps({"stamp": sec + ns * 1e-9, "sec": sec, "nanosec": ns,
                                "pose": pose, "frame_id": frame_id,
                                "child_frame_id": child, "var_x": var_x}) + "\n")
    if args.diagnostics:
        with open(args.diagnostics, "w") as f:
            f.writelines(json.dumps(d) + "\n" for d in diagnostics)
    share = len(latencies) / len(frames)
    with open(args.out + ".summary.json", "w") as f:
        json.dump({"frames": len(frames), "received": len(latencies), "imu_sent": imu_sent,
                   "latency_ms": latencies, "published": sorted(published),
                   "unmatched": sorted(k for k in received if k not in published),
                   "received_order": order, "controls": calls}, f)
    p = lambda q: latencies[min(len(latencies) - 1, int(q * len(latencies)))] if latencies else float("nan")
    print(f"cyclone: /odom received for {len(latencies)} of {len(frames)} frames ({100 * share:.1f} %); "
          f"latency colour published -> /odom received p50 {p(0.5):.1f} ms, p99 {p(0.99):.1f} ms",
          flush=True)


if __name__ == "__main__":
    main()
