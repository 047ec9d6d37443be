#!/usr/bin/env python3
"""A wide-angle (~180 deg) stereo chessboard session made entirely by OpenCV, and OpenCV's own
`cv2.fisheye.stereoCalibrate` result on it (see README.md).

    pip install opencv-python-headless numpy
    python3 make.py          # writes left.json, right.json, reference.json next to this file

Deterministic: a fixed seed; running it again writes byte-identical files (same OpenCV build).
"""

import json
import math
import os
import sys

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))

SEED = 20261201
W, H = 1280, 960
COLS, ROWS, SQUARE = 9, 6, 25.0  # inner corners, mm
NOISE_PX = 0.2  # Gaussian, per coordinate
MARGIN_PX = 5.0  # every corner at least this far inside both images
MAX_VIEW_ANGLE_DEG = 65.0  # board normal vs the ray to the board centre, both cameras

# Two Kannala-Brandt (cv2.fisheye) cameras: theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8).
# f = 320 px: theta = 90 deg at r ~ 490 px, i.e. the 180 deg circle spans the image height.
K1_TRUE = np.array([[320.0, 0.0, 641.3], [0.0, 319.4, 478.6], [0.0, 0.0, 1.0]])
D1_TRUE = np.array([-0.02, 0.01, -0.005, 0.001])
K2_TRUE = np.array([[317.8, 0.0, 636.7], [0.0, 318.3, 482.9], [0.0, 0.0, 1.0]])
D2_TRUE = np.array([-0.015, 0.006, -0.003, 0.0005])
# right_from_left, OpenCV convention X_right = R X_left + T (mm): right camera ~120 mm to +x.
RIG_RVEC_TRUE = np.deg2rad([0.8, -2.4, 0.5])
R_TRUE = cv2.Rodrigues(RIG_RVEC_TRUE)[0]
T_TRUE = np.array([-120.0, 0.5, 1.0])

# OpenCV's fisheye::calibrate without a guess starts at f = max(w, h) / 2 = 640 px, twice this
# lens's focal length, and diverges (InitExtrinsics: "Too few image points can be undistorted")
# on this session, so every call gets CALIB_USE_INTRINSIC_GUESS: the mono calibrations start
# from the equidistant lens whose 90 deg ray meets the top and bottom image edges, the stereo
# calibration from the mono results (main() checks that other starts reach the same result).
BASE_FLAGS = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
FLAGS = BASE_FLAGS | cv2.fisheye.CALIB_USE_INTRINSIC_GUESS
FLAGS_TEXT = "cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW | cv2.fisheye.CALIB_USE_INTRINSIC_GUESS"
F_GUESS = (H / 2) / (math.pi / 2)
K_GUESS = np.array([[F_GUESS, 0.0, (W - 1) / 2], [0.0, F_GUESS, (H - 1) / 2], [0.0, 0.0, 1.0]])
D_GUESS = np.zeros(4)
CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)

# Board-centre directions in the left camera: (off-axis angle, azimuth) in degrees, distance
# range in mm. Spread over the whole field, a third of the views near the border.
TARGETS = (
    [(5.0, 0.0, (330.0, 450.0)), (12.0, 200.0, (280.0, 380.0))]
    + [(28.0, 60.0 * k, (300.0, 420.0)) for k in range(6)]
    + [(48.0, 22.5 + 45.0 * k, (260.0, 380.0)) for k in range(8)]
    + [(66.0, 15.0 + 30.0 * k, (230.0, 330.0)) for k in range(12)]
)


