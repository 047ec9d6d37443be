"""StereoMatcher against the command line (the same maps bit for bit) and against the truth."""

import resource

import numpy as np
import pytest

import parallax
from conftest import ROOT, keys, read_pfm, xtask


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.where(np.isnan(a), np.float32(np.inf), a).astype(np.float32)
    b = np.where(np.isnan(b), np.float32(np.inf), b).astype(np.float32)
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


@pytest.mark.parametrize(
    "scene,args,kwargs",
    [
        ("planes", ["--method", "bm"], dict(method="bm")),
        ("clutter", ["--method", "sgm"], dict(method="sgm")),
        ("textureless", ["--method", "sgm", "--accurate"], dict(method="sgm", accurate=True)),
        ("colour", ["--method", "sgm", "--colour"], dict(method="sgm", colour=True)),
        ("gain-gamma", ["--method", "bm", "--cost", "ncc", "--block", "7"], dict(method="bm", cost="ncc", block_size=7)),
    ],
)
def test_maps_equal_the_command_lines_bit_for_bit(zoo, tmp_path, scene, args, kwargs):
    d = zoo / scene
    out = tmp_path / "out"
    r = xtask("disparity", "--left", d / "left.png", "--right", d / "right.png", "--disparities", "48",
              "--runs", "1", "--confidence", "--out", out, *args)
    colour = kwargs.get("colour", False)
    left, right = parallax.load_pair(d / "left.png", d / "right.png", colour=colour)
    disparity, confidence = parallax.StereoMatcher(num_disparities=48, **kwargs).compute(left, right)
    assert disparity.dtype == np.float32 and disparity.shape == (240, 320)
    assert same_bits(disparity, read_pfm(out / "disparity.pfm"))
    assert same_bits(confidence, read_pfm(out / "confidence.pfm"))
    # and the density the command printed
    density = 100.0 * np.isfinite(disparity).mean()
    assert abs(density - float(keys(r.stdout)["density"])) < 0.01


def test_a_tuned_configuration_file_gives_the_maps_of_disparity_config(zoo, tmp_path):
    space = tmp_path / "space.ron"
    space.write_text("(method: [Sgm], sgm_block: (min: 3, max: 3, step: 1), sgm_paths: [Five], "
                     "p1: (min: 12, max: 12, step: 1), p2: (min: 64, max: 64, step: 1), "
                     "uniqueness: (min: 0, max: 0, step: 1), lr_max_diff: [None], "
                     "speckle_window: (min: 0, max: 0, step: 1), colour: [false], prefilter: [XSobel(cap: 31)])")
    xtask("tune", "--space", space, "--search", "grid", "--scenes", ROOT / "fixtures/zoo/planes.ron",
          "--out", tmp_path / "tune")
    config = tmp_path / "tune" / "config.ron"
    d = zoo / "spheres"
    xtask("disparity", "--config", config, "--left", d / "left.png", "--right", d / "right.png",
          "--disparities", "48", "--runs", "1", "--out", tmp_path / "out")
    left, right = parallax.load_pair(d / "left.png", d / "right.png")
    disparity, _ = parallax.StereoMatcher(num_disparities=48, config=config).compute(left, right)
    assert same_bits(disparity, read_pfm(tmp_path / "out" / "disparity.pfm"))


def test_maps_are_close_to_the_rendered_truth(zoo):
    d = zoo / "planes"
    left, right = parallax.load_pair(d / "left.png", d / "right.png")
    disparity, confidence = parallax.StereoMatcher("sgm", num_disparities=48).compute(left, right)
    truth = read_pfm(d / "disparity.pfm")
    import cv2

    occluded = cv2.imread(str(d / "occluded.png"), cv2.IMREAD_GRAYSCALE) == 255
    scored = ~occluded
    bad = (~np.isfinite(disparity) | (np.abs(disparity - truth) > 2.0)) & scored
    # the command line's `tune` scores the default SGM on this world; a wrong map is mostly bad
    assert bad.sum() / scored.sum() < 0.15
    assert ((confidence > 0) <= np.isfinite(disparity)).all()


