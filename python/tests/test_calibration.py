"""Calibration, rectification, triangulation, hand-eye and files: against the command line on the
same images (to 1e-9, relative) and against OpenCV (cv2) on the same points."""

from pathlib import Path

import cv2
import numpy as np
import pytest

import parallax
from conftest import ROOT, shared_or_skip, xtask

FIXTURES = ROOT / "fixtures" / "stereo"
COLS, ROWS, SQUARE = 9, 6, 25.0


def board_points() -> np.ndarray:
    objp = np.zeros((COLS * ROWS, 3), np.float64)
    objp[:, :2] = np.mgrid[0:COLS, 0:ROWS].T.reshape(-1, 2) * SQUARE
    return objp


def corners(paths):
    found = []
    for p in paths:
        ok, c = parallax.find_chessboard(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), (COLS, ROWS))
        found.append(c if ok else None)
    return found


def close(a, b, rtol=1e-9, atol=1e-12):
    a, b = np.asarray(a, np.float64).ravel(), np.asarray(b, np.float64).ravel()
    return a.shape == b.shape and np.allclose(a, b, rtol=rtol, atol=atol)


@pytest.fixture(scope="module")
def stereo_corners():
    left = corners(sorted(FIXTURES.glob("left_*.png")))
    right = corners(sorted(FIXTURES.glob("right_*.png")))
    assert sum(c is not None for c in left) >= 4
    return left, right


def test_mono_calibration_equals_the_command_lines(stereo_corners, tmp_path):
    out = tmp_path / "calib.json"
    xtask("calibrate", "--images", "fixtures/stereo/left_*.png", "--board", "9x6", "--square", "25", "--out", out)
    cli = parallax.read_calibration(out)
    found = [c for c in stereo_corners[0] if c is not None]
    rms, K, D, rvecs, tvecs, std_i, std_e, per_view = parallax.calibrate_camera(
        [board_points()] * len(found), found, (640, 480))
    assert close(K, cli["K"]) and close(D, cli["D"]), f"{K}\n{cli['K']}\n{D}\n{cli['D']}"
    assert abs(rms - cli["rms"]) <= 1e-9 * rms
    assert len(rvecs) == len(found) and std_e.shape == (6 * len(found), 1) and per_view.shape == (len(found), 1)
    assert (std_i[:4] > 0).all()


def test_mono_calibration_agrees_with_opencv_on_the_same_corners(stereo_corners):
    found = [c for c in stereo_corners[0] if c is not None]
    obj = [board_points().astype(np.float32)] * len(found)
    img = [c.astype(np.float32) for c in found]
    rms_cv, K_cv, D_cv, _, _ = cv2.calibrateCamera(obj, img, (640, 480), None, None)
    rms, K, D, *_ = parallax.calibrate_camera([board_points()] * len(found), found, (640, 480))
    # two maximum-likelihood solvers on the same points (OpenCV's in float32 corners)
    assert abs(K[0, 0] / K_cv[0, 0] - 1) < 1e-3 and abs(K[1, 1] / K_cv[1, 1] - 1) < 1e-3
    assert abs(K[0, 2] - K_cv[0, 2]) < 0.5 and abs(K[1, 2] - K_cv[1, 2]) < 0.5
    assert rms <= rms_cv * 1.01


@pytest.fixture(scope="module")
def stereo(stereo_corners):
    pairs = [(l, r) for l, r in zip(*stereo_corners) if l is not None and r is not None]
    return parallax.stereo_calibrate([board_points()] * len(pairs), [p[0] for p in pairs], [p[1] for p in pairs],
                                     (640, 480))


def test_stereo_calibration_equals_the_command_lines(stereo, tmp_path):
    out = tmp_path / "stereo.json"
    xtask("calibrate", "--images", "fixtures/stereo/left_*.png", "--right", "fixtures/stereo/right_*.png",
          "--board", "9x6", "--square", "25", "--out", out)
    cli = parallax.read_calibration(out)
    rms, K1, D1, K2, D2, R, T, E, F = stereo
    for ours, theirs in [(K1, "K1"), (D1, "D1"), (K2, "K2"), (D2, "D2"), (R, "R"), (T, "T")]:
        assert close(ours, cli[theirs]), f"{theirs}: {ours} vs {cli[theirs]}"
    # E = [T]x R and F = K2^-T E K1^-1, up to scale
    tx = np.array([[0, -T[2, 0], T[1, 0]], [T[2, 0], 0, -T[0, 0]], [-T[1, 0], T[0, 0], 0]])
    assert close(E / np.linalg.norm(E), tx @ R / np.linalg.norm(tx @ R), rtol=1e-6, atol=1e-9)


