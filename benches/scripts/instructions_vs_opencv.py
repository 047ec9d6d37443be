#!/usr/bin/env python3
"""Instructions executed per disparity evaluation, ours against OpenCV, on the same pairs and
options as disparity_vs_opencv.py: a figure this VM's timing noise does not touch, and the one
that bounds a speed ratio when both sides run at the same instructions per cycle.

  cargo build --release -p xtask
  python3 benches/scripts/instructions_vs_opencv.py bm|sgm      (NS=1..3 sizes, SGM_PATHS as there)

Counted with valgrind's callgrind (`apt-get install valgrind`), one thread each side: the
instructions of one compute are the difference between a run with three computes and one with
one, so reading, prefiltering set-up and writing cancel out. Our kernels are AVX2 (256-bit),
the build that runs natively too; OpenCV's StereoBM and SGBM in the pip build are 128-bit
either way. Evaluations are counted as width x height x disparities."""
import os, re, subprocess, sys, tempfile
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pairs import pairs as make_pairs, our_options, out_dir

XT = os.environ.get("XTASK") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target", "release", "xtask")
mode = sys.argv[1] if len(sys.argv) > 1 else "bm"
if mode not in ("bm", "sgm"):
    raise SystemExit("usage: instructions_vs_opencv.py bm|sgm")

OPENCV = """
import cv2, sys
sys.path.insert(0, {here!r})
from pairs import opencv_matcher
cv2.setNumThreads(1)
l, r = cv2.imread(sys.argv[1], 0), cv2.imread(sys.argv[2], 0)
m = opencv_matcher({mode!r}, int(sys.argv[3]))
for _ in range(int(sys.argv[4])):
    m.compute(l, r)
"""


def instructions(cmd):
    """Instructions valgrind counted for the whole command."""
    out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null"] + cmd,
                         capture_output=True, text=True)
    m = re.search(r"Collected : (\d+)", out.stderr)
    if out.returncode != 0 or not m:
        raise SystemExit(f"valgrind failed on {cmd[:2]}:\n{out.stderr[-2000:]}")
    return int(m.group(1))


with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
    f.write(OPENCV.format(here=os.path.dirname(os.path.abspath(__file__)), mode=mode))
    script = f.name
print(f"mode {mode}" + (f", our paths {os.environ.get('SGM_PATHS', '3')}" if mode == "sgm" else "") + ", one thread each")
for w, h, nd, l, r, pl, pr in make_pairs():
    ours = lambda runs: instructions([XT, "disparity", "--left", pl, "--right", pr, "--disparities", str(nd), "--runs",
                                      str(runs), "--out", os.path.join(out_dir(), "oi"), "--allow-swapped", "--threads", "1"]
                                     + our_options(mode))
    theirs = lambda n: instructions([sys.executable, script, pl, pr, str(nd), str(n)])
    a = (ours(3) - ours(1)) / 2
    b = (theirs(3) - theirs(1)) / 2
    n = w * h * nd
    print(f"{w}x{h}x{nd}: ours {a / 1e6:.0f} M instructions ({a / n:.2f} per evaluation), OpenCV {b / 1e6:.0f} M "
          f"({b / n:.2f}); OpenCV / ours {b / a:.2f}", flush=True)
os.unlink(script)
