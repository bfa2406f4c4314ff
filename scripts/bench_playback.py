#!/usr/bin/env python3
"""Frames per second playing a trajectory natively (issue 18): `penumbra render --frames` over a scene
whose particles carry a trajectory, for local lighting, issm and issm + particle_ao (paper 003 Fig. 8's
three configurations; issm at 1024² and at the paper's 512²), with the time split into reading the
frame, rebuilding (spheres, shadow map, AO) and rendering.

    scripts/bench_playback.py [--build build/release] [--frames 0:150:3] [--size 1920x1200] [--out DIR]
                              [--topology FILE --trajectory FILE] [--configs "local lighting,issm + particle_ao"]

Default data: the GROMACS run of ../shared/data (md_1tii_chainD.gro + .xtc, 18,182 atoms, 151 frames).
A million moving atoms (issue 42): scripts/make_moving_atoms.py DIR, then --topology DIR/moving.gro
--trajectory DIR/moving.dcd --frames 0:24 --size 1920x1080.
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
    # the AO's cones kept while atoms move little (ambient.reuse, in density cells)
    ("issm + particle_ao reuse 0.25", {"technique": "issm", "resolution": 1024}, {"technique": "particle_ao", "reuse": 0.25}),
    ("issm + particle_ao reuse 0.5", {"technique": "issm", "resolution": 1024}, {"technique": "particle_ao", "reuse": 0.5}),
]
FRESH_AO = "issm + particle_ao"  # what the reuse rows' frames are compared with


def run(cli, topology, trajectory, frames, width, height, shadows, ambient, folder):
    scene = {
        "particles": [{"file": topology, "trajectory": trajectory}],
        "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
        "shadows": shadows,
        "ambient": ambient,
        "camera": {"direction": [0.2, 0.3, 1.0], "fov_deg": 30, "width": width, "height": height},
    }
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "scene.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    stats = os.path.join(folder, "stats.json")
    out = subprocess.run([cli, "render", path, "--frames", frames, "-o", os.path.join(folder, "frame.png"),
                          "--stats", stats], capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"bench_playback: penumbra render failed:\n{out.stderr}")
    with open(stats) as f:
        everything = json.load(f)
    per_frame = everything["frames"][1:]  # the first frame builds everything once
    t = lambda key: [fr["timings_ms"][key] for fr in per_frame]
    total = [fr["read_ms"] + fr["timings_ms"]["total"] for fr in per_frame]
    # rebuilt per frame: the BVH (when Embree needs one), the AO's density volume, the shadow map; the
    # rest of the frame (total - render - these) is moving the spheres and preparing them
    rebuild = [fr["timings_ms"]["bvh"] + fr["timings_ms"]["ambient"] + fr["timings_ms"]["build"] for fr in per_frame]
    return {
        "atoms": everything["counts"]["spheres"] if "spheres" in everything.get("counts", {}) else 0,
        "frames": len(per_frame),
        "fps": 1000.0 / statistics.mean(total),
        "frame_ms": statistics.median(total),
        "read_ms": statistics.median(fr["read_ms"] for fr in per_frame),
        "rebuild_ms": statistics.median(rebuild),
        "render_ms": statistics.median(t("render")),
        "other_ms": statistics.median(fr["timings_ms"]["total"] - fr["timings_ms"]["render"] - fr["timings_ms"]["bvh"]
                                      - fr["timings_ms"]["ambient"] - fr["timings_ms"]["build"] for fr in per_frame),
        "rebuilt": sorted(set(r for fr in per_frame for r in fr["rebuilt"])),
        "ambient_kept": [fr.get("ambient_kept", 0) for fr in per_frame],
        "frame_files": [fr["file"] for fr in per_frame],
    }


def psnr_against(files, reference_files):
    """Worst and median PSNR (dB, 8-bit RGB) and the largest pixel difference of frames against a reference's."""
    import numpy as np
    from PIL import Image
    values, worst_pixel = [], 0
    for a, b in zip(files, reference_files):
        x = np.asarray(Image.open(a).convert("RGB"), dtype=np.float64)
        y = np.asarray(Image.open(b).convert("RGB"), dtype=np.float64)
        mse = float(((x - y) ** 2).mean())
        values.append(float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse))
        worst_pixel = max(worst_pixel, int(np.abs(x - y).max()))
    return min(values), statistics.median(values), worst_pixel


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--topology", default=os.path.join(DATA, "md_1tii_chainD.gro"))
    ap.add_argument("--trajectory", default=os.path.join(DATA, "md_1tii_chainD.xtc"))
    ap.add_argument("--frames", default="0:150:3")
    ap.add_argument("--size", default="1920x1200")
    ap.add_argument("--out", default=".")
    ap.add_argument("--configs", default=",".join(name for name, _, _ in CONFIGS),
                    help="comma-separated names of the configurations to run")
    args = ap.parse_args()
    chosen = [c.strip() for c in args.configs.split(",")]
    unknown = [c for c in chosen if c not in {name for name, _, _ in CONFIGS}]
    if unknown:
        sys.exit(f"bench_playback: unknown configuration {unknown}; known: {[name for name, _, _ in CONFIGS]}")
    width, height = (int(v) for v in args.size.split("x"))
    cli = os.path.join(args.build, "penumbra")
    for f in (cli, args.topology, args.trajectory):
        if not os.path.exists(f):
            sys.exit(f"bench_playback: {f} not found")
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, shadows, ambient in (c for c in CONFIGS if c[0] in chosen):
            results[name] = run(cli, args.topology, args.trajectory, args.frames, width, height, shadows, ambient,
                                os.path.join(folder, name.replace(" ", "_").replace("+", "and")))
        for name, r in results.items():
            if "reuse" in name and FRESH_AO in results:
                r["psnr_worst"], r["psnr_median"], r["max_pixel_difference"] = psnr_against(r["frame_files"], results[FRESH_AO]["frame_files"])
    ll = results["local lighting"]["fps"] if "local lighting" in results else float("nan")
    print(f"{os.path.basename(args.trajectory)}, frames {args.frames}, {width}×{height}\n")
    print("| configuration | fps | × local lighting | frame ms (median) | read ms | spheres ms | rebuild ms | render ms | read / frame |"
          " AO cones kept (median) | PSNR vs traced anew (worst / median), max diff |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for name, r in results.items():
        kept = f"{100 * statistics.median(r['ambient_kept']) / max(1, r['atoms']):.0f} %" if "reuse" in name else ""
        psnr = f"{r['psnr_worst']:.1f} / {r['psnr_median']:.1f} dB, {r['max_pixel_difference']}/255" if "psnr_worst" in r else ""
        print(f"| {name} | {r['fps']:.1f} | {r['fps'] / ll:.2f} | {r['frame_ms']:.1f} | {r['read_ms']:.2f} | {r['other_ms']:.1f} | "
              f"{r['rebuild_ms']:.1f} | {r['render_ms']:.1f} | {100 * r['read_ms'] / r['frame_ms']:.1f} % | {kept} | {psnr} |")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "playback.json"), "w") as f:
        json.dump({"frames": args.frames, "width": width, "height": height, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
