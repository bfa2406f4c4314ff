#!/usr/bin/env python3
"""penumbra side by side with its peers on this machine, for docs/BENCHMARKS.md (issue 17).

usage: scripts/bench_peers.py [--build build/release] [--suite spheres volumes] [--spheres N] [--repeats N]
                              [--volume blobs|marschner-lobb] [--paraview all|ray-cast] [--out DIR] [--penumbra-only]
                              [--quick]

Spheres against Tachyon (VMD's ray tracer, the ISSM paper's reference; Debian `tachyon`): N
non-overlapping spheres (one per cell of a jittered grid, 1 M by default) at 1920×1200, one sample per
pixel, one directional light. Tachyon renders with shadows (`-fullshade`) and with ambient occlusion
(`-fullshade -auto_skylight 0.7 -skylight_samples 12`); its own "Ray Tracing Time" excludes parsing
and its grid build, which are reported beside it. penumbra renders `issm` and `issm` + `particle_ao`
through its Python module, the frame timed by the engine (no conversion to bytes): once with the
light moving (the shadow map rebuilt each frame, after two untimed moves that warm the allocator) and
once with it cached. Each penumbra frame's error
(RMSE, PSNR) is measured against penumbra's exact reference (ray-traced shadows; ray-traced AO with 64
rays) at a reduced frame, since the reference takes minutes at full size.

Volumes against ParaView (Debian `paraview`; `pvbatch` under `xvfb-run` when there is no display): a
256³ float field of blobs in a shell, 512² frame, the same camera and transfer function, gradient
shading; ParaView's CPU ray cast mapper ("Ray Cast Only") against penumbra unshadowed, and its GPU
mapper with volumetric shadows (VolumetricScatteringBlending 2, under Mesa's llvmpipe here) against
penumbra with cssm shadows. `--volume marschner-lobb` takes Marschner and Lobb's signal at 256³ uint8
instead (the transfer function's values scaled to 0-255). `--suite spheres` or `--suite volumes` runs
one half.

Without `tachyon` on the PATH the Tachyon rows say "not run" and the rest still runs; the
script never fails for a missing peer (pvbatch likewise). It writes DIR/peers.json and DIR/peers.md
(the table with the commit and the machine) and prints the table.
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
    sRGB bytes, so both show the same colours). Tachyon's camera is left-handed (its image is the
    mirror of a right-handed camera's), so the scene is written mirrored in x: the pictures then match."""
    def mirror(v):
        return (-v[0], v[1], v[2])

    view = np.subtract(TARGET, EYE)
    view = view / np.linalg.norm(view)
    up = np.subtract(UP, np.dot(UP, view) * view)  # Tachyon takes UPDIR as given: orthogonal to VIEWDIR
    up = up / np.linalg.norm(up)
    zoom = 0.5 / math.tan(math.radians(FOV_DEG) / 2)
    with open(path, "w") as f:
        f.write(f"BEGIN_SCENE\nRESOLUTION {WIDTH} {HEIGHT}\n")
        f.write(f"CAMERA\n ZOOM {zoom:.6f}\n ASPECTRATIO 1.0\n ANTIALIASING 0\n RAYDEPTH 4\n")
        f.write(" CENTER {:.6f} {:.6f} {:.6f}\n VIEWDIR {:.6f} {:.6f} {:.6f}\n UPDIR {:.6f} {:.6f} {:.6f}\nEND_CAMERA\n".format(
            *mirror(EYE), *mirror(view), *mirror(up)))
        f.write("BACKGROUND 1 1 1\n")
        f.write("DIRECTIONAL_LIGHT DIRECTION {:.6f} {:.6f} {:.6f} COLOR 1 1 1\n".format(*mirror(LIGHT)))
        for k, c in enumerate(PALETTE):
            f.write(f"TEXDEF c{k} AMBIENT {AMBIENT} DIFFUSE {DIFFUSE} SPECULAR 0 OPACITY 1 COLOR {c[0]:.4f} {c[1]:.4f} {c[2]:.4f} TEXFUNC 0\n")
        lines = [f"SPHERE CENTER {-x:.6f} {y:.6f} {z:.6f} RAD {radius:.6f} c{k}\n" for (x, y, z), k in zip(centres.tolist(), colour_index.tolist())]
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
    # Two light moves before timing: the first rebuilt maps allocate their arrays and fault their pages
    # in (the moving frame's ISSM build 94-99 ms, then 62-73 ms steady), as a user's first drag does.
    for k in range(1, 3):
        r.set("lights.0.direction", turned(LIGHT, -0.01 * k))
        r.render(accumulate=False)
    moving, cached, camera = [], [], []
    for k in range(1, repeats + 1):
        r.set("lights.0.direction", turned(LIGHT, 0.01 * k))
        r.render(accumulate=False)
        moving.append(r.stats["timings_ms"])
        r.render(accumulate=False)
        cached.append(r.stats["timings_ms"])
    # the camera moving, the light still: each pixel's sphere found and shaded anew, the map kept
    for k in range(1, repeats + 1):
        r.set("camera.eye", turned(EYE, 0.01 * k))
        r.render(accumulate=False)
        camera.append(r.stats["timings_ms"])
    med = lambda runs: {k: statistics.median(x[k] for x in runs) for k in runs[0]}
    return {"first": first, "moving": med(moving), "cached": med(cached), "camera": med(camera)}


