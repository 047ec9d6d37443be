#!/usr/bin/env python3
"""Interleaved speed and accuracy comparison of the multi-camera rig calibration: our solver
(example `rig_solve`, median of REPEATS solves) against OpenCV's `calibrateMultiview` (median of
5 solves), on the same fixture (default: the 4-camera pinhole rig
crates/planar-calibration/tests/data/rig/pinhole4.json, 60 frames, 0.2 px noise), alternating,
R rounds.

  cargo build --release -p parallax-planar-calibration --example rig_solve
  python3 benches/scripts/rig_vs_opencv.py [fixture.json] [rounds] [threads]

OpenCV is called as the fixture's generator calls it (make_rig.py): calibrateMultiviewExtended,
all cameras CALIB_MODEL_PINHOLE, no initial guess, flags 0 (K and k1 k2 p1 p2 k3 per camera),
invisible views as (-1, -1) points with detectionMask 0, object points in metres (in mm
OpenCV 5.1 throws "Pattern points are collinear!"), translations converted back to mm. Its RMS
is the root of the mean over views of the per-view mean squared point distance; with full views
that is the per-point RMS sqrt(sum |e|^2 / N), the same definition as our `rms_px`.
Ratios are ours / OpenCV time (below 1: we are faster). Both sides use the same number of
threads (default 2: cv2.setNumThreads, RAYON_NUM_THREADS). Say the machine load when quoting."""
import cv2, numpy as np, subprocess, statistics, time, os, sys, json

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
path = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "crates", "planar-calibration", "tests", "data", "rig", "pinhole4.json")
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
threads = int(sys.argv[3]) if len(sys.argv) > 3 else 2
cv2.setNumThreads(threads)
N = 5
REPEATS = 5
EX = os.path.join(ROOT, "target", "release", "examples", "rig_solve")

doc = json.load(open(path))
cams, frames, board = doc["cameras"], doc["frames"], doc["board"]
if any(c["lens"] != "pinhole" for c in cams):
    raise SystemExit("calibrateMultiview does not mix camera models: use an all-pinhole fixture")
cols, rows, sq = board["cols"], board["rows"], board["square"]
k = np.arange(cols * rows)
obj = (np.stack([(k % cols) * sq, (k // cols) * sq, np.zeros(k.size)], 1) / 1000.0).astype(np.float32)
nc, nf = len(cams), len(frames)
obj_pts = [obj.copy() for _ in range(nf)]
img_pts = [[np.asarray(f["views"][c], np.float32) if f["views"][c] is not None
            else np.full((obj.shape[0], 2), -1, np.float32) for f in frames] for c in range(nc)]
mask = np.array([[f["views"][c] is not None for f in frames] for c in range(nc)], np.uint8)
models = np.full((nc, 1), cv2.CALIB_MODEL_PINHOLE, np.uint8)
sizes = [(c["width"], c["height"]) for c in cams]


def opencv_solve():
    return cv2.calibrateMultiviewExtended(obj_pts, img_pts, sizes, mask, models, None, None, None, None, flags=0)


def opencv():
    out = opencv_solve()
    ts = []
    for _ in range(N):
        t = time.perf_counter(); opencv_solve(); ts.append(time.perf_counter() - t)
    rms, Ks, Ds, Rs, Ts = out[:5]
    rvec = [np.asarray(r, np.float64).ravel() if np.asarray(r).size == 3
            else cv2.Rodrigues(np.asarray(r, np.float64))[0].ravel() for r in Rs]
    return statistics.median(ts), {"rms_px": float(rms), "fx": [float(K[0, 0]) for K in Ks],
                                    "fy": [float(K[1, 1]) for K in Ks],
                                    "t": [list(np.asarray(t, np.float64).ravel() * 1000.0) for t in Ts],
                                    "rvec": [list(r) for r in rvec]}


def ours():
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run([EX, path, str(REPEATS)], capture_output=True, text=True, env=env)
    for line in out.stdout.splitlines():
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    raise SystemExit(f"rig_solve failed ({out.returncode}):\n{out.stdout}{out.stderr}")


print(f"fixture {os.path.relpath(path)}: {nc} cameras, {nf} frames; threads {threads}, load before: {os.getloadavg()}")
t_cv, t_us, ratios = [], [], []
res_cv = res_us = None
for r in range(rounds):
    c, res_cv = opencv()
    res_us = ours()
    o = res_us["seconds_per_solve"]
    t_cv.append(c); t_us.append(o); ratios.append(o / c)
    print(f"round {r}: opencv {c*1e3:8.2f} ms  ours {o*1e3:8.2f} ms  ours/opencv {o/c:5.3f}", flush=True)
print(f"median: opencv {statistics.median(t_cv)*1e3:.2f} ms, ours {statistics.median(t_us)*1e3:.2f} ms, "
      f"ratio {statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})")
print(f"rms: opencv {res_cv['rms_px']:.6f} px, ours {res_us['rms_px']:.6f} px, "
      f"ours - opencv {res_us['rms_px'] - res_cv['rms_px']:+.6f} px")
for c in range(nc):
    fx_t = cams[c]["K"][0][0]
    t_t = np.asarray(cams[c]["t"])
    d_fx = (res_us["fx"][c] - res_cv["fx"][c]) / res_cv["fx"][c]
    d_fy = (res_us["fy"][c] - res_cv["fy"][c]) / res_cv["fy"][c]
    tu, tc = np.asarray(res_us["t"][c]), np.asarray(res_cv["t"][c])
    print(f"camera {c}: fx ours {res_us['fx'][c]:.3f} opencv {res_cv['fx'][c]:.3f} (rel diff {d_fx:+.2e}, fy {d_fy:+.2e}; "
          f"vs truth ours {(res_us['fx'][c] - fx_t) / fx_t:+.2e} opencv {(res_cv['fx'][c] - fx_t) / fx_t:+.2e}) | "
          f"t ours - opencv {np.round(tu - tc, 3)} mm (|d| {np.linalg.norm(tu - tc):.3f}; vs truth ours "
          f"{np.linalg.norm(tu - t_t):.3f} opencv {np.linalg.norm(tc - t_t):.3f} mm)")
print(f"load after: {os.getloadavg()}")
