#!/usr/bin/env python3
"""Edit-to-image latency of penumbra's interactive engine, for docs/BENCHMARKS.md.

usage: scripts/bench_engine.py PENUMBRA [SCENE ...]

For each scene a scripted session is written and replayed with `penumbra render --edits` (what the
viewer does: each edit, a preview, then the full-quality frame). The session is built from the scene
itself, so any scene works: camera moves (camera.direction turning), a light drag (the first light's
direction or position turning), transfer-function edits (the first visible volume's opacity_scale),
isovalue edits (the first isosurface's value), selection edits (the first particle file's `select`
cycling through SELECTIONS), technique switches (shadows.technique to another
technique that takes the scene's casters, and back), and one cancelled full frame. The table gives,
per edit type, the median and 95th percentile of the time from the edit to its first preview and to
its full-quality frame. Then, for the first scene with a cssm volume, the PSNR of accumulated
frames against the ray_traced reference.
"""
import json, math, os, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STEPS = 8  # edits per type
# NAME or NAME:WxH (the viewport)
DEFAULT_SCENES = ["cranium.json", "1aon.json:1920x1200", "ct-body.json", "ct-implants.json"]
# particles[].select edits, in turn (1AON: GroEL chains A-N, GroES O-U, ADP and Mg ions)
SELECTIONS = ["protein", "chainID A B C D E F G", "around 6 resname ADP", "backbone", "all", "resid 1:300",
              "byres around 4 chainID O", "not name C*"]
ALTERNATIVE = {"cssm": "shadow_map", "shadow_map": "cssm", "deep_shadow_map": "cssm", "issm": "ray_traced",
               "light_pass": "ray_traced", "ray_traced": "shadow_map", "sat_cone": "cssm", "none": "shadow_map"}


def turned(v, angle):  # v rotated about the y axis
    c, s = math.cos(angle), math.sin(angle)
    return [v[0] * c + v[2] * s, v[1], -v[0] * s + v[2] * c]