# ---------------------------------------------------------------- volumes: ParaView

VOLUME_N = 256
VOLUME_FRAME = 512
# value, r, g, b, alpha (alpha per unit of distance in voxels, as ParaView's scalar opacity unit distance 1)
VOLUME_TF = [[0.0, 0.9, 0.5, 0.3, 0.0], [0.25, 0.9, 0.5, 0.3, 0.0], [0.45, 0.95, 0.8, 0.6, 0.05], [1.0, 1.0, 1.0, 1.0, 0.4]]


def volume_field(n=VOLUME_N, seed=3):
    """A smooth n³ float32 field in [0, 1]: twelve Gaussian blobs of random size and strength, with a
    shell around the centre (surfaces to shade, gaps for light to pass)."""
    rng = np.random.default_rng(seed)
    x = (np.arange(n, dtype=np.float32) + 0.5) / n - 0.5
    z, y, xx = np.meshgrid(x, x, x, indexing="ij")
    f = np.zeros((n, n, n), np.float32)
    for _ in range(12):
        c = rng.uniform(-0.3, 0.3, 3).astype(np.float32)
        s = np.float32(rng.uniform(0.04, 0.12))
        f += np.float32(rng.uniform(0.5, 1.0)) * np.exp(-((xx - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / (2 * s * s))
    r = np.sqrt(xx ** 2 + y ** 2 + z ** 2)
    f += 0.6 * np.exp(-((r - 0.42) / 0.02) ** 2)
    return np.clip(f, 0, 1).astype(np.float32)


def marschner_lobb_field(n=VOLUME_N, alpha=0.25, fm=6.0):
    """Marschner and Lobb's test signal (1994) on [-1, 1]³ at n³, quantised to uint8 (0-255), z the axis
    of its sine: the issue's "Marschner–Lobb 256³ uint8" row."""
    t = np.linspace(-1, 1, n, dtype=np.float64)
    z, y, x = np.meshgrid(t, t, t, indexing="ij")
    rho_r = np.cos(2 * np.pi * fm * np.cos(np.pi * np.sqrt(x * x + y * y) / 2))
    f = (1 - np.sin(np.pi * z / 2) + alpha * (1 + rho_r)) / (2 * (1 + alpha))
    return np.clip(np.rint(255 * f), 0, 255).astype(np.uint8)


def volume_input(kind, n):
    """The field, its transfer function's points in data units, and ParaView's name for its type."""
    if kind == "marschner-lobb":
        return marschner_lobb_field(n), [[255 * p[0], *p[1:]] for p in VOLUME_TF], "unsigned char"
    return volume_field(n), VOLUME_TF, "float"


# the eye's distance in volume edges: the blobs lie in a ball, Marschner-Lobb fills its cube (seen whole)
CAMERA_DISTANCE = {"blobs": 1.9, "marschner-lobb": 3.3}


def volume_camera(n=VOLUME_N, distance=1.9):
    centre = [(n - 1) / 2] * 3
    eye = [centre[0] + distance * n * 0.55, centre[1] + distance * n * 0.35, centre[2] + distance * n * 0.75]
    return eye, centre, [0.0, 1.0, 0.0]


PV_SCRIPT = r"""
import json, statistics, sys, time
from paraview.simple import *
cfg = json.loads(sys.argv[1])
n = cfg["n"]
reader = ImageReader(FileNames=[cfg["raw"]], DataScalarType=cfg["type"], DataByteOrder="LittleEndian",
                     DataExtent=[0, n - 1, 0, n - 1, 0, n - 1])
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [cfg["frame"], cfg["frame"]]
view.OrientationAxesVisibility = 0
view.Background = [1, 1, 1]
if hasattr(view, "UseColorPaletteForBackground"):
    view.UseColorPaletteForBackground = 0
shown = Show(reader, view)
shown.SetRepresentationType("Volume")
array = reader.PointData.keys()[0]
ColorBy(shown, ("POINTS", array))
ctf = GetColorTransferFunction(array)
ctf.RGBPoints = [v for p in cfg["tf"] for v in (p[0], p[1], p[2], p[3])]
otf = GetOpacityTransferFunction(array)
otf.Points = [v for p in cfg["tf"] for v in (p[0], p[4], 0.5, 0.0)]
shown.ScalarOpacityUnitDistance = 1.0
shown.Shade = 1
shown.VolumeRenderingMode = cfg["mode"]
if cfg["shadows"]:
    shown.VolumetricScatteringBlending = 2.0
    shown.GlobalIlluminationReach = 0.5
view.CameraPosition, view.CameraFocalPoint, view.CameraViewUp = cfg["eye"], cfg["target"], cfg["up"]
view.CameraViewAngle = cfg["fov"]
t = time.perf_counter(); Render(view); first = 1000 * (time.perf_counter() - t)
times = []
for k in range(cfg["repeats"]):
    view.CameraPosition = [cfg["eye"][0], cfg["eye"][1] + 1e-3 * (k + 1), cfg["eye"][2]]  # a new frame each time
    t = time.perf_counter(); Render(view); times.append(1000 * (time.perf_counter() - t))
SaveScreenshot(cfg["png"], view)
print("PENUMBRA_BENCH " + json.dumps({"first_ms": first, "frame_ms": statistics.median(times)}))
"""


def paraview_runs(tmp, out, raw, n, tf, scalar_type, distance, repeats, modes, timeout_s=900):
    """ParaView's CPU ray cast ("Ray Cast Only") and its GPU mapper with volumetric shadows (under
    llvmpipe here): frame times in ms, or None without pvbatch (or without a display or xvfb-run)."""
    if not shutil.which("pvbatch"):
        return None
    command = ["pvbatch"]
    if not os.environ.get("DISPLAY"):
        if not shutil.which("xvfb-run"):
            print("paraview: pvbatch needs a display; install xvfb (xvfb-run) to measure it", file=sys.stderr)
            return None
        command = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "pvbatch"]
    script = os.path.join(tmp, "pv_bench.py")
    with open(script, "w") as f:
        f.write(PV_SCRIPT)
    eye, target, up = volume_camera(n, distance)
    result = {}
    for name, mode, shadows in (("ray cast", "Ray Cast Only", False), ("GPU + volumetric shadows", "GPU Based", True)):
        if modes == "ray-cast" and shadows:
            continue
        cfg = {"n": n, "raw": raw, "type": scalar_type, "frame": VOLUME_FRAME, "tf": tf, "mode": mode, "shadows": shadows,
               "eye": eye, "target": target, "up": up, "fov": FOV_DEG, "repeats": repeats,
               "png": os.path.join(out, "paraview_" + name.replace(" + ", "_").replace(" ", "_") + ".png")}
        try:
            run = subprocess.run(command + [script, json.dumps(cfg)], capture_output=True, text=True, timeout=timeout_s)
        except subprocess.TimeoutExpired:
            print(f"paraview {name}: no result within {timeout_s} s", file=sys.stderr)
            result[name] = {"timed_out_s": timeout_s}
            continue
        line = next((l for l in run.stdout.splitlines() if l.startswith("PENUMBRA_BENCH ")), None)
        if line is None:
            print(f"paraview {name}: failed\n{run.stderr[-2000:]}", file=sys.stderr)
            continue
        result[name] = json.loads(line.split(" ", 1)[1])
        print(f"paraview {name}: {result[name]}", file=sys.stderr)
    return result


def penumbra_volume_runs(penumbra, field, tf, distance, repeats, out):
    eye, target, up = volume_camera(field.shape[0], distance)
    result = {}
    for name, technique in (("unshadowed", "none"), ("cssm shadows", "cssm")):
        doc = {"camera": {"eye": eye, "target": target, "up": up, "fov_deg": FOV_DEG, "width": VOLUME_FRAME, "height": VOLUME_FRAME},
               "lights": [{"type": "directional", "direction": [-0.5, -0.7, -0.5]}], "background": [1, 1, 1],
               "shadows": {"technique": technique}}
        scene = penumbra.Scene(doc)
        scene.add_volume(field, transfer_function={"points": tf})
        r = penumbra.Renderer(scene)
        write_png(os.path.join(out, "penumbra_volume_" + name.replace(" ", "_") + ".png"), r.render(accumulate=False), penumbra)
        first = r.stats["timings_ms"]["total"]
        times = []
        for k in range(repeats):
            r.set("camera.eye", [eye[0], eye[1] + 1e-3 * (k + 1), eye[2]])
            r.render(accumulate=False)
            times.append(r.stats["timings_ms"]["total"])
        result[name] = {"first_ms": first, "frame_ms": statistics.median(times)}
        print(f"penumbra volume {name}: {result[name]}", file=sys.stderr)
    return result


def error(a, b):
    d = a.astype(np.float64) / 255.0 - b.astype(np.float64) / 255.0
    rmse = float(np.sqrt(np.mean(d[..., :3] ** 2)))
    return {"rmse": rmse, "psnr_db": float("inf") if rmse == 0 else 20 * math.log10(1 / rmse)}


def run_spheres(a, penumbra, report):
    centres, radius, colour_index = spheres(a.spheres)
    report.update({"spheres": a.spheres, "frame": f"{WIDTH}x{HEIGHT}", "tachyon": None, "penumbra": {}, "error": {}})
    with tempfile.TemporaryDirectory() as tmp:
        scene_path = os.path.join(tmp, "spheres.dat")
        if shutil.which("tachyon") and not a.penumbra_only:
            tachyon_scene(scene_path, centres, radius, colour_index)
            report["tachyon"] = tachyon_runs(scene_path, tmp, a.repeats, a.out)

    issm = {"technique": "issm"}
    configs = {"issm": (issm, {"technique": "none"}),
               "issm + particle_ao": (issm, {"technique": "particle_ao"})}
    # local lighting: what a light move costs beside (issue 42: the ISSM rebuilt per frame ≤ 1.25× it)
    for name, (shadows, ambient) in dict(configs, **{"local lighting": ({"technique": "none"}, {"technique": "none"})}).items():
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


def run_volumes(a, penumbra, report):
    # volumes beside ParaView
    field, tf, scalar_type = volume_input(a.volume, 64 if a.quick else VOLUME_N)
    report["volume"] = {"field": a.volume, "dims": list(field.shape), "type": str(field.dtype), "frame": f"{VOLUME_FRAME}x{VOLUME_FRAME}",
                        "penumbra": penumbra_volume_runs(penumbra, field, tf, CAMERA_DISTANCE[a.volume], a.repeats, a.out), "paraview": None}
    if not a.penumbra_only and not a.quick:
        with tempfile.TemporaryDirectory() as tmp:
            raw = os.path.join(tmp, "volume.raw")
            field.astype(field.dtype.newbyteorder("<")).tofile(raw)
            report["volume"]["paraview"] = paraview_runs(tmp, a.out, raw, field.shape[0], tf, scalar_type, CAMERA_DISTANCE[a.volume], a.repeats,
                                                         a.paraview)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--spheres", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--reference-width", type=int, default=640)
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "bench-peers"))
    ap.add_argument("--quick", action="store_true", help="50 k spheres, one repeat: checks the script")
    ap.add_argument("--penumbra-only", action="store_true", help="skip the peers (before/after figures of a change)")
    ap.add_argument("--suite", nargs="+", choices=["spheres", "volumes"], default=["spheres", "volumes"])
    ap.add_argument("--volume", choices=["blobs", "marschner-lobb"], default="blobs",
                    help="the volume suite's field: 256³ float blobs in a shell, or Marschner-Lobb 256³ uint8")
    ap.add_argument("--paraview", choices=["all", "ray-cast"], default="all",
                    help="ParaView's mappers: both, or the CPU ray cast only (its GPU mapper under llvmpipe takes minutes a frame)")
    a = ap.parse_args()
    if a.quick:
        a.spheres, a.repeats = 50_000, 1
    sys.path.insert(0, os.path.join(a.build, "python"))
    import penumbra  # noqa: E402  (the build's module)

    os.makedirs(a.out, exist_ok=True)
    report = {"commit": commit(), "machine": machine(), "date": time.strftime("%Y-%m-%d")}
    if "spheres" in a.suite:
        run_spheres(a, penumbra, report)
    if "volumes" in a.suite:
        run_volumes(a, penumbra, report)

    with open(os.path.join(a.out, "peers.json"), "w") as f:
        json.dump(report, f, indent=1)
    md = table(report)
    with open(os.path.join(a.out, "peers.md"), "w") as f:
        f.write(md)
    print(md)


