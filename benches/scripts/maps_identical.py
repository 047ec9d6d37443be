"""Are two builds' disparity maps byte-identical? Runs `xtask disparity` of BEFORE and AFTER (two
xtask binaries) on tsukuba, venus, teddy and the 1282x1110 teddy resize (pairs.py, SET=middlebury)
with 11 option sets covering every kernel family (16- and 32-bit block matching, NCC, the
prefilters, the decisions, SGM's path counts and costs), at the SIMD level the machine has (the
other levels are compared with the naive matcher by the crate's fast_vs_naive and sgm_vs_naive
tests), and compares the PFM maps and confidence maps byte for byte.

    python3 benches/scripts/maps_identical.py /path/to/before/xtask /path/to/after/xtask

Prints one line per case and `identical: N/N`; exits 1 on any difference."""
import filecmp, os, subprocess, sys, tempfile

os.environ.setdefault("SET", "middlebury")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pairs import pairs  # noqa: E402

OPTIONS = {
    "bm-stereobm": ["--prefilter", "xsobel", "--uniqueness", "0", "--lr-max-diff", "-1", "--speckle-window", "0",
                    "--texture", "10", "--block", "9"],
    "bm-defaults": [],
    "bm-rank-lr-conf": ["--prefilter", "rank", "--lr-max-diff", "1", "--confidence", "--block", "7"],
    "bm-none-sad32": ["--prefilter", "none", "--block", "11", "--uniqueness", "5"],
    "bm-ssd": ["--prefilter", "none", "--cost", "ssd", "--block", "9"],
    "bm-ncc": ["--cost", "ncc", "--prefilter", "none", "--block", "7"],
    "bm-norm-fill": ["--prefilter", "norm", "--fill", "--min-confidence", "0.1"],
    "sgm-3": ["--method", "sgm", "--sgm-paths", "3", "--uniqueness", "10", "--lr-max-diff", "1",
              "--speckle-window", "0", "--texture", "0"],
    "sgm-5-bt": ["--method", "sgm", "--sgm-paths", "5", "--sgm-cost", "bt", "--confidence"],
    "sgm-8": ["--method", "sgm", "--sgm-paths", "8", "--lr-rule", "subpixel"],
    "sgm-accurate": ["--method", "sgm", "--accurate"],
}


def main():
    before, after = sys.argv[1], sys.argv[2]
    same = total = 0
    with tempfile.TemporaryDirectory() as tmp:
        for (w, h, nd, _l, _r, pl, pr) in pairs():
            for name, opts in OPTIONS.items():
                outs = []
                for tag, exe in (("before", before), ("after", after)):
                    out = os.path.join(tmp, f"{tag}-{w}-{name}")
                    cmd = [exe, "disparity", "--left", pl, "--right", pr, "--disparities", str(nd), "--out", out,
                           "--threads", "2"] + opts
                    r = subprocess.run(cmd, capture_output=True, text=True)
                    if r.returncode != 0:
                        raise SystemExit(f"{tag} failed: {' '.join(cmd)}\n{r.stderr}")
                    outs.append(out)
                files = sorted(f for f in os.listdir(outs[0]) if f.endswith(".pfm"))
                ok = bool(files) and all(filecmp.cmp(os.path.join(outs[0], f), os.path.join(outs[1], f),
                                                     shallow=False) for f in files)
                total += 1
                same += ok
                print(f"{w}x{h}x{nd} {name:16} {'identical' if ok else 'DIFFERENT'} ({', '.join(files)})",
                      flush=True)
    print(f"identical: {same}/{total}")
    sys.exit(0 if same == total else 1)


if __name__ == "__main__":
    main()
