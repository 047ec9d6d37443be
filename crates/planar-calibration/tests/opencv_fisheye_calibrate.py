#!/usr/bin/env python3
"""Side by side: cv2.fisheye.calibrate against parallax's calibrate_fisheye on the same corner sets.

1. Export the corner sets (and our results on them) from the Rust test:
       cargo test -p parallax-planar-calibration --test fisheye export_corner_sets_for_opencv -- --ignored
   which writes target/fisheye_sets.json: 2 families x 20 sets, each 20 views of a 14x10-corner
   board seen by a 180-degree Kannala-Brandt camera (1280x960, fx 397, fy 396.5, cx 639.3,
   cy 479.6, k = 0.02, -0.005, 0.001, -0.0002), corner noise sigma = 0.2 px:
     "front": every board point within 85 degrees of the optical axis (z > 0, which OpenCV's
              fisheye model needs: it divides by z);
     "full":  views anywhere in the 180-degree field (some corners beyond 90 degrees).
2. python3 crates/planar-calibration/tests/opencv_fisheye_calibrate.py [target/fisheye_sets.json]
   (pip install opencv-python-headless numpy; measured with OpenCV 5.0.0).

OpenCV is run as its documentation recommends: flags CALIB_RECOMPUTE_EXTRINSIC | CALIB_CHECK_COND
| CALIB_FIX_SKEW, criteria (COUNT + EPS, 100, 1e-12). When CALIB_CHECK_COND rejects a set (the
frequent "CALIB_CHECK_COND - Ill-conditioned matrix" error) it is counted and the set is re-run
without CALIB_CHECK_COND so its numbers can still be compared.
RMS is sqrt(sum |e|^2 / N) over all corners for both, computed here with cv2.fisheye.projectPoints
for OpenCV's estimate and reported by parallax for ours. Parameter errors are |estimate - truth|.
"""
import json
import sys

import cv2
import numpy as np

path = sys.argv[1] if len(sys.argv) > 1 else "target/fisheye_sets.json"
sets = json.load(open(path))
flags = cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_CHECK_COND | cv2.CALIB_FIX_SKEW
criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
names = ["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"]


def run(obj, img, size, fl):
    K = np.zeros((3, 3))
    D = np.zeros((4, 1))
    rms, K, D, rvecs, tvecs = cv2.fisheye.calibrate(obj, img, size, K, D, flags=fl, criteria=criteria)
    err2, n = 0.0, 0
    for o, i, r, t in zip(obj, img, rvecs, tvecs):
        p, _ = cv2.fisheye.projectPoints(o, r, t, K, D)
        err2 += float(np.sum((p.reshape(-1, 2) - i.reshape(-1, 2)) ** 2))
        n += len(o)
    params = [K[0, 0], K[1, 1], K[0, 2], K[1, 2]] + list(D.ravel())
    return np.sqrt(err2 / n), np.array(params)


print(f"OpenCV {cv2.__version__}; {len(sets)} corner sets from {path}")
summary = {}
for s in sets:
    fam = s["family"]
    st = summary.setdefault(fam, dict(sets=0, cond_fail=0, cv_error=0, rms_worse=0, param_worse=0, rows=[]))
    st["sets"] += 1
    obj = [np.array(s["object"], np.float64).reshape(-1, 1, 3) for _ in s["image"]]
    img = [np.array(v, np.float64).reshape(-1, 1, 2) for v in s["image"]]
    size = (s["width"], s["height"])
    truth = np.array(s["truth"])
    ours = np.array(s["ours"])
    cond = "ok"
    try:
        cv_rms, cv_params = run(obj, img, size, flags)
    except cv2.error:
        st["cond_fail"] += 1
        cond = "CHECK_COND failed"
        try:
            cv_rms, cv_params = run(obj, img, size, flags & ~cv2.CALIB_CHECK_COND)
        except cv2.error as e:
            st["cv_error"] += 1
            cv_rms, cv_params = float("nan"), np.full(8, np.nan)
            cond = "error: " + str(e).strip().splitlines()[-1][:60]
    our_err = np.abs(ours - truth)
    cv_err = np.abs(cv_params - truth)
    # "no worse": within 1e-6 relative of OpenCV's (both at the same optimum) or better.
    rms_worse = not (s["ours_rms"] <= cv_rms * (1 + 1e-6)) and np.isfinite(cv_rms)
    worse = [names[i] for i in range(8) if np.isfinite(cv_err[i]) and our_err[i] > cv_err[i] * (1 + 1e-6) + 1e-12]
    st["rms_worse"] += int(rms_worse)
    st["param_worse"] += int(bool(worse))
    print(
        f"{fam:5s} set {s['seed']:2d}: ours rms {s['ours_rms']:.6f}  fx err {our_err[0]:.4f}  k1 err {our_err[4]:.2e} | "
        f"OpenCV rms {cv_rms:.6f}  fx err {cv_err[0]:.4f}  k1 err {cv_err[4]:.2e}  [{cond}]"
        + (f"  ours worse in {worse}" if worse else "")
    )
for fam, st in summary.items():
    print(
        f"{fam}: {st['sets']} sets; OpenCV CALIB_CHECK_COND failures {st['cond_fail']} (of which OpenCV errors also "
        f"without the check: {st['cv_error']}); sets where our RMS is worse: {st['rms_worse']}; sets where any of our "
        f"parameter errors is worse: {st['param_worse']}"
    )
