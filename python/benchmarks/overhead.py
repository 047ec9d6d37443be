"""The Python call's overhead on a 640x480 SGM frame: the wall time of `StereoMatcher.compute`
from Python (numpy in, numpy out, the GIL released and taken back) against the time the same
call spent matching inside Rust (`StereoMatcher.last_seconds`), per call, in one process; and,
for reference, the command line's own timing of the same match (`cargo xtask disparity --runs
N --confidence`, the median after a warm-up) in interleaved rounds.

    python python/benchmarks/overhead.py [ROUNDS] [RUNS] [THREADS]"""

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import parallax

ROOT = Path(__file__).resolve().parents[2]
XTASK = ROOT / "target" / "release" / "xtask"


def xtask(*args):
    exe = [str(XTASK)] if XTASK.is_file() else ["cargo", "run", "--release", "--quiet", "-p", "xtask", "--"]
    return subprocess.run(exe + [str(a) for a in args], cwd=ROOT, capture_output=True, text=True, check=True).stdout


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 30
    threads = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    tmp = Path(tempfile.mkdtemp())
    world = (ROOT / "fixtures" / "zoo" / "clutter.ron").read_text()
    world = world.replace("width: 320", "width: 640").replace("height: 240", "height: 480")
    world = world.replace("focal_px: 300.0", "focal_px: 600.0").replace("disparities: 48", "disparities: 96")
    (tmp / "clutter640.ron").write_text(world)
    xtask("scenes", "--scenes", tmp / "clutter640.ron", "--render", tmp)
    left, right = parallax.load_pair(tmp / "clutter640" / "left.png", tmp / "clutter640" / "right.png")
    matcher = parallax.StereoMatcher("sgm", num_disparities=96, threads=threads)
    print(f"640x480, 96 disparities, SGM defaults, {threads} threads, simd {matcher.simd}")
    import numpy as np

    outs = (np.empty(left.shape, np.float32), np.empty(left.shape, np.float32))
    overheads, reused, walls, inners, clis = [], [], [], [], []
    for k in range(rounds):
        for mode in ("new arrays", "output arrays"):
            kwargs = dict(disparity=outs[0], confidence=outs[1]) if mode == "output arrays" else {}
            matcher.compute(left, right, **kwargs)
            wall, inner = [], []
            for _ in range(runs):
                t = time.perf_counter()
                matcher.compute(left, right, **kwargs)
                wall.append(time.perf_counter() - t)
                inner.append(matcher.last_seconds)
            extra = statistics.median(w - i for w, i in zip(wall, inner))
            pct = 100.0 * extra / statistics.median(inner)
            (overheads if mode == "new arrays" else reused).append(pct)
            print(f"round {k}, {mode}: call {1e3 * statistics.median(wall):.2f} ms, matching inside it "
                  f"{1e3 * statistics.median(inner):.2f} ms, overhead {1e3 * extra:.3f} ms = {pct:.2f} %")
        walls.append(statistics.median(wall))
        inners.append(statistics.median(inner))
        out = xtask("disparity", "--method", "sgm", "--disparities", "96", "--threads", threads, "--runs", runs,
                    "--confidence", "--left", tmp / "clutter640" / "left.png",
                    "--right", tmp / "clutter640" / "right.png", "--out", tmp / "out")
        clis.append(float(next(l.split(": ")[1] for l in out.splitlines() if l.startswith("seconds: "))))
        print(f"round {k}: the command line's match {1e3 * clis[-1]:.2f} ms")
    print(f"median overhead: {statistics.median(overheads):.2f} % of the matching with new arrays, "
          f"{statistics.median(reused):.2f} % with output arrays; median call (output arrays) "
          f"{1e3 * statistics.median(walls):.2f} ms against the command line's {1e3 * statistics.median(clis):.2f} ms")


if __name__ == "__main__":
    main()