def table(r):
    lines = [f"Commit {r['commit']}, {r['date']}, {r['machine']}."]
    if "spheres" in r:
        lines += sphere_table(r)
    if "volume" in r:
        lines += volume_table(r["volume"])
    return "\n".join(lines) + "\n"


def sphere_table(r):
    t = r["tachyon"]
    lines = ["", f"{r['spheres']:,} spheres, {r['frame']}, one sample per pixel:", "",
             "| renderer | frame ms, light moving | frame ms, camera moving | frame ms, cached | ratio to Tachyon (light moving / camera moving / cached) | error vs exact reference |",
             "|---|---:|---:|---:|---:|---|"]
    for name, tname in (("issm", "shadows"), ("issm + particle_ao", "ao")):
        p = r["penumbra"][name]
        e = r["error"][name]
        if t:
            tt = t[tname]["trace_ms"]
            lines.append(f"| Tachyon -fullshade{' + AO (12 samples)' if tname == 'ao' else ''} | {tt:.0f} (parse {t[tname]['parse_ms']:.0f}, grid {t[tname]['grid_ms']:.0f}) | {tt:.0f} | {tt:.0f} | 1 | – |")
            ratio = f"{tt / p['moving']['total']:.2f}× / {tt / p['camera']['total']:.2f}× / {tt / p['cached']['total']:.2f}×"
        else:
            lines.append(f"| Tachyon ({tname}) | not run (not installed, or --penumbra-only) | | | | |")
            ratio = "–"
        lines.append(f"| penumbra {name} | {p['moving']['total']:.0f} | {p['camera']['total']:.0f} | {p['cached']['total']:.0f} | {ratio} | RMSE {e['rmse']:.4f}, {e['psnr_db']:.1f} dB at {e['frame']} |")
    if "local lighting" in r["penumbra"]:
        local = r["penumbra"]["local lighting"]["moving"]["total"]
        lines += ["", f"Light moving against local lighting (the ISSM rebuilt every frame): issm "
                      f"{r['penumbra']['issm']['moving']['total']:.0f} ms / local lighting {local:.0f} ms = "
                      f"{r['penumbra']['issm']['moving']['total'] / local:.2f}×"]
    lines += ["", "Split of penumbra's frames (ms): " + "; ".join(
        f"{name}: hits {p['camera']['hits']:.0f} (camera moving), render {p['cached']['render']:.0f}, build {p['moving']['build']:.0f} (light moving), ambient {p['first']['ambient']:.0f} (first)"
        for name, p in r["penumbra"].items())]
    return lines