def object_points():
    i = np.arange(COLS * ROWS)
    return np.stack([(i % COLS) * SQUARE, (i // COLS) * SQUARE, np.zeros(i.size)], axis=1).astype(np.float64)


def rot(axis, a):
    c, s = math.cos(a), math.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def facing(direction):
    """camera_from_board rotation whose board z axis is `direction` (the board faces the camera)."""
    z = direction / np.linalg.norm(direction)
    up = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def project(obj, rvec, tvec, K, D):
    p, _ = cv2.fisheye.projectPoints(obj.reshape(-1, 1, 3), rvec.reshape(3, 1), tvec.reshape(3, 1), K, D)
    return p.reshape(-1, 2).astype(np.float64)


def acceptable(obj, R, t):
    """All corners in front of both cameras, inside both images with the margin; the board seen at
    most MAX_VIEW_ANGLE_DEG off its normal from both cameras."""
    centre = obj.mean(axis=0)
    for Rc, tc, K, D in ((R, t, K1_TRUE, D1_TRUE), (R_TRUE @ R, R_TRUE @ t + T_TRUE, K2_TRUE, D2_TRUE)):
        X = obj @ Rc.T + tc
        if np.any(X[:, 2] <= 0.0):
            return False
        c = Rc @ centre + tc
        cos_view = abs(Rc[:, 2] @ c) / np.linalg.norm(c)
        if cos_view < math.cos(math.radians(MAX_VIEW_ANGLE_DEG)):
            return False
        uv = project(obj, cv2.Rodrigues(Rc)[0], tc, K, D)
        if not np.all(np.isfinite(uv)):
            return False
        if np.any(uv[:, 0] < MARGIN_PX) or np.any(uv[:, 0] > W - 1 - MARGIN_PX):
            return False
        if np.any(uv[:, 1] < MARGIN_PX) or np.any(uv[:, 1] > H - 1 - MARGIN_PX):
            return False
    return True


def make_poses(rng, obj):
    centre_b = obj.mean(axis=0)
    poses = []
    for theta_deg, phi_deg, (dmin, dmax) in TARGETS:
        for attempt in range(4000):
            shrink = 1.0 if attempt < 2000 else 0.6  # milder tilts if the first ones never fit
            theta = math.radians(theta_deg + rng.uniform(-4.0, 4.0))
            phi = math.radians(phi_deg + rng.uniform(-8.0, 8.0))
            d = rng.uniform(dmin, dmax)
            ray = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])
            a = rng.choice([-1.0, 1.0]) * rng.uniform(15.0, 55.0) * shrink
            b = rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 50.0) * shrink
            c = rng.uniform(-40.0, 40.0)
            if rng.uniform() < 0.5:
                a, b = b, a
            R = facing(ray) @ rot("x", math.radians(a)) @ rot("y", math.radians(b)) @ rot("z", math.radians(c))
            t = d * ray - R @ centre_b
            if acceptable(obj, R, t):
                poses.append((cv2.Rodrigues(R)[0].reshape(3), t))
                break
        else:
            sys.exit(f"no acceptable pose for target {theta_deg, phi_deg}")
    return poses


def fl(x):
    """Plain Python floats (repr is the shortest string that reads back the same double)."""
    return np.asarray(x, dtype=np.float64).tolist()


def mono(obj_list, img_list, K0=K_GUESS, D0=D_GUESS, criteria=CRITERIA, flags=FLAGS):
    rms, K, D, _, _ = cv2.fisheye.calibrate(
        obj_list, img_list, (W, H), K0.copy(), D0.copy(), flags=flags, criteria=criteria
    )
    return rms, K, D.reshape(4)


def stereo(obj_list, img1, img2, K1, D1, K2, D2, criteria=CRITERIA, flags=FLAGS):
    out = cv2.fisheye.stereoCalibrate(
        obj_list, img1, img2, K1.copy(), D1.copy(), K2.copy(), D2.copy(), (W, H), flags=flags, criteria=criteria
    )
    assert len(out) == 9, "the overload with the per-view poses"
    rms, K1o, D1o, K2o, D2o, R, T, rvecs, tvecs = out
    return rms, K1o, D1o.reshape(4), K2o, D2o.reshape(4), R, T.reshape(3), rvecs, tvecs


def vec(r):
    return np.concatenate([r[1].ravel(), r[2], r[3].ravel(), r[4], r[5].ravel(), r[6]])


def rel_change(a, b):
    return float(np.max(np.abs(vec(a) - vec(b)) / np.maximum(np.abs(vec(b)), 1e-3)))


def rot_err_deg(Ra, Rb):
    return math.degrees(cv2.norm(cv2.Rodrigues(Ra @ Rb.T)[0]))