def session(scene):
    steps = []  # (type, step)
    cam = scene.get("camera", {})
    direction = cam.get("direction", [1.0, 0.55, 1.3])
    key = "camera.eye" if "eye" in cam else "camera.direction"
    base = cam.get("eye", direction)
    up = cam.get("up", [0, 1, 0])
    for i in range(1, STEPS + 1):
        a = 0.04 * i
        v = turned(base, a) if up[1] else [base[0] * math.cos(a) - base[1] * math.sin(a), base[0] * math.sin(a) + base[1] * math.cos(a), base[2]]
        steps.append(("camera", {"set": {key: v}}))
    light = (scene.get("lights") or [{"type": "directional", "direction": [-0.4, -1.0, -0.3]}])[0]
    for i in range(1, STEPS + 1):
        if light.get("type", "directional") == "point":
            steps.append(("light drag", {"set": {"lights.0.position": turned(light["position"], 0.05 * i)}}))
        else:
            steps.append(("light drag", {"set": {"lights.0.direction": turned(light.get("direction", [-0.4, -1.0, -0.3]), 0.05 * i)}}))
    for vi, v in enumerate(scene.get("volumes", [])):
        if v.get("visible", True) and isinstance(v.get("transfer_function"), dict) and "preset" in v["transfer_function"]:
            for i in range(1, STEPS + 1):
                steps.append(("transfer function", {"set": {f"volumes.{vi}.transfer_function.opacity_scale": 1.0 + 0.05 * (i % 4 + 1) * (-1) ** i}}))
            break
    if scene.get("isosurfaces"):
        value = scene["isosurfaces"][0]["value"]
        for i in range(1, STEPS + 1):
            steps.append(("isovalue", {"set": {"isosurfaces.0.value": value * (1 + 0.01 * i * (-1) ** i)}}))
    for pi, p in enumerate(scene.get("particles", [])):
        if "file" in p and "trajectory" not in p:
            for i in range(STEPS):
                steps.append(("selection", {"set": {f"particles.{pi}.select": SELECTIONS[i % len(SELECTIONS)]}}))
            break
    technique = scene.get("shadows", {}).get("technique", "none")
    other = ALTERNATIVE.get(technique, "shadow_map")
    if scene.get("particles") and not scene.get("volumes") and technique == "issm":
        other = "ray_traced"
    for i in range(STEPS // 2):
        steps.append(("technique switch", {"set": {"shadows.technique": other}}))
        steps.append(("technique switch", {"set": {"shadows.technique": technique}}))
    steps.append(("cancel", {"set": {"shadows.seed": 7}, "cancel_after_ms": 50}))
    return steps


def percentile(xs, p):
    xs = sorted(xs)
    k = (len(xs) - 1) * p / 100
    lo, hi = math.floor(k), math.ceil(k)
    return xs[lo] + (xs[hi] - xs[lo]) * (k - lo)


def run_session(binary, scene_file, size, d):
    scene = json.load(open(scene_file))
    steps = session(scene)
    edits = os.path.join(d, "edits.json")
    json.dump([s for _, s in steps], open(edits, "w"))
    stats = os.path.join(d, "stats.json")
    viewport = ["--width", str(size[0]), "--height", str(size[1])] if size else []
    subprocess.run([binary, "render", scene_file, "-o", os.path.join(d, "last.png"), "--edits", edits, "--stats", stats] + viewport,
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    s = json.load(open(stats))
    by_type = {}
    for (kind, _), e in zip(steps, s["edits"]):
        by_type.setdefault(kind, []).append(e)
    return s, by_type


def accumulation_psnr(binary, scene_file, size=256, samples=(1, 4, 16, 64), reference_samples=64):
    """PSNR of cssm after k accumulated samples against ray_traced averaged over as many samples (the
    same jitter average: what is left is cssm's own error)."""
    rows = []
    with tempfile.TemporaryDirectory() as d:
        common = ["--width", str(size), "--height", str(size)]
        ref = os.path.join(d, "ref.pfm")
        subprocess.run([binary, "render", scene_file, "-o", ref, "--set", "shadows.technique=ray_traced",
                        "--accumulate", str(reference_samples)] + common, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for k in samples:
            img = os.path.join(d, f"cssm{k}.pfm")
            subprocess.run([binary, "render", scene_file, "-o", img, "--set", "shadows.technique=cssm", "--accumulate", str(k)] + common,
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            out = subprocess.run([binary, "compare", img, ref], check=True, capture_output=True, text=True).stdout
            rows.append((k, out.strip().replace("\n", ", ")))
    return rows


def main():
    binary = sys.argv[1]
    scenes = sys.argv[2:] or DEFAULT_SCENES
    print("| scene | edit | n | preview median / p95 ms | full median / p95 ms | rebuilt (first step) |")
    print("|---|---|---:|---:|---:|---|")
    for spec in scenes:
        name, _, wh = spec.partition(":")
        size = tuple(int(x) for x in wh.split("x")) if wh else None
        path = name if os.path.exists(name) else os.path.join(ROOT, "scenes", name)
        with tempfile.TemporaryDirectory() as d:
            s, by_type = run_session(binary, path, size, d)
        first = s["timings_ms"]["total"]
        print(f"| {os.path.basename(path)} ({s['width']}×{s['height']}) | first frame | 1 | | {first:.0f} | everything |")
        for kind, es in by_type.items():
            if kind == "cancel":
                c = es[0].get("cancel", {})
                ret = c.get("returned_ms")
                print(f"| | cancel a full frame {c.get('after_ms', 0):.0f} ms in | 1 | | "
                      f"{'returned in %.1f ms' % ret if ret is not None else 'finished first'} | |")
                continue
            p = [e["preview_ms"] for e in es]
            f = [e["full_ms"] for e in es]
            rebuilt = ", ".join(sorted({r["structure"] for r in es[0]["rebuilt"]})) or "nothing"
            print(f"| | {kind} | {len(es)} | {statistics.median(p):.0f} / {percentile(p, 95):.0f} | "
                  f"{statistics.median(f):.0f} / {percentile(f, 95):.0f} | {rebuilt} |")
        sys.stdout.flush()
    for spec in scenes:
        name = spec.partition(":")[0]
        path = name if os.path.exists(name) else os.path.join(ROOT, "scenes", name)
        scene = json.load(open(path))
        if scene.get("shadows", {}).get("technique") == "cssm" and scene.get("volumes"):
            print(f"\n{os.path.basename(path)}, 256×256: cssm after k accumulated samples against ray_traced (64 samples)\n")
            print("| samples | cssm vs ray_traced |")
            print("|---:|---|")
            for k, line in accumulation_psnr(binary, path):
                print(f"| {k} | {line} |")
            break


if __name__ == "__main__":
    main()
