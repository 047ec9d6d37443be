"""Writes the cv2_* fixtures with OpenCV's own FileStorage, and checks our files against OpenCV.

Run once, from this folder (pip install opencv-python-headless numpy):

    python3 make_cv2_fixtures.py

Inputs (written by parallax, see README.md): ours_stereo.{json,yml,xml}, ours_mono.{json,yml},
ours_handeye.yml. Outputs (written by cv2.FileStorage): cv2_stereo.yml, cv2_stereo.xml,
cv2_intrinsics.yml + cv2_extrinsics.yml (stereo_calib.cpp's split), cv2_mono.yml,
cv2_mono.xml, cv2_handeye.yml. Prints the largest differences it measured.
"""
import json

import cv2
import numpy as np

print("OpenCV", cv2.__version__)


def read(path, keys):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    assert fs.isOpened(), path
    out = {}
    for k in keys:
        node = fs.getNode(k)
        out[k] = node.mat() if node.isMap() else node.real()
    fs.release()
    return out


stereo_keys = ["M1", "D1", "M2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"]
ours = json.load(open("ours_stereo.json"))["calibration"]["opencv"]
worst = 0.0
for path in ["ours_stereo.yml", "ours_stereo.xml"]:
    got = read(path, stereo_keys + ["image_width", "image_height"])
    for k in stereo_keys:
        ref = np.array(ours[k], dtype=np.float64).reshape(got[k].shape)
        worst = max(worst, float(np.max(np.abs(got[k] - ref))))
    assert int(got["image_width"]) == ours["image_width"]
print(f"our stereo YAML/XML read by cv2 vs our JSON: max |diff| = {worst:.3e}")
assert worst <= 1e-12

mono = json.load(open("ours_mono.json"))["calibration"]
got = read("ours_mono.yml", ["camera_matrix", "distortion_coefficients", "avg_reprojection_error"])
d_mono = max(
    float(np.max(np.abs(got["camera_matrix"] - np.array(mono["opencv"]["camera_matrix"])))),
    float(np.max(np.abs(got["distortion_coefficients"].ravel() - np.array(mono["opencv"]["distortion_coefficients"])))),
    abs(got["avg_reprojection_error"] - mono["rms_px"]),
)
print(f"our mono YAML read by cv2 vs our JSON: max |diff| = {d_mono:.3e}")
assert d_mono <= 1e-12

# cv2.stereoRectify on the K, D, R, T cv2 read from our file, with the settings `rectify` uses
# (alpha 0, CALIB_ZERO_DISPARITY), against the R1 R2 P1 P2 Q we wrote.
s = read("ours_stereo.yml", stereo_keys)
size = (640, 480)
R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
    s["M1"], s["D1"], s["M2"], s["D2"], size, s["R"], s["T"], flags=cv2.CALIB_ZERO_DISPARITY, alpha=0
)
for name, mine, theirs in [("R1", s["R1"], R1), ("R2", s["R2"], R2), ("P1", s["P1"], P1), ("P2", s["P2"], P2), ("Q", s["Q"], Q)]:
    print(f"cv2.stereoRectify vs written {name}: max |diff| = {np.max(np.abs(mine - theirs)):.3e}")

# Files written by OpenCV itself, from the values it read out of our files.
def write(path, entries):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    for k, v in entries:
        fs.write(k, v)
    fs.release()

rect = [("R1", R1), ("R2", R2), ("P1", P1), ("P2", P2), ("Q", Q)]
intr = [("image_width", 640), ("image_height", 480), ("M1", s["M1"]), ("D1", s["D1"]), ("M2", s["M2"]), ("D2", s["D2"])]
extr = [("R", s["R"]), ("T", s["T"]), ("E", s["E"]), ("F", s["F"])]
write("cv2_stereo.yml", intr + extr + rect)
write("cv2_stereo.xml", intr + extr + rect)
write("cv2_intrinsics.yml", intr)
write("cv2_extrinsics.yml", [("R", s["R"]), ("T", s["T"])] + rect)
m = read("ours_mono.yml", ["camera_matrix", "distortion_coefficients", "avg_reprojection_error", "per_view_reprojection_errors"])
mono_entries = [
    ("image_width", 640),
    ("image_height", 480),
    ("camera_matrix", m["camera_matrix"]),
    ("distortion_coefficients", m["distortion_coefficients"]),
    ("avg_reprojection_error", m["avg_reprojection_error"]),
    ("per_view_reprojection_errors", m["per_view_reprojection_errors"]),
]
write("cv2_mono.yml", mono_entries)
write("cv2_mono.xml", mono_entries)
h = read("ours_handeye.yml", ["R_cam2gripper", "t_cam2gripper"])
write("cv2_handeye.yml", [("R_cam2gripper", h["R_cam2gripper"]), ("t_cam2gripper", h["t_cam2gripper"])])
print("wrote cv2_stereo.yml, cv2_stereo.xml, cv2_intrinsics.yml, cv2_extrinsics.yml, cv2_mono.yml, cv2_mono.xml, cv2_handeye.yml")
