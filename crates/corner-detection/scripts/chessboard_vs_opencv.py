"""Side-by-side timing of OpenCV's findChessboardCorners + cornerSubPix against parallax's
detector, interleaved image by image: the `time_chessboards` example runs as a server holding
one reused `ChessboardDetector` (images decoded once), and for every image of every round the
script runs parallax and OpenCV back to back (the order alternating), so both see the same
machine load at the same moment.

    pip install opencv-python-headless numpy
    cargo build --release -p parallax-corner-detection --example time_chessboards
    python3 chessboard_vs_opencv.py DIR COLSxROWS [ROUNDS] [--baseline PATH]

`--baseline PATH` runs a second `time_chessboards` binary (e.g. built from an earlier commit)
in the same interleaving, for before/after figures under the same load.

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


class Server:
    """One `time_chessboards` process and its per-image times and CPU counters."""

    def __init__(self, binary, pattern, paths):
        self.proc = subprocess.Popen([binary, pattern] + paths, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True)
        head = self.proc.stdout.readline().split()
        assert head and head[0] == "ready", head
        self.last = [int(v) for v in head[1:]]
        self.cpu = [0, 0, 0, 0]  # user ticks, system ticks, minor faults, major faults
        self.times = [[] for _ in paths]
        self.found = [None for _ in paths]

    def run(self, k):
        self.proc.stdin.write(f"{k}\n")
        self.proc.stdin.flush()
        f = self.proc.stdout.readline().split()
        now = [int(v) for v in f[2:]]
        for j in range(4):
            self.cpu[j] += now[j] - self.last[j]
        self.last = now
        self.times[k].append(float(f[0]))
        self.found[k] = f[1] == "1"

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def main():
    args = sys.argv[1:]
    baseline = None
    if "--baseline" in args:
        i = args.index("--baseline")
        baseline = args[i + 1]
        del args[i:i + 2]
    d, pattern = args[0], args[1]
    rounds = int(args[2]) if len(args) > 2 else 10
    cols, rows = map(int, pattern.split("x"))
    paths = sorted(glob.glob(os.path.join(d, "*.png")) + glob.glob(os.path.join(d, "*.jpg")))
    images = [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in paths]
    servers = [("parallax", Server(SERVER, pattern, paths))]
    if baseline:
        servers.append(("baseline", Server(baseline, pattern, paths)))
    cv_cpu = [0.0, 0.0, 0, 0]  # user s, system s, minor faults, major faults
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    t_cv = [[] for _ in paths]
    found_cv = [None for _ in paths]

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
        found_cv[k] = bool(ok)

    runners = [s.run for _, s in servers] + [opencv]
    load0 = os.getloadavg()
    for r in range(rounds):
        for k in range(len(paths)):
            # Rotate the order so that no side always runs first.
            shift = (r + k) % len(runners)
            for run in runners[shift:] + runners[:shift]:
                run(k)
    for _, s in servers:
        s.close()
    n = rounds * len(paths)
    print(f"{d}: {len(paths)} images x {rounds} rounds, OpenCV {cv2.__version__} with {cv2.getNumThreads()} threads")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f} ({os.cpu_count()} CPUs)")
    names = [name for name, _ in servers]
    print("image               " + "".join(f"{name + ' ms':>13s}" for name in names) + "    opencv ms"
          + "".join(f"{name[:8] + '/cv':>12s}" for name in names) + "  found (" + ", ".join(names) + ", opencv)")
    med = {name: [] for name in names}
    med_cv = []
    ratios = {name: [] for name in names}
    for k, p in enumerate(paths):
        b = statistics.median(t_cv[k])
        med_cv.append(b)
        line = f"{os.path.basename(p):20s}"
        cols_r = ""
        for name, s in servers:
            a = statistics.median(s.times[k])
            med[name].append(a)
            ratios[name].append(a / b)
            line += f"{a:13.2f}"
            cols_r += f"{a / b:12.2f}"
        found = tuple(s.found[k] for _, s in servers) + (found_cv[k],)
        print(f"{line}{b:13.2f}{cols_r}  {found}")
    for name, s in servers:
        m = statistics.median(med[name])
        print(f"{name}: median over images {m:.2f} ms against OpenCV {statistics.median(med_cv):.2f} ms, "
              f"ratio of medians {m / statistics.median(med_cv):.2f}, per-image ratios "
              f"{min(ratios[name]):.2f}-{max(ratios[name]):.2f}")
        print(f"  per image: user {s.cpu[0] / TICK / n * 1e3:.1f} ms, system {s.cpu[1] / TICK / n * 1e3:.1f} ms, "
              f"{s.cpu[2] / n:.0f} minor / {s.cpu[3] / n:.1f} major page faults")
    print(f"OpenCV per image: user {cv_cpu[0] / n * 1e3:.1f} ms, system {cv_cpu[1] / n * 1e3:.1f} ms, "
          f"{cv_cpu[2] / n:.0f} minor / {cv_cpu[3] / n:.1f} major page faults")


if __name__ == "__main__":
    main()
