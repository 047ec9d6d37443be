#!/usr/bin/env python3
"""Interleaved speed comparison of the speckle filter: our `filter_speckles` (example
`speckle_speed`, median of N calls) and OpenCV's `filterSpeckles` (median of N calls) on the same
disparity maps, alternating, R rounds.

  cargo build --release -p parallax-block-matching --example speckle_speed
  python3 benches/scripts/speckle_vs_opencv.py MAP.pfm [MAP.pfm ...]   (ROUNDS=5)

Maps: any PFM disparity map, e.g. `cargo xtask disparity ... --speckle-window 0` writes
`disparity.pfm`. OpenCV filters the map in 1/16 px (`CV_16SC1`, as StereoBM/SGBM return it):
window 100, range 2 px = 32, invalid pixels as the new value; ours the float map with window 100,
range 2.0. The pixels removed are printed for both (1/16 px rounding can move a few). Both
single-threaded (the filter is sequential in both). Say the machine load when quoting the ratios."""
import cv2, numpy as np, subprocess, statistics, time, os, sys
cv2.setNumThreads(1)
HERE = os.path.dirname(os.path.abspath(__file__))
EX = os.environ.get("SPECKLE_SPEED") or os.path.join(HERE, "..", "..", "target", "release", "examples", "speckle_speed")
ROUNDS = int(os.environ.get("ROUNDS", "5"))
N = 21
def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"Pf"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        d = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w)
    return np.flipud(d).astype(np.float32)
def ours(path):
    out = subprocess.run([EX, path, "100", "2.0", str(N)], capture_output=True, text=True).stdout
    v = dict(l.split(": ") for l in out.splitlines())
    return float(v["seconds"]), int(v["removed"])
def cv(d16):
    ts, removed = [], 0
    for _ in range(N):
        m = d16.copy()
        t = time.perf_counter(); cv2.filterSpeckles(m, -16, 100, 32); ts.append(time.perf_counter() - t)
        removed = int(((m == -16) & (d16 != -16)).sum())
    return statistics.median(ts), removed
print(f"load before: {os.getloadavg()}")
for path in sys.argv[1:]:
    d = read_pfm(path)
    d16 = np.where(np.isfinite(d), np.round(d * 16), -16).astype(np.int16)
    ratios = []
    for k in range(ROUNDS):
        (a, ra), (b, rb) = ours(path), cv(d16)
        ratios.append(b / a)
        print(f"{path} {d.shape[1]}x{d.shape[0]} round {k} (load {os.getloadavg()[0]:.1f}): ours {a*1e3:7.3f} ms ({ra} removed)  opencv {b*1e3:7.3f} ms ({rb} removed)  speed ratio {b/a:5.2f}")
    print(f"{path}: median speed ratio (opencv/ours) {statistics.median(ratios):.2f}")
print(f"load after: {os.getloadavg()}")
