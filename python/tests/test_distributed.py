"""Batch work on a local Dask cluster of 2 worker processes: the maps and the scores equal the
command line's batch."""

import shutil

import pytest

import parallax
from conftest import ROOT, keys, xtask

distributed = pytest.importorskip("dask.distributed")
from parallax.distributed import disparity_batch, score_configs  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_a_sequence_matched_on_the_cluster_equals_the_command_lines_batch(zoo, tmp_path, client):
    seq = tmp_path / "seq"
    (seq / "left").mkdir(parents=True)
    (seq / "right").mkdir()
    names = ["planes", "spheres", "clutter", "terrain", "ground", "vignetting", "posts-and-wires"]
    for i, n in enumerate(names):
        shutil.copy(zoo / n / "left.png", seq / "left" / f"frame_{i:03d}.png")
        shutil.copy(zoo / n / "right.png", seq / "right" / f"frame_{i:03d}.png")
    xtask("disparity", "--left", seq / "left", "--right", seq / "right", "--method", "sgm", "--disparities", "48",
          "--out", tmp_path / "cli")
    lefts = sorted((seq / "left").glob("*.png"))
    rights = sorted((seq / "right").glob("*.png"))
    maps = disparity_batch(lefts, rights, client=client, out_dir=tmp_path / "dask", frames_per_task=2,
                           method="sgm", num_disparities=48)
    assert [n for n, _ in maps] == [p.stem for p in lefts]
    for p in lefts:
        ours = (tmp_path / "dask" / f"{p.stem}.pfm").read_bytes()
        theirs = (tmp_path / "cli" / f"{p.stem}.pfm").read_bytes()
        assert ours == theirs, p.stem


def test_configurations_scored_on_the_cluster_equal_tunes_figures(tmp_path, client):
    worlds = tmp_path / "worlds"
    worlds.mkdir()
    for n in ["planes", "spheres", "textureless"]:
        shutil.copy(ROOT / "fixtures" / "zoo" / f"{n}.ron", worlds / f"{n}.ron")
    # a grid of one configuration: the default SGM, which tune then writes as its choice or ties
    space = tmp_path / "space.ron"
    space.write_text("(method: [Sgm], sgm_block: (min: 3, max: 3, step: 1), sgm_paths: [Three], "
                     "p1: (min: 20, max: 20, step: 1), p2: (min: 80, max: 80, step: 1), "
                     "uniqueness: (min: 0, max: 0, step: 1), lr_max_diff: [Some(2)], "
                     "speckle_window: (min: 100, max: 100, step: 1), colour: [false], prefilter: [XSobel(cap: 31)])")
    r = xtask("tune", "--space", space, "--search", "grid", "--scenes", worlds, "--out", tmp_path / "tune")
    lines = {int(l.split()[1]): keys(l.replace(" ", "\n").replace(":\n", ": ")) for l in r.stdout.splitlines()
             if l.startswith("config: ")}
    bm = tmp_path / "bm.ron"
    bm.write_text("(matcher: ())")  # MatcherConfig's defaults: tune's configuration 0
    scores = score_configs([bm, tmp_path / "tune" / "config.ron"], sorted(worlds.glob("*.ron")), client=client)
    for i, s in enumerate(scores):
        for key in ["bad2", "bad2_overlap", "density"]:
            assert f"{s[key]:.3f}" == lines[i][key] if key != "density" else f"{s[key]:.2f}" == lines[i][key], (i, key)
