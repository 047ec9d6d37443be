#!/usr/bin/env python3
"""Generator of the multi-camera rig fixtures in this directory (committed; re-run only to change them).

  python3 crates/planar-calibration/tests/data/rig/make_rig.py

Writes mixed4.json, parallel2.json, parallel3.json and pinhole4.json next to itself. Every pixel
is made with OpenCV's projection functions (cv2.projectPoints for pinhole / Brown-Conrady,
cv2.fisheye.projectPoints for Kannala-Brandt) or, for the double-sphere lens (no OpenCV
function), with the closed-form model of Usenko et al. 2018 in numpy; no code of this
repository is used. Deterministic: one numpy Generator (PCG64) per file, seeded below.

File format (all lengths in mm):
  board: object point k = ((k % cols) * square, (k // cols) * square, 0)
  cameras[i]: lens, width, height, K, D, R, t with X_camI = R X_cam0 + t (camera 0: identity)
  frames[j]: R, t = cam0_from_board; views[i] = null or the cols*rows noisy pixels in object order
  opencv: optional reference results of OpenCV on exactly these points.
"""
import json, os, statistics, sys, time

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
NOISE = 0.2
MARGIN = 10.0          # pixels must lie inside [10, W-11] x [10, H-11]
MIN_Z = 100.0          # "in front": z > 0.1 x distance scale (1 m) = 100 mm
MAX_PINHOLE_R = 1.5    # pinhole: undistorted radius |(x/z, y/z)| < 1.5 (guards against the
                       # fold-over of the radial polynomial far outside the field of view)


# ----------------------------------------------------------------------------- geometry
def rot(axis, deg):
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    R, _ = cv2.Rodrigues(a * np.deg2rad(deg))
    return R


def rot_y(deg):
    return rot([0, 1, 0], deg)


