"""The IMU in bags (run by interop.sh in its venv), on a `gfsvo synth --imu 400` folder
(60 frames, a BMI055-like IMU at 400 Hz, imu.txt):

1. `gfsvo convert` writes imu.txt as /camera/imu (sensor_msgs/Imu), read back with PyPI
   rosbags: every sample's stamp (integer nanoseconds) and six values equal imu.txt's;
   the covariances say no orientation (-1 in element 0) and the config's noise (>0 on
   the diagonal).
2. `gfsvo run` of that bag: the tracker took in (`imu_samples` of --json) exactly the
   samples the frames span (from the last at or before the first frame to the first
   past the last one).
3. The bag rewritten by rosbags with the IMU as RealSense sends it without
   `unite_imu_method`: /camera/gyro/sample at 400 Hz and /camera/accel/sample at 100 Hz
   (every fourth sample); `gfsvo run` unites them at the gyroscope's stamps: the
   tracker took in the united samples the frames span (the values of the union are
   checked in gfs-ros2's imu tests).
"""
import json
import time
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from harness import GFSVO, REPO, sh

HERE = Path(__file__).resolve().parent
WORK = REPO / "target" / "ros2-test" / "imu"
FRAMES = 60


def nanos(text):
    sec, _, frac = text.partition(".")
    return int(sec) * 1_000_000_000 + int((frac + "000000000")[:9])


def imu_txt(folder):
    rows = []
    for line in (folder / "imu.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            f = line.split()
            rows.append((nanos(f[0]), [float(v) for v in f[1:]]))
    return rows


def read(bag, topics):
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic in topics]
        return [(c.topic, reader.deserialize(raw, c.msgtype))
                for c, _, raw in reader.messages(connections=conns)]


def stamp(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def spanned(stamps, frames):
    """How many of `stamps` the frames take in: the last at or before the first frame to
    the first past the last."""
    first = max(i for i, s in enumerate(stamps) if s <= frames[0])
    last = min(i for i, s in enumerate(stamps) if s > frames[-1])
    return last - first + 1


def imu_samples(bag, config, out):
    line = sh(GFSVO, "--log", "warn", "run", bag, "--config", config, "--out", out,
              "--json").strip().splitlines()[-1]
    return json.loads(line)["imu_samples"]


def split(bag, out):
    """`bag` with /camera/imu split into gyro (every sample) and accel (every fourth)."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    Imu = ts.types["sensor_msgs/msg/Imu"]
    Vector3 = ts.types["geometry_msgs/msg/Vector3"]
    zero = Vector3(x=0.0, y=0.0, z=0.0)
    with AnyReader([bag]) as reader, Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for c in reader.connections:
            if c.topic != "/camera/imu":
                conns[c.topic] = w.add_connection(c.topic, c.msgtype, typestore=ts)
        gyro = w.add_connection("/camera/gyro/sample", Imu.__msgtype__, typestore=ts)
        accel = w.add_connection("/camera/accel/sample", Imu.__msgtype__, typestore=ts)
        count = 0
        for c, t, raw in reader.messages():
            if c.topic != "/camera/imu":
                w.write(conns[c.topic], t, raw)
                continue
            m = reader.deserialize(raw, c.msgtype)
            g = Imu(header=m.header, orientation=m.orientation,
                    orientation_covariance=m.orientation_covariance,
                    angular_velocity=m.angular_velocity,
                    angular_velocity_covariance=m.angular_velocity_covariance,
                    linear_acceleration=zero,
                    linear_acceleration_covariance=m.linear_acceleration_covariance)
            w.write(gyro, t, ts.serialize_cdr(g, Imu.__msgtype__))
            if count % 4 == 0:
                a = Imu(header=m.header, orientation=m.orientation,
                        orientation_covariance=m.orientation_covariance,
                        angular_velocity=zero,
                        angular_velocity_covariance=m.angular_velocity_covariance,
                        linear_acceleration=m.linear_acceleration,
                        linear_acceleration_covariance=m.linear_acceleration_covariance)
                w.write(accel, t, ts.serialize_cdr(a, Imu.__msgtype__))
            count += 1


def main():
    t0 = time.time()
    sh("rm", "-rf", WORK)
    WORK.mkdir(parents=True)
    folder = WORK / "synth"
    sh(GFSVO, "synth", "--traj", "fast", "--imu", "400", "--frames", FRAMES, "--out", folder)
    bag = WORK / "bag"
    sh(GFSVO, "convert", folder, bag)

    rows = imu_txt(folder)
    messages = read(bag, {"/camera/imu", "/camera/color/image_raw"})
    imu = [m for topic, m in messages if topic == "/camera/imu"]
    frames = sorted(stamp(m) for topic, m in messages if topic == "/camera/color/image_raw")
    assert len(imu) == len(rows), f"{len(imu)} messages for {len(rows)} lines of imu.txt"
    for m, (ns, values) in zip(imu, rows):
        got = [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z,
               m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]
        assert stamp(m) == ns, f"stamp {stamp(m)} != {ns}"
        assert got == values, f"at {ns}: {got} != {values}"
        assert m.orientation_covariance[0] == -1.0
        assert m.angular_velocity_covariance[0] > 0 and m.linear_acceleration_covariance[8] > 0
    print(f"convert: {len(imu)} /camera/imu messages equal imu.txt's {len(rows)} lines "
          "(stamps to the nanosecond, values exactly)", flush=True)

    stamps = [ns for ns, _ in rows]
    expected = spanned(stamps, frames)
    taken = imu_samples(bag, folder / "synthetic.toml", WORK / "run_unified")
    print(f"/camera/imu bag: the tracker took in {taken} samples, {expected} expected", flush=True)
    assert taken == expected

    split_bag = WORK / "split_bag"
    split(bag, split_bag)
    accel = stamps[::4]
    united = [s for s in stamps if accel[0] <= s <= accel[-1]]
    expected = spanned(united, frames)
    taken = imu_samples(split_bag, folder / "synthetic.toml", WORK / "run_split")
    print(f"gyro 400 Hz + accel 100 Hz bag: the tracker took in {taken} united samples, "
          f"{expected} expected", flush=True)
    assert taken == expected
    sh("rm", "-rf", WORK)
    print(f"ros2 imu bags: all checks passed in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
