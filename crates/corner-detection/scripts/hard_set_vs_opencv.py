"""The hard-print / hard-photo set side by side with OpenCV (issue 49).

Runs OpenCV's detectors on the views written by `tests/hard_set.rs`
(`HARD_SET_DUMP=DIR cargo test -p parallax-corner-detection --test hard_set`) and scores them
and our detections (`viewKK.ours.txt`, written by the same test) with one scorer against the
same truth:

- views: views where any point was returned;
- points: points returned within 1 px of their id's true position, of the visible points;
- off: points returned further than 1 px from their id's truth (a wrong id or a lost corner);
- RMS of the points within 1 px; and over the points both sides found within 1 px (like for
  like: a detector that finds more of the hard points is not charged for them).

OpenCV 5's detectors with their defaults: `CharucoDetector(board)` (9x7 squares, 25 / 18 mm,
DICT_4X4_50), `findChessboardCornersSB(img, (9, 6))`, `findCirclesGrid(img, (4, 11),
CALIB_CB_ASYMMETRIC_GRID)`. A whole-grid detector's order (chessboard, circle grid) is scored as
returned and, when that puts points off, also reversed (the grid turned by 180°); the better is
kept and the views where reversal was needed are counted (`rev`), for both sides alike.

    pip install opencv-python-headless numpy
    python3 hard_set_vs_opencv.py DIR
"""
import glob
import os
import sys

import cv2
import numpy as np


def read_truth(path):
    truth = {}
    for line in open(path):
        i, u, v, vis = line.split()
        truth[int(i)] = (np.array([float(u), float(v)]), vis == "1")
    return truth


def read_points(path):
    pts = []
    for line in open(path):
        i, u, v = line.split()
        pts.append((int(i), np.array([float(u), float(v)])))
    return pts


def score(points, truth):
    """(found, off, squared errors by id) of `points` (id, position) against `truth`."""
    found, off, sq = 0, 0, {}
    for i, p in points:
        t = truth.get(i)
        e = np.linalg.norm(p - t[0]) if t is not None else np.inf
        if e <= 1.0:
            found += 1
            sq[i] = e * e
        else:
            off += 1
    return found, off, sq


def best_order(points, truth, whole_grid):
    """Scores `points` as returned and, for a whole grid, reversed; the better, and whether it
    was the reversed one."""
    direct = score(points, truth)
    if not whole_grid or direct[1] == 0 or not points:
        return direct, False
    n = len(points)
    rev = score([(n - 1 - i, p) for i, p in points], truth)
    return (rev, True) if rev[1] < direct[1] else (direct, False)


class Row:
    def __init__(self):
        self.views = self.detected = self.visible = self.found = self.off = self.rev = 0
        self.sq = []
        self.by_view = []  # per view: squared errors by id

    def add(self, points, truth, whole_grid):
        self.views += 1
        self.detected += 1 if points else 0
        (found, off, sq), rev = best_order(points, truth, whole_grid)
        self.found += found
        self.off += off
        self.sq += list(sq.values())
        self.by_view.append(sq)
        self.rev += 1 if rev else 0

    def cells(self):
        rms = f"{np.sqrt(np.mean(self.sq)):.3f}" if self.sq else "-"
        return f"{self.detected}/{self.views}", f"{self.found}/{self.visible}", str(self.off), rms, str(self.rev)


def common_rms(a, b):
    """RMS of each side over the points both found within 1 px (like for like), and their count."""
    sa, sb = [], []
    for va, vb in zip(a.by_view, b.by_view):
        for i in va.keys() & vb.keys():
            sa.append(va[i])
            sb.append(vb[i])
    if not sa:
        return "-", "-", 0
    return f"{np.sqrt(np.mean(sa)):.3f}", f"{np.sqrt(np.mean(sb)):.3f}", len(sa)


def opencv_detector(target):
    if target == "charuco":
        A = cv2.aruco
        board = A.CharucoBoard((9, 7), 25.0, 18.0, A.getPredefinedDictionary(A.DICT_4X4_50))
        det = A.CharucoDetector(board)

        def run(img):
            corners, ids, _, _ = det.detectBoard(img)
            if ids is None:
                return []
            return [(int(i), c) for c, i in zip(corners.reshape(-1, 2), ids.ravel())]

        return run, False
    if target == "chessboard":
        def run(img):
            ok, corners = cv2.findChessboardCornersSB(img, (9, 6))
            return [(i, c) for i, c in enumerate(corners.reshape(-1, 2))] if ok else []

        return run, True

    def run(img):
        ok, centres = cv2.findCirclesGrid(img, (4, 11), flags=cv2.CALIB_CB_ASYMMETRIC_GRID)
        return [(i, c) for i, c in enumerate(centres.reshape(-1, 2))] if ok else []

    return run, True


def main():
    root = sys.argv[1]
    print(f"OpenCV {cv2.__version__}; per target and factor: views with points returned, points within 1 px "
          "of the truth / visible, points further off, RMS (px), the points both found and each side's RMS "
          "over them, views scored reversed")
    print()
    print("| target | factor | views ours | views OpenCV | points ours | points OpenCV | off ours | off OpenCV "
          "| RMS ours | RMS OpenCV | common points | RMS ours there | RMS OpenCV there | rev ours | rev OpenCV |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for target in ["charuco", "chessboard", "circles"]:
        run, whole_grid = opencv_detector(target)
        factors = sorted(os.listdir(os.path.join(root, target)), key=lambda f: FACTORS.index(f))
        for factor in factors:
            ours, theirs = Row(), Row()
            for path in sorted(glob.glob(os.path.join(root, target, factor, "view*.png"))):
                truth = read_truth(path[:-4] + ".truth.txt")
                visible = sum(1 for t in truth.values() if t[1])
                ours.visible += visible
                theirs.visible += visible
                ours.add(read_points(path[:-4] + ".ours.txt"), truth, whole_grid)
                theirs.add(run(cv2.imread(path, cv2.IMREAD_GRAYSCALE)), truth, whole_grid)
            o, t = ours.cells(), theirs.cells()
            co, ct, n = common_rms(ours, theirs)
            print(f"| {target} | {factor} | {o[0]} | {t[0]} | {o[1]} | {t[1]} | {o[2]} | {t[2]} | {o[3]} | {t[3]} "
                  f"| {n} | {co} | {ct} | {o[4]} | {t[4]} |")


FACTORS = ["clean", "outlined", "inverted", "low-contrast", "glare", "motion-blur", "defocus",
           "strong-perspective", "occlusion", "small-board", "jpeg", "uneven-light"]

if __name__ == "__main__":
    main()
