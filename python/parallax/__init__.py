"""parallax from Python: camera and stereo calibration, rectification, dense disparity,
triangulation and hand-eye calibration, computed by parallax's Rust crates.

Names and argument orders follow OpenCV's where the concept is the same; arrays are numpy
(images uint8 grey ``H x W`` or RGB ``H x W x 3``, uint16 grey for disparity; points float64).
Every call releases the GIL while it computes; every refusal raises :class:`ParallaxError`
(a ``ValueError``) with parallax's message.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple

import numpy as np

from . import _parallax
from ._parallax import ParallaxError, Rectifier as _Rectifier, StereoMatcher as _StereoMatcher

__version__: str = _parallax.__version__

__all__ = [
    "ParallaxError",
    "Rectifier",
    "StereoMatcher",
    "__version__",
    "calibrate_camera",
    "calibrate_hand_eye",
    "calibrate_rig",
    "detect_target",
    "find_chessboard",
    "load_pair",
    "read_calibration",
    "stereo_calibrate",
    "stereo_rectify",
    "triangulate",
    "write_calibration",
]


def _image(a) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype not in (np.uint8, np.uint16):
        raise ParallaxError(f"an image must be uint8 or uint16, got {a.dtype}")
    return np.ascontiguousarray(a)


def _m(a, shape=None) -> list:
    a = np.asarray(a, dtype=np.float64)
    if shape is not None and a.size != int(np.prod(shape)):
        raise ParallaxError(f"expected {int(np.prod(shape))} numbers ({shape}), got the shape {a.shape}")
    return a.ravel().tolist()


def _points(a, dim: int) -> list:
    a = np.asarray(a, dtype=np.float64)
    if a.size % dim:
        raise ParallaxError(f"points must have {dim} coordinates, got the shape {a.shape}")
    return a.reshape(-1, dim).tolist()


def _size(image_size) -> Tuple[int, int]:
    w, h = (int(v) for v in image_size)
    return (w, h)


def find_chessboard(image, pattern_size: Tuple[int, int]) -> Tuple[bool, Optional[np.ndarray]]:
    """Inner corners of a chessboard of ``pattern_size = (cols, rows)`` inner corners, in
    OpenCV's order (``cv2.findChessboardCorners``): ``(found, corners)`` with corners
    ``N x 1 x 2`` float64, or ``(False, None)``."""
    found = _parallax.find_chessboard(_image(image), int(pattern_size[0]), int(pattern_size[1]))
    if found is None:
        return False, None
    return True, np.asarray(found, dtype=np.float64).reshape(-1, 1, 2)


def detect_target(image, board: str):
    """Any target (``board`` as the command line's ``--board``: ``charuco:7x5:40:30:DICT_5X5_100``,
    ``aprilgrid:6x6:88:0.3``, ``circles:4x11:20:10``, ``chessboard:9x6:25``): ``(ids, corners
    N x 2, object_points N x 3)``, or ``None`` when it is not found."""
    found = _parallax.detect_target(_image(image), board)
    if found is None:
        return None
    ids, pixels, objects = found
    return (np.asarray(ids, dtype=np.int64), np.asarray(pixels, dtype=np.float64).reshape(-1, 2),
            np.asarray(objects, dtype=np.float64).reshape(-1, 3))


def calibrate_camera(object_points: Sequence, image_points: Sequence, image_size, lens: str = "pinhole",
                     fix_principal_point: bool = False, fix_aspect_ratio: bool = False,
                     zero_tangential: bool = False, fix_k3: bool = False, rational_model: bool = False):
    """Calibrates one camera (``cv2.calibrateCameraExtended``; any ``lens``: ``pinhole``,
    ``kannala-brandt``, ``double-sphere``): ``(rms, K, D, rvecs, tvecs, std_intrinsics,
    std_extrinsics, per_view_errors)``. ``std_intrinsics`` holds ``fx fy cx cy`` then the lens
    parameters (0 for a fixed one); ``std_extrinsics`` 6 per view (rotation, translation)."""
    r = _parallax.calibrate_camera([_points(o, 3) for o in object_points], [_points(p, 2) for p in image_points],
                                   *_size(image_size), lens=lens, fix_principal_point=fix_principal_point,
                                   fix_aspect_ratio=fix_aspect_ratio, zero_tangential=zero_tangential,
                                   fix_k3=fix_k3, rational_model=rational_model)
    return (r["rms"], np.array(r["K"]).reshape(3, 3), np.array(r["D"]).reshape(1, -1),
            [np.array(v).reshape(3, 1) for v in r["rvecs"]], [np.array(v).reshape(3, 1) for v in r["tvecs"]],
            np.array(r["std_intrinsics"]).reshape(-1, 1), np.array(r["std_extrinsics"]).reshape(-1, 1),
            np.array(r["per_view_errors"]).reshape(-1, 1))


def stereo_calibrate(object_points: Sequence, image_points1: Sequence, image_points2: Sequence, image_size,
                     image_size2=None, lens: str = "pinhole"):
    """Calibrates a stereo rig from views both cameras saw (``cv2.stereoCalibrate`` without an
    intrinsic guess): ``(rms, K1, D1, K2, D2, R, T, E, F)``."""
    size2 = _size(image_size2) if image_size2 is not None else _size(image_size)
    r = _parallax.stereo_calibrate([_points(o, 3) for o in object_points], [_points(p, 2) for p in image_points1],
                                   [_points(p, 2) for p in image_points2], _size(image_size), size2, lens=lens)
    return (r["rms"], np.array(r["K1"]).reshape(3, 3), np.array(r["D1"]).reshape(1, -1),
            np.array(r["K2"]).reshape(3, 3), np.array(r["D2"]).reshape(1, -1), np.array(r["R"]).reshape(3, 3),
            np.array(r["T"]).reshape(3, 1), np.array(r["E"]).reshape(3, 3), np.array(r["F"]).reshape(3, 3))


def calibrate_rig(object_points: Sequence, image_points: Sequence, image_sizes: Sequence, lens="pinhole"):
    """Calibrates a rig of N cameras in one joint problem (OpenCV 5's ``calibrateMultiview``):
    ``object_points[f]`` the target points of frame ``f``; ``image_points[c][f]`` their pixels
    in camera ``c`` (``None`` where camera ``c`` did not see frame ``f``); ``lens`` one name for
    every camera or one per camera. Camera 0 is the reference. Returns ``(rms, Ks, Ds, Rs, Ts,
    per_view_errors)`` with ``Rs[c], Ts[c]`` = ``camC_from_cam0`` (identity for camera 0)."""
    cams = len(image_points)
    lenses = [lens] * cams if isinstance(lens, str) else list(lens)
    frames = []
    for f, obj in enumerate(object_points):
        o = _points(obj, 3)
        frames.append([None if image_points[c][f] is None else (o, _points(image_points[c][f], 2))
                       for c in range(cams)])
    r = _parallax.calibrate_rig(frames, [_size(s) for s in image_sizes], lenses)
    return (r["rms"], [np.array(k).reshape(3, 3) for k in r["K"]], [np.array(d).reshape(1, -1) for d in r["D"]],
            [np.array(m).reshape(3, 3) for m in r["R"]], [np.array(t).reshape(3, 1) for t in r["T"]],
            r["per_view_errors"])


def _rect(r: dict):
    return (np.array(r["R1"]).reshape(3, 3), np.array(r["R2"]).reshape(3, 3), np.array(r["P1"]).reshape(3, 4),
            np.array(r["P2"]).reshape(3, 4), np.array(r["Q"]).reshape(4, 4), tuple(r["roi1"]), tuple(r["roi2"]))


def stereo_rectify(K1, D1, K2, D2, image_size, R, T, alpha: float = -1.0, new_image_size=(0, 0),
                   lens: str = "pinhole"):
    """Bouguet rectification (``cv2.stereoRectify`` with ``CALIB_ZERO_DISPARITY``):
    ``(R1, R2, P1, P2, Q, roi1, roi2)``."""
    r = _parallax.stereo_rectify(_m(K1, (3, 3)), _m(D1), _m(K2, (3, 3)), _m(D2), _size(image_size),
                                 _m(R, (3, 3)), _m(T, (3,)), alpha=float(alpha), new_size=_size(new_image_size),
                                 lens=lens)
    return _rect(r)


class Rectifier:
    """A rig's rectification with its maps: ``Rectifier(K1, D1, K2, D2, image_size, R, T)`` then
    ``remap(left, right)`` (bilinear, black outside; grey or RGB uint8)."""

    def __init__(self, K1, D1, K2, D2, image_size, R, T, alpha: float = -1.0, new_image_size=(0, 0),
                 lens: str = "pinhole"):
        self._inner = _Rectifier(_m(K1, (3, 3)), _m(D1), _m(K2, (3, 3)), _m(D2), _size(image_size), _m(R, (3, 3)),
                                 _m(T, (3,)), alpha=float(alpha), new_size=_size(new_image_size), lens=lens)
        self.R1, self.R2, self.P1, self.P2, self.Q, self.roi1, self.roi2 = _rect(self._inner.matrices())

    def remap(self, left, right) -> Tuple[np.ndarray, np.ndarray]:
        return self._inner.remap(_image(left), _image(right))


class StereoMatcher:
    """Dense disparity with the options of ``cargo xtask disparity`` (same names, same
    defaults, the same maps bit for bit): ``method`` ``"bm"`` or ``"sgm"``, ``num_disparities``,
    ``min_disparity``, ``block_size``, ``cost``, ``prefilter``, ``uniqueness``, ``texture``,
    ``lr_max_diff``, ``speckle_window``, ``min_confidence``, ``fill``, ``accurate``, ``colour``,
    ``sgm_cost``, ``sgm_paths``, ``lr_rule``, ``threads``; or ``config=`` the file ``tune`` wrote.

    ``compute(left, right)`` returns ``(disparity, confidence)``: float32 ``H x W``, NaN where no
    disparity is returned, confidence 0 there."""

    def __init__(self, method: str = "bm", num_disparities: int = 64, min_disparity: int = 0, **options):
        if "config" in options and options["config"] is not None:
            options["config"] = os.fspath(options["config"])
        self._inner = _StereoMatcher(method=method, num_disparities=int(num_disparities),
                                     min_disparity=int(min_disparity), **options)

    def compute(self, left, right, disparity: Optional[np.ndarray] = None,
                confidence: Optional[np.ndarray] = None) -> Tuple[np.ndarray, np.ndarray]:
        """``(disparity, confidence)`` of a rectified pair; given float32 ``H x W`` arrays
        ``disparity`` and ``confidence`` (OpenCV's output arguments) are filled and returned,
        with no new memory per frame. New arrays otherwise, on the memory of earlier results you
        no longer hold when there are any (the matcher keeps up to four such buffers)."""
        return self._inner.compute(_image(left), _image(right), disparity, confidence)

    @property
    def simd(self) -> str:
        """The SIMD level the matcher runs."""
        return self._inner.simd()

    @property
    def last_seconds(self) -> float:
        """Seconds the last ``compute`` spent matching inside Rust (its call overhead is the rest)."""
        return self._inner.last_seconds


def load_pair(left, right, colour: bool = False) -> Tuple[np.ndarray, np.ndarray]:
    """A rectified pair of image files loaded as ``cargo xtask disparity`` loads them."""
    return _parallax.load_pair(os.fspath(left), os.fspath(right), colour=colour)


def triangulate(K1, D1, K2, D2, image_size, R, T, points1, points2, lens: str = "pinhole") -> np.ndarray:
    """Triangulates matched pixels of a rig (raw, distorted pixels; optimal triangulation):
    ``N x 3`` points in the left camera's frame."""
    pts = _parallax.triangulate(_m(K1, (3, 3)), _m(D1), _m(K2, (3, 3)), _m(D2), _size(image_size), _m(R, (3, 3)),
                                _m(T, (3,)), _points(points1, 2), _points(points2, 2), lens=lens)
    return np.asarray(pts, dtype=np.float64).reshape(-1, 3)


def calibrate_hand_eye(R_gripper2base, t_gripper2base, R_target2cam, t_target2cam, method: str = "refined",
                       setup: str = "eye-in-hand"):
    """Hand-eye calibration (``cv2.calibrateHandEye``'s arguments and result): ``(R_cam2gripper,
    t_cam2gripper)`` (eye-to-hand: ``R_cam2base``, ``t_cam2base``). ``method``: ``tsai``,
    ``park``, ``horaud``, ``andreff``, ``daniilidis``, ``rodrigues`` or ``refined``."""
    robot = [(_m(r, (3, 3)), _m(t, (3,))) for r, t in zip(R_gripper2base, t_gripper2base)]
    camera = [(_m(r, (3, 3)), _m(t, (3,))) for r, t in zip(R_target2cam, t_target2cam)]
    if len(robot) != len(R_gripper2base) or len(camera) != len(R_target2cam):
        raise ParallaxError("rotations and translations must come in pairs")
    R, t = _parallax.calibrate_hand_eye(robot, camera, method=method, setup=setup)
    return np.array(R).reshape(3, 3), np.array(t).reshape(3, 1)


def read_calibration(path) -> dict:
    """Reads a calibration file of any format (OpenCV YAML / XML, ROS, Kalibr, JSON, RON): a dict
    with ``kind`` (``mono``, ``stereo``, ``hand-eye``) and OpenCV's matrices as numpy arrays."""
    c = _parallax.read_calibration(os.fspath(path))
    shapes = {"K": (3, 3), "K1": (3, 3), "K2": (3, 3), "R": (3, 3), "T": (3, 1), "t": (3, 1)}
    out = {}
    for k, v in c.items():
        if k in shapes:
            out[k] = np.array(v, dtype=np.float64).reshape(shapes[k])
        elif k.startswith("D"):
            out[k] = np.array(v, dtype=np.float64).reshape(1, -1)
        else:
            out[k] = v
    return out


def write_calibration(path, calibration: dict, format: Optional[str] = None) -> list:
    """Writes a mono or stereo calibration (a dict as :func:`read_calibration` returns) in a
    format by name or by the extension; returns the files written (ROS writes one per camera)."""
    c = {k: (np.asarray(v, dtype=np.float64).ravel().tolist() if isinstance(v, np.ndarray) else v)
         for k, v in calibration.items()}
    return [os.fspath(p) for p in _parallax.write_calibration(os.fspath(path), c, format)]
