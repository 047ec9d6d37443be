"""Throughput of `parallax.distributed.disparity_batch` on a local Dask cluster of 1 and of 2
worker processes (one thread each, one matcher thread each) over a rendered sequence of 204
frames (the 12 zoo worlds, 17 times each), interleaved rounds; and the maps against the command
line's batch (bytes of every PFM).

    python python/benchmarks/distributed_throughput.py [ROUNDS]"""

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from dask.distributed import Client, LocalCluster

from parallax.distributed import disparity_batch

ROOT = Path(__file__).resolve().parents[2]


def xtask(*args):
    exe = ROOT / "target" / "release" / "xtask"
    cmd = [str(exe)] if exe.is_file() else ["cargo", "run", "--release", "--quiet", "-p", "xtask", "--"]
    return subprocess.run(cmd + [str(a) for a in args], cwd=ROOT, capture_output=True, text=True, check=True).stdout


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    tmp = Path(tempfile.mkdtemp())
    xtask("scenes", "--render", tmp / "zoo")
    worlds = sorted(p for p in (tmp / "zoo").iterdir() if p.is_dir())
    for side in ["left", "right"]:
        (tmp / side).mkdir()
    k = 0
    for rep in range(17):
        for w in worlds:
            for side in ["left", "right"]:
                shutil.copy(w / f"{side}.png", tmp / side / f"frame_{k:04d}.png")
            k += 1
    lefts, rights = sorted((tmp / "left").glob("*.png")), sorted((tmp / "right").glob("*.png"))
    options = dict(method="sgm", num_disparities=48)
    clusters = {n: LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
                for n in (1, 2)}
    clients = {n: Client(c) for n, c in clusters.items()}
    rates = {1: [], 2: []}
    for r in range(rounds):
        for n in (1, 2):
            disparity_batch(lefts[:8], rights[:8], client=clients[n], frames_per_task=4, **options)  # warm
            t = time.perf_counter()
            disparity_batch(lefts, rights, client=clients[n], out_dir=tmp / f"out{n}", frames_per_task=10, **options)
            rates[n].append(len(lefts) / (time.perf_counter() - t))
        print(f"round {r}: 1 worker {rates[1][-1]:.1f} frames/s, 2 workers {rates[2][-1]:.1f} frames/s, "
              f"ratio {rates[2][-1] / rates[1][-1]:.2f}")
    print(f"median ratio: {statistics.median(b / a for a, b in zip(rates[1], rates[2])):.2f} "
          f"({len(lefts)} frames of 320x240, 48 disparities, SGM defaults)")
    xtask("disparity", "--left", tmp / "left", "--right", tmp / "right", "--method", "sgm", "--disparities", "48",
          "--threads", "1", "--out", tmp / "cli")
    same = all((tmp / "out2" / f"{p.stem}.pfm").read_bytes() == (tmp / "cli" / f"{p.stem}.pfm").read_bytes()
               for p in lefts)
    print(f"maps equal to the command line's batch: {same}")
    for c in clients.values():
        c.close()
    for c in clusters.values():
        c.close()


if __name__ == "__main__":
    main()
