"""Type stubs of the native module (the Rust side); the public API is `parallax`'s."""

from os import PathLike
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class ParallaxError(ValueError): ...

_Path = Union[str, PathLike]
_Image = npt.NDArray[Any]

def version() -> str: ...
def find_chessboard(image: _Image, cols: int, rows: int) -> Optional[list[Tuple[float, float]]]: ...
def detect_target(
    image: _Image, board: str
) -> Optional[Tuple[list[int], list[Tuple[float, float]], list[Tuple[float, float, float]]]]: ...
def calibrate_camera(
    object_points: Sequence[Sequence[Sequence[float]]],
    image_points: Sequence[Sequence[Sequence[float]]],
    width: int,
    height: int,
    lens: str = "pinhole",
    fix_principal_point: bool = False,
    fix_aspect_ratio: bool = False,
    zero_tangential: bool = False,
    fix_k3: bool = False,
    rational_model: bool = False,
) -> dict[str, Any]: ...
def stereo_calibrate(
    object_points: Sequence[Sequence[Sequence[float]]],
    image_points1: Sequence[Sequence[Sequence[float]]],
    image_points2: Sequence[Sequence[Sequence[float]]],
    size1: Tuple[int, int],
    size2: Tuple[int, int],
    lens: str = "pinhole",
) -> dict[str, Any]: ...
def calibrate_rig(
    frames: Sequence[Sequence[Optional[Tuple[Sequence[Sequence[float]], Sequence[Sequence[float]]]]]],
    sizes: Sequence[Tuple[int, int]],
    lenses: Sequence[str],
) -> dict[str, Any]: ...
def stereo_rectify(
    k1: Sequence[float],
    d1: Sequence[float],
    k2: Sequence[float],
    d2: Sequence[float],
    size: Tuple[int, int],
    r: Sequence[float],
    t: Sequence[float],
    alpha: float = -1.0,
    new_size: Tuple[int, int] = (0, 0),
    lens: str = "pinhole",
) -> dict[str, Any]: ...
def load_pair(left: _Path, right: _Path, colour: bool = False) -> Tuple[_Image, _Image]: ...
def triangulate(
    k1: Sequence[float],
    d1: Sequence[float],
    k2: Sequence[float],
    d2: Sequence[float],
    size: Tuple[int, int],
    r: Sequence[float],
    t: Sequence[float],
    points1: Sequence[Sequence[float]],
    points2: Sequence[Sequence[float]],
    lens: str = "pinhole",
) -> list[Tuple[float, float, float]]: ...
def calibrate_hand_eye(
    base_from_gripper: Sequence[Tuple[Sequence[float], Sequence[float]]],
    camera_from_board: Sequence[Tuple[Sequence[float], Sequence[float]]],
    method: str = "refined",
    setup: str = "eye-in-hand",
) -> Tuple[list[float], Tuple[float, float, float]]: ...
def read_calibration(path: _Path) -> dict[str, Any]: ...
def write_calibration(path: _Path, calibration: dict[str, Any], format: Optional[str] = None) -> list[str]: ...
def score_world(world: _Path, config: _Path, threads: int = 1, runs: int = 1) -> dict[str, float]: ...

class Rectifier:
    def __init__(
        self,
        k1: Sequence[float],
        d1: Sequence[float],
        k2: Sequence[float],
        d2: Sequence[float],
        size: Tuple[int, int],
        r: Sequence[float],
        t: Sequence[float],
        alpha: float = -1.0,
        new_size: Tuple[int, int] = (0, 0),
        lens: str = "pinhole",
    ) -> None: ...
    def matrices(self) -> dict[str, Any]: ...
    def remap(self, left: _Image, right: _Image) -> Tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]: ...

class StereoMatcher:
    def __init__(
        self,
        method: str = "bm",
        num_disparities: int = 64,
        min_disparity: int = 0,
        block_size: Optional[int] = None,
        cost: str = "sad",
        prefilter: Optional[str] = None,
        uniqueness: Optional[int] = None,
        texture: Optional[int] = None,
        lr_max_diff: Optional[int] = None,
        speckle_window: Optional[int] = None,
        min_confidence: Optional[float] = None,
        fill: bool = False,
        accurate: bool = False,
        colour: bool = False,
        sgm_cost: Optional[str] = None,
        sgm_paths: Optional[int] = None,
        lr_rule: Optional[str] = None,
        threads: int = 0,
        config: Optional[_Path] = None,
    ) -> None: ...
    def compute(
        self,
        left: _Image,
        right: _Image,
        disparity: Optional[npt.NDArray[np.float32]] = None,
        confidence: Optional[npt.NDArray[np.float32]] = None,
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def simd(self) -> str: ...
    @property
    def last_seconds(self) -> float: ...