def board_points(cols, rows, square):
    k = np.arange(cols * rows)
    return np.stack([(k % cols) * square, (k // cols) * square, np.zeros(k.size)], 1).astype(np.float64)


def from_cam0(rvec, tvec):
    """(R_world_cam, centre) of the camera whose camI_from_cam0 is the rotation vector `rvec` and
    translation `tvec`."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, float))
    return R.T, -R.T @ np.asarray(tvec, float)


def camera(lens, w, h, fx, fy, cx, cy, D, R_world_cam, centre):
    """R_world_cam: orientation of the camera in the camera-0 frame; centre: its position there.
    Stored as camI_from_cam0: R = R_world_cam^T, t = -R^T centre."""
    R = np.asarray(R_world_cam, float).T
    t = -R @ np.asarray(centre, float)
    return {"lens": lens, "width": w, "height": h,
            "K": np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]), "D": np.asarray(D, float),
            "R": R, "t": t}


def project_double_sphere(Xc, K, D):
    xi, alpha = D
    x, y, z = Xc[:, 0], Xc[:, 1], Xc[:, 2]
    d1 = np.sqrt(x * x + y * y + z * z)
    zz = xi * d1 + z
    d2 = np.sqrt(x * x + y * y + zz * zz)
    den = alpha * d2 + (1 - alpha) * zz
    return np.stack([K[0, 0] * x / den + K[0, 2], K[1, 1] * y / den + K[1, 2]], 1)


def check_double_sphere():
    """Numeric sanity checks of the double-sphere formula against closed forms."""
    rng = np.random.default_rng(1)
    X = rng.uniform([-1, -1, 0.2], [1, 1, 2], (50, 3))
    K = np.array([[300.0, 0, 600], [0, 310, 500], [0, 0, 1]])
    # xi = 0, alpha = 0: pinhole
    p = project_double_sphere(X, K, (0.0, 0.0))
    q = np.stack([300 * X[:, 0] / X[:, 2] + 600, 310 * X[:, 1] / X[:, 2] + 500], 1)
    assert np.abs(p - q).max() < 1e-9
    # xi = 0, alpha = 0.5: stereographic, r = 2 f tan(theta / 2)
    p = project_double_sphere(X, K, (0.0, 0.5))
    th = np.arccos(X[:, 2] / np.linalg.norm(X, axis=1))
    phi = np.arctan2(X[:, 1], X[:, 0])
    q = np.stack([300 * 2 * np.tan(th / 2) * np.cos(phi) + 600, 310 * 2 * np.tan(th / 2) * np.sin(phi) + 500], 1)
    assert np.abs(p - q).max() < 1e-9
    # alpha = 0: unified camera model with parameter xi, u = f x / (z + xi d)
    p = project_double_sphere(X, K, (0.7, 0.0))
    d = np.linalg.norm(X, axis=1)
    q = np.stack([300 * X[:, 0] / (X[:, 2] + 0.7 * d) + 600, 310 * X[:, 1] / (X[:, 2] + 0.7 * d) + 500], 1)
    assert np.abs(p - q).max() < 1e-9


def project(cam, obj, R_cb, t_cb):
    """Pixels of the board points for pose cam_from_board, or None if not all points are
    in front / inside the image (before noise)."""
    Xc = obj @ R_cb.T + t_cb
    if np.any(Xc[:, 2] <= MIN_Z):
        return None
    rvec, _ = cv2.Rodrigues(R_cb)
    tvec = t_cb.reshape(3, 1)
    if cam["lens"] == "pinhole":
        if np.any(np.hypot(Xc[:, 0] / Xc[:, 2], Xc[:, 1] / Xc[:, 2]) >= MAX_PINHOLE_R):
            return None
        uv, _ = cv2.projectPoints(obj, rvec, tvec, cam["K"], cam["D"])
        uv = uv.reshape(-1, 2)
    elif cam["lens"] == "kannala-brandt":
        uv, _ = cv2.fisheye.projectPoints(obj.reshape(-1, 1, 3), rvec, tvec, cam["K"], cam["D"])
        uv = uv.reshape(-1, 2)
    else:
        uv = project_double_sphere(Xc, cam["K"], cam["D"])
    W, H = cam["width"], cam["height"]
    if (uv[:, 0].min() < MARGIN or uv[:, 1].min() < MARGIN or uv[:, 0].max() > W - 11
            or uv[:, 1].max() > H - 11):
        return None
    return uv


def cam_from_board(cam, R0b, t0b):
    return cam["R"] @ R0b, cam["R"] @ t0b + cam["t"]


def visibility(cams, obj, R0b, t0b):
    out = []
    for cam in cams:
        R, t = cam_from_board(cam, R0b, t0b)
        out.append(project(cam, obj, R, t))
    return out


def tilted_board_pose(rng, cam, board, dist, half_angle, tilt_range, roll=20.0):
    """Board centre on a random ray within half_angle of `cam`'s optical axis at distance
    `dist` from its centre; board normal tilted tilt_range degrees from that line of sight, in a
    uniformly random direction; plus a random roll of +-roll degrees. Returns cam0_from_board
    and the tilt angle."""
    Rwc = cam["R"].T
    centre = -Rwc @ cam["t"]
    a = np.deg2rad(half_angle) * np.sqrt(rng.uniform())
    b = rng.uniform(0, 2 * np.pi)
    ray_c = np.array([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b) * 0.75, np.cos(a)])
    ray_c /= np.linalg.norm(ray_c)
    ray = Rwc @ ray_c
    P = centre + dist * ray
    # base orientation: z along the line of sight (away from the camera), x ~ camera x
    z = ray
    x = Rwc[:, 0] - z * (Rwc[:, 0] @ z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    Rb = np.stack([x, y, z], 1)
    tilt = rng.uniform(*tilt_range)
    d = rng.uniform(0, 2 * np.pi)
    Rt = rot([np.cos(d), np.sin(d), 0], tilt)
    Rr = rot([0, 0, 1], rng.uniform(-roll, roll))
    R0b = Rb @ Rt @ Rr
    cols, rows, sq = board
    centre_b = np.array([(cols - 1) * sq / 2, (rows - 1) * sq / 2, 0])
    t0b = P - R0b @ centre_b
    return R0b, t0b, tilt


# ----------------------------------------------------------------------------- output
def fl(a):
    return [float(v) for v in np.asarray(a).ravel()]


def mat(a):
    return [[float(v) for v in row] for row in np.asarray(a)]


def provenance(seed, how):
    return (f"Made by make_rig.py (this directory) with OpenCV {cv2.__version__}, numpy {np.__version__}, "
            f"Python {sys.version.split()[0]}, numpy Generator PCG64 seed {seed}. " + how +
            f" A camera sees a frame only if every board point has z > {MIN_Z:g} mm in it, and every pixel "
            f"lies inside [10, W-11] x [10, H-11] before noise; pinhole cameras additionally need the undistorted "
            f"radius |(x/z, y/z)| < {MAX_PINHOLE_R:g} for every point (guard against the fold-over of the radial "
            f"polynomial). Then i.i.d. Gaussian noise sigma = {NOISE:g} px is added to u and v; otherwise the view "
            f"is null. Pinhole pixels: cv2.projectPoints(obj, rvec, tvec, K, D) with D = k1 k2 p1 p2 k3; "
            f"Kannala-Brandt: cv2.fisheye.projectPoints(obj.reshape(-1,1,3), rvec, tvec, K, D) with D = k1..k4; "
            f"double sphere (Usenko et al. 2018, no OpenCV function): numpy, d1 = |X|, d2 = |(x, y, xi d1 + z)|, "
            f"u = fx x / (alpha d2 + (1 - alpha)(xi d1 + z)) + cx, same for v (checked against the pinhole, "
            f"stereographic and unified-model special cases). Poses: camI_from_board = camI_from_cam0 o "
            f"cam0_from_board. Lengths in mm.")


def write(name, doc):
    path = os.path.join(HERE, name)
    with open(path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {path} ({os.path.getsize(path) / 1e3:.0f} kB)")


def cams_json(cams):
    return [{"lens": c["lens"], "width": c["width"], "height": c["height"], "K": mat(c["K"]),
             "D": fl(c["D"]), "R": mat(c["R"]), "t": fl(c["t"])} for c in cams]


def frames_json(frames):
    return [{"R": mat(f["R"]), "t": fl(f["t"]),
             "views": [None if v is None else [[float(p[0]), float(p[1])] for p in v] for v in f["views"]]}
            for f in frames]


def add_noise(rng, views):
    return [None if v is None else v + rng.normal(0, NOISE, v.shape) for v in views]


def stats(frames, ncam):
    vis = np.array([[v is not None for v in f["views"]] for f in frames])
    share = vis.T.astype(int) @ vis.astype(int)
    return vis, share


# ----------------------------------------------------------------------------- 4-camera rigs
# sets of cameras seeing a frame: number of frames. mixed4: the wide Kannala-Brandt camera 2 sees
# nearly everything cameras 0 and 1 see, so the quota is built around the set {0, 1, 2}.
QUOTA_MIXED4 = {(0, 1, 2): 20, (0, 2): 3, (1, 2): 3, (0,): 2, (2, 3): 8, (3,): 24}
MIXED4_DIST = (400, 1000)
QUOTA_PINHOLE4 = {(0, 1): 14, (0, 1, 2): 12, (0,): 2, (0, 2): 2, (1, 2): 2, (2,): 4, (2, 3): 10, (3,): 14}


def make_rig4(rng, cams, board, n_frames, anchors, quota, dist=(500, 1500)):
    """Rejection sampling of board poses, each generated around an anchor camera at a distance
    drawn from `dist` (mm); a pose is kept if the set of cameras seeing it still has room in QUOTA
    (cameras 0 and 3 never together)."""
    cols, rows, sq = board
    obj = board_points(cols, rows, sq)
    quota = dict(quota)
    assert sum(quota.values()) == n_frames
    frames = []
    for attempt in range(200000):
        if not any(quota.values()):
            break
        a, half = anchors[rng.integers(len(anchors))]
        R0b, t0b, tilt = tilted_board_pose(rng, cams[a], board, rng.uniform(*dist), half, (15, 45))
        views = visibility(cams, obj, R0b, t0b)
        key = tuple(i for i, v in enumerate(views) if v is not None)
        if quota.get(key, 0) > 0:
            quota[key] -= 1
            frames.append({"R": R0b, "t": t0b, "views": views, "tilt": tilt, "key": key})
    assert not any(quota.values()), f"could not fill {quota}"
    order = rng.permutation(len(frames))
    frames = [frames[i] for i in order]
    for f in frames:
        f["views"] = add_noise(rng, f["views"])
    vis, share = stats(frames, len(cams))
    n = len(frames)
    for c in range(len(cams)):
        assert 0.30 * n <= vis[:, c].sum() <= 0.60 * n, (c, vis[:, c].sum())
    assert share[0, 3] == 0
    assert vis.any(1).all()
    # connectivity to camera 0 over links with >= 5 shared frames
    linked, todo = {0}, [0]
    while todo:
        c = todo.pop()
        for d in range(len(cams)):
            if d not in linked and share[c, d] >= 5:
                linked.add(d)
                todo.append(d)
    assert linked == set(range(len(cams)))
    for f in frames:
        assert 15 <= f["tilt"] <= 45
        # distance from the anchor within `dist`
    return frames, vis, share


def mixed4():
    seed = 20240601
    rng = np.random.default_rng(seed)
    cams = [
        camera("pinhole", 1280, 960, 960.0, 958.5, 641.3, 479.2, [-0.25, 0.08, 0.001, -0.0005, -0.01],
               np.eye(3), [0, 0, 0]),
        camera("pinhole", 1280, 960, 942.0, 943.1, 636.8, 484.9, [-0.23, 0.065, -0.0008, 0.0006, -0.004],
               *from_cam0([0.01, -0.02, 0.005], [-150.0, 1.5, -2.0])),
        camera("kannala-brandt", 1280, 1024, 452.0, 451.3, 643.5, 508.7, [0.05, -0.01, 0.002, -0.0005],
               *from_cam0([0.0, -np.deg2rad(40), 0.01], [-250.0, 5.0, 40.0])),
        camera("double-sphere", 1280, 1024, 352.0, 351.2, 638.4, 515.9, [-0.2, 0.6],
               *from_cam0([0.02, -np.deg2rad(85), 0.0], [-400.0, -10.0, 150.0])),
    ]
    # (since 2026-12-07 the rig of tests/rig.rs's scene and its 16x12 board of 26 mm, nearer: the
    # extrinsic bars of issue 46, 0.05 deg and 0.1 % of |t|; before, the rig of pinhole4 and a 9x6
    # board of 40 mm at 0.5-1.5 m)
    board = (16, 12, 26.0)
    frames, vis, share = make_rig4(rng, cams, board, 60, [(0, 25), (2, 55), (3, 55)], QUOTA_MIXED4, MIXED4_DIST)
    return seed, cams, board, frames, vis, share


def pinhole4():
    seed = 20240602
    rng = np.random.default_rng(seed)
    cams = [
        camera("pinhole", 1280, 960, 960.0, 958.5, 641.3, 479.2, [-0.25, 0.08, 0.001, -0.0005, -0.01],
               np.eye(3), [0, 0, 0]),
        camera("pinhole", 1280, 960, 942.0, 943.1, 636.8, 484.9, [-0.23, 0.065, -0.0008, 0.0006, -0.004],
               rot([0.3, 1.0, 0.2], 1.5), [150.0, 1.2, -2.5]),
        camera("pinhole", 1280, 960, 720.0, 721.4, 645.2, 476.0, [-0.21, 0.05, 0.0007, 0.0009, -0.006],
               rot_y(40), [75.0, -40.0, 10.0]),
        camera("pinhole", 1280, 960, 705.0, 703.8, 633.9, 488.1, [-0.27, 0.09, -0.0012, -0.0003, -0.015],
               rot_y(80) @ rot([1, 0, 0], 2.0), [200.0, 5.0, -30.0]),
    ]
    board = (9, 6, 40.0)
    frames, vis, share = make_rig4(rng, cams, board, 60, [(0, 28), (2, 30), (3, 30)], QUOTA_PINHOLE4)
    return seed, cams, board, frames, vis, share


def run_multiview(cams, board, frames, repeats=5):
    # Object points go in in METRES: OpenCV normalises them by the largest SQUARED pairwise distance
    # (getScaleOfObjPoints), so in mm the normalised board is ~1e-3 wide and thresholdPatternCameraAngles'
    # 1e-6 test on |cross|^2 throws "Pattern points are collinear!". Translations are converted back to mm.
    obj_mm = board_points(*board)
    obj = (obj_mm / 1000.0).astype(np.float32)
    nc, nf = len(cams), len(frames)
    obj_pts = [obj.copy() for _ in range(nf)]
    img_pts = [[(np.asarray(f["views"][c], np.float32) if f["views"][c] is not None
                 else np.full((obj.shape[0], 2), -1, np.float32)) for f in frames] for c in range(nc)]
    mask = np.array([[f["views"][c] is not None for f in frames] for c in range(nc)], np.uint8)
    models = np.full((nc, 1), cv2.CALIB_MODEL_PINHOLE, np.uint8)
    sizes = [(c["width"], c["height"]) for c in cams]

    def solve():
        return cv2.calibrateMultiviewExtended(obj_pts, img_pts, sizes, mask, models, None, None, None, None,
                                              flags=0)
    out = solve()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter(); solve(); ts.append(time.perf_counter() - t)
    rms, Ks, Ds, Rs, Ts, pairs, rvecs0, tvecs0, per_frame = out
    rvecs0, tvecs0 = np.asarray(rvecs0).reshape(nf, 3), np.asarray(tvecs0).reshape(nf, 3)
    Rs = [np.asarray(r, np.float64) if np.asarray(r).size == 9 else cv2.Rodrigues(np.asarray(r, np.float64))[0]
          for r in Rs]
    # recompute the RMS from the returned parameters: per-point sqrt(sum |e|^2 / N)
    se, n, mse_views = 0.0, 0, []
    for c in range(nc):
        rc, _ = cv2.Rodrigues(Rs[c])
        for f in range(nf):
            if not mask[c, f]:
                continue
            r, t = cv2.composeRT(np.asarray(rvecs0[f], np.float64).reshape(3, 1),
                                 np.asarray(tvecs0[f], np.float64).reshape(3, 1),
                                 rc.reshape(3, 1), np.asarray(Ts[c], np.float64).reshape(3, 1))[:2]
            uv, _ = cv2.projectPoints(obj.astype(np.float64), r, t, Ks[c], Ds[c])  # all in metres
            e = uv.reshape(-1, 2) - img_pts[c][f].astype(np.float64)
            se += (e ** 2).sum(); n += e.shape[0]; mse_views.append((e ** 2).sum(1).mean())
    check = {"per_point": float(np.sqrt(se / n)), "per_coordinate": float(np.sqrt(se / (2 * n))),
             "mean_of_view_mse": float(np.sqrt(np.mean(mse_views)))}
    return {"rms": float(rms), "K": [mat(k) for k in Ks], "D": [fl(d) for d in Ds],
            "R": [mat(r) for r in Rs], "T": [fl(np.asarray(t) * 1000.0) for t in Ts],
            "seconds_per_solve": float(statistics.median(ts)),
            "flags": "cv2.calibrateMultiviewExtended(objPoints, imagePoints, imageSize, detectionMask, models = "
                     "CALIB_MODEL_PINHOLE x4, Ks = distortions = Rs = Ts = None, flags = 0, flagsForIntrinsics "
                     "default (0 per camera: K with fx, fy, cx, cy and 5 distortion coefficients k1 k2 p1 p2 k3), "
                     "criteria default); object points passed in metres (square 0.04; with mm OpenCV 5.1 throws 'Pattern points are collinear!' because it normalises by the largest squared pairwise distance), T converted back to mm; invisible views passed as (-1, -1) points with detectionMask 0; "
                     f"threads cv2.getNumThreads() = {cv2.getNumThreads()}; seconds_per_solve = median of "
                     f"{repeats} timed solves (after one untimed)",
            "initialization_pairs": [[int(a) for a in p] for p in np.asarray(pairs).reshape(-1, 2)],
            "rms_recomputed": check,
            "version": cv2.__version__}, check


RMS_DEFINITION = (
    "calibrateMultiview returns sqrt(sum_errors / cnt_errors) where, for every (camera, frame) in the "
    "detection mask, err2 = multiview::computeReprojectionMSE(...) = norm(projected - observed, NORM_L2SQR) / "
    "number_of_points, i.e. the mean squared point error |e|^2 = ex^2 + ey^2 of that view, sum_errors += err2, "
    "cnt_errors += 1 (opencv/opencv modules/calib/src/multiview_calibration.cpp, end of cv::calibrateMultiview: "
    "'return norm(tmpImagePoints, NORM_L2SQR) / tmpImagePoints.rows;' in computeReprojectionMSE and "
    "'return sqrt(sum_errors / cnt_errors);'). So it is the root of the mean over views of the per-view "
    "mean squared per-POINT error (2-D distance), not per coordinate; with every view holding all the board "
    "points (here) it equals the per-point RMS sqrt(sum |e|^2 / N_points) = sqrt(2) x the per-coordinate RMS. "
    "The final LM itself minimises a robust (exp(-|e|^2/30)-weighted) cost over the extrinsics and board poses "
    "only; the intrinsics come from the per-camera calibrateCamera. 'rms_recomputed' re-projects with the "
    "returned parameters to confirm.")


# ----------------------------------------------------------------------------- parallel rigs
def make_parallel(rng, cams, board, n_frames):
    cols, rows, sq = board
    obj = board_points(cols, rows, sq)
    centre_b = np.array([(cols - 1) * sq / 2, (rows - 1) * sq / 2, 0])
    frames = []
    for attempt in range(100000):
        if len(frames) == n_frames:
            break
        dist = rng.uniform(400, 1000)
        # board centre anywhere in camera 0's image (normalized coordinates), roll +-20 deg
        u = rng.uniform(-0.6, 0.6); v = rng.uniform(-0.45, 0.45)
        P = dist * np.array([u, v, 1.0])
        tilt = rng.uniform(0, 1.0)
        d = rng.uniform(0, 2 * np.pi)
        R0b = rot([np.cos(d), np.sin(d), 0], tilt) @ rot([0, 0, 1], rng.uniform(-20, 20))
        t0b = P - R0b @ centre_b
        views = visibility(cams, obj, R0b, t0b)
        if all(v is not None for v in views):
            n = R0b[:, 2]
            assert np.degrees(np.arccos(abs(n[2]))) <= 1.0
            frames.append({"R": R0b, "t": t0b, "views": add_noise(rng, views)})
    assert len(frames) == n_frames
    return frames


def parallel(ncam):
    seed = 20240610 + ncam
    rng = np.random.default_rng(seed)
    cams = [
        camera("pinhole", 1280, 960, 1000.0, 1001.2, 638.7, 482.4, [-0.08, 0.12, 0.0004, -0.0003, -0.05],
               np.eye(3), [0, 0, 0]),
        camera("pinhole", 1280, 960, 1004.5, 1003.9, 645.1, 476.3, [-0.07, 0.10, -0.0005, 0.0002, -0.04],
               rot([0.2, 1.0, -0.1], 0.8), [110.0, 0.4, -0.6]),
        camera("pinhole", 1280, 960, 996.8, 997.5, 633.2, 485.6, [-0.09, 0.13, 0.0002, 0.0006, -0.06],
               rot([1.0, -0.2, 0.1], 0.7), [0.3, -110.0, 0.5]),
    ][:ncam]
    board = (7, 6, 30.0)
    frames = make_parallel(rng, cams, board, 30)
    return seed, cams, board, frames


def stereo_reference(cams, board, frames):
    obj = board_points(*board).astype(np.float32)
    op = [obj] * len(frames)
    p1 = [np.asarray(f["views"][0], np.float32) for f in frames]
    p2 = [np.asarray(f["views"][1], np.float32) for f in frames]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-6)
    rms, K1, D1, K2, D2, R, T, E, F = cv2.stereoCalibrate(op, p1, p2, None, None, None, None,
                                                          (cams[0]["width"], cams[0]["height"]),
                                                          flags=0, criteria=crit)
    tt = np.linalg.norm(cams[1]["t"])
    return {"rms": float(rms), "K1": mat(K1), "D1": fl(D1), "K2": mat(K2), "D2": fl(D2), "R": mat(R),
            "T": fl(T), "baseline_error_percent": float(100 * (np.linalg.norm(T) - tt) / tt),
            "call": "cv2.stereoCalibrate(objectPoints (float32), imagePoints1, imagePoints2, None, None, None, None, "
                    "(1280, 960), flags=0, criteria=(COUNT+EPS, 100, 1e-6)); rms as returned",
            "version": cv2.__version__}


# ----------------------------------------------------------------------------- main
def describe(vis, share):
    n = vis.shape[0]
    s = "; ".join(f"camera {c} sees {vis[:, c].sum()} of {n} frames" for c in range(vis.shape[1]))
    pairs = ", ".join(f"{a}-{b}: {share[a, b]}" for a in range(vis.shape[1]) for b in range(a + 1, vis.shape[1]))
    return s + "; shared frames " + pairs + "."


RIG4_NEAR = ("Rig: camera 0 at the origin; camera 1 about 150 mm to the right, rotated 1.5 deg; camera 2 rotated "
             "40 deg about y (towards +x) near (75, -40, 10); camera 3 rotated {rot3} deg about y (and 2 deg about x) "
             "at (200, 5, -30).")
RIG4_WIDE = ("Rig (the one of tests/rig.rs's scene), camI_from_cam0 as rotation vector (rad) and translation (mm): "
             "camera 1 (0.01, -0.02, 0.005), (-150, 1.5, -2); camera 2 (0, -40 deg, 0.01), (-250, 5, 40); camera 3 "
             "(0.02, -85 deg, 0), (-400, -10, 150): a pair 150 mm apart, a wide camera turned 40 deg, a second one "
             "turned 85 deg and 427 mm away.")
RIG4_HOW = (
    "{rig} Board poses are drawn around an anchor camera (0, 2 or 3, at random): the board centre on a "
    "random ray near its optical axis at {dist} m from it, the board normal tilted 15-45 deg from that line of "
    "sight in a uniformly random direction, roll +-20 deg. A pose is kept only while the set of cameras that see "
    "it still has room in the quota {quota} (sets of camera indices: frame counts); cameras 0 and 3 are never "
    "together in a frame because no such set is in the quota (poses seen by both are rejected, never edited). "
    "The kept frames are then shuffled. Asserted: each camera sees 30-60 % of the frames, every frame is seen, "
    "camera 0 and 3 share none, and every camera reaches camera 0 over links of >= 5 shared frames. ")


def main():
    # (names on the command line: write only those sets, e.g. `make_rig.py mixed4`)
    only = set(sys.argv[1:])
    want = lambda name: not only or name in only
    check_double_sphere()
    if want("mixed4"):
        write_mixed4()
    if want("pinhole4"):
        write_pinhole4()
    for ncam in (2, 3):
        if want(f"parallel{ncam}"):
            write_parallel(ncam)


def write_mixed4():
    seed, cams, board, frames, vis, share = mixed4()
    how = RIG4_HOW.format(rig=RIG4_WIDE, dist="-".join(f"{d / 1000:g}" for d in MIXED4_DIST),
                          quota={"+".join(map(str, k)): v for k, v in QUOTA_MIXED4.items()}) + describe(vis, share)
    doc = {"provenance": provenance(seed, how), "board": {"cols": board[0], "rows": board[1], "square": board[2]},
           "noise_px": NOISE, "cameras": cams_json(cams), "frames": frames_json(frames)}
    write("mixed4.json", doc)
    print("mixed4:", describe(vis, share))


def write_pinhole4():
    seed, cams, board, frames, vis, share = pinhole4()
    how = ("All four cameras pinhole (Brown-Conrady k1 k2 p1 p2 k3), 1280x960. " +
           RIG4_HOW.format(rig=RIG4_NEAR.format(rot3=80), dist="0.5-1.5", quota={"+".join(map(str, k)): v for k, v in QUOTA_PINHOLE4.items()}) + describe(vis, share))
    cv2.setNumThreads(2)
    ref, check = run_multiview(cams, board, frames)
    ref["rms_definition"] = RMS_DEFINITION
    doc = {"provenance": provenance(seed, how) + " The 'opencv' entry: " + ref["flags"] + ".",
           "board": {"cols": board[0], "rows": board[1], "square": board[2]},
           "noise_px": NOISE, "cameras": cams_json(cams), "frames": frames_json(frames), "opencv": ref}
    write("pinhole4.json", doc)
    print("pinhole4:", describe(vis, share))
    print(f"pinhole4 calibrateMultiview rms {ref['rms']:.6f} (recomputed {check}), "
          f"{ref['seconds_per_solve'] * 1e3:.1f} ms/solve, pairs {ref['initialization_pairs']}")


def write_parallel(ncam):
    seed, cams, board, frames = parallel(ncam)
    how = (f"{ncam} pinhole cameras 1280x960, fx about 1000, mild distortion: camera 1 about 110 mm to the "
           "right of camera 0 (rotated 0.8 deg)" + (", camera 2 about 110 mm above camera 0 (rotated 0.7 deg)"
                                                    if ncam == 3 else "") +
           ". 30 frames, all seen by every camera (poses drawn until 30 are seen by all): board 7x6, square "
           "30 mm, centre at 0.4-1.0 m in depth anywhere in camera 0's image, normal within 1 deg of camera "
           "0's optical axis (fronto-parallel), roll +-20 deg.")
    doc = {"provenance": provenance(seed, how),
           "board": {"cols": board[0], "rows": board[1], "square": board[2]},
           "noise_px": NOISE, "cameras": cams_json(cams), "frames": frames_json(frames)}
    if ncam == 2:
        doc["opencv"] = stereo_reference(cams, board, frames)
        o = doc["opencv"]
        print(f"parallel2 stereoCalibrate rms {o['rms']:.4f}, |T| {np.linalg.norm(o['T']):.3f}, "
              f"baseline error {o['baseline_error_percent']:.2f} %, fx1 {o['K1'][0][0]:.1f}, fx2 {o['K2'][0][0]:.1f}")
    write(f"parallel{ncam}.json", doc)


if __name__ == "__main__":
    main()