def test_inputs_the_matcher_refuses_raise_parallax_error():
    with pytest.raises(parallax.ParallaxError, match="--method must be bm or sgm"):
        parallax.StereoMatcher(method="census")
    with pytest.raises(parallax.ParallaxError, match="ncc"):
        parallax.StereoMatcher(method="bm", cost="ncc", colour=True)
    m = parallax.StereoMatcher(num_disparities=16)
    with pytest.raises(parallax.ParallaxError, match="uint8 or uint16"):
        m.compute(np.zeros((32, 32), np.float32), np.zeros((32, 32), np.float32))
    with pytest.raises(ValueError):  # ParallaxError is a ValueError
        m.compute(np.zeros((32, 32), np.uint8), np.zeros((32, 40), np.uint8))
    assert issubclass(parallax.ParallaxError, ValueError)


def test_the_version_is_the_workspaces():
    import re

    text = (ROOT / "Cargo.toml").read_text()
    version = re.search(r'\[workspace\.package\]\s*\nversion = "([^"]+)"', text).group(1)
    assert parallax.__version__ == version


def test_output_arrays_are_filled_with_the_same_maps(zoo):
    d = zoo / "clutter"
    left, right = parallax.load_pair(d / "left.png", d / "right.png")
    m = parallax.StereoMatcher("sgm", num_disparities=48)
    disparity, confidence = m.compute(left, right)
    outs = (np.full(left.shape, 7.0, np.float32), np.full(left.shape, 7.0, np.float32))
    got = m.compute(left, right, disparity=outs[0], confidence=outs[1])
    assert got[0] is outs[0] and got[1] is outs[1]
    assert same_bits(outs[0], disparity) and same_bits(outs[1], confidence)
    assert m.last_seconds > 0
    with pytest.raises(parallax.ParallaxError, match="shape"):
        m.compute(left, right, disparity=np.zeros((10, 10), np.float32))


def test_returned_arrays_own_their_memory_and_reuse_what_the_caller_dropped(zoo):
    d = zoo / "clutter"
    left, right = parallax.load_pair(d / "left.png", d / "right.png")
    other_left, other_right = parallax.load_pair(zoo / "planes" / "left.png", zoo / "planes" / "right.png")
    m = parallax.StereoMatcher("sgm", num_disparities=48)
    kept = m.compute(left, right)
    copies = tuple(a.copy() for a in kept)
    address = lambda a: a.__array_interface__["data"][0]  # noqa: E731
    # Results still held are never reused: a later frame does not change them.
    second = m.compute(other_left, other_right)
    assert {address(a) for a in second}.isdisjoint(address(a) for a in kept)
    assert all(same_bits(a, c) for a, c in zip(kept, copies))
    assert not same_bits(second[0], kept[0])
    # Dropped results' memory comes back for the next frame, which holds that frame's maps.
    freed = {address(a) for a in second}
    del second
    third = m.compute(left, right)
    assert {address(a) for a in third} <= freed
    assert all(same_bits(a, c) for a, c in zip(third, copies))
    # The arrays are ordinary, writeable numpy arrays that outlive their matcher.
    del m
    third[0][0, 0] = 1.5
    assert third[0][0, 0] == np.float32(1.5) and third[0].flags.writeable and third[0].shape == left.shape


def test_a_frame_whose_earlier_results_were_dropped_touches_no_fresh_pages():
    # Fresh memory for two 640x480 float32 maps faults in 2 x 300 pages on first touch (glibc
    # gives it back to the kernel between frames at this size); the pooled buffers are resident
    # already. The least of five frames, against stray faults.
    rng = np.random.default_rng(7)
    right = rng.integers(0, 256, (480, 640), dtype=np.uint8)
    left = np.roll(right, 20, axis=1)
    m = parallax.StereoMatcher("bm", num_disparities=64)
    m.compute(left, right)
    faults = []
    for _ in range(5):
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        m.compute(left, right)
        faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
    assert min(faults) < 100, faults