def test_stereo_rectify_and_remap_agree_with_opencv(stereo):
    _, K1, D1, K2, D2, R, T, _, _ = stereo
    ours = parallax.stereo_rectify(K1, D1, K2, D2, (640, 480), R, T)
    theirs = cv2.stereoRectify(K1, D1, K2, D2, (640, 480), R, T, flags=cv2.CALIB_ZERO_DISPARITY, alpha=-1)
    for a, b, name in zip(ours[:5], theirs[:5], ["R1", "R2", "P1", "P2", "Q"]):
        assert np.allclose(a, b, rtol=1e-6, atol=1e-6), f"{name}:\n{a}\n{b}"
    rect = parallax.Rectifier(K1, D1, K2, D2, (640, 480), R, T)
    left = cv2.imread(str(FIXTURES / "left_00.png"), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(FIXTURES / "right_00.png"), cv2.IMREAD_GRAYSCALE)
    rl, rr = rect.remap(left, right)
    m1, m2 = cv2.initUndistortRectifyMap(K1, D1, theirs[0], theirs[2], (640, 480), cv2.CV_32FC1)
    cv_left = cv2.remap(left, m1, m2, cv2.INTER_LINEAR)
    inside = (rl > 0) & (cv_left > 0)
    # OpenCV's bilinear weights are fixed-point (1/32 px): within a grey level on average
    assert rl.shape == (480, 640) and np.abs(rl[inside].astype(int) - cv_left[inside]).mean() < 1.0
    assert rr.shape == rl.shape


def test_triangulation_recovers_points_projected_by_opencv(stereo):
    _, K1, D1, K2, D2, R, T, _, _ = stereo
    rng = np.random.default_rng(1)
    X = np.column_stack([rng.uniform(-200, 200, 50), rng.uniform(-150, 150, 50), rng.uniform(400, 1200, 50)])
    p1, _ = cv2.projectPoints(X, np.zeros(3), np.zeros(3), K1, D1)
    p2, _ = cv2.projectPoints(X, cv2.Rodrigues(R)[0], T, K2, D2)
    ours = parallax.triangulate(K1, D1, K2, D2, (640, 480), R, T, p1.reshape(-1, 2), p2.reshape(-1, 2))
    assert np.abs(ours - X).max() < 1e-4 * 1200


def random_rotation(rng):
    return cv2.Rodrigues(rng.normal(size=3) * 0.6)[0]


def pose(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, np.ravel(t)
    return T


def test_hand_eye_agrees_with_opencv_and_the_truth():
    rng = np.random.default_rng(3)
    X = pose(random_rotation(rng), [30.0, -20.0, 80.0])  # gripper_from_camera
    B = pose(random_rotation(rng), [400.0, 100.0, -50.0])  # base_from_board
    Rg, tg, Rc, tc = [], [], [], []
    for _ in range(12):
        # the board 400–700 in front of the camera, tilted up to ~30°
        C = pose(cv2.Rodrigues(rng.normal(size=3) * 0.3)[0], [*rng.uniform(-80, 80, 2), rng.uniform(400, 700)])
        G = B @ np.linalg.inv(C) @ np.linalg.inv(X)  # base_from_gripper
        Rg.append(G[:3, :3]), tg.append(G[:3, 3:]), Rc.append(C[:3, :3]), tc.append(C[:3, 3:])
    for method, cv_method in [("park", cv2.CALIB_HAND_EYE_PARK), ("tsai", cv2.CALIB_HAND_EYE_TSAI)]:
        R, t = parallax.calibrate_hand_eye(Rg, tg, Rc, tc, method=method)
        R_cv, t_cv = cv2.calibrateHandEye(Rg, tg, Rc, tc, method=cv_method)
        assert np.abs(R - X[:3, :3]).max() < 1e-9 and np.abs(t.ravel() - X[:3, 3]).max() < 1e-6, method
        assert np.abs(R - R_cv).max() < 1e-6 and np.abs(t - t_cv).max() < 1e-4, method
    R, t = parallax.calibrate_hand_eye(Rg, tg, Rc, tc)  # the refined method
    assert np.abs(R - X[:3, :3]).max() < 1e-9 and np.abs(t.ravel() - X[:3, 3]).max() < 1e-6


def test_files_round_trip_and_opencv_reads_ours(stereo, tmp_path):
    rms, K1, D1, K2, D2, R, T, _, _ = stereo
    calib = dict(kind="stereo", lens="pinhole", size=(640, 480), K1=K1, D1=D1, K2=K2, D2=D2, R=R, T=T, rms=rms)
    written = parallax.write_calibration(tmp_path / "stereo.yml", calib)
    assert written == [str(tmp_path / "stereo.yml")]
    fs = cv2.FileStorage(str(tmp_path / "stereo.yml"), cv2.FILE_STORAGE_READ)
    assert np.allclose(fs.getNode("M1").mat(), K1, rtol=1e-15) and np.allclose(fs.getNode("T").mat(), T, rtol=1e-15)
    for ext in ["yml", "json", "ron"]:
        if ext != "yml":
            parallax.write_calibration(tmp_path / f"stereo.{ext}", calib)
        back = parallax.read_calibration(tmp_path / f"stereo.{ext}")
        assert back["kind"] == "stereo"
        for k in ["K1", "D1", "K2", "D2", "R", "T"]:
            assert close(back[k], calib[k], rtol=1e-15), f"{ext} {k}"
    with pytest.raises(parallax.ParallaxError):
        parallax.write_calibration(tmp_path / "bad.yml", dict(calib, K1=np.zeros((3, 3))))
    assert not (tmp_path / "bad.yml").exists()


def test_charuco_boards_opencv_draws_are_found_with_opencv_corners():
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100)
    board = cv2.aruco.CharucoBoard((7, 5), 40.0, 30.0, dictionary)
    img = board.generateImage((700, 500), marginSize=20)
    found = parallax.detect_target(img, "charuco:7x5:40:30:DICT_5X5_100")
    assert found is not None
    ids, pixels, objects = found
    c_cv, id_cv, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(img)
    assert len(ids) == 24 and set(ids.tolist()) == set(id_cv.ravel().tolist())
    by_id = {int(i): p for i, p in zip(id_cv.ravel(), c_cv.reshape(-1, 2))}
    assert max(np.abs(p - by_id[int(i)]).max() for i, p in zip(ids, pixels)) < 0.2
    assert objects.shape == (24, 3)


