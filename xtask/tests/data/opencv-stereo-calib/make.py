#!/usr/bin/env python3
"""OpenCV's own files and images for two checks of parallax against OpenCV (see README.md).

    pip install opencv-python-headless numpy
    python3 make.py     # from this folder; needs the repository's fixtures/stereo and, for the
                        # F reference, ../shared/data/opencv-stereo-chessboard beside the repository

1. `intrinsics.yml`, `extrinsics.yml`: the file pair OpenCV's `samples/cpp/stereo_calib.cpp`
   writes, made the way it makes them (`findChessboardCorners` + `cornerSubPix` 11x11,
   `initCameraMatrix2D`, `stereoCalibrate` with the sample's flags, `stereoRectify` with
   `CALIB_ZERO_DISPARITY` and alpha 1, `cv2.FileStorage` with the sample's keys in its order) on
   the repository's rendered pair set `fixtures/stereo` (9x6 board, 25 mm). Then OpenCV's
   rectified images of pair 00 with the stored matrices (`initUndistortRectifyMap` CV_16SC2 +
   `remap` INTER_LINEAR, as the sample; and the same float map sampled by exact bilinear
   interpolation), and `reprojectImageTo3D` with the stored Q of a
   disparity ramp at sample pixels (`q_samples` in reference.json).
2. `shared_left.json`, `shared_right.json` (committed corner files of the shared OpenCV stereo
   chessboards, written by `cargo xtask corners`) and OpenCV's `stereoCalibrate` on exactly
   those corners (`f_reference` in reference.json: M1 D1 M2 D2 R T E F).
"""

import glob
import json
import os

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "../../../.."))
COLS, ROWS = 9, 6


def exact_bilinear(img, mx, my):
    src = img.astype(np.float64)
    h, w = src.shape
    x0, y0 = np.floor(mx).astype(np.int64), np.floor(my).astype(np.int64)
    ax, ay = mx - x0, my - y0

    def at(y, x):
        inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
        out = np.zeros(x.shape)
        out[inside] = src[y[inside], x[inside]]
        return out

    v = (at(y0, x0) * (1 - ax) * (1 - ay) + at(y0, x0 + 1) * ax * (1 - ay)
         + at(y0 + 1, x0) * (1 - ax) * ay + at(y0 + 1, x0 + 1) * ax * ay)
    return np.clip(np.floor(v + 0.5), 0, 255).astype(np.uint8)


