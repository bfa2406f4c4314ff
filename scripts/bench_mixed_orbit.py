#!/usr/bin/env python3
"""Issue 42's cliff: an orbit around a protein (1tii.pdb, every atom of the file) with ISSM
shadows and particle AO beside a 64³ translucent volume. Each orbit frame is a camera-only edit: it
must rebuild nothing and cost about what a frame of each kind alone costs.

    PYTHONPATH=build/release/python /usr/bin/python3 scripts/bench_mixed_orbit.py [--data ../shared/data]
"""
import argparse
import os
import statistics

import numpy as np

import penumbra


def orbit(scene, frames=8):
    r = penumbra.Renderer(scene)
    r.render()
    first = r.stats["timings_ms"]["total"]
    times = []
    for k in range(frames):
        a = 0.4 * k
        r.set("camera.direction", [float(np.cos(a)), 0.5, float(np.sin(a))])
        r.render()
        assert r.stats["rebuilt"] == [], r.stats["rebuilt"]
        times.append(r.stats["timings_ms"]["total"])
    return first, times


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    args = ap.parse_args()
    z, y, x = np.mgrid[0:64, 0:64, 0:64].astype(np.float32)
    vol = np.ascontiguousarray(np.clip(1 - np.sqrt((x - 32) ** 2 + (y - 32) ** 2 + (z - 32) ** 2) / 30, 0, 1), dtype=np.float32)
    common = {"ambient": {"technique": "particle_ao"}, "shadows": {"technique": "issm"}, "camera": {"width": 512, "height": 512}}
    atoms = {"file": os.path.join(args.data, "1tii.pdb")}
    tf = [[0, 0.2, 0.4, 1, 0], [1, 0.2, 0.4, 1, 0.05]]
    cases = {}
    both = penumbra.Scene(common | {"particles": [atoms]})
    both.add_volume(vol, spacing=1.0, origin=(9.5 - 32, 8.6 - 32, 48.1 - 32), transfer_function=tf)
    cases["spheres + volume"] = both
    no_ao = penumbra.Scene(common | {"particles": [atoms], "ambient": {"technique": "none"}})
    no_ao.add_volume(vol, spacing=1.0, origin=(9.5 - 32, 8.6 - 32, 48.1 - 32), transfer_function=tf)
    cases["both, without AO"] = no_ao
    cases["spheres alone"] = penumbra.Scene(common | {"particles": [atoms]})
    for name, scene in cases.items():
        first, times = orbit(scene)
        print(f"{name:18s} first frame {first:7.0f} ms   orbit frames: median {statistics.median(times):6.0f} ms, "
              f"range {min(times):.0f}-{max(times):.0f} ms")


if __name__ == "__main__":
    main()
