"""The Python call's overhead on a 640x480 SGM frame: `StereoMatcher.compute` from Python
(numpy in, numpy out) against the same match timed inside the command line (`cargo xtask
disparity --runs N`, the median of N runs after a warm-up), interleaved rounds.

    python python/benchmarks/overhead.py [ROUNDS] [RUNS]

Prints each round's figures and the median overhead in percent."""

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
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    tmp = Path(tempfile.mkdtemp())
    world = (ROOT / "fixtures" / "zoo" / "clutter.ron").read_text()
    world = world.replace("width: 320", "width: 640").replace("height: 240", "height: 480")
    world = world.replace("focal_px: 300.0", "focal_px: 600.0").replace("disparities: 48", "disparities: 96")
    (tmp / "clutter640.ron").write_text(world)
    xtask("scenes", "--scenes", tmp / "clutter640.ron", "--render", tmp)
    left, right = parallax.load_pair(tmp / "clutter640" / "left.png", tmp / "clutter640" / "right.png")
    matcher = parallax.StereoMatcher("sgm", num_disparities=96, threads=2)
    print(f"640x480, 96 disparities, SGM defaults, 2 threads, simd {matcher.simd}")
    overheads = []
    for k in range(rounds):
        matcher.compute(left, right)
        times = []
        for _ in range(runs):
            t = time.perf_counter()
            matcher.compute(left, right)
            times.append(time.perf_counter() - t)
        py = statistics.median(times)
        out = xtask("disparity", "--method", "sgm", "--disparities", "96", "--threads", "2", "--runs", runs,
                    "--left", tmp / "clutter640" / "left.png", "--right", tmp / "clutter640" / "right.png",
                    "--out", tmp / "out")
        cli = float(next(l.split(": ")[1] for l in out.splitlines() if l.startswith("seconds: ")))
        overheads.append(100.0 * (py / cli - 1.0))
        print(f"round {k}: python {1e3 * py:.2f} ms, inside the command line {1e3 * cli:.2f} ms, "
              f"overhead {overheads[-1]:+.1f} %")
    print(f"median overhead: {statistics.median(overheads):+.1f} %")


if __name__ == "__main__":
    main()
