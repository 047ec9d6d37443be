"""Side-by-side timing of OpenCV's findChessboardCorners + cornerSubPix against parallax's
detector, interleaved image by image: the `time_chessboards` example runs as a server holding
one reused `ChessboardDetector` (images decoded once), and for every image of every round the
script runs parallax and OpenCV back to back (the order alternating), so both see the same
machine load at the same moment.

    pip install opencv-python-headless numpy
    cargo build --release -p parallax-corner-detection --example time_chessboards
    python3 chessboard_vs_opencv.py DIR COLSxROWS [ROUNDS]

Prints per-image medians (ms, detection + sub-pixel refinement, image decoding excluded), the
ratio parallax / OpenCV, and for each side the user and system CPU time and the page faults per
image summed over all rounds (parallax: the server's /proc/self/stat, 10 ms ticks; OpenCV:
getrusage of this process around its calls). OpenCV: default flags (adaptive threshold +
normalise) and its default thread count, then cornerSubPix with a 5x5 window (11x11, half-size
5) and (30 iterations, 0.001) as in the usual calibration scripts.
"""
import glob
import os
import resource
import statistics
import subprocess
import sys
import time

import cv2

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
SERVER = os.path.join(ROOT, "target", "release", "examples", "time_chessboards")
TICK = os.sysconf("SC_CLK_TCK")


def main():
    d, pattern = sys.argv[1], sys.argv[2]
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    cols, rows = map(int, pattern.split("x"))
    paths = sorted(glob.glob(os.path.join(d, "*.png")) + glob.glob(os.path.join(d, "*.jpg")))
    images = [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in paths]
    server = subprocess.Popen([SERVER, pattern] + paths, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    head = server.stdout.readline().split()
    assert head[0] == "ready", head
    last = [int(v) for v in head[1:]]
    ours_cpu = [0, 0, 0, 0]  # user ticks, system ticks, minor faults, major faults
    cv_cpu = [0.0, 0.0, 0, 0]  # user s, system s, minor faults, major faults
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    t_ours = [[] for _ in paths]
    t_cv = [[] for _ in paths]
    found = [[None, None] for _ in paths]

    def ours(k):
        nonlocal last
        server.stdin.write(f"{k}\n")
        server.stdin.flush()
        f = server.stdout.readline().split()
        now = [int(v) for v in f[2:]]
        for j in range(4):
            ours_cpu[j] += now[j] - last[j]
        last = now
        t_ours[k].append(float(f[0]))
        found[k][0] = f[1] == "1"

    def opencv(k):
        img = images[k]
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.perf_counter()
        ok, c = cv2.findChessboardCorners(img, (cols, rows))
        if ok:
            cv2.cornerSubPix(img, c, (5, 5), (-1, -1), crit)
        t_cv[k].append((time.perf_counter() - t0) * 1e3)
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        cv_cpu[0] += r1.ru_utime - r0.ru_utime
        cv_cpu[1] += r1.ru_stime - r0.ru_stime
        cv_cpu[2] += r1.ru_minflt - r0.ru_minflt
        cv_cpu[3] += r1.ru_majflt - r0.ru_majflt
        found[k][1] = bool(ok)

    load0 = os.getloadavg()
    for r in range(rounds):
        for k in range(len(paths)):
            if (r + k) % 2 == 0:
                ours(k)
                opencv(k)
            else:
                opencv(k)
                ours(k)
    server.stdin.close()
    server.wait()
    n = rounds * len(paths)
    print(f"{d}: {len(paths)} images x {rounds} rounds, OpenCV {cv2.__version__} with {cv2.getNumThreads()} threads")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}")
    print("image                 parallax ms  opencv ms  ratio  found (parallax, opencv)")
    ro, rc, ratios = [], [], []
    for k, p in enumerate(paths):
        a, b = statistics.median(t_ours[k]), statistics.median(t_cv[k])
        ro.append(a)
        rc.append(b)
        ratios.append(a / b)
        print(f"{os.path.basename(p):20s} {a:11.2f} {b:10.2f} {a / b:6.2f}  {tuple(found[k])}")
    print(f"median over images: parallax {statistics.median(ro):.2f} ms, OpenCV {statistics.median(rc):.2f} ms, "
          f"ratio of medians {statistics.median(ro) / statistics.median(rc):.2f}, "
          f"ratios {min(ratios):.2f}-{max(ratios):.2f}")
    print(f"per image: parallax user {ours_cpu[0] / TICK / n * 1e3:.1f} ms, system {ours_cpu[1] / TICK / n * 1e3:.1f} ms, "
          f"{ours_cpu[2] / n:.0f} minor / {ours_cpu[3] / n:.1f} major faults")
    print(f"per image: OpenCV   user {cv_cpu[0] / n * 1e3:.1f} ms, system {cv_cpu[1] / n * 1e3:.1f} ms, "
          f"{cv_cpu[2] / n:.0f} minor / {cv_cpu[3] / n:.1f} major faults")


if __name__ == "__main__":
    main()
