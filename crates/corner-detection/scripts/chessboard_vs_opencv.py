"""Side-by-side timing of OpenCV's findChessboardCorners + cornerSubPix against parallax's
detector (the `dump_corners` example), interleaved: each round runs parallax over all images,
then OpenCV over the same images, so both see the same machine load.

    pip install opencv-python-headless numpy
    cargo build --release -p parallax-corner-detection --example dump_corners
    python3 chessboard_vs_opencv.py DIR COLSxROWS [ROUNDS] [--truth]

Prints per-image medians (ms, detection + sub-pixel refinement, image decoding excluded) and
the ratio parallax / OpenCV. OpenCV: default flags (adaptive threshold + normalise), then
cornerSubPix with a 5x5 window (11x11 half-size 5) and (30 iterations, 0.001) as in the usual
calibration scripts.
"""
import glob
import os
import statistics
import subprocess
import sys
import time

import cv2

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
DUMP = os.path.join(ROOT, "target", "release", "examples", "dump_corners")


def ours(paths, pattern):
    out = subprocess.run([DUMP, "saddle", pattern] + paths, capture_output=True, text=True, check=True).stdout
    res = {}
    for line in out.splitlines():
        p = line.split()
        res[p[0]] = (float(p[1]), p[2] != "none")
    return res


def opencv(paths, cols, rows):
    res = {}
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    for p in paths:
        img = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
        t0 = time.perf_counter()
        ok, c = cv2.findChessboardCorners(img, (cols, rows))
        if ok:
            cv2.cornerSubPix(img, c, (5, 5), (-1, -1), crit)
        res[p] = ((time.perf_counter() - t0) * 1e3, bool(ok))
    return res


def main():
    d, pattern = sys.argv[1], sys.argv[2]
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    cols, rows = map(int, pattern.split("x"))
    paths = sorted(glob.glob(os.path.join(d, "*.png")) + glob.glob(os.path.join(d, "*.jpg")))
    t_ours = {p: [] for p in paths}
    t_cv = {p: [] for p in paths}
    found = {}
    for _ in range(rounds):
        for p, (ms, ok) in ours(paths, pattern).items():
            t_ours[p].append(ms)
            found.setdefault(p, [None, None])[0] = ok
        for p, (ms, ok) in opencv(paths, cols, rows).items():
            t_cv[p].append(ms)
            found[p][1] = ok
    print(f"load average before/after: {os.getloadavg()}")
    print("image                 parallax ms  opencv ms  ratio  found (parallax, opencv)")
    ro, rc = [], []
    for p in paths:
        a, b = statistics.median(t_ours[p]), statistics.median(t_cv[p])
        ro.append(a)
        rc.append(b)
        print(f"{os.path.basename(p):20s} {a:11.2f} {b:10.2f} {a / b:6.2f}  {found[p]}")
    print(f"median over images: parallax {statistics.median(ro):.2f} ms, OpenCV {statistics.median(rc):.2f} ms, "
          f"ratio {statistics.median(ro) / statistics.median(rc):.2f}")


if __name__ == "__main__":
    main()
