#!/usr/bin/env python3
"""Frames per second of a molecular-dynamics trajectory played through the Python package, for
docs/BENCHMARKS.md.

usage: PYTHONPATH=build/release/python scripts/bench_trajectory.py [TOPOLOGY TRAJECTORY] [--frames N]
       [--size WxH] [--selection SEL]

MDAnalysis reads each frame; Renderer.update_particles moves the spheres; the renderer rebuilds the
spheres, the implicit sphere shadow map (issm) and the particle ambient occlusion and renders a full
frame (paper 003's treatment of dynamic data: everything rebuilt per frame). Reported per selection:
atoms, frames per second of the whole loop, and the median milliseconds of reading the frame, updating
the spheres, and each rebuilt structure and the render. Defaults: the GROMACS run of ../shared/data
(tpr + xtc), the protein and then every atom (water and ions included), 30 frames, 1024x768.
"""
import argparse
import json
import os
import statistics
import sys
import time

import MDAnalysis as mda
import numpy as np

import penumbra

DATA = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "..", "shared", "data")


def play(u, selection, frames, width, height):
    atoms = u.select_atoms(selection)
    u.trajectory[0]
    scene = penumbra.Scene({
        "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
        "shadows": {"technique": "issm", "resolution": 512, "rings": 1},
        "ambient": {"technique": "particle_ao", "directions": 16, "max_distance": 7},
        "camera": {"direction": [0.2, 0.3, 1.0], "fov_deg": 30, "width": width, "height": height},
    })
    path = scene.add_atoms(atoms)
    r = penumbra.Renderer(scene)
    r.render()  # the first frame builds everything once
    read, update, render, total = [], [], [], []
    parts = {}
    start = time.perf_counter()
    for ts in u.trajectory[1:frames + 1]:
        t0 = time.perf_counter()
        positions = atoms.positions
        t1 = time.perf_counter()
        r.update_particles(path, positions)
        t2 = time.perf_counter()
        r.render()
        t3 = time.perf_counter()
        read.append(1e3 * (t1 - t0))
        update.append(1e3 * (t2 - t1))
        render.append(1e3 * (t3 - t2))
        total.append(1e3 * (t3 - t0))
        for key, ms in r.stats["timings_ms"].items():
            parts.setdefault(key, []).append(ms)
        rebuilt = sorted(e["structure"] for e in r.stats["rebuilt"])
    elapsed = time.perf_counter() - start
    n = len(total)
    return {
        "selection": selection, "atoms": len(atoms), "frames": n, "fps": n / elapsed,
        "read_ms": statistics.median(read), "update_ms": statistics.median(update),
        "render_call_ms": statistics.median(render), "frame_ms_p95": sorted(total)[int(0.95 * (n - 1))],
        "engine_ms": {k: round(statistics.median(v), 1) for k, v in parts.items()},
        "rebuilt": rebuilt,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", default=[os.path.join(DATA, "md_1tii_chainD.tpr"), os.path.join(DATA, "md_1tii_chainD.xtc")])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--size", default="1024x768")
    ap.add_argument("--selection", action="append")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    u = mda.Universe(*args.files)
    results = [play(u, sel, args.frames, width, height) for sel in (args.selection or ["protein", "all"])]
    print(json.dumps(results, indent=1))
    print(f"\n| selection | atoms | frames | fps | read ms | update ms | render ms (median) | p95 frame ms | rebuilt |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['selection']} | {r['atoms']} | {r['frames']} | {r['fps']:.1f} | {r['read_ms']:.1f} | {r['update_ms']:.1f} | "
              f"{r['render_call_ms']:.0f} | {r['frame_ms_p95']:.0f} | {', '.join(r['rebuilt'])} |")


if __name__ == "__main__":
    sys.exit(main())
