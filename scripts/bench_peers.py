#!/usr/bin/env python3
"""penumbra side by side with its peers on this machine, for docs/BENCHMARKS.md (issue 17).

usage: scripts/bench_peers.py [--build build/release] [--spheres N] [--out DIR] [--quick]

Spheres against Tachyon (VMD's ray tracer, the ISSM paper's reference; Debian `tachyon`): N
non-overlapping spheres (one per cell of a jittered grid, 1 M by default) at 1920×1200, one sample per
pixel, one directional light. Tachyon renders with shadows (`-fullshade`) and with ambient occlusion
(`-fullshade -auto_skylight 0.7 -skylight_samples 12`); its own "Ray Tracing Time" excludes parsing
and its grid build, which are reported beside it. penumbra renders `issm` and `issm` + `particle_ao`
through its Python module, the frame timed by the engine (no conversion to bytes): once with the
light moving (the shadow map rebuilt each frame) and once with it cached. Each penumbra frame's error
(RMSE, PSNR) is measured against penumbra's exact reference (ray-traced shadows; ray-traced AO with 64
rays) at a reduced frame, since the reference takes minutes at full size.

Without `tachyon` on the PATH the Tachyon rows say "not run" and the rest still runs; the
script never fails for a missing peer. It writes DIR/peers.json and DIR/peers.md (the table with the
commit and the machine) and prints the table.
"""
import argparse
import json
import math
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

WIDTH, HEIGHT = 1920, 1200
FOV_DEG = 30.0
EYE = (1.25, 0.95, 1.55)
TARGET = (0.0, 0.0, 0.0)
UP = (0.0, 1.0, 0.0)
LIGHT = (-0.45, -0.8, -0.4)  # direction the light travels
PALETTE = np.array([[0.90, 0.35, 0.30], [0.35, 0.60, 0.90], [0.95, 0.80, 0.35], [0.45, 0.80, 0.45],
                    [0.75, 0.50, 0.85], [0.90, 0.60, 0.40], [0.40, 0.80, 0.80], [0.85, 0.85, 0.85]], dtype=np.float32)
AMBIENT, DIFFUSE = 0.1, 0.9  # both renderers: no specular, so the shading terms line up


