"""Shared helpers: the repository, the command line (`cargo xtask`, built by the Rust tests),
PFM files and ../shared's data."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"


def xtask(*args, check=True) -> subprocess.CompletedProcess:
    """Runs `cargo xtask ARGS` from the repository root (the built binary when it is there)."""
    exe = ROOT / "target" / "debug" / "xtask"
    cmd = [str(exe)] if exe.is_file() else ["cargo", "run", "--quiet", "-p", "xtask", "--"]
    r = subprocess.run(cmd + [str(a) for a in args], cwd=ROOT, capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"xtask {' '.join(map(str, args))} failed:\n{r.stdout}\n{r.stderr}")
    return r


def keys(stdout: str) -> dict:
    """The `key: value` lines of a command's output."""
    out = {}
    for line in stdout.splitlines():
        if ": " in line and " " not in line.split(": ", 1)[0]:
            k, v = line.split(": ", 1)
            out[k] = v.strip()
    return out


def read_pfm(path) -> np.ndarray:
    """A PFM disparity map (inf and NaN as NaN), rows top to bottom."""
    data = Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    w, h = (int(v) for v in parts[1].split())
    scale = float(parts[2])
    d = np.frombuffer(parts[3], dtype="<f4" if scale < 0 else ">f4").reshape(h, w)[::-1].astype(np.float32)
    return np.where(np.isfinite(d), d, np.float32(np.nan))


@pytest.fixture(scope="session")
def zoo(tmp_path_factory):
    """The zoo rendered by `cargo xtask scenes --render` (left.png, right.png, disparity.pfm, ...)."""
    out = tmp_path_factory.mktemp("zoo")
    xtask("scenes", "--render", out)
    return out


def shared_or_skip(*parts) -> Path:
    p = SHARED.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"skipped: ../shared not found ({p})")
    return p
