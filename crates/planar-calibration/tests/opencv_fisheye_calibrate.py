#!/usr/bin/env python3
"""Side by side: cv2.fisheye.calibrate against parallax's calibrate_camera (lens kannala-brandt) on the same corner sets.

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
| CALIB_FIX_SKEW, criteria (COUNT + EPS, 100, 1e-12), points as (1, N, 3) / (1, N, 2) float64
arrays (the (N, 1, 3) layout of the docs fails in OpenCV 5.0.0's Python binding with "Sizes of
input arguments do not match"). Attempts, in order, until one returns:
  A. no guess (OpenCV starts from f = max(w, h)/pi, the image centre, D = 0);
  B. CALIB_USE_INTRINSIC_GUESS with a focal guess f = 400 px (truth 397), the image centre, D = 0
     -- a guess our calibration does not need;
  C. B without CALIB_CHECK_COND.
Each failure is counted by kind ("CHECK_COND": the "Ill-conditioned matrix" error of
CALIB_CHECK_COND; "assert": any other OpenCV error, e.g. "fabs(norm_u1) > 0" in InitExtrinsics).
RMS is sqrt(sum |e|^2 / N) over all corners for both, computed here with cv2.fisheye.projectPoints
for OpenCV's estimate and reported by parallax for ours. Parameter errors are |estimate - truth|;
ours counts as worse on a parameter only when its error exceeds OpenCV's by more than 1e-3 of our
standard deviation of it (two runs at the same optimum differ by far less). "Model error" is the
RMS pixel distance between the estimated and the true projection over directions up to 85 degrees
from the axis (a 10 x 36 grid in theta, phi), the single number that sums up all parameter errors.
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


def kb_project(p, theta, phi):
    fx, fy, cx, cy, k1, k2, k3, k4 = p
    t2 = theta * theta
    td = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    return np.stack([fx * td * np.cos(phi) + cx, fy * td * np.sin(phi) + cy], -1)


TH, PH = np.meshgrid(np.linspace(0, np.radians(85), 10), np.linspace(0, 2 * np.pi, 36, endpoint=False))


def model_error(p, truth):
    if not np.all(np.isfinite(p)):
        return float("nan")
    d = kb_project(p, TH, PH) - kb_project(truth, TH, PH)
    return float(np.sqrt(np.mean(np.sum(d * d, -1))))


def run(obj, img, size, fl, guess=False):
    K = np.array([[400.0, 0, (size[0] - 1) / 2], [0, 400.0, (size[1] - 1) / 2], [0, 0, 1]]) if guess else np.zeros((3, 3))
    D = np.zeros((4, 1))
    if guess:
        fl |= cv2.CALIB_USE_INTRINSIC_GUESS
    rms, K, D, rvecs, tvecs = cv2.fisheye.calibrate(obj, img, size, K, D, flags=fl, criteria=criteria)
    err2, n = 0.0, 0
    for o, i, r, t in zip(obj, img, rvecs, tvecs):
        p, _ = cv2.fisheye.projectPoints(o, r, t, K, D)
        err2 += float(np.sum((p.reshape(-1, 2) - i.reshape(-1, 2)) ** 2))
        n += o.reshape(-1, 3).shape[0]
    params = [K[0, 0], K[1, 1], K[0, 2], K[1, 2]] + list(D.ravel())
    return np.sqrt(err2 / n), np.array(params)


print(f"OpenCV {cv2.__version__}; {len(sets)} corner sets from {path}")
summary = {}
for s in sets:
    fam = s["family"]
    st = summary.setdefault(fam, dict(sets=0, A=0, B=0, C=0, none=0, fails={}, rms_worse=0, param_worse=0, model_worse=0, same=0))
    st["sets"] += 1
    obj = [np.array(s["object"], np.float64).reshape(1, -1, 3) for _ in s["image"]]
    img = [np.array(v, np.float64).reshape(1, -1, 2) for v in s["image"]]
    size = (s["width"], s["height"])
    truth = np.array(s["truth"])
    ours = np.array(s["ours"])
    cv_rms, cv_params, used = float("nan"), np.full(8, np.nan), "none"
    notes = []
    for name, fl, guess in [("A", flags, False), ("B", flags, True), ("C", flags & ~cv2.CALIB_CHECK_COND, True)]:
        try:
            cv_rms, cv_params = run(obj, img, size, fl, guess)
            used = name
            break
        except cv2.error as e:
            kind = "CHECK_COND" if "CALIB_CHECK_COND" in str(e) or "Ill-conditioned" in str(e) else "assert"
            notes.append(f"{name}:{kind}")
            st["fails"][f"{name}:{kind}"] = st["fails"].get(f"{name}:{kind}", 0) + 1
    st[used] += 1
    cond = " ".join(notes) + (f" -> {used}" if used != "none" else " -> no result")
    our_err = np.abs(ours - truth)
    cv_err = np.abs(cv_params - truth)
    # "no worse": within 1e-6 relative of OpenCV's (both at the same optimum) or better.
    rms_worse = not (s["ours_rms"] <= cv_rms * (1 + 1e-6)) and np.isfinite(cv_rms)
    std = np.array(s["ours_std"])
    worse = [names[i] for i in range(8) if np.isfinite(cv_err[i]) and our_err[i] > cv_err[i] + 1e-3 * std[i]]
    apart = float(np.max(np.abs(ours - cv_params) / std)) if np.all(np.isfinite(cv_params)) else float("nan")
    me_ours, me_cv = model_error(ours, truth), model_error(cv_params, truth)
    st["rms_worse"] += int(rms_worse)
    st["param_worse"] += int(bool(worse))
    st["model_worse"] += int(me_ours > me_cv + 1e-6)
    st["same"] += int(apart < 1e-3)
    print(
        f"{fam:5s} set {s['seed']:2d}: ours rms {s['ours_rms']:.4f} model err {me_ours:.4f} px | OpenCV rms {cv_rms:.4f} "
        f"model err {me_cv:.4f} px | max |ours - OpenCV|/sigma {apart:.1e} [{cond}]"
        + (f"  ours worse in {worse}" if worse else "")
    )
for fam, st in summary.items():
    print(
        f"{fam}: {st['sets']} sets; OpenCV results from attempt A {st['A']}, B {st['B']}, C {st['C']}, none {st['none']}; "
        f"failures by attempt:kind {st['fails']}; same optimum (all parameters within 1e-3 sigma): {st['same']}; "
        f"sets where our RMS is worse: {st['rms_worse']}; where our model error is worse: {st['model_worse']}; "
        f"where any of our parameter errors is worse by more than 1e-3 sigma: {st['param_worse']} "
        f"(parallax converged on all {st['sets']}, no guess)"
    )
