"""Batch work on a Dask cluster: disparity over a stereo sequence and the scoring of matcher
configurations over a scene set, as maps over frames and scenes.

The same code runs on a local cluster or a multi-machine one — only the client changes::

    from dask.distributed import Client, LocalCluster
    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))   # this machine
    client = Client("tcp://scheduler:8786")                            # a cluster

Work is split into tasks of ``frames_per_task`` consecutive frames (one matcher made per task,
its scratch reused across the task's frames); ``threads`` is each matcher's thread count — with
one worker process per core, 1. Every worker must see the input files at the same paths (a
shared file system) and have this package installed. Results are the command line's bit for
bit: ``disparity_batch`` with ``out_dir`` writes the ``<name>.pfm`` files ``cargo xtask
disparity --left DIR --right DIR`` writes.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np


def pfm_bytes(disparity: np.ndarray) -> bytes:
    """A disparity map as the command line's PFM: little-endian, scale -1, rows bottom to top,
    invalid pixels (NaN) as +inf."""
    d = np.asarray(disparity, dtype=np.float32)
    h, w = d.shape
    body = np.where(np.isfinite(d), d, np.float32(np.inf))[::-1].astype("<f4").tobytes()
    return f"Pf\n{w} {h}\n-1\n".encode() + body


def _match_frames(frames: Sequence[Tuple[str, str, str]], options: dict) -> List[Tuple[str, np.ndarray]]:
    import parallax

    colour = bool(options.get("colour", False))
    matcher = parallax.StereoMatcher(**options)
    out = []
    for name, left, right in frames:
        l, r = parallax.load_pair(left, right, colour=colour)
        disparity, _ = matcher.compute(l, r)
        out.append((name, disparity))
    return out


def _chunks(items: Sequence, size: int) -> Iterable[Sequence]:
    for i in range(0, len(items), size):
        yield items[i:i + size]


def disparity_batch(lefts: Sequence, rights: Sequence, client=None, out_dir: Optional[os.PathLike] = None,
                    frames_per_task: int = 8, threads: int = 1, **matcher_options) -> List[Tuple[str, np.ndarray]]:
    """Disparity of every ``(left, right)`` file pair (in order; named by the left file's stem)
    with ``parallax.StereoMatcher(**matcher_options)``, as Dask tasks of ``frames_per_task``
    frames on ``client`` (``None``: in this process). Returns ``[(name, disparity)]``; with
    ``out_dir`` also writes ``<name>.pfm`` there."""
    if len(lefts) != len(rights):
        raise ValueError(f"{len(lefts)} left images and {len(rights)} right images")
    if frames_per_task < 1:
        raise ValueError("frames_per_task must be at least 1")
    names = [Path(l).stem for l in lefts]
    if len(set(names)) != len(names):
        raise ValueError("left images must have distinct names (each map is written as <name>.pfm)")
    options = dict(matcher_options, threads=threads)
    frames = [(n, os.fspath(l), os.fspath(r)) for n, l, r in zip(names, lefts, rights)]
    chunks = list(_chunks(frames, frames_per_task))
    if client is None:
        results = [_match_frames(c, options) for c in chunks]
    else:
        futures = [client.submit(_match_frames, c, options, pure=False) for c in chunks]
        results = client.gather(futures)
    maps = [m for chunk in results for m in chunk]
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        for name, d in maps:
            tmp = out / f".{name}.pfm.tmp"
            tmp.write_bytes(pfm_bytes(d))
            tmp.replace(out / f"{name}.pfm")
    return maps


def _score(world: str, config: str, threads: int) -> dict:
    import parallax._parallax as native

    return native.score_world(world, config, threads=threads)


def score_configs(configs: Sequence, worlds: Sequence, client=None, threads: int = 1) -> List[dict]:
    """``tune``'s scores of each configuration file (``config.ron``) over the worlds (RON), one
    task per (configuration, world): per configuration the means over the worlds of ``bad2``,
    ``bad2_overlap`` and ``density`` — the figures ``cargo xtask tune`` prints — and ``ms``."""
    pairs = [(os.fspath(w), os.fspath(c)) for c in configs for w in worlds]
    if client is None:
        scores = [_score(w, c, threads) for w, c in pairs]
    else:
        scores = client.gather([client.submit(_score, w, c, threads, pure=False) for w, c in pairs])
    out = []
    n = len(worlds)
    for i in range(len(configs)):
        part = scores[i * n:(i + 1) * n]
        overlap = [s["bad2_overlap"] for s in part if np.isfinite(s["bad2_overlap"])]
        out.append({
            "bad2": float(np.mean([s["bad2"] for s in part])),
            "bad2_overlap": float(np.mean(overlap)) if overlap else float("nan"),
            "density": float(np.mean([s["density"] for s in part])),
            "ms": float(np.mean([s["ms"] for s in part])),
        })
    return out
