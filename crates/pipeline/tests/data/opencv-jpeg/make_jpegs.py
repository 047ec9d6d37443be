"""JPEG files written by OpenCV (`cv2.imwrite`, libjpeg-turbo) for `src/jpeg_scan.rs`'s tests:
the forms a camera or OpenCV writes — colour 4:2:0 with restart markers every 4 MCUs, colour
4:4:4, grey, progressive (not checked, accepted) — of a small textured image whose size is not a
multiple of the MCU. Run: `python3 make_jpegs.py` (numpy, opencv-python; tested with 5.1.0)."""
import os
import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
y, x = np.mgrid[0:75, 0:101]
img = np.dstack([(x * 37 + y * 91) % 256, (x * 11 + y * 5 + (x * y) % 17) % 256, (x ^ y) % 256]).astype(np.uint8)
cv2.imwrite(os.path.join(HERE, "rst_420.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 90, cv2.IMWRITE_JPEG_RST_INTERVAL, 4])
cv2.imwrite(os.path.join(HERE, "colour_444.jpg"), img,
            [cv2.IMWRITE_JPEG_QUALITY, 90, cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444])
cv2.imwrite(os.path.join(HERE, "grey.jpg"), img[:, :, 0], [cv2.IMWRITE_JPEG_QUALITY, 80])
cv2.imwrite(os.path.join(HERE, "progressive.jpg"), img, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1])
