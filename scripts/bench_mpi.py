#!/usr/bin/env python3
"""Data-parallel frames under mpirun (docs/distributed.md, issue 20): 1-4 ranks on the shipped CT scenes
and (spheres split by space) molecules,
per-rank times and bytes sent for the image and for the shadow structure, each frame checked bit for
bit against the brick loop (`render --slabs N`); then the communication model for 8-1,024 ranks on a
4096^3 volume at 1920x1080 (full-frame bound for the image), checked against the measured byte counts
first.

  scripts/bench_mpi.py [--penumbra build/release/penumbra] [--ranks 1,2,3,4] [--json out.json]
  scripts/bench_mpi.py --sequences [--ranks 1,2,3,4]    # sequences under mpirun: an orbit, a trajectory
  scripts/bench_mpi.py --compositors [--ranks 2,3,4]    # direct send against IceT (radix-k, binary swap)

`--sequences` times `render --orbit 8` of mri-head and `render --frames 0:150:15` of the staged GROMACS
run (1tii, ISSM + particle AO, 1920x1200) on each rank count: the median frame, the time to open the
scene at a frame, the MB a rank read for the first and for the later frames, and the worst frame's PSNR
against the single-process sequence.

`--compositors` renders the shipped CT scenes and 1af6 with each compositor (`--compositor direct-send,
icet, icet-bswap`; IceT when built with it, scripts/fetch-icet.sh): each frame's PSNR against direct
send's, the compositing step's time (the fastest rank's: the others also wait there for the slowest
render) and the image bytes a rank sent (the most).

On one machine the ranks are oversubscribed (they share its cores), so the times are not scaling figures.
"""
import argparse
import filecmp
import json
import math
import os
import subprocess
import sys
import tempfile

SCENES = [  # (scene, --set overrides, what shadows it, deep shadow map nodes)
    ("mri-head", [], "cssm", 0),
    ("cranium", ["planes=[]"], "cssm", 0),
    ("chest", ["planes=[]"], "deep_shadow_map", 4),
]


def run(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stdout}{r.stderr}")
    return r


# Bytes one rank sends per frame (distributed/distributed_frame.h): the shadow reduction (resolution^2 x 3
# floats per round, ceil(log2 N) rounds of recursive doubling; CSSM only), the direct-send exchange
# ((N-1)/N of a W x H x 4-float image, exactly the other ranks' bands) and its band to rank 0.
def band_rows(height, n, r):
    return height * (r + 1) // n - height * r // n


# The image's bound: every rank's active rectangle the whole frame (the exchange sends only the part of
# each band inside the rank's rectangle, after an all-gather of the rectangles, 16 bytes to each rank).
def model_image_bytes(width, height, n, rank):
    rectangles = 16 * (n - 1)
    exchange = sum(band_rows(height, n, r) for r in range(n) if r != rank) * width * 16
    gather = 0 if rank == 0 else band_rows(height, n, rank) * width * 12
    return rectangles + exchange + gather


# Floats per texel in the shadow reductions, each sent in ceil(log2 N) rounds (shadows/*.h "Across
# bricks"): the CSSM's minimum of 3 depths; the deep shadow map's two exclusive products of 3
# transmittances (rays up and down in z), its ends (2 depths, then 6 values) and per interior node
# three minima (per_channel: 3 errors, 3 depths, 3 values; shared_depth: 1, 1, 3).
def model_shadow_floats(shadows, nodes=3, shared=False):
    if shadows == "cssm":
        return 3
    if shadows == "deep_shadow_map":
        return 6 + 2 + 6 + max(0, nodes - 2) * (5 if shared else 9)
    return 0


def model_shadow_bytes(resolution, n, shadows, nodes=3):
    return 4 * resolution * resolution * model_shadow_floats(shadows, nodes) * math.ceil(math.log2(n)) if n > 1 else 0


# Particle scenes split by space (distributed/sphere_split.h): the shipped molecules under the ISSM
# and particle AO, each frame compared with the single-process one. The ISSM's reduction sends
# 20 bytes a texel (depth, centre, radius) a round; the particle AO a double a density cell a round.
SPHERE_SCENES = [("1af6", 512), ("bace1", 512)]  # (scene, its shadows.resolution)


def model_issm_bytes(resolution, n):
    return 20 * resolution * resolution * math.ceil(math.log2(n)) if n > 1 else 0


