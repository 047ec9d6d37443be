"""Circle grids ordered by their owner, OpenCV: `findCirclesGrid`'s output order on grids drawn
here (OpenCV's `gen_pattern.py` geometry: a symmetric grid of `cols x rows` circles at
`spacing`; an asymmetric one with every other row shifted by half a spacing, OpenCV's
`patternSize = (cols, rows)` with `rows` counting both staggered rows), seen frontally and through
perspective warps that turn the grid by 0-330 degrees. Writes one PNG per view and `grids.json`:
the `--board` form and OpenCV's centres, in OpenCV's order, for the views OpenCV finds.

    python3 make_circle_grids.py      # numpy, opencv-python (tested with 5.1.0)

Running it again gives the same bytes."""
import json, os
import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
W, H = 640, 480
S = 8  # drawn at 8x, then area-averaged down: smooth edges without OpenCV's anti-aliasing


def draw(centres, radius, hom):
    big = np.full((H * S, W * S), 255, np.uint8)
    # the grid's plane drawn through the homography: each circle as its warped polygon
    t = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    for c in centres:
        ring = np.stack([c[0] + radius * np.cos(t), c[1] + radius * np.sin(t), np.ones_like(t)])
        p = hom @ ring
        pts = (p[:2] / p[2]).T * S
        cv2.fillPoly(big, [np.round(pts).astype(np.int32)], 0)
    return cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)


def homography(angle_deg, tilt, centre):
    a = np.deg2rad(angle_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    move = np.array([[1, 0, W / 2], [0, 1, H / 2], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, 1, 0], [tilt, 0.3 * tilt, 1]])
    back = np.array([[1, 0, -centre[0]], [0, 1, -centre[1]], [0, 0, 1]])
    return move @ rot @ back


def main():
    out = []
    for kind, cols, rows, spacing, flags in [("circles", 7, 6, 40.0, cv2.CALIB_CB_SYMMETRIC_GRID),
                                             ("acircles", 4, 11, 40.0, cv2.CALIB_CB_ASYMMETRIC_GRID)]:
        if kind == "circles":
            centres = [(x * spacing, y * spacing) for y in range(rows) for x in range(cols)]
        else:
            # OpenCV's asymmetric layout (calib3d's calcBoardCornerPositions): ((2x + y % 2) s, y s)
            centres = [((2 * x + y % 2) * spacing / 2, y * spacing / 2) for y in range(rows) for x in range(cols)]
        centre = np.mean(centres, axis=0)
        diameter = 0.5 * spacing if kind == "circles" else 0.3 * spacing
        for k, (angle, tilt) in enumerate([(0, 0.0), (30, 4e-4), (90, -3e-4), (160, 5e-4), (200, -5e-4), (270, 2e-4), (330, -4e-4)]):
            img = draw(centres, diameter / 2, homography(angle, tilt, centre))
            name = f"{kind}_{cols}x{rows}_{k}.png"
            found, c = cv2.findCirclesGrid(img, (cols, rows), flags=flags)
            if not found:
                print(f"{name}: OpenCV did not find it (left out)")
                continue
            cv2.imwrite(os.path.join(HERE, name), img)
            # the --board spacing is OpenCV's squareSize: the asymmetric grid's is half the spacing
            # of the circles in a row
            square = spacing if kind == "circles" else spacing / 2
            board = f"{kind}:{cols}x{rows}:{square:g}:{diameter:g}"
            out.append({"image": name, "board": board, "angle_deg": angle, "opencv": c.reshape(-1, 2).tolist()})
            print(f"{name}: {board}, OpenCV found {len(c)} centres, first {c[0][0].round(2)}")
    with open(os.path.join(HERE, "grids.json"), "w") as f:
        json.dump({"opencv": cv2.__version__, "grids": out}, f, indent=1)


if __name__ == "__main__":
    main()
