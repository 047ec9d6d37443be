"""Runs OpenCV's findCirclesGrid on the views written by `tests/circles.rs`
(`CIRCLES_DUMP=DIR cargo test -p parallax-corner-detection --test circles`) and compares with
the truth in parallax's order: found, same order as parallax (point k within 2 px of truth k),
reversed order (180°), and the centre RMS of OpenCV's centres.

    pip install opencv-python-headless numpy
    python3 circles_vs_opencv.py DIR
"""
import glob
import os
import sys

import cv2
import numpy as np


def main():
    d = sys.argv[1]
    for tag, size, flags in [("s", (7, 6), cv2.CALIB_CB_SYMMETRIC_GRID), ("a", (4, 11), cv2.CALIB_CB_ASYMMETRIC_GRID)]:
        found = same = rev = other = 0
        sq = []
        for path in sorted(glob.glob(os.path.join(d, tag + "[0-9]*.png"))):
            img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
            truth = np.loadtxt(path[:-4] + ".truth.txt")
            ok, c = cv2.findCirclesGrid(img, size, flags=flags)
            if not ok:
                continue
            found += 1
            c = c.reshape(-1, 2)
            if np.all(np.linalg.norm(c - truth, axis=1) < 2):
                same += 1
                sq.extend(np.sum((c - truth) ** 2, axis=1))
            elif np.all(np.linalg.norm(c[::-1] - truth, axis=1) < 2):
                rev += 1
                sq.extend(np.sum((c[::-1] - truth) ** 2, axis=1))
            else:
                other += 1
        kind = "symmetric" if tag == "s" else "asymmetric"
        rms = np.sqrt(np.mean(sq)) if sq else float("nan")
        print(f"OpenCV {cv2.__version__} findCirclesGrid {kind} {size}: found {found}, order as parallax {same}, "
              f"reversed {rev}, other {other}, centre RMS {rms:.4f} px")


if __name__ == "__main__":
    main()