def stereo_calib_sample():
    lefts = sorted(glob.glob(os.path.join(ROOT, "fixtures/stereo/left_*.png")))
    rights = sorted(glob.glob(os.path.join(ROOT, "fixtures/stereo/right_*.png")))
    obj = np.array([[c * 25.0, r * 25.0, 0.0] for r in range(ROWS) for c in range(COLS)], np.float32)
    pts = [[], []]
    size = None
    for l, r in zip(lefts, rights):
        found = []
        for k, path in enumerate((l, r)):
            img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
            size = (img.shape[1], img.shape[0])
            ok, corners = cv2.findChessboardCorners(
                img, (COLS, ROWS), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
            )
            if not ok:
                break
            corners = cv2.cornerSubPix(
                img, corners, (11, 11), (-1, -1),
                (cv2.TERM_CRITERIA_MAX_ITER + cv2.TERM_CRITERIA_EPS, 30, 0.01),
            )
            found.append(corners)
        if len(found) == 2:
            pts[0].append(found[0])
            pts[1].append(found[1])
    n = len(pts[0])
    assert n >= 4, f"board found in {n} pairs"
    objs = [obj] * n
    m1 = cv2.initCameraMatrix2D(objs, pts[0], size, 0)
    m2 = cv2.initCameraMatrix2D(objs, pts[1], size, 0)
    d1, d2 = np.zeros((8, 1)), np.zeros((8, 1))
    flags = (
        cv2.CALIB_FIX_ASPECT_RATIO | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_USE_INTRINSIC_GUESS
        | cv2.CALIB_SAME_FOCAL_LENGTH | cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_FIX_K3 | cv2.CALIB_FIX_K4
        | cv2.CALIB_FIX_K5
    )
    rms, m1, d1, m2, d2, R, T, E, F = cv2.stereoCalibrate(
        objs, pts[0], pts[1], m1, d1, m2, d2, size, flags=flags,
        criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-5),
    )
    fs = cv2.FileStorage(os.path.join(HERE, "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    for key, m in (("M1", m1), ("D1", d1), ("M2", m2), ("D2", d2)):
        fs.write(key, m)
    fs.release()
    R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
        m1, d1, m2, d2, size, R, T, flags=cv2.CALIB_ZERO_DISPARITY, alpha=1, newImageSize=size
    )
    fs = cv2.FileStorage(os.path.join(HERE, "extrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    for key, m in (("R", R), ("T", T), ("R1", R1), ("R2", R2), ("P1", P1), ("P2", P2), ("Q", Q)):
        fs.write(key, m)
    fs.release()
    # the rectified images of pair 00, as the sample makes them
    for side, path, m, d, r, p in (("left", lefts[0], m1, d1, R1, P1), ("right", rights[0], m2, d2, R2, P2)):
        mx, my = cv2.initUndistortRectifyMap(m, d, r, p, size, cv2.CV_16SC2)
        img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        cv2.imwrite(os.path.join(HERE, f"opencv_{side}_rectified.png"), cv2.remap(img, mx, my, cv2.INTER_LINEAR))
        # OpenCV's remap interpolates from a table of 1/32-pixel steps, which differs from exact
        # bilinear interpolation by up to a few grey levels on a sharp edge: the same float map
        # sampled exactly (float64, zero outside the image, rounded) is the second reference
        fx, fy = cv2.initUndistortRectifyMap(m, d, r, p, size, cv2.CV_32FC1)
        cv2.imwrite(os.path.join(HERE, f"exact_{side}_rectified.png"), exact_bilinear(img, fx, fy))
    # reprojectImageTo3D with the stored Q, read back from the file as a user's program would
    stored = cv2.FileStorage(os.path.join(HERE, "extrinsics.yml"), cv2.FILE_STORAGE_READ)
    q = stored.getNode("Q").mat()
    stored.release()
    w, h = size
    disp = np.fromfunction(lambda y, x: 8.0 + 40.0 * x / w + 10.0 * y / h, (h, w), dtype=np.float64).astype(np.float32)
    xyz = cv2.reprojectImageTo3D(disp, q)
    samples = []
    for u in range(7, w, 97):
        for v in range(5, h, 83):
            samples.append({"u": u, "v": v, "d": float(disp[v, u]), "xyz": [float(c) for c in xyz[v, u]]})
    return {
        "pairs": n,
        "image_size": list(size),
        "stereo_rms_px": rms,
        "roi1": list(roi1),
        "roi2": list(roi2),
        "disparity_ramp": "d(u, v) = 8 + 40 u / width + 10 v / height, as float32",
        "q_samples": samples,
    }


def shared_f_reference():
    data = os.path.normpath(os.path.join(ROOT, "../shared/data/opencv-stereo-chessboard"))
    assert os.path.isdir(data), f"{data}: the shared data is needed for the F reference"
    views = {}
    for side in ("left", "right"):
        doc = json.load(open(os.path.join(HERE, f"shared_{side}.json")))
        for img in doc["images"]:
            if img.get("grid"):
                key = os.path.basename(img["image"]).replace(side, "")
                views.setdefault(key, {})[side] = np.array(img["grid"]["corners"], np.float64).reshape(-1, 1, 2)
    keys = sorted(k for k, v in views.items() if len(v) == 2)
    obj = np.array([[c * 30.0, r * 30.0, 0.0] for r in range(ROWS) for c in range(COLS)], np.float64).reshape(-1, 1, 3)
    objs = [obj] * len(keys)
    lp = [views[k]["left"] for k in keys]
    rp = [views[k]["right"] for k in keys]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    size = (640, 480)
    _, m1, d1, _, _ = cv2.calibrateCamera(objs, lp, size, None, None, criteria=crit)
    _, m2, d2, _, _ = cv2.calibrateCamera(objs, rp, size, None, None, criteria=crit)
    rms, m1, d1, m2, d2, R, T, E, F = cv2.stereoCalibrate(
        objs, lp, rp, m1, d1, m2, d2, size, flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=crit
    )
    rows = lambda m: [[float(x) for x in r] for r in np.asarray(m).reshape(m.shape[0], -1)]
    return {
        "pairs": len(keys),
        "flags": "mono calibrateCamera (default flags) of each side, then stereoCalibrate with CALIB_USE_INTRINSIC_GUESS",
        "criteria": "COUNT + EPS, 100, 1e-12",
        "rms": rms,
        "M1": rows(m1), "D1": [float(x) for x in d1.ravel()],
        "M2": rows(m2), "D2": [float(x) for x in d2.ravel()],
        "R": rows(R), "T": [float(x) for x in T.ravel()],
        "E": rows(E), "F": rows(F),
    }


def main():
    ref = {
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "stereo_calib": stereo_calib_sample(),
        "f_reference": shared_f_reference(),
    }
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(ref, f, indent=1)
        f.write("\n")
    print(json.dumps({k: ref["stereo_calib"][k] for k in ("pairs", "stereo_rms_px", "roi1", "roi2")}))
    print("F rms", ref["f_reference"]["rms"], "F[2][2]", ref["f_reference"]["F"][2][2])


if __name__ == "__main__":
    main()
