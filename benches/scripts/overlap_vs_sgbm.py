#!/usr/bin/env python3
"""Like-for-like accuracy against OpenCV on tsukuba, venus and teddy from ../shared (nonocc mask,
the disparities of ../shared/data/README.md): our `xtask disparity` defaults (block matching and
`--method sgm`, on the images as given: colour is read as grey), OpenCV StereoSGBM 3-way on the
colour images and on grey (blockSize 5, P1 = 8*3*25, P2 = 32*3*25, uniquenessRatio 10,
disp12MaxDiff 1, speckleWindowSize 100, speckleRange 2, OpenCV's defaults otherwise) and
StereoBM 9x9 with its defaults (grey).

Prints per pair and method bad2 (missing = bad, over the mask), bad2_overlap (missing = bad) and
density_overlap, over the mask's pixels in the columns where OpenCV's matchers also answer,
x >= min_disparity + disparities (min_disparity 0 here). One evaluator scores every map: the
formula in this script (`score`), applied to our written disparity.pfm and to OpenCV's maps
alike; for our maps it is checked against the CLI's own keys (they must agree to the printed
0.01, or the script stops).

  cargo build --release -p xtask
  python3 benches/scripts/overlap_vs_sgbm.py            (XTASK=path for another build)"""
import os, subprocess, sys, tempfile
import cv2, numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pairs import _shared  # noqa: E402

XT = os.environ.get("XTASK") or os.path.join(
    os.environ.get("CARGO_TARGET_DIR") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target"),
    "release", "xtask")
SETS = (("tsukuba", 16, 16), ("venus", 32, 8), ("teddy", 64, 4))  # name, disparities, ground-truth scale
OURS = {"ours bm (default)": [], "ours sgm (default)": ["--method", "sgm"]}


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"Pf", path
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=w * h)
    d = np.flipud(data.reshape(h, w)).astype(np.float64)
    return np.where(np.isfinite(d), d, np.nan)  # invalid is written as +inf (Middlebury's PFMs)


def score(disp, truth, mask, first):
    """(bad2, bad2_overlap, density_overlap) in percent; disp NaN = no disparity; over mask (and
    known truth), the overlap keys over its pixels with x >= first."""
    known = mask & (truth > 0)
    cols = np.zeros_like(known)
    cols[:, first:] = True
    out = []
    for m in (known, known & cols):
        d, t = disp[m], truth[m]
        bad = np.isnan(d) | (np.abs(np.nan_to_num(d, nan=-1e9) - t) > 2.0)
        out.append((100.0 * bad.sum() / m.sum(), 100.0 * (~np.isnan(d)).sum() / m.sum()))
    return out[0][0], out[1][0], out[1][1]


def opencv(name, nd, dirp):
    colour = cv2.imread(f"{dirp}/imL.png", cv2.IMREAD_COLOR), cv2.imread(f"{dirp}/imR.png", cv2.IMREAD_COLOR)
    grey = cv2.imread(f"{dirp}/imL.png", 0), cv2.imread(f"{dirp}/imR.png", 0)
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=nd, blockSize=5, P1=8 * 3 * 25, P2=32 * 3 * 25,
                                 disp12MaxDiff=1, uniquenessRatio=10, speckleWindowSize=100, speckleRange=2,
                                 mode=cv2.StereoSGBM_MODE_SGBM_3WAY)
    bm = cv2.StereoBM_create(numDisparities=nd, blockSize=9)
    out = {}
    for label, m, (l, r) in (("opencv sgbm 3-way colour", sgbm, colour), ("opencv sgbm 3-way grey", sgbm, grey),
                             ("opencv stereobm 9x9", bm, grey)):
        raw = m.compute(l, r).astype(np.float64) / 16.0
        out[label] = np.where(raw >= 0, raw, np.nan)  # invalid: (minDisparity - 1) * 16
    return out


def main():
    root = os.path.join(_shared(), "data", "middlebury")
    print(f"xtask {XT}; OpenCV {cv2.__version__}; evaluator: this script's score() on every map")
    print(f"{'pair':8} {'method':26} {'bad2':>7} {'bad2_overlap':>13} {'density_overlap':>16}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, nd, scale in SETS:
            d = os.path.join(root, name)
            truth = cv2.imread(f"{d}/groundtruth.png", 0).astype(np.float64) / scale
            mask = cv2.imread(f"{d}/nonocc.png", 0) > 128
            maps = {}
            for label, opts in OURS.items():
                out = os.path.join(tmp, f"{name}-{len(maps)}")
                p = subprocess.run([XT, "disparity", "--left", f"{d}/imL.png", "--right", f"{d}/imR.png",
                                    "--disparities", str(nd), "--gt", f"{d}/groundtruth.png", "--gt-scale",
                                    str(scale), "--mask", f"{d}/nonocc.png", "--runs", "1", "--out", out] + opts,
                                   capture_output=True, text=True)
                if p.returncode != 0:
                    raise SystemExit(p.stdout + p.stderr)
                keys = dict(line.split(": ", 1) for line in p.stdout.splitlines() if ": " in line)
                maps[label] = read_pfm(os.path.join(out, "disparity.pfm"))
                mine = score(maps[label], truth, mask, nd)
                cli = tuple(float(keys[k]) for k in ("bad2", "bad2_overlap", "density_overlap"))
                if any(abs(a - b) > 0.0051 for a, b in zip(mine, cli)):
                    raise SystemExit(f"{name} {label}: the script's {mine} against the CLI's {cli}")
            maps.update(opencv(name, nd, d))
            for label, disp in maps.items():
                b, bo, do = score(disp, truth, mask, nd)
                print(f"{name:8} {label:26} {b:7.2f} {bo:13.2f} {do:16.2f}")


if __name__ == "__main__":
    main()