def test_refusals_raise_parallax_error_with_the_message():
    with pytest.raises(parallax.ParallaxError, match="view"):
        parallax.calibrate_camera([board_points()], [board_points()[:, :2]], (640, 480))
    with pytest.raises(parallax.ParallaxError, match="lens"):
        parallax.calibrate_camera([board_points()] * 3, [board_points()[:, :2]] * 3, (640, 480), lens="fish")
    with pytest.raises(parallax.ParallaxError):
        parallax.find_chessboard(np.zeros((10, 10), np.float64), (9, 6))


def test_real_chessboards_calibrate_as_opencv_does():
    folder = shared_or_skip("opencv-stereo-chessboard")
    found = [c for c in corners(sorted(Path(folder).glob("left*.jpg"))) if c is not None]
    assert len(found) >= 10
    size = cv2.imread(str(next(Path(folder).glob("left*.jpg"))), cv2.IMREAD_GRAYSCALE).shape[::-1]
    rms, K, *_ = parallax.calibrate_camera([board_points()] * len(found), found, size)
    rms_cv, K_cv, *_ = cv2.calibrateCamera([board_points().astype(np.float32)] * len(found),
                                           [c.astype(np.float32) for c in found], size, None, None)
    assert abs(K[0, 0] / K_cv[0, 0] - 1) < 2e-3 and rms <= rms_cv * 1.01


def test_a_rig_of_three_cameras_with_partial_views_recovers_its_truth():
    # three cameras in a row, 80 apart, each seeing the board in most frames; points by cv2
    rng = np.random.default_rng(5)
    K = np.array([[700.0, 0, 320], [0, 700, 240], [0, 0, 1]])
    D = np.array([-0.1, 0.05, 0.0, 0.0, 0.0])
    rigs = [(np.eye(3), np.zeros(3)), (cv2.Rodrigues(np.array([0.0, 0.05, 0.0]))[0], np.array([-80.0, 0, 0])),
            (cv2.Rodrigues(np.array([0.0, -0.05, 0.01]))[0], np.array([-160.0, 2, 0]))]
    objp = board_points()
    obj, pts = [], [[], [], []]
    for f in range(14):
        r0 = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3)])
        t0 = np.array([rng.uniform(-150, 0), rng.uniform(-100, 0), rng.uniform(500, 800)])
        R0 = cv2.Rodrigues(r0)[0]
        obj.append(objp)
        for c, (Rc, Tc) in enumerate(rigs):
            Rcb, tcb = Rc @ R0, Rc @ t0 + Tc
            p, _ = cv2.projectPoints(objp, cv2.Rodrigues(Rcb)[0], tcb, K, D)
            seen = (f + c) % 5 != 0 and ((p >= 0) & (p < [640, 480])).all()
            pts[c].append(p.reshape(-1, 2) if seen else None)
    rms, Ks, Ds, Rs, Ts, _ = parallax.calibrate_rig(obj, pts, [(640, 480)] * 3)
    assert rms < 1e-6
    for c in range(3):
        assert np.abs(Ks[c] - K).max() < 1e-4 and np.abs(Ds[c] - D).max() < 1e-6
        assert np.abs(Rs[c] - rigs[c][0]).max() < 1e-8 and np.abs(Ts[c].ravel() - rigs[c][1]).max() < 1e-5
