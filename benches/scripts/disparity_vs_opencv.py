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
SGM_PATHS=5 or 8 for ours with more). Both sides use 2 threads (THREADS=n to change). Say the machine load when quoting
the ratios. XTASK=path times another build of xtask (e.g. a copy of the previous one)."""
import cv2, numpy as np, subprocess, statistics, time, os, sys
THREADS = int(os.environ.get("THREADS", "2"))
cv2.setNumThreads(THREADS)
def _shared():
    # ../shared beside the worktree (also for worktrees one level deeper), or $PARALLAX_SHARED
    here = os.path.dirname(os.path.abspath(__file__))
    for c in (os.environ.get("PARALLAX_SHARED"), os.path.join(here, "..", "..", "..", "shared"),
              os.path.join(here, "..", "..", "..", "..", "shared")):
        if c and os.path.isdir(os.path.join(c, "data", "middlebury")):
            return c
    raise SystemExit("../shared/data/middlebury not found (set PARALLAX_SHARED)")
D = os.path.join(_shared(), "data", "middlebury", "teddy")
OUT = os.environ.get("PAIRS_OUT", "/tmp/parallax-pairs"); os.makedirs(OUT, exist_ok=True)
L0 = cv2.imread(f"{D}/imL.png", 0); R0 = cv2.imread(f"{D}/imR.png", 0)
sizes = [(450, 375, 64), (626, 555, 96), (1282, 1110, 224)][:int(os.environ.get("NS", "3"))]
pairs = []
if os.environ.get("SET") == "middlebury":
    # SET=middlebury: tsukuba (16 disparities), venus (32) and teddy (64) as they are, then the
    # teddy pair resized to 1282x1110 (224; the size of aloe, not in ../shared)
    for name, nd in (("tsukuba", 16), ("venus", 32), ("teddy", 64)):
        d = os.path.join(os.path.dirname(D), name)
        l, r = cv2.imread(f"{d}/imL.png", 0), cv2.imread(f"{d}/imR.png", 0)
        pairs.append((l.shape[1], l.shape[0], nd, l, r, f"{d}/imL.png", f"{d}/imR.png"))
    sizes = sizes[2:]
for w, h, nd in sizes:
    l = L0 if w == 450 else cv2.resize(L0, (w, h), interpolation=cv2.INTER_CUBIC)
    r = R0 if w == 450 else cv2.resize(R0, (w, h), interpolation=cv2.INTER_CUBIC)
    pl, pr = f"{OUT}/l{w}.png", f"{OUT}/r{w}.png"
    cv2.imwrite(pl, l); cv2.imwrite(pr, r)
    pairs.append((w, h, nd, l, r, pl, pr))
XT = os.environ.get("XTASK") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target", "release", "xtask")
mode = sys.argv[1] if len(sys.argv) > 1 else "bm"
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
N = 7
BEFORE = os.environ.get("XTASK_BEFORE")  # optional: an older xtask build, timed in the same rounds
def ours(pl, pr, nd, XT=XT):
    if mode == "bm":
        extra = ["--prefilter", "xsobel", "--uniqueness", "0", "--lr-max-diff", "-1", "--speckle-window", "0", "--texture", "10", "--block", "9"]
    else:
        extra = ["--method", "sgm", "--sgm-paths", os.environ.get("SGM_PATHS", "3"), "--uniqueness", "10", "--lr-max-diff", "1", "--speckle-window", "0", "--texture", "0"]
    out = subprocess.run([XT, "disparity", "--left", pl, "--right", pr, "--disparities", str(nd), "--runs", str(N), "--out", os.path.join(OUT, "o"), "--allow-swapped", "--threads", str(THREADS)] + extra, capture_output=True, text=True)
    for line in out.stdout.splitlines():
        if line.startswith("seconds:"):
            return float(line.split()[1])
    raise SystemExit(out.stdout + out.stderr)
def cv(l, r, nd):
    if mode == "bm":
        m = cv2.StereoBM_create(numDisparities=nd, blockSize=9); m.setUniquenessRatio(0)
    else:
        m = cv2.StereoSGBM_create(minDisparity=0, numDisparities=nd, blockSize=5, P1=200, P2=800, disp12MaxDiff=1, preFilterCap=63, uniquenessRatio=10, speckleWindowSize=0, speckleRange=0, mode=cv2.StereoSGBM_MODE_SGBM_3WAY)
    m.compute(l, r)
    ts = []
    for _ in range(N):
        t = time.perf_counter(); m.compute(l, r); ts.append(time.perf_counter() - t)
    return statistics.median(ts)
print(f"mode {mode}, threads {THREADS}" + (f", our paths {os.environ.get('SGM_PATHS', '3')}" if mode == "sgm" else "") + f", load before: {os.getloadavg()}")
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
