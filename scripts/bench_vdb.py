#!/usr/bin/python3
"""Sparse OpenVDB volumes against the same voxels dense: load time, the volume's memory, peak memory of
the process and the frame time, for a render of each (docs/BENCHMARKS.md, "OpenVDB").

    scripts/bench_vdb.py [build/release/penumbra]

Renders at 512×512 with the automatic scene (cssm shadows); prepare = gradients, min/max grid and
tables, shadows = the light's structure, render = the eye pass.

Makes two grids with pyopenvdb (Debian python3-openvdb) in a temporary folder: a level-set sphere
(radius 120 voxels, a narrow band of 3 voxels each side) and a fog of 60 soft balls (radius 10 voxels)
scattered through a 480³ box. Each is written as .vdb and, dense over the box penumbra loads (the
active box, its low corner down to a multiple of 8), as a raw .nrrd. Peak memory is GNU time's maximum
resident set size of the whole process."""
import json
import os
import random
import re
import subprocess
import sys
import tempfile

import numpy as np
import pyopenvdb as vdb

PENUMBRA = sys.argv[1] if len(sys.argv) > 1 else "build/release/penumbra"


def fog_balls():
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    acc = g.getAccessor()
    rng = random.Random(3)
    r = 10
    ball = [(i, j, k, 1.0 - (i * i + j * j + k * k) ** 0.5 / r)
            for i in range(-r, r + 1) for j in range(-r, r + 1) for k in range(-r, r + 1) if i * i + j * j + k * k < r * r]
    for _ in range(60):
        c = [rng.randrange(r, 480 - r) for _ in range(3)]
        for i, j, k, v in ball:
            acc.setValueOn((c[0] + i, c[1] + j, c[2] + k), v)
    return g


def sphere():
    g = vdb.createLevelSetSphere(radius=120.0, center=(0, 0, 0), voxelSize=1.0, halfWidth=3.0)
    g.name = "surface"
    return g


def write_dense(grid, path):
    """The voxels penumbra loads, dense, as a raw NRRD."""
    lo, hi = grid.evalActiveVoxelBoundingBox()
    lo = [(c // 8) * 8 for c in lo]
    dims = [h - l + 1 for l, h in zip(lo, hi)]
    a = np.empty((dims[0], dims[1], dims[2]), dtype=np.float32)
    grid.copyToArray(a, ijk=tuple(lo))
    a = np.ascontiguousarray(a.transpose(2, 1, 0))  # z, y, x: x fastest on disk
    vs = grid.transform.voxelSize()
    origin = grid.transform.indexToWorld(tuple(lo))
    with open(path, "wb") as f:
        f.write(("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
                 "space dimension: 3\nspace directions: (%g,0,0) (0,%g,0) (0,0,%g)\nspace origin: (%g,%g,%g)\n\n"
                 % (dims[0], dims[1], dims[2], vs[0], vs[1], vs[2], origin[0], origin[1], origin[2])).encode())
        f.write(a.tobytes())
    return dims


def timed(args):
    r = subprocess.run(["/usr/bin/time", "-f", "PEAK %M"] + args, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{r.stderr}")
    peak = int(re.search(r"PEAK (\d+)", r.stderr).group(1)) / 1024
    return r.stdout, peak


def measure(path, tmp, extra):
    out, _ = timed([PENUMBRA, "info", path])
    read_ms = float(re.search(r"read in ([\d.]+) ms", out).group(1))
    volume_bytes = int(re.search(r"\((\d+) bytes in memory\)", out).group(1))
    stats = os.path.join(tmp, "stats.json")
    _, peak = timed([PENUMBRA, "render", path, "-o", os.path.join(tmp, "x.png"), "--width", "512", "--height", "512",
                     "--stats", stats] + extra)
    with open(stats) as f:
        s = json.load(f)
    return read_ms, volume_bytes / 2**20, peak, s["timings_ms"]


def main():
    print("| grid | voxels in the box | file | load ms | volume MiB | peak MiB (render) | prepare ms | shadows ms | render ms |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, grid, extra in [("level-set sphere, r = 120 voxels", sphere(), []),
                                  ("60 fog balls in 480³", fog_balls(), [])]:
            v = os.path.join(tmp, "g.vdb")
            n = os.path.join(tmp, "g.nrrd")
            vdb.write(v, grids=[grid])
            dims = write_dense(grid, n)
            count = dims[0] * dims[1] * dims[2]
            for label, path in [(".vdb (sparse)", v), (".nrrd (dense)", n)]:
                read_ms, mib, peak, t = measure(path, tmp, extra)
                size = os.path.getsize(path) / 2**20
                print(f"| {name} | {dims[0]}×{dims[1]}×{dims[2]} = {count / 1e6:.1f} M | {label} {size:.1f} MiB | "
                      f"{read_ms:.0f} | {mib:.1f} | {peak:.0f} | {t['prepare']:.0f} | {t['build']:.0f} | {t['render']:.0f} |")


if __name__ == "__main__":
    main()
