"""The reset service and topic, called by Cyclone DDS (run by interop.sh in its venv), on
../shared/data/tum_fr1_rpy_head300 published live to `gfsvo ros2` at 10 Hz (so that a
loaded machine still tracks every frame: at 30 Hz with a load of 10 on two cores, frames
were dropped, tracking was lost and long outages started maps of their own):

- frame 45 (the camera turned about 100 degrees from the first frame, where a map that
  restarted the odometry would put it back): /gfsvo/reset (std_srvs/srv/Empty, a
  Cyclone service client): the reply comes, a new map starts (/diagnostics: "maps
  started" higher a second after the call than before it) and /odom goes on from the last pose:
  from 30 frames before the call to 30 after, each step between two /odom moves as the
  ground truth does within 5 cm and 10 degrees.
- frames 150 and 160: /gfsvo/reset_to_pose with a NaN position, then with a quaternion of
  norm 2: each refused with a warning naming the topic; no new map, no panic.
- frame 210: /gfsvo/reset_to_pose with the base at (1, 2, 0) m turned 90 degrees about z
  in odom: another map, and /odom goes on from exactly that pose (the only step of 50 cm
  or more of the run).

Throughout, every /odom stamp comes after the one before (received in order). Which frame
a request applies to depends on how far behind the tracker is (realtime): the checks
look around the frame it was made at, not at one frame.
"""
import bisect
import json
import math
import time

import numpy as np

from harness import loopback_cyclone
from live_checks import DATA, REPO, WORK, live

TOPIC = "/gfsvo/reset_to_pose"
GIVEN = [1.0, 2.0, 0.0, 0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)]
STEP_M = 0.05
STEP_DEG = 10.0
JUMP_M = 0.5
AROUND = 30


def matrix(pose):
    """4x4 of x y z qx qy qz qw."""
    x, y, z, qx, qy, qz, qw = pose
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                 [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                 [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
    m[:3, 3] = [x, y, z]
    return m


# The base in odom is B T_wc B^-1 (docs/ros2.md, Frames): the default camera in base.
BASE = matrix([0.0, 0.0, 0.0, -0.5, 0.5, -0.5, 0.5])


def ground_truth():
    """The base pose of the ground truth nearest to a stamp (100 Hz)."""
    rows = [list(map(float, line.split())) for line in (DATA / "groundtruth.txt").read_text().splitlines()
            if line and not line.startswith("#")]
    stamps = [r[0] for r in rows]

    def at(t):
        i = bisect.bisect_left(stamps, t)
        i = min((k for k in (i - 1, i) if 0 <= k < len(rows)), key=lambda k: abs(stamps[k] - t))
        return BASE @ matrix(rows[i][1:]) @ np.linalg.inv(BASE)
    return at


def step_errors(poses, truth):
    """(frame, cm, degrees) per consecutive pair of /odom: how far its step is from the
    ground truth's between the same two frames."""
    out = []
    for (_, ta, pa), (b, tb, pb) in zip(poses, poses[1:]):
        odom = np.linalg.inv(matrix(pa)) @ matrix(pb)
        true = np.linalg.inv(truth(ta)) @ truth(tb)
        e = np.linalg.inv(odom) @ true
        angle = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(e[:3, :3]) - 1) / 2))))
        out.append((b, 100 * float(np.linalg.norm(e[:3, 3])), angle))
    return out


def main():
    WORK.mkdir(parents=True, exist_ok=True)
    loopback_cyclone(WORK)
    t0 = time.time()
    diag_file = WORK / "reset.diagnostics.jsonl"
    controls = ["45:reset", "150:pose:nan,0,0,0,0,0,1", "160:pose:0,0,0,0,0,0,2",
                "210:pose:" + ",".join(map(str, GIVEN))]
    peer_args = ["--diagnostics", diag_file, "--rate", "10"]
    for c in controls:
        peer_args += ["--control", c]
    summary, _, odom, text = live("reset", DATA, REPO / "configs" / "tum1.toml", peer_args)

    reset = next(c for c in summary["controls"] if c["kind"] == "reset")
    print(f"/gfsvo/reset called at frame {reset['frame']}: reply after "
          f"{reset.get('replied_s', float('nan')):.3f} s", flush=True)
    assert "replied_s" in reset, "the reset service replied"

    reports = [(r["received"], int(r["values"]["maps started"]), int(r["values"]["keyframes in map"]))
               for r in (json.loads(line) for line in diag_file.read_text().splitlines())
               if "maps started" in r["values"]]
    print(f"/diagnostics (maps started, keyframes in map): {[r[1:] for r in reports]}", flush=True)
    for call in summary["controls"]:
        before = [r for r in reports if r[0] < call["sent"]]
        after = [r for r in reports if r[0] > call["sent"] + 1.5]
        new_map = bool(before and after and after[0][1] > before[-1][1])
        print(f"frame {call['frame']} {call['kind']} {call['values'] or ''}: maps started "
              f"{before[-1][1:] if before else None} before, {after[0][1:] if after else None} "
              f"1.5 s after", flush=True)
        valid = call["kind"] == "reset" or all(math.isfinite(v) for v in call["values"]) and \
            abs(math.hypot(*call["values"][3:]) - 1) < 1e-3
        assert new_map or not valid, "a new map after each valid request"

    refused = [line for line in text.splitlines() if TOPIC in line and "reset refused" in line]
    print(f"refused: {len(refused)}: {[line[-110:] for line in refused]}", flush=True)
    assert len(refused) == 2 and "not finite" in refused[0] and "norm is 2.0000" in refused[1]
    assert "panicked" not in text

    order = [tuple(k) for k in summary["received_order"]]
    assert all(a < b for a, b in zip(order, order[1:])), "/odom stamps increase as received"
    frame_of = {tuple(k): i for i, k in enumerate(summary["published"])}
    poses = sorted((frame_of[(o["sec"], o["nanosec"])], o["stamp"], o["pose"]) for o in odom)
    errors = step_errors(poses, ground_truth())
    around = [e for e in errors if abs(e[0] - reset["frame"]) <= AROUND]
    worst_cm = max(e[1] for e in around)
    worst_deg = max(e[2] for e in around)
    print(f"/odom: {len(poses)} poses; frames {reset['frame'] - AROUND}..{reset['frame'] + AROUND} "
          f"({len(around)} steps): step off the ground truth's by at most {worst_cm:.2f} cm, "
          f"{worst_deg:.2f} degrees", flush=True)
    assert worst_cm < 100 * STEP_M and worst_deg < STEP_DEG, "/odom goes on from the last pose"

    steps = [(b, float(np.linalg.norm(np.subtract(pb[:3], pa[:3]))))
             for (_, _, pa), (b, _, pb) in zip(poses, poses[1:])]
    jumps = [(b, round(s, 3)) for b, s in steps if s >= JUMP_M]
    print(f"/odom steps of {100 * JUMP_M:.0f} cm or more (frame, m): {jumps}", flush=True)
    assert len(jumps) == 1, "one jump: to the pose given at frame 210"
    landed = dict((f, p) for f, _, p in poses)[jumps[0][0]]
    # q and -q are the same rotation.
    error = min(float(np.abs(np.subtract(landed, [*GIVEN[:3], *(sign * v for v in GIVEN[3:])])).max())
                for sign in (1, -1))
    print(f"reset_to_pose: /odom of frame {jumps[0][0]} at {np.round(landed, 4).tolist()}, "
          f"{error:.1e} from the pose given", flush=True)
    assert error < 1e-6, "/odom goes on from the given pose"
    print(f"ros2 reset: all checks passed in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
