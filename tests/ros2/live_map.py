"""Map files over ROS 2, called by Cyclone DDS (run by interop.sh in its venv), on
../shared/data/tum_fr1_rpy_head300 published live to `gfsvo ros2` at 10 Hz (so that a
loaded machine tracks every frame, as live_reset.py):

1. Mapping, `gfsvo ros2 --save-map FILE`, frames 0-199: /initialpose at frame 60 is
   ignored with a warning naming the topic (a pose hint needs a loaded map to localise
   in); /gfsvo/save_map (std_srvs/srv/Trigger, a Cyclone service client) called with
   frame 199 answers success with the file, its keyframes and bytes; before the node
   stops (which writes the file again), the file has those bytes: the service wrote it.
2. Localising in a copy of that file, `gfsvo ros2 --load-map COPY --localize`, frames
   100-199 (the file loads): /gfsvo/save_map answers false, naming --save-map; an
   /initialpose in `odom` is refused naming the topic and the stamp; an /initialpose in
   `map` 2 cm from the first run's pose of frame 120: the tracker relocalises near it,
   and every /odom from 5 frames later on is within 5 cm of the first run's /odom of
   the same frame (the map's frame: the first run's odometry is its map's frame).
"""
import math
import re
import shutil
import time

import tum

from harness import loopback_cyclone
from live_checks import DATA, REPO, WORK, live

MAPPED = 200
START = 100
HINT_AT = 120
HINT_OFFSET_M = 0.02
SETTLE = 5
CLOSE_M = 0.05


def main():
    WORK.mkdir(parents=True, exist_ok=True)
    loopback_cyclone(WORK)
    t0 = time.time()
    tum1 = REPO / "configs" / "tum1.toml"
    saved, copy = WORK / "live_map.gfsmap", WORK / "live_map_copy.gfsmap"
    for f in (saved, copy):
        f.unlink(missing_ok=True)

    copied = {}

    def keep_the_asked_file():
        copied["bytes"] = saved.stat().st_size if saved.exists() else None
        if saved.exists():
            shutil.copy(saved, copy)

    peer = ["--rate", "10", "--frames", str(MAPPED), "--control", "60:hint:0,0,0,0,0,0,1",
            "--control", f"{MAPPED - 1}:save"]
    summary, _, mapped, text = live("map_save", DATA, tum1, peer, ["--save-map", saved],
                                    before_stop=keep_the_asked_file)
    hint, call = summary["controls"]
    print(f"mapping: /gfsvo/save_map replied after {call.get('replied_s', float('nan')):.3f} s: "
          f"success {call.get('success')}, {call.get('message')!r}; the file had "
          f"{copied['bytes']} bytes before the node stopped", flush=True)
    assert call.get("success") is True, "the map was saved"
    found = re.fullmatch(r"(.+): (\d+) keyframes, (\d+) bytes", call["message"])
    assert found and found.group(1) == str(saved), "the reply names the file"
    keyframes, size = int(found.group(2)), int(found.group(3))
    assert keyframes >= 5 and copied["bytes"] == size, "the file the reply names, as it says"
    ignored = [line for line in text.splitlines() if "/initialpose" in line and "ignored" in line]
    print(f"mapping: /initialpose at frame {hint['frame']}: {[line[-90:] for line in ignored]}",
          flush=True)
    assert len(ignored) == 1 and "panicked" not in text

    frames = list(tum.frames(DATA))
    first = {round(o["stamp"], 6): o["pose"] for o in mapped}
    stamp_of = [round(float(t), 6) for t, _, _, _ in frames]
    truth = first[stamp_of[HINT_AT]]
    given = [truth[0] + HINT_OFFSET_M, *truth[1:]]
    values = ",".join(map(str, given))
    peer = ["--rate", "10", "--start", str(START), "--frames", str(MAPPED - START),
            "--control", "5:odomhint:" + values, "--control", "10:save",
            "--control", f"{HINT_AT - START}:hint:" + values]
    log = ["--log", "warn,gfs_pipeline::stages::tracker=info"]
    summary, out, localised, text = live("map_localise", DATA, tum1, peer,
                                         ["--load-map", copy, "--localize", *log])
    refused_hint, refused_save, _ = summary["controls"]
    print(f"localising: /gfsvo/save_map without --save-map: success "
          f"{refused_save.get('success')}, {refused_save.get('message')!r}", flush=True)
    assert refused_save.get("success") is False and "--save-map" in refused_save["message"]
    refused = [line for line in text.splitlines() if "pose hint refused" in line]
    stamp = f"{frames[START + refused_hint['frame']][0]}"
    print(f"localising: /initialpose in odom: {[line[-120:] for line in refused]}", flush=True)
    assert len(refused) == 1 and "/initialpose" in refused[0] and stamp[:14] in refused[0]
    near = [line for line in text.splitlines() if "relocalising near the pose hint" in line]
    assert len(near) == 1, f"the tracker took the hint once: {near}"

    errors = []
    for o in localised:
        index = stamp_of.index(round(o["stamp"], 6))
        if index >= HINT_AT + SETTLE:
            errors.append((index, math.dist(o["pose"][:3], first[round(o["stamp"], 6)][:3])))
    worst = max(errors, key=lambda e: e[1])
    rms = math.sqrt(sum(e * e for _, e in errors) / len(errors))
    print(f"localising: {len(localised)} /odom for {summary['frames']} frames; from frame "
          f"{HINT_AT + SETTLE} on {len(errors)}, off the first run's by {100 * rms:.2f} cm RMS, "
          f"at most {100 * worst[1]:.2f} cm (frame {worst[0]})", flush=True)
    assert len(errors) >= 0.9 * (MAPPED - HINT_AT - SETTLE), "/odom for the frames after the hint"
    assert worst[1] < CLOSE_M, "every /odom after the hint in the map's frame, near the first run's"
    assert all(o["frame_id"] == "odom" for o in localised)
    print(f"ros2 map: all checks passed in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