def independent_gauss_newton(obj, img1, img2, res):
    """A check outside OpenCV's optimiser: Gauss-Newton on the same cost (both cameras' squared
    reprojection errors; fx fy cx cy k1..k4 per camera, the rig's Rodrigues vector and T, every
    left pose), Jacobian by central differences of cv2.fisheye.projectPoints, started at OpenCV's
    result (its per-view poses too). Returns the minimum it reaches (K, D, rig: 22 values), OpenCV's
    values in the same order, their standard deviations, the step sizes and the rms."""
    _, K1, D1, K2, D2, R, T, rvecs, tvecs = res
    n = len(obj)

    def K_of(v):
        return np.array([[v[0], 0.0, v[2]], [0.0, v[1], v[3]], [0.0, 0.0, 1.0]])

    def view(x, i):
        om, T, p = x[16:19], x[19:22], x[22 + 6 * i: 28 + 6 * i]
        Rr, Rl = cv2.Rodrigues(om)[0], cv2.Rodrigues(p[:3])[0]
        e1 = img1[i].reshape(-1, 2) - project(obj[i], p[:3], p[3:], K_of(x[0:4]), x[4:8])
        e2 = img2[i].reshape(-1, 2) - project(obj[i], cv2.Rodrigues(Rr @ Rl)[0], Rr @ p[3:] + T, K_of(x[8:12]), x[12:16])
        return np.concatenate([e1.ravel(), e2.ravel()])

    def residuals(x):
        return np.concatenate([view(x, i) for i in range(n)])

    cam = lambda K, D: [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *D]
    x0 = np.array(cam(K1, D1) + cam(K2, D2) + list(cv2.Rodrigues(R)[0].ravel()) + list(T)
                  + [v for rv, tv in zip(rvecs, tvecs) for v in (*np.ravel(rv), *np.ravel(tv))])
    m = 4 * COLS * ROWS  # residuals per view
    x, steps = x0.copy(), []
    for _ in range(4):
        r = residuals(x)
        J = np.zeros((r.size, x.size))
        for k in range(x.size):
            h = 1e-6 * max(abs(x[k]), 1.0)
            xp, xm = x.copy(), x.copy()
            xp[k] += h
            xm[k] -= h
            if k < 22:
                J[:, k] = (residuals(xm) - residuals(xp)) / (2 * h)  # d(model)/dx
            else:
                i = (k - 22) // 6
                J[m * i: m * (i + 1), k] = (view(xm, i) - view(xp, i)) / (2 * h)
        step = np.linalg.solve(J.T @ J, J.T @ r)
        x += step
        steps.append(step)
    r = residuals(x)
    sigma2 = r @ r / (r.size - x.size)
    std = np.sqrt(np.diag(np.linalg.inv(J.T @ J)) * sigma2)
    return x[:22], x0[:22], std[:22], [float(np.max(np.abs(st[:22]) / std[:22])) for st in steps], math.sqrt(r @ r / (r.size / 2))


