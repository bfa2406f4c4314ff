#!/usr/bin/env python3
"""The Python library's figures (issue 41, docs/BENCHMARKS.md): Ctrl-C latency into a long frame, the
cost of the in-place change check (digest) per GB, and MD playback through MDAnalysis (set_frame)
against penumbra's own trajectory reader (set("time", k)).

    PYTHONPATH=build/release/python /usr/bin/python3 scripts/bench_python.py [--data ../shared/data]
"""
import argparse
import os
import signal
import statistics
import threading
import time

import numpy as np

import penumbra


def ctrl_c_latency(runs):
    scene = {"volumes": [{"procedural": {"name": "test-spheres", "size": 160}, "transfer_function": {"preset": "test-spheres"}}],
             "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}], "shadows": {"technique": "ray_traced"}}
    r = penumbra.Renderer(scene)
    r.render(width=48, height=40)
    latencies = []
    for k in range(runs):
        r.set("lights.0.direction", [0.3, -1, 0.2 + 0.01 * k])
        sent = []
        timer = threading.Timer(0.3, lambda: (sent.append(time.perf_counter()), os.kill(os.getpid(), signal.SIGINT)))
        timer.start()
        try:
            r.render(width=1200, height=1000)
        except KeyboardInterrupt:
            latencies.append(1000 * (time.perf_counter() - sent[0]))
        timer.join()
    return latencies


def digest_ms_per_gb(runs):
    a = np.random.default_rng(1).integers(0, 255, size=(512, 1024, 1024), dtype=np.uint8)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        penumbra._penumbra.digest(a)
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times) * (1 << 30) / a.nbytes


def playback(data, frames):
    import MDAnalysis as mda
    gro, xtc = os.path.join(data, "md_1tii_chainD.gro"), os.path.join(data, "md_1tii_chainD.xtc")
    common = {"camera": {"width": 480, "height": 360}, "shadows": {"technique": "issm", "resolution": 512}}
    u = mda.Universe(gro, xtc)
    protein = u.select_atoms("protein")
    scene = penumbra.Scene(common)
    scene.add_atoms(protein)
    r = penumbra.Renderer(scene)
    r.render()
    t = time.perf_counter()
    for k in range(1, frames + 1):
        r.set_frame(k)
        r.render()
    mda_fps = frames / (time.perf_counter() - t)
    own = penumbra.Renderer(common | {"particles": [{"file": gro, "trajectory": xtc, "select": "protein"}]})
    own.render()
    t = time.perf_counter()
    for k in range(1, frames + 1):
        own.set("time", k)
        own.render()
    return mda_fps, frames / (time.perf_counter() - t)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    lat = ctrl_c_latency(args.runs)
    print(f"Ctrl-C into a 1200x1000 ray-traced frame: median {statistics.median(lat):.0f} ms, max {max(lat):.0f} ms ({len(lat)} runs)")
    print(f"digest (in-place change check): {digest_ms_per_gb(args.runs):.0f} ms per GB")
    mda_fps, own_fps = playback(args.data, 30)
    print(f"protein of the 1tii run, 480x360 issm 512: set_frame (MDAnalysis) {mda_fps:.1f} fps, set('time') (own reader) {own_fps:.1f} fps")


if __name__ == "__main__":
    main()
