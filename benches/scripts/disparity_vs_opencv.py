#!/usr/bin/env python3
"""Interleaved speed comparison: our `xtask disparity` (median compute seconds of N runs) and
OpenCV (median of N compute() calls) on the same images, alternating, R rounds.

  cargo build --release -p xtask
  python3 benches/scripts/disparity_vs_opencv.py bm|sgm [rounds]   (NS=1..3 sizes)
  SET=middlebury python3 benches/scripts/disparity_vs_opencv.py sgm [rounds]

Pairs: Middlebury teddy (../shared) and teddy resized to 626x555 (96 disparities) and 1282x1110
(224). BM: StereoBM 9x9 uniqueness 0 against ours with the same options (x-Sobel, texture 10,
uniqueness 0, no left-right check, no speckle filter). SGM: StereoSGBM 3-way (block 5, P1 200,
P2 800, disp12MaxDiff 1, uniqueness 10) against the SGM measurement preset without texture and
speckle filters, on three paths (left-to-right, right-to-left, down: 3-way's directions;
SGM_PATHS=5 or 8 for ours with more; SGM_PRESET=accurate for the accurate preset; PRESET=defaults for both sides' defaults, see pairs.py; SGBM_MODE=hh or sgbm for OpenCV's 8- or 5-direction modes). Both sides use 2 threads (THREADS=n to change). Say the machine load when quoting
the ratios. XTASK=path times another build of xtask (e.g. a copy of the previous one)."""
import cv2, numpy as np, subprocess, statistics, time, os, sys
THREADS = int(os.environ.get("THREADS", "2"))
cv2.setNumThreads(THREADS)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pairs import pairs as make_pairs, our_options, opencv_matcher, out_dir
pairs = make_pairs()
OUT = out_dir()
XT = os.environ.get("XTASK") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target", "release", "xtask")
mode = sys.argv[1] if len(sys.argv) > 1 else "bm"
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
N = 7
BEFORE = os.environ.get("XTASK_BEFORE")  # optional: an older xtask build, timed in the same rounds
def ours(pl, pr, nd, XT=XT):
    extra = our_options(mode)
    out = subprocess.run([XT, "disparity", "--left", pl, "--right", pr, "--disparities", str(nd), "--runs", str(N), "--out", os.path.join(OUT, "o"), "--allow-swapped", "--threads", str(THREADS)] + extra, capture_output=True, text=True)
    for line in out.stdout.splitlines():
        if line.startswith("seconds:"):
            return float(line.split()[1])
    raise SystemExit(out.stdout + out.stderr)
def cv(l, r, nd):
    m = opencv_matcher(mode, nd)
    m.compute(l, r)
    ts = []
    for _ in range(N):
        t = time.perf_counter(); m.compute(l, r); ts.append(time.perf_counter() - t)
    return statistics.median(ts)
print(f"mode {mode}, threads {THREADS}" + (f", ours {' '.join(our_options(mode))}" if mode == "sgm" else "") + f", load before: {os.getloadavg()}")
for w, h, nd, l, r, pl, pr in pairs:
    ratios, before = [], []
    for k in range(rounds):
        a = ours(pl, pr, nd); b = cv(l, r, nd)
        ratios.append(b / a)
        extra = ""
        if BEFORE:
            a0 = ours(pl, pr, nd, BEFORE)
            before.append(b / a0)
            extra = f"  before {a0*1e3:8.2f} ms (speed ratio {b/a0:5.2f})"
        print(f"{w}x{h}x{nd} round {k} (load {os.getloadavg()[0]:.1f}): ours {a*1e3:8.2f} ms  opencv {b*1e3:8.2f} ms  speed ratio (opencv/ours) {b/a:5.2f}  ours {w*h*nd/a/1e9:.2f} G/s{extra}", flush=True)
    print(f"{w}x{h}x{nd}: median speed ratio {statistics.median(ratios):.2f} (time ratio ours/opencv {1 / statistics.median(ratios):.2f})"
          + (f"; before: speed ratio {statistics.median(before):.2f}" if BEFORE else ""))
print(f"load after: {os.getloadavg()}")