def volume_table(v):
    lines = ["", f"Volume {v.get('field', 'blobs')} {'×'.join(map(str, v['dims']))} {v.get('type', 'float32')}, {v['frame']}, gradient-shaded, "
                 "one directional light (ms per frame, camera moving):", "",
             "| renderer | frame ms | penumbra's speed-up |", "|---|---:|---:|"]
    p = v["penumbra"]
    for name, pv_name, mine in (("ParaView ray cast (CPU, Ray Cast Only)", "ray cast", "unshadowed"),
                                ("ParaView GPU mapper + volumetric shadows (llvmpipe)", "GPU + volumetric shadows", "cssm shadows")):
        pv = (v["paraview"] or {}).get(pv_name)
        if pv and "frame_ms" in pv:
            lines.append(f"| {name} | {pv['frame_ms']:.0f} | {pv['frame_ms'] / p[mine]['frame_ms']:.1f}× (against penumbra {mine}) |")
        elif pv:
            lines.append(f"| {name} | no frame within {pv['timed_out_s']} s | |")
        else:
            lines.append(f"| {name} | not run (no pvbatch, --penumbra-only or --paraview ray-cast) | |")
    for name in p:
        lines.append(f"| penumbra {name} | {p[name]['frame_ms']:.0f} | |")
    return lines


if __name__ == "__main__":
    main()
