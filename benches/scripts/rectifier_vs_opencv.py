#!/usr/bin/env python3
"""Interleaved speed comparison of the rectification map build: our `Rectifier::new` /
`Rectifier::rebuild` (example `rectifier_speed`, median of N builds) against OpenCV's
`stereoRectify` + `initUndistortRectifyMap` of both cameras (median of N builds), on the same
rig (OpenCV's joint calibration of the stereo chessboard, 640x480), alternating, R rounds.

  cargo build --release -p parallax-stereo-rectify --example rectifier_speed
  python3 benches/scripts/rectifier_vs_opencv.py [rounds] [threads]

OpenCV is timed for both map types it offers: CV_32FC1 (two float maps per camera) and
CV_16SC2 (fixed-point 1/32 px, what `remap` uses fastest). Our build makes the fixed-point
table per camera (1/256 px, with the exact positions of the border pixels); the f32 maps are
built only when asked for. Ratios are ours / OpenCV time (below 1: we are faster).
Both sides use the same number of threads (default 2). Say the machine load when quoting."""
import cv2, numpy as np, subprocess, statistics, time, os, sys

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
threads = int(sys.argv[2]) if len(sys.argv) > 2 else 2
cv2.setNumThreads(threads)
N = 50
EX = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target", "release", "examples", "rectifier_speed")

K1 = np.array([[536.32, 0, 341.84], [0, 536.32, 235.60], [0, 0, 1]])
D1 = np.array([-0.2714, 0.0128, 0.00171, -0.00045, 0.1330])
K2 = np.array([[541.44, 0, 327.67], [0, 540.84, 247.72], [0, 0, 1]])
D2 = np.array([-0.2822, 0.1084, -0.00061, 0.00091, -0.0253])
R, _ = cv2.Rodrigues(np.array([0.00481, 0.00343, -0.00378]))
T = np.array([[-100.120], [1.161], [0.074]])
size = (640, 480)


def opencv(mtype):
    def build():
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(K1, D1, K2, D2, size, R, T, flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
        a = cv2.initUndistortRectifyMap(K1, D1, R1, P1, size, mtype)
        b = cv2.initUndistortRectifyMap(K2, D2, R2, P2, size, mtype)
        return a, b
    build()
    ts = []
    for _ in range(N):
        t = time.perf_counter(); m = build(); ts.append(time.perf_counter() - t)
        del m
    return statistics.median(ts)


def opencv_remap():
    """Both maps as CV_16SC2 (OpenCV's fastest remap), then remap of two 8-bit grey images,
    bilinear, constant border: the per-frame cost."""
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(K1, D1, K2, D2, size, R, T, flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
    a = cv2.initUndistortRectifyMap(K1, D1, R1, P1, size, cv2.CV_16SC2)
    b = cv2.initUndistortRectifyMap(K2, D2, R2, P2, size, cv2.CV_16SC2)
    u, v = np.meshgrid(np.arange(640, dtype=np.uint32), np.arange(480, dtype=np.uint32))
    tex = lambda u, v: (((u * np.uint32(2654435761)) ^ (v * np.uint32(40503))) >> 9).astype(np.uint8)
    left, right = tex(u, v), tex(u + 7, v)
    def run():
        return (cv2.remap(left, a[0], a[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0),
                cv2.remap(right, b[0], b[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0))
    run()
    ts = []
    for _ in range(N):
        t = time.perf_counter(); m = run(); ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def ours():
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run([EX, str(N)], capture_output=True, text=True, env=env)
    res = {}
    for line in out.stdout.splitlines():
        k, _, v = line.partition(":")
        try:
            res[k.strip()] = float(v.split()[0])
        except (ValueError, IndexError):
            pass
    if not res:
        raise SystemExit(out.stdout + out.stderr)
    return res


print(f"threads {threads}, load before: {os.getloadavg()}")
ratios = {}
for k in range(rounds):
    o = ours(); c32 = opencv(cv2.CV_32FC1); c16 = opencv(cv2.CV_16SC2); crm = opencv_remap()
    line = f"round {k}: opencv 32F {c32*1e3:6.3f} ms  16SC2 {c16*1e3:6.3f} ms  remap {crm*1e3:6.3f} ms"
    if "remap_pair" in o:
        t = o.pop("remap_pair")
        line += f" | remap_pair {t*1e3:6.3f} ms (/remap {t/crm:4.2f})"
        ratios.setdefault(("remap_pair", "remap"), []).append(t / crm)
    for name, t in o.items():
        line += f" | {name} {t*1e3:6.3f} ms (/32F {t/c32:4.2f}, /16SC2 {t/c16:4.2f})"
        ratios.setdefault((name, "32F"), []).append(t / c32)
        ratios.setdefault((name, "16SC2"), []).append(t / c16)
    print(line, flush=True)
for (name, kind), r in ratios.items():
    print(f"median time ratio {name} / opencv {kind}: {statistics.median(r):.2f}  (range {min(r):.2f}-{max(r):.2f})")
print(f"load after: {os.getloadavg()}")
