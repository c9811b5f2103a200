"""A Cyclone DDS viewer of the visualisation topics (run by live_visualisation.py, in a
process of its own so that decoding them does not hold up the camera peer): subscribes
to the /gfsvo/* topics with reliable QoS, as RViz does, until SIGINT / SIGTERM, then
writes what each message held as JSON.

Usage: visualisation_peer.py OUT.json"""
import json
import os
import signal
import sys
import time
from dataclasses import dataclass

import numpy as np
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.internal import InvalidSample
from cyclonedds.idl.types import float32, int32, sequence, uint8, uint32
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from cyclone_peer import CompressedImage, Header, Image, Point, Pose, Vector3


@dataclass
class PointField(IdlStruct, typename="sensor_msgs::msg::dds_::PointField_"):
    name: str
    offset: uint32
    datatype: uint8
    count: uint32


@dataclass
class PointCloud2(IdlStruct, typename="sensor_msgs::msg::dds_::PointCloud2_"):
    header: Header
    height: uint32
    width: uint32
    fields: sequence[PointField]
    is_bigendian: bool
    point_step: uint32
    row_step: uint32
    data: sequence[uint8]
    is_dense: bool


@dataclass
class ColorRGBA(IdlStruct, typename="std_msgs::msg::dds_::ColorRGBA_"):
    r: float32
    g: float32
    b: float32
    a: float32


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32
    nanosec: uint32


@dataclass
class UVCoordinate(IdlStruct, typename="visualization_msgs::msg::dds_::UVCoordinate_"):
    u: float32
    v: float32


@dataclass
class MeshFile(IdlStruct, typename="visualization_msgs::msg::dds_::MeshFile_"):
    filename: str
    data: sequence[uint8]


@dataclass
class Marker(IdlStruct, typename="visualization_msgs::msg::dds_::Marker_"):
    header: Header
    ns: str
    id: int32
    type: int32
    action: int32
    pose: Pose
    scale: Vector3
    color: ColorRGBA
    lifetime: Duration
    frame_locked: bool
    points: sequence[Point]
    colors: sequence[ColorRGBA]
    texture_resource: str
    texture: CompressedImage
    uv_coordinates: sequence[UVCoordinate]
    text: str
    mesh_resource: str
    mesh_file: MeshFile
    mesh_use_embedded_materials: bool


@dataclass
class MarkerArray(IdlStruct, typename="visualization_msgs::msg::dds_::MarkerArray_"):
    markers: sequence[Marker]


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@dataclass
class NavPath(IdlStruct, typename="nav_msgs::msg::dds_::Path_"):
    header: Header
    poses: sequence[PoseStamped]


class Visualisation:
    """Readers of the /gfsvo/* topics; `seen` holds what each message carried."""

    def __init__(self, dp, qos):
        topic = lambda name, kind: DataReader(dp, Topic(dp, "rt/gfsvo/" + name, kind), qos=qos)  # noqa: E731
        self.readers = {"landmarks": topic("landmarks", PointCloud2),
                        "frame_points": topic("frame_points", PointCloud2),
                        "structure": topic("structure", MarkerArray),
                        "keyframes": topic("keyframes", NavPath),
                        "path": topic("path", NavPath),
                        "tracking_image": topic("tracking_image", Image)}
        self.seen = {name: [] for name in self.readers}

    @staticmethod
    def stamp(header):
        return header.stamp.sec + header.stamp.nanosec * 1e-9

    def take(self):
        now = time.time()
        for name, reader in self.readers.items():
            for m in reader.take(N=50):
                if isinstance(m, InvalidSample):  # a writer gone (the run's end)
                    continue
                entry = {"received": now, "stamp": self.stamp(m.header) if hasattr(m, "header") else 0.0}
                if isinstance(m, PointCloud2):
                    raw = np.array(m.data, dtype=np.uint8).tobytes()
                    xyz = np.frombuffer(raw, dtype="<f4").reshape(-1, 4)[:, :3]
                    entry.update(frame_id=m.header.frame_id, width=m.width,
                                 finite=bool(np.isfinite(xyz).all()),
                                 min_z=float(xyz[:, 2].min()) if len(xyz) else 0.0,
                                 sample=xyz[::max(1, len(xyz) // 200)].astype(float).tolist())
                elif isinstance(m, MarkerArray):
                    entry.update(stamp=self.stamp(m.markers[0].header) if m.markers else 0.0,
                                 markers={k.ns: len(k.points) for k in m.markers})
                elif isinstance(m, NavPath):
                    entry.update(frame_id=m.header.frame_id,
                                 poses=[self.stamp(p.header) for p in m.poses])
                else:
                    entry.update(frame_id=m.header.frame_id, width=m.width, height=m.height,
                                 encoding=m.encoding, bytes=len(m.data))
                self.seen[name].append(entry)


def main():
    dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0") or 0))
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                   Policy.History.KeepLast(50), xcdr1)
    shown = Visualisation(dp, reliable)
    stop = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(True))
    while not stop:
        shown.take()
        time.sleep(0.005)
    with open(sys.argv[1], "w") as f:
        json.dump(shown.seen, f)


if __name__ == "__main__":
    main()