def main():
    print("cv2", cv2.__version__, "numpy", np.__version__)
    rng = np.random.default_rng(SEED)
    obj = object_points()
    poses = make_poses(rng, obj)
    obj_list, img1, img2 = [], [], []
    for rv, t in poses:
        R = cv2.Rodrigues(rv)[0]
        u1 = project(obj, rv, t, K1_TRUE, D1_TRUE)
        u2 = project(obj, cv2.Rodrigues(R_TRUE @ R)[0], R_TRUE @ t + T_TRUE, K2_TRUE, D2_TRUE)
        u1 = u1 + rng.normal(0.0, NOISE_PX, u1.shape)
        u2 = u2 + rng.normal(0.0, NOISE_PX, u2.shape)
        obj_list.append(obj.reshape(-1, 1, 3).copy())
        img1.append(u1.reshape(-1, 1, 2))
        img2.append(u2.reshape(-1, 1, 2))
    n = len(poses)

    # coverage of the field
    def field(K, D, img):
        pts = np.concatenate(img).reshape(-1, 1, 2)
        und = cv2.fisheye.undistortPoints(pts, K, D).reshape(-1, 2)
        return np.degrees(np.arctan(np.linalg.norm(und, axis=1)))

    f1, f2 = field(K1_TRUE, D1_TRUE, img1), field(K2_TRUE, D2_TRUE, img2)
    print(f"{n} views of {COLS}x{ROWS} corners, {W}x{H}; corners up to {f1.max():.1f} deg (left) / "
          f"{f2.max():.1f} deg (right) off axis, {np.mean(f1 > 60):.0%} / {np.mean(f2 > 60):.0%} beyond 60 deg")
    for name, img in (("left", img1), ("right", img2)):
        pts = np.concatenate(img).reshape(-1, 2)
        print(f"  {name}: u in [{pts[:, 0].min():.1f}, {pts[:, 0].max():.1f}], v in [{pts[:, 1].min():.1f}, {pts[:, 1].max():.1f}]")

    # mono calibrations (the start of the stereo calibration)
    m1 = mono(obj_list, img1)
    m2 = mono(obj_list, img2)
    for name, m, img, (K, D) in (("left", m1, img1, (K1_TRUE, D1_TRUE)), ("right", m2, img2, (K2_TRUE, D2_TRUE))):
        m_more = mono(obj_list, img, criteria=(3, 400, 0.0))
        m_other = [mono(obj_list, img, K0=np.diag([f, f, 1.0]) + K_GUESS * [[0, 0, 1], [0, 0, 1], [0, 0, 0]])
                   for f in (330.0, 400.0, 450.0)]
        mv = lambda r: np.concatenate([r[1].ravel(), r[2]])
        rel = lambda a: float(np.max(np.abs(mv(a) - mv(m)) / np.maximum(np.abs(mv(m)), 1e-3)))
        print(f"mono {name}: rms {m[0]:.6f} px, fx {m[1][0, 0]:.5f} fy {m[1][1, 1]:.5f} cx {m[1][0, 2]:.5f} "
              f"cy {m[1][1, 2]:.5f} D {np.array2string(m[2], precision=6)}  (truth fx {K[0, 0]} fy {K[1, 1]}, D {D})")
        print(f"  400 iterations (eps 0) move it {rel(m_more):.1e} rel; starts at f = 330, 400, 450 px: "
              f"{max(rel(o) for o in m_other):.1e} rel")
        try:
            mono(obj_list, img, flags=BASE_FLAGS)
            print("  without a guess: converged too")
        except cv2.error as e:
            print("  without a guess (f = max(w, h) / 2): cv2.error", str(e).strip().splitlines()[-1].strip())

    # stereo: without CALIB_FIX_INTRINSIC OpenCV first re-runs fisheye::calibrate per camera with the
    # same flags and TermCriteria(COUNT+EPS, 20, 1e-6) (starting from K/D with
    # CALIB_USE_INTRINSIC_GUESS, else from f = max(w, h) / 2), then the median of the per-view
    # relative poses, then Gauss-Newton on everything. We pass the mono results.
    s = stereo(obj_list, img1, img2, m1[1], m1[2], m2[1], m2[2])
    s_more = stereo(obj_list, img1, img2, m1[1], m1[2], m2[1], m2[2], criteria=(3, 400, 0.0))
    s_truth_in = stereo(obj_list, img1, img2, K1_TRUE, D1_TRUE, K2_TRUE, D2_TRUE)
    s_guess_in = stereo(obj_list, img1, img2, K_GUESS, D_GUESS, K_GUESS, D_GUESS)
    print(f"stereo: 400 iterations (eps 0) vs criteria {CRITERIA}: max rel change {rel_change(s_more, s):.1e}")
    print(f"stereo: started from the truth instead of the mono results: max rel change {rel_change(s_truth_in, s):.1e}")
    print(f"stereo: started from the equidistant guess (f {F_GUESS:.3f}): max rel change {rel_change(s_guess_in, s):.1e}")
    try:
        stereo(obj_list, img1, img2, m1[1], m1[2], m2[1], m2[2], flags=BASE_FLAGS)
        print("stereo without CALIB_USE_INTRINSIC_GUESS: converged too")
    except cv2.error as e:
        print("stereo without CALIB_USE_INTRINSIC_GUESS (K/D ignored): cv2.error", str(e).strip().splitlines()[-1].strip())

    rms, K1, D1, K2, D2, R, T, _, _ = s
    print(f"stereo rms {rms:.6f} px")
    for name, K, D, Kt, Dt in (("left", K1, D1, K1_TRUE, D1_TRUE), ("right", K2, D2, K2_TRUE, D2_TRUE)):
        print(f"  {name}: fx {K[0, 0]:.5f} ({100 * (K[0, 0] / Kt[0, 0] - 1):+.4f} %), fy {K[1, 1]:.5f} "
              f"({100 * (K[1, 1] / Kt[1, 1] - 1):+.4f} %), cx {K[0, 2]:.4f} ({K[0, 2] - Kt[0, 2]:+.4f}), "
              f"cy {K[1, 2]:.4f} ({K[1, 2] - Kt[1, 2]:+.4f}), D {np.array2string(D, precision=6)} (truth {Dt})")
    print(f"  T {np.array2string(T, precision=5)} (truth {T_TRUE}); baseline {np.linalg.norm(T):.5f} mm "
          f"({np.linalg.norm(T) - np.linalg.norm(T_TRUE):+.5f}), rotation error {rot_err_deg(R, R_TRUE):.5f} deg")

    xg, xo, std, steps, rms_gn = independent_gauss_newton(obj_list, img1, img2, s)
    names = ["fx1", "fy1", "cx1", "cy1", "k1_1", "k2_1", "k3_1", "k4_1", "fx2", "fy2", "cx2", "cy2",
             "k1_2", "k2_2", "k3_2", "k4_2", "om_x", "om_y", "om_z", "Tx", "Ty", "Tz"]
    print("independent Gauss-Newton (numeric Jacobian of cv2.fisheye.projectPoints) from OpenCV's result: "
          "steps (max over K, D, rig, in sigmas) " + ", ".join(f"{st:.1e}" for st in steps) + f"; rms {rms_gn:.6f}")
    print(f"  OpenCV vs that minimum: max {np.max(np.abs(xo - xg) / std):.1e} sigma, "
          f"max {np.max(np.abs(xo - xg) / np.abs(xg)):.1e} relative")
    tru = np.concatenate([[K1_TRUE[0, 0], K1_TRUE[1, 1], K1_TRUE[0, 2], K1_TRUE[1, 2]], D1_TRUE,
                          [K2_TRUE[0, 0], K2_TRUE[1, 1], K2_TRUE[0, 2], K2_TRUE[1, 2]], D2_TRUE, RIG_RVEC_TRUE, T_TRUE])
    print("  sigma: " + ", ".join(f"{k} {v:.2g}" for k, v in zip(names, std)))
    print("  (OpenCV - truth) / sigma: " + ", ".join(f"{k} {(e - t) / v:+.1f}" for k, e, t, v in zip(names, xo, tru, std)))

    # files
    def corners_file(side, img):
        images = []
        for i, u in enumerate(img):
            pts = ",".join(f"[{x!r},{y!r}]" for x, y in u.reshape(-1, 2).tolist())
            images.append(
                f'{{"image":"{side}_{i:02d}.png","width":{W},"height":{H},'
                f'"grid":{{"cols":{COLS},"rows":{ROWS},"corners":[{pts}]}},"time_ms":0.0}}'
            )
        text = f'{{"cols":{COLS},"rows":{ROWS},"refinement":"Saddle","images":[\n' + ",\n".join(images) + "\n]}\n"
        back = json.loads(text)  # the file reads back exactly what OpenCV received
        assert all(np.array_equal(np.array(b["grid"]["corners"]), u.reshape(-1, 2)) for b, u in zip(back["images"], img))
        with open(os.path.join(HERE, f"{side}.json"), "w") as f:
            f.write(text)

    corners_file("left", img1)
    corners_file("right", img2)

    ref = {
        "opencv_version": cv2.__version__,
        "generator": "make.py",
        "seed": SEED,
        "flags": FLAGS_TEXT,
        "flags_value": int(FLAGS),
        "criteria": {"type": "COUNT+EPS", "max_count": CRITERIA[1], "epsilon": CRITERIA[2]},
        "image_size": [W, H],
        "board": {"cols": COLS, "rows": ROWS, "square": SQUARE},
        "noise_px": NOISE_PX,
        "views": n,
        "truth": {
            "K1": fl(K1_TRUE), "D1": fl(D1_TRUE), "K2": fl(K2_TRUE), "D2": fl(D2_TRUE),
            "R": fl(R_TRUE), "T": fl(T_TRUE),
            "left_rvecs": [fl(p[0]) for p in poses], "left_tvecs": [fl(p[1]) for p in poses],
        },
        "stereo": {
            "call": "cv2.fisheye.stereoCalibrate(objectPoints, left, right, K1, D1, K2, D2, image_size, "
                    "flags=flags, criteria=criteria), K1 D1 K2 D2 = mono_left and mono_right",
            "rms": float(rms), "K1": fl(K1), "D1": fl(D1), "K2": fl(K2), "D2": fl(D2), "R": fl(R), "T": fl(T),
        },
        "mono_call": "cv2.fisheye.calibrate(objectPoints, points, image_size, K_guess, D_guess, flags=flags, "
                     "criteria=criteria)",
        "mono_guess": {"K": fl(K_GUESS), "D": fl(D_GUESS)},
        "mono_left": {"rms": float(m1[0]), "K": fl(m1[1]), "D": fl(m1[2])},
        "mono_right": {"rms": float(m2[0]), "K": fl(m2[1]), "D": fl(m2[2])},
    }
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(ref, f, indent=1)
        f.write("\n")
    for name in ("left.json", "right.json", "reference.json"):
        print(f"wrote {name} ({os.path.getsize(os.path.join(HERE, name))} bytes)")


if __name__ == "__main__":
    main()
