"""ChArUco boards drawn by their owner, OpenCV (`cv2.aruco.CharucoBoard.generateImage`), for the
layout test in `tests/charuco.rs`: the current layout and the legacy one (`setLegacyPattern(True)`,
boards made before OpenCV 4.6.0; it differs only with an even number of rows), several
dictionaries. Writes one PNG per board and `boards.json`: the board in the `--board` form, the
truth (OpenCV's `getChessboardCorners()`, ids in OpenCV's order, mapped to pixels of the image:
`margin + p / square · square_px − 0.5`, pixel (0, 0) the centre of the first pixel) and what
OpenCV's own `CharucoDetector` finds in the image (checked here against the truth).

    python3 make_charuco_boards.py      # needs numpy and opencv-python >= 4.7 (tested with 5.1.0)

Running it again gives the same bytes."""
import json, os
import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
# (name, squares x, squares y, square px, marker px, dictionary, legacy, margin px)
BOARDS = [
    ("charuco_7x5_dict5x5_100", 7, 5, 60, 45, "DICT_5X5_100", False, 30),
    ("charuco_6x8_dict4x4_50", 6, 8, 50, 35, "DICT_4X4_50", False, 25),
    ("charuco_6x8_dict4x4_50_legacy", 6, 8, 50, 35, "DICT_4X4_50", True, 25),
    ("charuco_5x4_dict6x6_250_legacy", 5, 4, 64, 48, "DICT_6X6_250", True, 32),
]


def main():
    out = []
    for name, sx, sy, sq, mk, dname, legacy, margin in BOARDS:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dname))
        board = cv2.aruco.CharucoBoard((sx, sy), float(sq), float(mk), dictionary)
        board.setLegacyPattern(legacy)
        size = (sx * sq + 2 * margin, sy * sq + 2 * margin)
        img = board.generateImage(size, marginSize=margin, borderBits=1)
        cv2.imwrite(os.path.join(HERE, name + ".png"), img)
        obj = board.getChessboardCorners().reshape(-1, 3)
        truth = [[margin + float(p[0]) - 0.5, margin + float(p[1]) - 0.5] for p in obj]
        det = cv2.aruco.CharucoDetector(board)
        corners, ids, _, marker_ids = det.detectBoard(img)
        assert ids is not None and len(ids) == len(obj), f"{name}: OpenCV found {0 if ids is None else len(ids)} of {len(obj)}"
        found = {int(i): [float(c[0]), float(c[1])] for i, c in zip(ids.reshape(-1), corners.reshape(-1, 2))}
        worst = max(np.hypot(*np.subtract(found[i], truth[i])) for i in found)
        assert worst < 0.3, f"{name}: OpenCV's corners {worst:.3f} px from the truth"
        out.append({
            "image": name + ".png",
            "board": f"charuco:{sx}x{sy}:{sq}:{mk}:{dname}" + (":legacy" if legacy else ""),
            "squares_x": sx, "squares_y": sy, "square_px": sq, "marker_px": mk, "dictionary": dname,
            "legacy": legacy, "margin_px": margin,
            "truth": truth,
            "opencv_ids": sorted(found),
            "opencv_points": [found[i] for i in sorted(found)],
            "opencv_markers": sorted(int(i) for i in marker_ids.reshape(-1)),
        })
        print(f"{name}: {img.shape[1]}x{img.shape[0]}, {len(obj)} corners, OpenCV {len(found)} "
              f"(worst {worst:.3f} px), {len(marker_ids)} markers")
    with open(os.path.join(HERE, "boards.json"), "w") as f:
        json.dump({"opencv": cv2.__version__, "boards": out}, f, indent=1)


if __name__ == "__main__":
    main()
