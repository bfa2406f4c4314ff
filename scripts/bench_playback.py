#!/usr/bin/env python3
"""Frames per second playing a trajectory natively (issue 18): `penumbra render --frames` over a scene
whose particles carry a trajectory, for local lighting, issm and issm + particle_ao (paper 003 Fig. 8's
three configurations; issm at 1024² and at the paper's 512²), with the time split into reading the
frame, rebuilding (spheres, shadow map, AO) and rendering.

    scripts/bench_playback.py [--build build/release] [--frames 0:150:3] [--size 1920x1200] [--out DIR]

Default data: the GROMACS run of ../shared/data (md_1tii_chainD.gro + .xtc, 18,182 atoms, 151 frames).
Prints a Markdown table and writes playback.json into --out. The first frame (which builds everything
once) is left out of the figures.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")

# the shadow map at penumbra's default (1024²) and at paper 003's benchmark setting (512² "for all tests")
CONFIGS = [
    ("local lighting", {"technique": "none"}, {"technique": "none"}),
    ("issm", {"technique": "issm", "resolution": 1024}, {"technique": "none"}),
    ("issm + particle_ao", {"technique": "issm", "resolution": 1024}, {"technique": "particle_ao"}),
    ("issm 512²", {"technique": "issm", "resolution": 512}, {"technique": "none"}),
    ("issm 512² + particle_ao", {"technique": "issm", "resolution": 512}, {"technique": "particle_ao"}),
]


def run(cli, topology, trajectory, frames, width, height, shadows, ambient, folder):
    scene = {
        "particles": [{"file": topology, "trajectory": trajectory}],
        "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
        "shadows": shadows,
        "ambient": ambient,
        "camera": {"direction": [0.2, 0.3, 1.0], "fov_deg": 30, "width": width, "height": height},
    }
    path = os.path.join(folder, "scene.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    stats = os.path.join(folder, "stats.json")
    out = subprocess.run([cli, "render", path, "--frames", frames, "-o", os.path.join(folder, "frame.png"),
                          "--stats", stats], capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"bench_playback: penumbra render failed:\n{out.stderr}")
    with open(stats) as f:
        per_frame = json.load(f)["frames"][1:]  # the first frame builds everything once
    t = lambda key: [fr["timings_ms"][key] for fr in per_frame]
    total = [fr["read_ms"] + fr["timings_ms"]["total"] for fr in per_frame]
    # rebuilt per frame: the BVH (when Embree needs one), the AO's density volume, the shadow map; the
    # rest of the frame (total - render - these) is moving the spheres and preparing them
    rebuild = [fr["timings_ms"]["bvh"] + fr["timings_ms"]["ambient"] + fr["timings_ms"]["build"] for fr in per_frame]
    return {
        "frames": len(per_frame),
        "fps": 1000.0 / statistics.mean(total),
        "frame_ms": statistics.median(total),
        "read_ms": statistics.median(fr["read_ms"] for fr in per_frame),
        "rebuild_ms": statistics.median(rebuild),
        "render_ms": statistics.median(t("render")),
        "other_ms": statistics.median(fr["timings_ms"]["total"] - fr["timings_ms"]["render"] - fr["timings_ms"]["bvh"]
                                      - fr["timings_ms"]["ambient"] - fr["timings_ms"]["build"] for fr in per_frame),
        "rebuilt": sorted(set(r for fr in per_frame for r in fr["rebuilt"])),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--topology", default=os.path.join(DATA, "md_1tii_chainD.gro"))
    ap.add_argument("--trajectory", default=os.path.join(DATA, "md_1tii_chainD.xtc"))
    ap.add_argument("--frames", default="0:150:3")
    ap.add_argument("--size", default="1920x1200")
    ap.add_argument("--out", default=".")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    cli = os.path.join(args.build, "penumbra")
    for f in (cli, args.topology, args.trajectory):
        if not os.path.exists(f):
            sys.exit(f"bench_playback: {f} not found")
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, shadows, ambient in CONFIGS:
            results[name] = run(cli, args.topology, args.trajectory, args.frames, width, height, shadows, ambient, folder)
    ll = results["local lighting"]["fps"]
    print(f"{os.path.basename(args.trajectory)}, frames {args.frames}, {width}×{height}\n")
    print("| configuration | fps | × local lighting | frame ms (median) | read ms | spheres ms | rebuild ms | render ms | read / frame |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, r in results.items():
        print(f"| {name} | {r['fps']:.1f} | {r['fps'] / ll:.2f} | {r['frame_ms']:.1f} | {r['read_ms']:.2f} | {r['other_ms']:.1f} | "
              f"{r['rebuild_ms']:.1f} | {r['render_ms']:.1f} | {100 * r['read_ms'] / r['frame_ms']:.1f} % |")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "playback.json"), "w") as f:
        json.dump({"frames": args.frames, "width": width, "height": height, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