def psnr_of(penumbra, a, b):
    if filecmp.cmp(a, b, shallow=False):
        return math.inf
    return float(dict(l.split()[:2] for l in run([penumbra, "compare", a, b]).stdout.splitlines())["psnr"])


def measure_spheres(a, env, ranks, tmp):
    rows = []
    for scene, resolution in SPHERE_SCENES:
        args = [f"scenes/{scene}.json"]
        whole = os.path.join(tmp, f"{scene}_whole.pfm")
        run([a.penumbra, "render", *args, "-o", whole])
        for n in ranks:
            out, stats = os.path.join(tmp, f"{scene}{n}.pfm"), os.path.join(tmp, f"{scene}{n}.json")
            run(["mpirun", "--oversubscribe", "--bind-to", "none", "-np", str(n), a.penumbra, "render", *args, "-o", out,
                 "--stats", stats], env)
            p = psnr_of(a.penumbra, out, whole)
            same, psnr = math.isinf(p), f"{p:g}"
            s = json.load(open(stats))
            issm = model_issm_bytes(resolution, n)
            for rank in s["ranks"]:
                if rank["shadow_bytes_sent"] < issm:
                    sys.exit(f"{scene} np {n} rank {rank['rank']}: shadow bytes {rank['shadow_bytes_sent']} below the ISSM's {issm}")
            worst = lambda k: max(x[k] for x in s["ranks"])
            rows.append({"scene": scene, "ranks": n, "same_as_single_process": same, "psnr": psnr,
                         "spheres": [x["spheres"] for x in s["ranks"]], "build_ms": worst("build_ms"),
                         "render_ms": worst("render_ms"), "composite_ms": worst("composite_ms"),
                         "communication_ms": worst("communication_ms"), "issm_kB": issm / 1024,
                         "shadow_kB": s["ranks"][-1]["shadow_bytes_sent"] / 1024,
                         "image_kB": max(x["image_bytes_sent"] for x in s["ranks"]) / 1024, "size": f"{s['width']}x{s['height']}"})
    print("| scene | ranks | = one process | spheres a rank | shadows ms | render ms | composite ms | communication ms | "
          "kB sent: ISSM (model) | shadows in all (ISSM + AO) | image |")
    print("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        same = "bit for bit" if r["same_as_single_process"] else f"{r['psnr']} dB"
        print(f"| {r['scene']} ({r['size']}) | {r['ranks']} | {same} | {'/'.join(str(k) for k in r['spheres'])} | {r['build_ms']:.0f} | "
              f"{r['render_ms']:.0f} | {r['composite_ms']:.1f} | {r['communication_ms']:.0f} | {r['issm_kB']:.0f} | "
              f"{r['shadow_kB']:.0f} | {r['image_kB']:.0f} |")
    return rows



def measure_sequences(a, env, ranks, tmp):
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")
    trajectory = os.path.join(tmp, "1tii_md.json")
    json.dump({"particles": [{"file": os.path.join(data, "md_1tii_chainD.gro"), "trajectory": os.path.join(data, "md_1tii_chainD.xtc")}],
               "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
               "shadows": {"technique": "issm", "resolution": 512}, "ambient": {"technique": "particle_ao"},
               "camera": {"direction": [0.2, 0.3, 1.0], "fov_deg": 30, "width": 1920, "height": 1200}}, open(trajectory, "w"))
    sequences = [("mri-head", "scenes/mri-head.json", ["--orbit", "8"], 8)]
    if os.path.exists(os.path.join(data, "md_1tii_chainD.xtc")):
        sequences.append(("1tii MD, issm + AO", trajectory, ["--frames", "0:150:15"], 11))
    rows = []
    for name, scene, args, count in sequences:
        key = name.split()[0]
        whole = os.path.join(tmp, f"{key}_whole.pfm")
        run([a.penumbra, "render", scene, *args, "-o", whole])
        for n in ranks:
            out, stats = os.path.join(tmp, f"{key}{n}.pfm"), os.path.join(tmp, f"{key}{n}.json")
            run(["mpirun", "--oversubscribe", "--bind-to", "none", "-np", str(n), a.penumbra, "render", scene, *args, "-o", out,
                 "--stats", stats], env)
            frames = json.load(open(stats))["frames"]
            later = frames[1:]
            psnr = min(psnr_of(a.penumbra, f"{out[:-4]}_{k:03d}.pfm", f"{whole[:-4]}_{k:03d}.pfm") for k in range(count))
            median = lambda v: sorted(v)[len(v) // 2]
            rows.append({"sequence": name, "args": " ".join(args), "ranks": n, "frames": len(frames),
                         "frame_ms": median([f["ms"] for f in later]), "open_ms": median([f["open_ms"] for f in later]),
                         "first_MB": max(r["bytes_read"] for r in frames[0]["ranks"]) / 1e6,
                         "later_MB": max(r["bytes_read"] for f in later for r in f["ranks"]) / 1e6, "worst_psnr": psnr})
    print("| sequence | ranks | frames | frame ms (median) | opening the scene ms | MB read a rank: first frame | later frames (most) | worst frame against one process |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        psnr = "bit for bit" if math.isinf(r["worst_psnr"]) else f"{r['worst_psnr']:.1f} dB"
        print(f"| {r['sequence']} `{r['args']}` | {r['ranks']} | {r['frames']} | {r['frame_ms']:.0f} | {r['open_ms']:.1f} | "
              f"{r['first_MB']:.1f} | {r['later_MB']:.1f} | {psnr} |")
    return rows


def measure_compositors(a, env, ranks, tmp):
    scenes = [(f"scenes/{scene}.json", [x for s in sets for x in ("--set", s)]) for scene, sets, _, _ in SCENES]
    scenes.append(("scenes/1af6.json", []))
    rows = []
    print("| scene | ranks | compositor | PSNR against direct send | compositing ms (fastest rank) | image kB sent (most) |")
    print("|---|---:|---|---|---:|---:|")
    for path, sets in scenes:
        for n in ranks:
            direct = None
            for compositor in ("direct-send", "icet", "icet-bswap"):
                out, stats = os.path.join(tmp, f"{compositor}{n}.pfm"), os.path.join(tmp, f"{compositor}{n}.json")
                run(["mpirun", "--oversubscribe", "--bind-to", "none", "-np", str(n), a.penumbra, "render", path, *sets, "-o", out,
                     "--compositor", compositor, "--stats", stats], env)
                s = json.load(open(stats))
                if direct is None:
                    direct, psnr = out, "-"
                else:
                    p = psnr_of(a.penumbra, out, direct)
                    psnr = "bit for bit" if math.isinf(p) else f"{p:.1f} dB"
                row = {"scene": os.path.basename(path)[:-5], "ranks": n, "compositor": compositor, "psnr": psnr,
                       "compositing_ms": min(x["compositing_ms"] for x in s["ranks"]),
                       "image_kB": max(x["image_bytes_sent"] for x in s["ranks"]) / 1024}
                rows.append(row)
                print(f"| {row['scene']} | {n} | {compositor} | {psnr} | {row['compositing_ms']:.1f} | {row['image_kB']:.0f} |", flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--penumbra", default="build/release/penumbra")
    ap.add_argument("--ranks", default="1,2,3,4")
    ap.add_argument("--json")
    ap.add_argument("--sequences", action="store_true", help="time sequences under mpirun (an orbit, a trajectory) only")
    ap.add_argument("--compositors", action="store_true", help="direct send against IceT's radix-k and binary swap only")
    a = ap.parse_args()
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    ranks = [int(x) for x in a.ranks.split(",")]
    for chosen, name, measure in ((a.compositors, "compositors", measure_compositors), (a.sequences, "sequences", measure_sequences)):
        if chosen:
            with tempfile.TemporaryDirectory() as tmp:
                rows = measure(a, env, ranks, tmp)
            if a.json:
                json.dump({name: rows}, open(a.json, "w"), indent=1)
            return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene, sets, shadows, nodes in SCENES:
            args = [f"scenes/{scene}.json"] + [x for s in sets for x in ("--set", s)]
            for n in ranks:
                out, loop, stats = (os.path.join(tmp, f) for f in (f"{scene}{n}.pfm", f"{scene}{n}_loop.pfm", f"{scene}{n}.json"))
                r = run(["mpirun", "--oversubscribe", "--bind-to", "none", "-np", str(n), a.penumbra, "render", *args, "-o", out,
                         "--stats", stats], env)
                run([a.penumbra, "render", *args, "--slabs", str(n), "-o", loop])
                p = psnr_of(a.penumbra, out, loop)
                same, psnr = math.isinf(p), f"{p:g}"
                s = json.load(open(stats))
                resolution = 1024
                for rank in s["ranks"]:
                    want_image = model_image_bytes(s["width"], s["height"], n, rank["rank"])
                    want_shadow = model_shadow_bytes(resolution, n, shadows, nodes)
                    if rank["image_bytes_sent"] > want_image or rank["shadow_bytes_sent"] != want_shadow:
                        sys.exit(f"{scene} np {n} rank {rank['rank']}: bytes {rank['image_bytes_sent']}/{rank['shadow_bytes_sent']} "
                                 f"against the model's {want_image} (at most)/{want_shadow}")
                worst = lambda k: max(x[k] for x in s["ranks"])
                rows.append({"scene": scene, "shadows": shadows, "ranks": n, "same_as_brick_loop": same, "psnr": psnr,
                             "bricks_read": s.get("bricks_read", False),
                             "read_MB": max(x["bytes_read"] for x in s["ranks"]) / 1e6,
                             "held_MB": max(x["volume_bytes"] for x in s["ranks"]) / 1e6,
                             "build_ms": worst("build_ms"), "render_ms": worst("render_ms"), "composite_ms": worst("composite_ms"),
                             "communication_ms": worst("communication_ms"),
                             "shadow_kB": s["ranks"][-1]["shadow_bytes_sent"] / 1024,
                             "image_kB": max(x["image_bytes_sent"] for x in s["ranks"]) / 1024,
                             "image_bound_kB": max(model_image_bytes(s["width"], s["height"], n, x["rank"]) for x in s["ranks"]) / 1024,
                             "size": f"{s['width']}x{s['height']}"})
    print("| scene | shadows | ranks | = --slabs N | MB read / held a rank (most) | shadows ms | render ms | composite ms | communication ms | kB sent: shadows | image | image, full frame |")
    print("|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        same = "bit for bit" if r["same_as_brick_loop"] else f"{r['psnr']} dB"
        print(f"| {r['scene']} ({r['size']}) | {r['shadows']} | {r['ranks']} | {same} | {r['read_MB']:.1f} / {r['held_MB']:.1f} | "
              f"{r['build_ms']:.0f} | {r['render_ms']:.0f} | {r['composite_ms']:.1f} | {r['communication_ms']:.0f} | "
              f"{r['shadow_kB']:.0f} | {r['image_kB']:.0f} | {r['image_bound_kB']:.0f} |")
    print("\nevery rank's shadow bytes equal the model's, its image bytes at most the full-frame bound (checked above)\n")
    with tempfile.TemporaryDirectory() as tmp:
        sphere_rows = measure_spheres(a, env, ranks, tmp)
    print()

    # The model at scale: 4096^3 floats (256 GiB) in z-slabs, 1920x1080, a 1024^2 CSSM; a 100 Gb/s link
    # (12.5 GB/s) and 1.5 us a message.
    width, height, resolution, bandwidth, latency = 1920, 1080, 1024, 12.5e9, 1.5e-6
    print("| ranks | voxel slices a rank | brick GiB | image MB sent a rank (bound) | messages | image ms | CSSM MB sent a rank | CSSM ms | "
          "ISSM MB sent a rank | ISSM ms |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    model = []
    for n in (8, 64, 512, 1024):
        image = max(model_image_bytes(width, height, n, r) for r in (1, n - 1))
        shadow = model_shadow_bytes(resolution, n, "cssm")
        image_ms = 1e3 * (image / bandwidth + n * latency)
        shadow_ms = 1e3 * (shadow / bandwidth + math.ceil(math.log2(n)) * latency)
        issm = model_issm_bytes(resolution, n)  # spheres split by space, a 1024^2 ISSM
        issm_ms = 1e3 * (issm / bandwidth + math.ceil(math.log2(n)) * latency)
        model.append({"ranks": n, "image_bytes": image, "shadow_bytes": shadow, "image_ms": image_ms, "shadow_ms": shadow_ms,
                      "issm_bytes": issm, "issm_ms": issm_ms})
        print(f"| {n} | {4096 // n} | {4096 ** 3 * 4 / n / 2 ** 30:.2f} | {image / 1e6:.1f} | {n} | {image_ms:.1f} | {shadow / 1e6:.1f} | "
              f"{shadow_ms:.1f} | {issm / 1e6:.1f} | {issm_ms:.1f} |")
    if a.json:
        json.dump({"measured": rows, "spheres": sphere_rows, "model": model}, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
