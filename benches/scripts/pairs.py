"""What the comparison scripts share: the matchers' options on both sides (our_options,
opencv_matcher) and the pairs: Middlebury teddy from ../shared (or $PARALLAX_SHARED) as
it is and resized to 626x555 (96 disparities) and 1282x1110 (224), written as PNGs to
$PAIRS_OUT (default /tmp/parallax-pairs); SET=middlebury: tsukuba, venus and teddy as they are,
then the 1282x1110 resize. NS=1..3 keeps the first sizes."""
import cv2, os


def _shared():
    # ../shared beside the worktree (also for worktrees one level deeper), or $PARALLAX_SHARED
    here = os.path.dirname(os.path.abspath(__file__))
    for c in (os.environ.get("PARALLAX_SHARED"), os.path.join(here, "..", "..", "..", "shared"),
              os.path.join(here, "..", "..", "..", "..", "shared")):
        if c and os.path.isdir(os.path.join(c, "data", "middlebury")):
            return c
    raise SystemExit("../shared/data/middlebury not found (set PARALLAX_SHARED)")


def pairs():
    """[(w, h, disparities, left, right, left path, right path)]"""
    D = os.path.join(_shared(), "data", "middlebury", "teddy")
    OUT = out_dir(); os.makedirs(OUT, exist_ok=True)
    L0 = cv2.imread(f"{D}/imL.png", 0); R0 = cv2.imread(f"{D}/imR.png", 0)
    sizes = [(450, 375, 64), (626, 555, 96), (1282, 1110, 224)][:int(os.environ.get("NS", "3"))]
    out = []
    if os.environ.get("SET") == "middlebury":
        # tsukuba (16 disparities), venus (32) and teddy (64) as they are, then the teddy pair
        # resized to 1282x1110 (224; the size of aloe, not in ../shared)
        for name, nd in (("tsukuba", 16), ("venus", 32), ("teddy", 64)):
            d = os.path.join(os.path.dirname(D), name)
            l, r = cv2.imread(f"{d}/imL.png", 0), cv2.imread(f"{d}/imR.png", 0)
            out.append((l.shape[1], l.shape[0], nd, l, r, f"{d}/imL.png", f"{d}/imR.png"))
        sizes = sizes[2:]
    for w, h, nd in sizes:
        l = L0 if w == 450 else cv2.resize(L0, (w, h), interpolation=cv2.INTER_CUBIC)
        r = R0 if w == 450 else cv2.resize(R0, (w, h), interpolation=cv2.INTER_CUBIC)
        pl, pr = f"{OUT}/l{w}.png", f"{OUT}/r{w}.png"
        cv2.imwrite(pl, l); cv2.imwrite(pr, r)
        out.append((w, h, nd, l, r, pl, pr))
    return out


def out_dir():
    return os.environ.get("PAIRS_OUT", "/tmp/parallax-pairs")


def our_options(mode):
    """`xtask disparity` options matching opencv_matcher(mode): bm = StereoBM 9x9's (x-Sobel,
    texture 10, uniqueness 0, no left-right check, no speckle filter); sgm = the SGM measurement
    preset without texture and speckle filters, on SGM_PATHS paths (default 3, 3-way's directions);
    with SGM_PRESET=accurate, the accurate preset (`--accurate`: SGBM's cost and left-right rule,
    eight paths, its own uniqueness 0) without texture and speckle filters. PRESET=defaults:
    our defaults as they are (`--method sgm` alone for sgm, nothing for bm)."""
    if os.environ.get("PRESET") == "defaults":
        return ["--method", "sgm"] if mode == "sgm" else []
    if mode == "sgm" and os.environ.get("SGM_PRESET") == "accurate":
        return ["--method", "sgm", "--accurate", "--speckle-window", "0", "--texture", "0"]
    if mode == "bm":
        return ["--prefilter", "xsobel", "--uniqueness", "0", "--lr-max-diff", "-1", "--speckle-window", "0",
                "--texture", "10", "--block", "9"]
    return ["--method", "sgm", "--sgm-paths", os.environ.get("SGM_PATHS", "3"), "--uniqueness", "10",
            "--lr-max-diff", "1", "--speckle-window", "0", "--texture", "0"]


def opencv_matcher(mode, nd):
    """StereoBM 9x9 with uniqueness 0, or StereoSGBM 3-way (block 5, P1 200, P2 800,
    disp12MaxDiff 1, uniqueness 10, no speckle filter); SGBM_MODE=hh (eight directions, full
    cost volume) or sgbm (five directions) for SGBM's other modes. PRESET=defaults: StereoBM 9x9
    with its defaults, or SGBM with the settings of `overlap_vs_sgbm.py` (blockSize 5, P1 600,
    P2 2400, uniquenessRatio 10, disp12MaxDiff 1, speckleWindowSize 100, speckleRange 2)."""
    defaults = os.environ.get("PRESET") == "defaults"
    sgbm_mode = {"3way": cv2.StereoSGBM_MODE_SGBM_3WAY, "sgbm": cv2.StereoSGBM_MODE_SGBM,
                 "hh": cv2.StereoSGBM_MODE_HH}[os.environ.get("SGBM_MODE", "3way")]
    if mode == "bm" and defaults:
        return cv2.StereoBM_create(numDisparities=nd, blockSize=9)
    if defaults:
        return cv2.StereoSGBM_create(minDisparity=0, numDisparities=nd, blockSize=5, P1=8 * 3 * 25, P2=32 * 3 * 25,
                                     disp12MaxDiff=1, uniquenessRatio=10, speckleWindowSize=100, speckleRange=2,
                                     mode=sgbm_mode)
    if mode == "bm":
        m = cv2.StereoBM_create(numDisparities=nd, blockSize=9); m.setUniquenessRatio(0)
        return m
    return cv2.StereoSGBM_create(minDisparity=0, numDisparities=nd, blockSize=5, P1=200, P2=800, disp12MaxDiff=1,
                                 preFilterCap=63, uniquenessRatio=10, speckleWindowSize=0, speckleRange=0,
                                 mode=sgbm_mode)