def spheres(count, seed=7):
    """One sphere per cell of an n³ grid over [-0.5, 0.5]³ (n³ ≥ count, the first `count` cells in a
    shuffled order), radius 0.35 cell, centre jittered so that no two spheres overlap."""
    n = math.ceil(round(count ** (1 / 3), 6))
    rng = np.random.default_rng(seed)
    cells = rng.permutation(n ** 3)[:count]
    ijk = np.stack([cells % n, (cells // n) % n, cells // (n * n)], axis=1).astype(np.float32)
    cell = 1.0 / n
    radius = 0.35 * cell
    jitter = rng.uniform(-1, 1, size=(count, 3)).astype(np.float32) * (0.5 * cell - radius)
    centres = -0.5 + (ijk + 0.5) * cell + jitter
    colour_index = rng.integers(0, len(PALETTE), size=count)
    return centres.astype(np.float32), np.float32(radius), colour_index


def commit():
    try:
        return subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def machine():
    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores"


def read_ppm(path):
    """An 8-bit binary PPM (Tachyon's output) as (H, W, 4) uint8 RGBA, alpha 255."""
    with open(path, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:  # magic, width, height, maxval; whitespace-separated, '#' comments
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    w, h = int(fields[1]), int(fields[2])
    rgb = np.frombuffer(data, np.uint8, w * h * 3, pos + 1).reshape(h, w, 3)
    return np.concatenate([rgb, np.full((h, w, 1), 255, np.uint8)], axis=2)


def write_png(path, rgba8, penumbra=None):
    if penumbra is None:
        import penumbra  # noqa: F811  (the build's module, on sys.path by then)
    with open(path, "wb") as f:
        f.write(penumbra._png(rgba8))


# ---------------------------------------------------------------- Tachyon

def tachyon_scene(path, centres, radius, colour_index):
    """Tachyon's .dat scene: the same camera (Tachyon's ZOOM 1 spans a vertical half-height of 1/2 at
    distance 1, so zoom = 0.5 / tan(fov_y / 2)), the directional light and one texture per palette
    colour (Tachyon shades the colours as given and writes them unencoded: penumbra gets them as
    sRGB bytes, so both show the same colours)."""
    view = np.subtract(TARGET, EYE)
    view = view / np.linalg.norm(view)
    up = np.subtract(UP, np.dot(UP, view) * view)  # Tachyon takes UPDIR as given: orthogonal to VIEWDIR
    up = up / np.linalg.norm(up)
    zoom = 0.5 / math.tan(math.radians(FOV_DEG) / 2)
    with open(path, "w") as f:
        f.write(f"BEGIN_SCENE\nRESOLUTION {WIDTH} {HEIGHT}\n")
        f.write(f"CAMERA\n ZOOM {zoom:.6f}\n ASPECTRATIO 1.0\n ANTIALIASING 0\n RAYDEPTH 4\n")
        f.write(" CENTER {:.6f} {:.6f} {:.6f}\n VIEWDIR {:.6f} {:.6f} {:.6f}\n UPDIR {:.6f} {:.6f} {:.6f}\nEND_CAMERA\n".format(*EYE, *view, *up))
        f.write("BACKGROUND 1 1 1\n")
        f.write("DIRECTIONAL_LIGHT DIRECTION {:.6f} {:.6f} {:.6f} COLOR 1 1 1\n".format(*LIGHT))
        for k, c in enumerate(PALETTE):
            f.write(f"TEXDEF c{k} AMBIENT {AMBIENT} DIFFUSE {DIFFUSE} SPECULAR 0 OPACITY 1 COLOR {c[0]:.4f} {c[1]:.4f} {c[2]:.4f} TEXFUNC 0\n")
        lines = [f"SPHERE CENTER {x:.6f} {y:.6f} {z:.6f} RAD {radius:.6f} c{k}\n" for (x, y, z), k in zip(centres.tolist(), colour_index.tolist())]
        f.writelines(lines)
        f.write("END_SCENE\n")


def run_tachyon(scene, image, extra):
    """Runs Tachyon once; returns its own parse, preprocessing (grid) and ray-tracing times in ms."""
    out = subprocess.run(["tachyon", scene, "-fullshade", "-format", "PPM", "-o", image, *extra], capture_output=True, text=True, check=True).stdout

    def seconds(label):
        m = re.search(label + r":\s*([0-9.]+) seconds", out)
        return 1000 * float(m.group(1)) if m else float("nan")

    return {"parse_ms": seconds("Scene Parsing Time"), "grid_ms": seconds("Preprocessing Time"), "trace_ms": seconds("Ray Tracing Time")}


def tachyon_runs(scene_path, tmp, repeats, out):
    result = {}
    for name, extra in (("shadows", []), ("ao", ["-auto_skylight", "0.7", "-skylight_samples", "12"])):
        image = os.path.join(tmp, f"tachyon_{name}.ppm")
        runs = [run_tachyon(scene_path, image, extra) for _ in range(repeats)]
        write_png(os.path.join(out, f"tachyon_{name}.png"), read_ppm(image))
        result[name] = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        print(f"tachyon {name}: {result[name]}", file=sys.stderr)
    return result


# ---------------------------------------------------------------- penumbra

def penumbra_scene(penumbra, centres, radius, colour_index, shadows, ambient, width, height):
    doc = {
        "camera": {"eye": list(EYE), "target": list(TARGET), "up": list(UP), "fov_deg": FOV_DEG, "width": width, "height": height},
        "lights": [{"type": "directional", "direction": list(LIGHT)}],
        "shading": {"ambient": AMBIENT, "diffuse": DIFFUSE, "specular": 0},
        "background": [1, 1, 1],
        "shadows": shadows,
        "ambient": ambient,
    }
    scene = penumbra.Scene(doc)
    scene.add_particles(centres, radii=radius, colors=np.round(PALETTE[colour_index] * 255).astype(np.uint8))
    return scene


def turned(v, angle):
    c, s = math.cos(angle), math.sin(angle)
    return [c * v[0] - s * v[2], v[1], s * v[0] + c * v[2]]


def penumbra_runs(penumbra, scene, repeats, image_path):
    """Frame times (engine's total, ms): first frame, light moving (map rebuilt), cached; with the split."""
    r = penumbra.Renderer(scene)
    t = time.perf_counter()
    write_png(image_path, r.render(accumulate=False), penumbra)
    first = dict(r.stats["timings_ms"], wall=1000 * (time.perf_counter() - t))
    moving, cached = [], []
    for k in range(1, repeats + 1):
        r.set("lights.0.direction", turned(LIGHT, 0.01 * k))
        r.render(accumulate=False)
        moving.append(r.stats["timings_ms"])
        r.render(accumulate=False)
        cached.append(r.stats["timings_ms"])
    med = lambda runs: {k: statistics.median(x[k] for x in runs) for k in runs[0]}
    return {"first": first, "moving": med(moving), "cached": med(cached)}


def error(a, b):
    d = a.astype(np.float64) / 255.0 - b.astype(np.float64) / 255.0
    rmse = float(np.sqrt(np.mean(d[..., :3] ** 2)))
    return {"rmse": rmse, "psnr_db": float("inf") if rmse == 0 else 20 * math.log10(1 / rmse)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--spheres", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--reference-width", type=int, default=640)
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "bench-peers"))
    ap.add_argument("--quick", action="store_true", help="50 k spheres, one repeat: checks the script")
    ap.add_argument("--penumbra-only", action="store_true", help="skip the peers (before/after figures of a change)")
    a = ap.parse_args()
    if a.quick:
        a.spheres, a.repeats = 50_000, 1
    sys.path.insert(0, os.path.join(a.build, "python"))
    import penumbra  # noqa: E402  (the build's module)

    os.makedirs(a.out, exist_ok=True)
    centres, radius, colour_index = spheres(a.spheres)
    report = {"commit": commit(), "machine": machine(), "date": time.strftime("%Y-%m-%d"), "spheres": a.spheres,
              "frame": f"{WIDTH}x{HEIGHT}", "tachyon": None, "penumbra": {}, "error": {}}
    with tempfile.TemporaryDirectory() as tmp:
        scene_path = os.path.join(tmp, "spheres.dat")
        if shutil.which("tachyon") and not a.penumbra_only:
            tachyon_scene(scene_path, centres, radius, colour_index)
            report["tachyon"] = tachyon_runs(scene_path, tmp, a.repeats, a.out)

    issm = {"technique": "issm"}
    configs = {"issm": (issm, {"technique": "none"}),
               "issm + particle_ao": (issm, {"technique": "particle_ao"})}
    for name, (shadows, ambient) in configs.items():
        scene = penumbra_scene(penumbra, centres, radius, colour_index, shadows, ambient, WIDTH, HEIGHT)
        report["penumbra"][name] = penumbra_runs(penumbra, scene, a.repeats, os.path.join(a.out, "penumbra_" + name.replace(" + ", "_") + ".png"))
        print(f"penumbra {name}: {report['penumbra'][name]}", file=sys.stderr)

    # error against the exact references at a reduced frame
    rw = a.reference_width
    rh = round(rw * HEIGHT / WIDTH)
    references = {"issm": ({"technique": "ray_traced"}, {"technique": "none"}),
                  "issm + particle_ao": ({"technique": "ray_traced"}, {"technique": "ray_traced_ao", "rays": 64})}
    for name, (shadows, ambient) in configs.items():
        img = penumbra.Renderer(penumbra_scene(penumbra, centres, radius, colour_index, shadows, ambient, rw, rh)).render(accumulate=False)
        ref_s, ref_a = references[name]
        ref = penumbra.Renderer(penumbra_scene(penumbra, centres, radius, colour_index, ref_s, ref_a, rw, rh)).render(accumulate=False)
        report["error"][name] = dict(error(img, ref), frame=f"{rw}x{rh}")
        print(f"error {name}: {report['error'][name]}", file=sys.stderr)

    with open(os.path.join(a.out, "peers.json"), "w") as f:
        json.dump(report, f, indent=1)
    md = table(report)
    with open(os.path.join(a.out, "peers.md"), "w") as f:
        f.write(md)
    print(md)


def table(r):
    t = r["tachyon"]
    lines = [f"{r['spheres']:,} spheres, {r['frame']}, one sample per pixel; commit {r['commit']}, {r['date']}, {r['machine']}.", "",
             "| renderer | frame ms, light moving | frame ms, cached | ratio to Tachyon (moving / cached) | error vs exact reference |",
             "|---|---:|---:|---:|---|"]
    for name, tname in (("issm", "shadows"), ("issm + particle_ao", "ao")):
        p = r["penumbra"][name]
        e = r["error"][name]
        if t:
            tt = t[tname]["trace_ms"]
            lines.append(f"| Tachyon -fullshade{' + AO (12 samples)' if tname == 'ao' else ''} | {tt:.0f} (parse {t[tname]['parse_ms']:.0f}, grid {t[tname]['grid_ms']:.0f}) | {tt:.0f} | 1 | – |")
            ratio = f"{tt / p['moving']['total']:.2f}× / {tt / p['cached']['total']:.2f}×"
        else:
            lines.append(f"| Tachyon ({tname}) | not run (not installed, or --penumbra-only) | | | |")
            ratio = "–"
        lines.append(f"| penumbra {name} | {p['moving']['total']:.0f} | {p['cached']['total']:.0f} | {ratio} | RMSE {e['rmse']:.4f}, {e['psnr_db']:.1f} dB at {e['frame']} |")
    lines.append("")
    lines.append("Split of penumbra's cached frame (ms): " + "; ".join(
        f"{name}: hits {p['cached']['hits']:.0f}, render {p['cached']['render']:.0f}, build {p['moving']['build']:.0f} (moving), ambient {p['first']['ambient']:.0f} (first)"
        for name, p in r["penumbra"].items()))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
