"""The frames of a TUM RGB-D folder as numpy arrays: colour (rgb8) and depth (raw 16-bit)."""
from pathlib import Path

import numpy as np
from PIL import Image

# configs/tum1.toml: the camera of the folder (what a driver's CameraInfo would carry).
FR1 = dict(fx=517.306408, fy=516.469215, cx=318.643040, cy=255.313989,
           d=[0.262383, -0.953104, -0.005358, 0.002628, 1.163314])
TUM_DEPTH_SCALE = 5000.0


def frames(folder):
    """(colour stamp, depth stamp, rgb path, depth path) per line of associations.txt."""
    folder = Path(folder)
    for line in (folder / "associations.txt").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        t_rgb, rgb, t_depth, depth = line.split()[:4]
        yield float(t_rgb), float(t_depth), folder / rgb, folder / depth


def rgb8(path):
    return np.ascontiguousarray(np.asarray(Image.open(path).convert("RGB"), dtype=np.uint8))


def depth_raw(path):
    return np.asarray(Image.open(path), dtype=np.uint16)


def stamp(seconds):
    """(sec, nanosec) of a stamp as Time.from_secs rounds it."""
    whole = int(seconds // 1)
    total = whole * 1_000_000_000 + int(round((seconds - whole) * 1e9))
    return total // 1_000_000_000, total % 1_000_000_000
