"""The frames of a TUM RGB-D folder as numpy arrays: colour (rgb8) and depth (raw 16-bit)."""
from pathlib import Path

import numpy as np
from PIL import Image

# configs/tum1.toml: the camera of the folder (what a driver's CameraInfo would carry).
FR1 = dict(fx=517.306408, fy=516.469215, cx=318.643040, cy=255.313989,
           d=[0.262383, -0.953104, -0.005358, 0.002628, 1.163314])
TUM_DEPTH_SCALE = 5000.0


def frames(folder):
    """(colour stamp, depth stamp, rgb path, depth path) per line of associations.txt; the
    stamps as their text (1305031102.175304), for `stamp` to read exactly."""
    folder = Path(folder)
    for line in (folder / "associations.txt").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        t_rgb, rgb, t_depth, depth = line.split()[:4]
        yield t_rgb, t_depth, folder / rgb, folder / depth


def rgb8(path):
    return np.ascontiguousarray(np.asarray(Image.open(path).convert("RGB"), dtype=np.uint8))


def depth_raw(path):
    return np.asarray(Image.open(path), dtype=np.uint16)


def stamp(text):
    """(sec, nanosec) of a stamp in decimal seconds, exactly (no float on the way)."""
    whole, _, fraction = text.partition(".")
    return int(whole), int((fraction + "000000000")[:9])


def nine_digit_stamp(i, base_sec=1700000000):
    """(sec, nanosec) of frame i on a clock whose every stamp has nine non-zero nanosecond
    digits: 27 frames a second in [0.12 s, 0.99 s), each zero digit then made a one (at
    most 11.2 ms later, so the stamps still increase)."""
    nominal = 120_000_000 + (i % 27) * 32_200_000 + 12_345
    return base_sec + i // 27, int(f"{nominal:09d}".replace("0", "1"))
