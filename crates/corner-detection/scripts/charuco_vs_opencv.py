"""Runs OpenCV's CharucoDetector on the views written by `tests/charuco.rs`
(`CHARUCO_DUMP=DIR cargo test -p parallax-corner-detection --test charuco`) and scores it
against the same truth as the test: wrong ids (> 1 px from the truth of their id), RMS of the
others, share of the visible corners found, time per image.

    pip install opencv-python-headless numpy
    python3 charuco_vs_opencv.py DIR
"""
import glob
import os
import sys
import time

import cv2
import numpy as np


def main():
    d = sys.argv[1]
    A = cv2.aruco
    board = A.CharucoBoard((9, 7), 25.0, 18.0, A.getPredefinedDictionary(A.DICT_4X4_50))
    det = A.CharucoDetector(board)
    wrong = found = visible = 0
    sq = []
    times = []
    for path in sorted(glob.glob(os.path.join(d, "view*.png"))):
        img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        truth = {}
        for line in open(path[:-4] + ".truth.txt"):
            i, u, v, vis = line.split()
            truth[int(i)] = (np.array([float(u), float(v)]), vis == "1")
        visible += sum(1 for t in truth.values() if t[1])
        t0 = time.perf_counter()
        corners, ids, _, _ = det.detectBoard(img)
        times.append((time.perf_counter() - t0) * 1e3)
        if ids is None:
            continue
        for c, i in zip(corners.reshape(-1, 2), ids.ravel()):
            e = np.linalg.norm(c - truth[int(i)][0]) if int(i) in truth else 1e9
            if e > 1.0:
                wrong += 1
            else:
                found += 1
                sq.append(e * e)
    print(f"OpenCV {cv2.__version__} CharucoDetector (defaults): corners found {found} of {visible} visible "
          f"({100.0 * found / visible:.1f} %), wrong ids {wrong}, RMS {np.sqrt(np.mean(sq)):.4f} px, "
          f"worst {np.sqrt(np.max(sq)):.4f} px, median {np.median(times):.1f} ms per image")


if __name__ == "__main__":
    main()
