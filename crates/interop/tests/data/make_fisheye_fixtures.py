"""Writes the fisheye fixtures with OpenCV's own FileStorage (cv2_fisheye_*) and OpenCV's own
cv::fisheye functions, in the layouts the tools use. Run once, from this folder
(pip install opencv-python-headless numpy):

    python3 make_fisheye_fixtures.py

- cv2_fisheye_mono.yml / .xml: the keys OpenCV's calibration sample writes with its fisheye
  option (samples/cpp/tutorial_code/calib3d/camera_calibration/camera_calibration.cpp,
  saveCameraParams): calibration_time, nr_of_frames, image_width, image_height, board_width,
  board_height, square_size, flags, fisheye_model (1), camera_matrix, distortion_coefficients
  (4x1, cv::fisheye's k1 k2 k3 k4), avg_reprojection_error.
- cv2_fisheye_stereo.yml: stereo_calib.cpp's keys M1 D1 M2 D2 R T E for a cv::fisheye rig with
  the same marker, and R1 R2 P1 P2 Q from cv2.fisheye.stereoRectify (balance 0, fov_scale 1,
  CALIB_ZERO_DISPARITY).
- cv2_pinhole_d4.yml: calibration.cpp's keys with a 1x4 D and no marker (OpenCV's own
  k1 k2 p1 p2, what cv2.calibrateCamera returns with CALIB_FIX_K3 trimmed to 4).
The ROS and Kalibr files (ros_equidistant_*.yaml, kalibr_*.yaml) are hand-written; their
provenance is in README.md.
"""
import cv2
import numpy as np

print("OpenCV", cv2.__version__)
K1 = np.array([[310.5, 0.0, 319.25], [0.0, 310.25, 241.75], [0.0, 0.0, 1.0]])
D1 = np.array([[0.021], [-0.0052], [0.0011], [-0.00021]])
K2 = np.array([[309.75, 0.0, 321.5], [0.0, 309.5, 238.25], [0.0, 0.0, 1.0]])
D2 = np.array([[0.019], [-0.0048], [0.0009], [-0.00019]])
R, _ = cv2.Rodrigues(np.array([[0.01], [-0.02], [0.005]]))
T = np.array([[-80.0], [0.5], [1.25]])
size = (640, 480)

for ext in ["yml", "xml"]:
    fs = cv2.FileStorage(f"cv2_fisheye_mono.{ext}", cv2.FILE_STORAGE_WRITE)
    fs.write("calibration_time", "Tue Dec  1 16:00:00 2026")
    fs.write("nr_of_frames", 20)
    fs.write("image_width", size[0])
    fs.write("image_height", size[1])
    fs.write("board_width", 9)
    fs.write("board_height", 6)
    fs.write("square_size", 25.0)
    fs.write("flags", 0)
    fs.write("fisheye_model", 1)
    fs.write("camera_matrix", K1)
    fs.write("distortion_coefficients", D1)
    fs.write("avg_reprojection_error", 0.2125)
    fs.release()

R1, R2, P1, P2, Q = cv2.fisheye.stereoRectify(
    K1, D1, K2, D2, size, R, T, flags=cv2.CALIB_ZERO_DISPARITY, balance=0.0, fov_scale=1.0
)
tx = np.array([[0, -T[2, 0], T[1, 0]], [T[2, 0], 0, -T[0, 0]], [-T[1, 0], T[0, 0], 0]])
fs = cv2.FileStorage("cv2_fisheye_stereo.yml", cv2.FILE_STORAGE_WRITE)
fs.write("image_width", size[0])
fs.write("image_height", size[1])
fs.write("fisheye_model", 1)
for k, v in [("M1", K1), ("D1", D1.T), ("M2", K2), ("D2", D2.T), ("R", R), ("T", T), ("E", tx @ R)]:
    fs.write(k, v)
for k, v in [("R1", R1), ("R2", R2), ("P1", P1), ("P2", P2), ("Q", Q)]:
    fs.write(k, v)
fs.release()

fs = cv2.FileStorage("cv2_pinhole_d4.yml", cv2.FILE_STORAGE_WRITE)
fs.write("image_width", size[0])
fs.write("image_height", size[1])
fs.write("camera_matrix", K1)
fs.write("distortion_coefficients", np.array([[-0.12, 0.05, 5e-4, -3e-4]]))
fs.release()
print("P1", P1.tolist())
print("P2", P2.tolist())


# ROS camera_info, the layout of camera_calibration's calibrator.py (yaml()) for a fisheye
# calibration: distortion_model equidistant, D 1x4, R and P from cv::fisheye::stereoRectify.
def ros(path, name, K, D, Rr, P):
    def m(a):
        return ", ".join(repr(float(x)) for x in np.asarray(a).ravel())

    with open(path, "w") as f:
        f.write(f"image_width: {size[0]}\nimage_height: {size[1]}\ncamera_name: {name}\n")
        f.write(f"camera_matrix:\n  rows: 3\n  cols: 3\n  data: [{m(K)}]\n")
        f.write("distortion_model: equidistant\n")
        f.write(f"distortion_coefficients:\n  rows: 1\n  cols: 4\n  data: [{m(D)}]\n")
        f.write(f"rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [{m(Rr)}]\n")
        f.write(f"projection_matrix:\n  rows: 3\n  cols: 4\n  data: [{m(P)}]\n")


ros("ros_equidistant_left.yaml", "fisheye_stereo/left", K1, D1, R1, P1)
ros("ros_equidistant_right.yaml", "fisheye_stereo/right", K2, D2, R2, P2)
