#!/usr/bin/env python3
"""Volumes under a memory budget (issue 43): a pyramid written by `penumbra convert`, rendered with
`--memory-budget` against the finest level fully in memory. Each render is a fresh process under GNU
time (its own peak resident set); the image's error is RMSE/PSNR against the in-memory frame.

    scripts/bench_budget.py body [--build build/release] [--out DIR] [--size 512] [--file]
        the Visible-Woman-sized ct-body (512×512×1734 uint16, 867 MiB) at budgets of 1/8, 1/4 and 1/2
        of its size and fully in memory; with --file as one NRRD (no pyramid: opened reduced, read a slab
        at a time, volume_reduction.h) instead of the OME-Zarr pyramid
    scripts/bench_budget.py zoom [--size 512] [--file]
        a close view of the same ct-body's head under budgets of 1/8 and 1/4: the pyramid opened coarse,
        drawn from it alone and refined where the camera looks (render/view_refinement.h), against level 0
        in memory; then a session (--edits) that pans, backs away and comes back; with --file the ct-body
        as one NRRD (opened reduced and refined from the file's slices) instead of the pyramid
    scripts/bench_budget.py iso [--size 512] [--file]
        the same close view of the head as an isosurface (bone, 1400, points with light-pass shadows; the
        volume hidden): opened coarse, extracted from it alone and refined from a box of a finer level
        where the camera looks, against level 0 in memory (with --file: the ct-body as one NRRD)
    scripts/bench_budget.py big --dims 4096 4096 2048 [--budget 4G] [--keep] [--zoom] [--skip-orbit]
        a procedural ct-body larger than memory (4096×4096×2048 uint16: 64 GiB) converted (time, size,
        peak memory), then opened under the budget: time to the first image and frames per second over
        an orbit; the store is removed unless --keep

    scripts/bench_budget.py formats [--dims 512 512 400]
        one ct-body written as NRRD, gzip NIfTI (nibabel), an ImageJ TIFF stack (tifffile), a DICOM
        series (pydicom), a gzip HDF5 dataset (h5py) and legacy VTK (read whole, for contrast), each
        converted by `penumbra convert`: seconds and peak memory against the volume's size and a 16³
        file of the same format

Prints Markdown tables and writes budget_<case>.json into --out.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FULL_BYTES = 512 * 512 * 1734 * 2  # ct-body's level 0, uint16


def timed(args):
    """(seconds, peak MiB, stdout, stderr) of one process under GNU time."""
    t0 = time.perf_counter()
    r = subprocess.run(["/usr/bin/time", "-f", "peak_kib=%M", *map(str, args)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if r.returncode != 0:
        sys.exit(f"{' '.join(map(str, args))} failed:\n{r.stderr}")
    peak = int(re.search(r"peak_kib=([0-9]+)", r.stderr).group(1)) / 1024.0
    return seconds, peak, r.stdout, r.stderr


def compare(cli, a, b):
    out = subprocess.run([cli, "compare", a, b], capture_output=True, text=True, check=True).stdout
    rmse = float(re.search(r"rmse ([0-9.eE+-]+)", out).group(1))
    psnr = re.search(r"psnr ([0-9.eE+-]+|inf)", out).group(1)
    return rmse, psnr


def nrrd_of_level0(store, path):
    """The pyramid's level 0 as one raw NRRD (its spacing and origin), written a slab at a time."""
    import zarr
    level = zarr.open_group(store, mode="r")
    attrs = level.attrs["multiscales"][0]["datasets"][0]["coordinateTransformations"]
    scale = next(t["scale"] for t in attrs if t["type"] == "scale")
    shift = next((t["translation"] for t in attrs if t["type"] == "translation"), [0, 0, 0])
    a = level["0"]
    z, y, x = a.shape
    with open(path, "wb") as f:
        f.write((f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {x} {y} {z}\nspace: left-posterior-superior\n"
                 f"space directions: ({scale[2]},0,0) (0,{scale[1]},0) (0,0,{scale[0]})\n"
                 f"space origin: ({shift[2]},{shift[1]},{shift[0]})\nencoding: raw\nendian: little\n\n").encode())
        for first in range(0, z, 64):
            f.write(a[first:first + 64].astype("<u2").tobytes())


def body(o, cli, out):
    store = os.path.join(o.work, "ct_body.zarr")
    if not os.path.isdir(store):
        seconds, peak, stdout, _ = timed([cli, "convert", "--procedural", '{"name": "ct-body"}', "-o", store, "--unit", "millimeter"])
        print(f"convert: {stdout.strip()} ({seconds:.1f} s, peak {peak:.0f} MiB)")
    source, full = store, ["--level", "0"]
    if o.file:
        source, full = os.path.join(o.work, "ct_body.nrrd"), []
        if not os.path.isfile(source):
            nrrd_of_level0(store, source)
    rows = []
    ref = os.path.join(out, "budget_full.png")
    cases = [("in memory (level 0)", full), ("1/2", ["--memory-budget", str(FULL_BYTES // 2)]),
             ("1/4", ["--memory-budget", str(FULL_BYTES // 4)]), ("1/8", ["--memory-budget", str(FULL_BYTES // 8)])]
    for label, args in cases:
        image = ref if label.startswith("in memory") else os.path.join(out, f"budget_{label.replace('/', 'of')}.png")
        stats_file = os.path.join(out, "stats.json")
        seconds, peak, _, _ = timed([cli, "render", source, *args, "--width", o.size, "--height", o.size, "-o", image, "--stats", stats_file])
        stats = json.load(open(stats_file))
        rmse, psnr = compare(cli, image, ref)
        rows.append({"case": label, "dims": stats["volumes"][0]["dims"], "held_mib": (stats["memory_bytes"]["volume"] + stats["memory_bytes"]["volume_structures"]) / 2**20,
                     "gradients": "stored" if stats["memory_bytes"]["volume_structures"] >= 4 * stats["counts"]["voxels"] else "on the fly",
                     "first_image_s": seconds, "frame_ms": stats["timings_ms"]["total"], "prepare_ms": stats["timings_ms"]["prepare"],
                     "peak_mib": peak, "rmse": rmse, "psnr": psnr})
    print(f"\nct-body 512×512×1734 uint16 ({FULL_BYTES / 2**20:.0f} MiB) {'as one NRRD' if o.file else 'as an OME-Zarr pyramid'}, "
          f"{o.size}² frame, default scene of the file")
    print("| budget | level dims | held (MiB) | gradients | first image (s) | frame (ms) | peak RSS (MiB) | RMSE | PSNR (dB) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {'×'.join(map(str, r['dims']))} | {r['held_mib']:.0f} | {r['gradients']} | {r['first_image_s']:.1f} | "
              f"{r['frame_ms']:.0f} | {r['peak_mib']:.0f} | {r['rmse']:.4f} | {r['psnr']} |")
    json.dump(rows, open(os.path.join(out, "budget_body_file.json" if o.file else "budget_body.json"), "w"), indent=2)


def zoomed_scene(cli, store, out, name, distance, target):
    """The file's automatic scene (its transfer function, light, floor and CSSM) with the camera moved
    close: written once from the coarsest level (fast), then the level left to the budget."""
    written = os.path.join(out, f"{name}_auto.json")
    subprocess.run([cli, "render", store, "--level", "5", "--width", "16", "--height", "16", "-o", os.path.join(out, f"{name}_auto.png"),
                    "--write-scene", written], capture_output=True, text=True, check=True)
    doc = json.load(open(written))
    doc["volumes"][0]["file"] = os.path.abspath(store)
    doc["volumes"][0].pop("level", None)
    doc.pop("memory_budget", None)
    doc["camera"]["distance"] = distance
    doc["camera"]["target"] = target
    path = os.path.join(out, f"{name}.json")
    json.dump(doc, open(path, "w"), indent=1)
    return path


def refinement_row(stats):
    r = (stats.get("refinement") or [{}])[0]
    return {"level": r.get("level"), "box": r.get("dims"), "box_mib": r.get("held_bytes", 0) / 2**20,
            "read_mib": r.get("read_bytes", 0) / 2**20, "load_ms": r.get("load_ms", 0)}


def head_close_view(o, cli, out, name):
    """The automatic scene of ct-body's pyramid (converted once) with the camera close to the head; with
    --file it reads level 0 as one NRRD instead. Returns the scene's path and the arguments that hold
    level 0 in memory."""
    store = os.path.join(o.work, "ct_body.zarr")
    if not os.path.isdir(store):
        timed([cli, "convert", "--procedural", '{"name": "ct-body"}', "-o", store, "--unit", "millimeter"])
    scene = zoomed_scene(cli, store, out, name, 450.0, [0.0, 0.0, 650.0])
    if not o.file:
        return scene, ["--set", "volumes.0.level=0"]
    source = os.path.join(o.work, "ct_body.nrrd")
    if not os.path.isfile(source):
        nrrd_of_level0(store, source)
    doc = json.load(open(scene))
    doc["volumes"][0]["file"] = os.path.abspath(source)
    json.dump(doc, open(scene, "w"), indent=1)
    return scene, []


def budget_cases(o, cli, out, name, scene, in_memory):
    """`scene` rendered with level 0 in memory, then under budgets of 1/8 and 1/4 of it, drawn from the
    opened level only and refined: for each a row of its label, the volume's dims, the seconds from
    process start to PNG, the frame's stats, the peak RSS, what is held and the error against level 0."""
    size = ["--width", o.size, "--height", o.size]
    ref = os.path.join(out, f"{name}_full.png")
    rows = []
    cases = [("in memory (level 0)", in_memory),
             ("1/8, opened level only", ["--memory-budget", FULL_BYTES // 8, "--set", "volumes.0.refine=false"]),
             ("1/8, refined", ["--memory-budget", FULL_BYTES // 8]),
             ("1/4, opened level only", ["--memory-budget", FULL_BYTES // 4, "--set", "volumes.0.refine=false"]),
             ("1/4, refined", ["--memory-budget", FULL_BYTES // 4])]
    for label, args in cases:
        tag = re.sub(r"[^a-z0-9]+", "_", label.lower()).strip("_")
        image = ref if label.startswith("in memory") else os.path.join(out, f"{name}_{tag}.png")
        stats_file = os.path.join(out, f"{name}_{tag}.json")
        seconds, peak, _, _ = timed([cli, "render", scene, *args, *size, "-o", image, "--stats", stats_file])
        stats = json.load(open(stats_file))
        rmse, psnr = compare(cli, image, ref)
        rows.append({"case": label, "dims": stats["volumes"][0]["dims"], "first_image_s": seconds,
                     "frame_ms": stats["timings_ms"]["total"], "render_ms": stats["timings_ms"]["render"],
                     "extract_ms": stats["timings_ms"].get("extract"), "peak_mib": peak,
                     "held_mib": stats.get("memory_budget", {}).get("held", 0) / 2**20, "rmse": rmse, "psnr": psnr,
                     **refinement_row(stats)})
    return rows


def zoom(o, cli, out):
    """A close view of the head of the Visible-Woman-sized ct-body under budgets of 1/8 and 1/4 of its
    size, refined (the visible box from a finer level) and not, against level 0 in memory; then a
    session (--edits): zoom in, pan a little, back away, come back."""
    scene, in_memory = head_close_view(o, cli, out, "zoom")
    if o.extinction:  # what reads the extinction SAT: cone shadows and the volume's ambient occlusion
        doc = json.load(open(scene))
        doc["shadows"] = {"technique": "sat_cone"}
        doc["ambient"] = {"technique": "sat_shells"}
        json.dump(doc, open(scene, "w"), indent=1)
    rows = budget_cases(o, cli, out, "zoom", scene, in_memory)
    print(f"\nct-body 512×512×1734 uint16 ({FULL_BYTES / 2**20:.0f} MiB), a close view of the head at {o.size}²")
    print("| case | level opened | drawn from | held (MiB) | box read (MiB on disk) | process start to PNG (s) | frame (ms) | peak RSS (MiB) | RMSE | PSNR (dB) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        drawn = f"level {r['level']}: {'×'.join(map(str, r['box']))}" if r["box"] else "the opened level"
        print(f"| {r['case']} | {'×'.join(map(str, r['dims']))} | {drawn} | {r['held_mib']:.0f} | {r['read_mib']:.1f} | {r['first_image_s']:.1f} | "
              f"{r['frame_ms']:.0f} | {r['peak_mib']:.0f} | {r['rmse']:.4f} | {r['psnr']} |")
    session = session_steps(cli, scene, out, ["--memory-budget", FULL_BYTES // 8, "--width", o.size, "--height", o.size],
                            [0.0, 0.0, 650.0], 450.0)
    name = "budget_zoom" + ("_extinction" if o.extinction else "") + ("_file" if o.file else "")
    json.dump({"cases": rows, "session": session}, open(os.path.join(out, name + ".json"), "w"), indent=2)


def iso(o, cli, out):
    """The close view of the head as the bone isosurface of a hidden volume: the pyramid (or the file)
    opened coarse under 1/8 and 1/4 of its size, the surface extracted from the opened level alone and
    refined from a box where the camera looks, against level 0 in memory; then the session of `zoom` at 1/8."""
    scene, in_memory = head_close_view(o, cli, out, "iso")
    doc = json.load(open(scene))
    doc["volumes"][0] = {"file": doc["volumes"][0]["file"], "visible": False}
    doc["isosurfaces"] = [{"value": 1400, "method": o.method, "color": [0.93, 0.89, 0.80]}]
    # the points' own shadows, or the exact rays of the exact reference
    doc["shadows"] = {"technique": "light_pass", "resolution": 512} if o.method == "points" else {"technique": "ray_traced"}
    json.dump(doc, open(scene, "w"), indent=1)
    rows = budget_cases(o, cli, out, "iso", scene, in_memory)
    print(f"\nct-body 512×512×1734 uint16 ({FULL_BYTES / 2**20:.0f} MiB) {'as one NRRD' if o.file else 'as an OME-Zarr pyramid'}, "
          f"bone isosurface ({'points, light-pass' if o.method == 'points' else 'raycast, ray-traced'} shadows), a close view of the head at {o.size}²")
    print("| case | level opened | extracted from | held (MiB) | box read (MiB) | box load (ms) | start to PNG (s) | frame (ms) | eye pass (ms) | peak RSS (MiB) | RMSE | PSNR (dB) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        drawn = f"level {r['level']}: {'×'.join(map(str, r['box']))} + the opened level" if r["box"] else "the opened level"
        extract = f"{r['extract_ms']:.0f}" if r["extract_ms"] is not None else "–"
        print(f"| {r['case']} | {'×'.join(map(str, r['dims']))} | {drawn} | {r['held_mib']:.0f} | {r['read_mib']:.1f} | {r['load_ms']:.0f} | "
              f"{r['first_image_s']:.1f} | {r['frame_ms']:.0f} | {extract} | {r['peak_mib']:.0f} | {r['rmse']:.4f} | {r['psnr']} |")
    session = session_steps(cli, scene, out, ["--memory-budget", FULL_BYTES // 8, "--width", o.size, "--height", o.size],
                            [0.0, 0.0, 650.0], 450.0)
    json.dump({"cases": rows, "session": session}, open(os.path.join(out, f"budget_iso_{o.method}{'_file' if o.file else ''}.json"), "w"),
              indent=2)


def session_steps(cli, scene, out, args, target, distance):
    """--edits: a small pan, a longer one, backing away, coming back: each step's preview and full-frame
    latency and what the refinement loaded, read, reused and evicted, and the process's peak RSS."""
    edits = [{"set": {"camera.target": [target[0] + distance * 0.02, target[1], target[2]]}},
             {"set": {"camera.target": [target[0] + distance * 0.12, target[1], target[2]]}},
             {"set": {"camera.distance": distance * 8}},
             {"set": {"camera.distance": distance, "camera.target": list(target)}}]
    edits_file = os.path.join(out, "session_edits.json")
    json.dump(edits, open(edits_file, "w"))
    stats_file = os.path.join(out, "session.json")
    _, peak, _, _ = timed([cli, "render", scene, *args, "-o", os.path.join(out, "session.png"), "--edits", edits_file, "--stats", stats_file])
    stats = json.load(open(stats_file))
    steps = [{"step": "the close view (first frame)", "preview_ms": None, "full_ms": stats["timings_ms"]["total"],
              "refinement": stats["refinement"]}]
    for name, e in zip(["a pan of 2 % of the distance", "a pan of 10 % more", "backing away 8×", "coming back"], stats["edits"]):
        steps.append({"step": name, "preview_ms": e["preview_ms"], "full_ms": e["full_ms"], "refinement": e["refinement"]})
    print("\n| step | preview (ms) | full frame (ms) | drawn from | loaded (MiB) | read (MiB) | reused (MiB) | box load (ms) | evicted (MiB) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for s in steps:
        r = (s["refinement"] or [{}])[0]
        drawn = f"level {r['level']}" if r.get("held_bytes") else "the opened level"
        pv = f"{s['preview_ms']:.0f}" if s["preview_ms"] is not None else "–"
        print(f"| {s['step']} | {pv} | {s['full_ms']:.0f} | {drawn} | {r.get('loaded_bytes', 0) / 2**20:.1f} | "
              f"{r.get('read_bytes', 0) / 2**20:.1f} | {r.get('reused_bytes', 0) / 2**20:.1f} | {r.get('load_ms', 0):.0f} | "
              f"{r.get('evicted_bytes', 0) / 2**20:.1f} |")
    print(f"the session's peak RSS: {peak:.0f} MiB")
    return {"steps": steps, "peak_mib": peak}


def big(o, cli, out):
    store = os.path.join(o.work, "big_body.zarr")
    spec = json.dumps({"name": "ct-body", "dims": o.dims})
    result = {}
    if not os.path.isdir(store):
        seconds, peak, stdout, _ = timed([cli, "convert", "--procedural", spec, "-o", store, "--codec", "zstd", "--clevel", "1"])
        du = subprocess.run(["du", "-sb", store], capture_output=True, text=True).stdout.split()[0]
        result["convert"] = {"seconds": seconds, "peak_mib": peak, "summary": stdout.strip(), "store_bytes": int(du)}
        print(f"convert: {stdout.strip()}\n  {seconds:.0f} s, peak {peak:.0f} MiB, {int(du) / 2**30:.1f} GiB on disk")
    stats_file = os.path.join(out, "stats.json")
    image = os.path.join(out, "budget_big.png")
    seconds, peak, _, _ = timed([cli, "render", store, "--memory-budget", o.budget, "--width", 1024, "--height", 1024, "-o", image,
                                 "--stats", stats_file])
    stats = json.load(open(stats_file))
    result["first"] = {"seconds": seconds, "peak_mib": peak, "dims": stats["volumes"][0]["dims"], "frame_ms": stats["timings_ms"]["total"],
                       "held_mib": stats["memory_budget"]["held"] / 2**20}
    if o.zoom:
        scene = zoomed_scene(cli, store, out, "big_zoom", 450.0, [0.0, 0.0, 650.0])
        args = ["--memory-budget", o.budget, "--width", 1024, "--height", 1024]
        p_seconds, p_peak, _, _ = timed([cli, "render", scene, *args, "--preview", "-o", os.path.join(out, "big_zoom_preview.png")])
        z_stats = os.path.join(out, "big_zoom_stats.json")
        z_seconds, z_peak, _, _ = timed([cli, "render", scene, *args, "-o", os.path.join(out, "big_zoom.png"), "--stats", z_stats])
        zs = json.load(open(z_stats))
        result["zoom"] = {"preview_s": p_seconds, "refined_s": z_seconds, "peak_mib": max(p_peak, z_peak),
                          "frame_ms": zs["timings_ms"]["total"], "held_mib": zs["memory_budget"]["held"] / 2**20, **refinement_row(zs),
                          "session": session_steps(cli, scene, out, args, [0.0, 0.0, 650.0], 450.0)}
        z = result["zoom"]
        print(f"\nclose view of the head, 1024²: process start to the preview {z['preview_s']:.1f} s, to the refined frame "
              f"{z['refined_s']:.1f} s (level {z['level']}, box {'×'.join(map(str, z['box'] or []))}, {z['held_mib']:.0f} MiB held in all, "
              f"{z['read_mib']:.0f} MiB read in {z['load_ms'] / 1000:.1f} s), peak {z['peak_mib']:.0f} MiB")
    if o.skip_orbit:
        json.dump(result, open(os.path.join(out, "budget_big.json"), "w"), indent=2)
        if not o.keep:
            shutil.rmtree(store)
        return
    orbit = os.path.join(out, "orbit.json")
    o_seconds, o_peak, _, _ = timed([cli, "render", store, "--memory-budget", o.budget, "--width", 1024, "--height", 1024,
                                     "-o", os.path.join(out, "orbit.png"), "--orbit", 12, "--stats", orbit])
    frames = json.load(open(orbit)).get("frames", [])
    totals = sorted(f["timings_ms"]["total"] for f in frames[1:]) if frames else []
    median = totals[len(totals) // 2] if totals else float("nan")
    result["orbit"] = {"seconds": o_seconds, "peak_mib": o_peak, "median_frame_ms": median, "fps": 1000 / median if totals else 0}
    print(f"\nct-body {'×'.join(map(str, o.dims))} uint16 under --memory-budget {o.budget}, 1024² frames")
    print("| what | figure |\n|---|---|")
    print(f"| level opened | {'×'.join(map(str, result['first']['dims']))} ({result['first']['held_mib']:.0f} MiB held) |")
    print(f"| time to first image (process start to PNG) | {result['first']['seconds']:.1f} s |")
    print(f"| its frame | {result['first']['frame_ms']:.0f} ms |")
    print(f"| orbit, 12 frames | {median:.0f} ms a frame ({result['orbit']['fps']:.1f} fps) |")
    print(f"| peak resident memory | {max(peak, o_peak):.0f} MiB |")
    json.dump(result, open(os.path.join(out, "budget_big.json"), "w"), indent=2)
    if not o.keep:
        shutil.rmtree(store)


def write_formats(a, spacing, folder):
    """The array `a` (z, y, x uint16) in every format that streams; {name: path}."""
    import h5py
    import nibabel
    import pydicom
    import pydicom.dataset
    import tifffile
    os.makedirs(folder, exist_ok=True)
    z, y, x = a.shape
    files = {"NRRD (raw)": os.path.join(folder, "v.nrrd"), "NIfTI (gzip)": os.path.join(folder, "v.nii.gz"),
             "TIFF (ImageJ)": os.path.join(folder, "v.tif"), "DICOM series": os.path.join(folder, "dicom"),
             "HDF5 (gzip chunks)": os.path.join(folder, "v.h5"), "legacy VTK (BINARY)": os.path.join(folder, "v.vtk")}
    with open(files["legacy VTK (BINARY)"], "wb") as f:
        f.write((f"# vtk DataFile Version 3.0\nct-body\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS {x} {y} {z}\n"
                 f"SPACING {spacing[2]} {spacing[1]} {spacing[0]}\nORIGIN 0 0 0\nPOINT_DATA {x * y * z}\n"
                 "SCALARS v unsigned_short 1\nLOOKUP_TABLE default\n").encode())
        for first in range(0, z, 64):
            f.write(a[first:first + 64].astype(">u2").tobytes())
    with open(files["NRRD (raw)"], "wb") as f:
        f.write((f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {x} {y} {z}\nspacings: {spacing[2]} {spacing[1]} {spacing[0]}\n"
                 "encoding: raw\nendian: little\n\n").encode())
        for first in range(0, z, 64):
            f.write(a[first:first + 64].astype("<u2").tobytes())
    nibabel.save(nibabel.Nifti1Image(a.transpose(2, 1, 0), np.diag([-spacing[2], -spacing[1], spacing[0], 1.0])), files["NIfTI (gzip)"])
    tifffile.imwrite(files["TIFF (ImageJ)"], a, imagej=True, metadata={"axes": "ZYX", "spacing": spacing[0]})
    with h5py.File(files["HDF5 (gzip chunks)"], "w") as f:
        d = f.create_dataset("v", shape=a.shape, dtype="<u2", chunks=tuple(min(c, n) for c, n in zip((16, 128, 128), a.shape)), compression="gzip", compression_opts=1)
        for first in range(0, z, 64):
            d[first:first + 64] = a[first:first + 64]
    try:  # VTK's own writer (python3-vtk9, not installed by install-deps.sh): the .vti rows need it
        import vtk
        from vtk.util import numpy_support
    except ImportError:
        vtk = None
    if vtk is not None:
        image = vtk.vtkImageData()
        image.SetDimensions(x, y, z)
        image.SetSpacing(spacing[2], spacing[1], spacing[0])
        flat = np.ascontiguousarray(a).ravel()
        image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(flat, deep=False, array_type=vtk.VTK_UNSIGNED_SHORT))
        for name, raw in [("VTI (VTK's default: appended base64, zlib)", False), ("VTI (appended raw)", True)]:
            files[name] = os.path.join(folder, "v_raw.vti" if raw else "v_default.vti")
            w = vtk.vtkXMLImageDataWriter()
            w.SetFileName(files[name])
            w.SetInputData(image)
            if raw:
                w.SetEncodeAppendedData(False)
                w.SetCompressorTypeToNone()
            if not w.Write():
                raise RuntimeError("VTK could not write " + files[name])
    os.makedirs(files["DICOM series"], exist_ok=True)
    meta = pydicom.dataset.FileMetaDataset()
    meta.TransferSyntaxUID = pydicom.uid.ExplicitVRLittleEndian
    meta.MediaStorageSOPClassUID = pydicom.uid.CTImageStorage
    series = pydicom.uid.generate_uid()
    for k in range(z):
        ds = pydicom.dataset.FileDataset(None, {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID, ds.SOPInstanceUID, ds.SeriesInstanceUID = meta.MediaStorageSOPClassUID, pydicom.uid.generate_uid(), series
        meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
        ds.Modality, ds.Rows, ds.Columns = "CT", y, x
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 12, 11, 0
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.RescaleSlope, ds.RescaleIntercept = 1, -1024
        ds.PixelSpacing = [spacing[1], spacing[2]]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [0, 0, k * spacing[0]]
        ds.PixelData = np.minimum(a[k], 4095).astype("<u2").tobytes()
        ds.save_as(os.path.join(files["DICOM series"], f"{k:05d}.dcm"), write_like_original=False)
    return files


def formats(o, cli, out):
    import zarr
    x, y, z = o.dims if o.dims != [4096, 4096, 2048] else [512, 512, 400]
    store = os.path.join(o.work, "body_formats.zarr")
    spec = json.dumps({"name": "ct-body", "dims": [x, y, z]})
    subprocess.run([cli, "convert", "--procedural", spec, "-o", store], check=True, capture_output=True)
    level = zarr.open_group(store, mode="r")
    a = level["0"][:]
    scale = next(t["scale"] for t in level.attrs["multiscales"][0]["datasets"][0]["coordinateTransformations"] if t["type"] == "scale")
    files = write_formats(a, scale, os.path.join(o.work, "formats"))
    tiny = write_formats(np.full((16, 16, 16), 100, np.uint16), scale, os.path.join(o.work, "formats_tiny"))
    rows = []
    for name, path in files.items():
        seconds, peak, stdout, _ = timed([cli, "convert", path, "-o", os.path.join(o.work, "out.zarr"), "--chunk", "64"])
        _, tiny_peak, _, _ = timed([cli, "convert", tiny[name], "-o", os.path.join(o.work, "tiny.zarr"), "--chunk", "64"])
        shutil.rmtree(os.path.join(o.work, "out.zarr"))
        shutil.rmtree(os.path.join(o.work, "tiny.zarr"))
        rows.append({"format": name, "streamed": "(streamed)" in stdout, "seconds": seconds, "peak_mib": peak, "tiny_peak_mib": tiny_peak})
    print(f"\nct-body {x}×{y}×{z} uint16 ({a.nbytes / 2**20:.0f} MiB) converted to OME-Zarr (64³ chunks, blosc), a fresh process each")
    print("| format | streamed | time (s) | peak RSS (MiB) | peak for a 16³ file (MiB) | over it (MiB) |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['format']} | {'yes' if r['streamed'] else 'no'} | {r['seconds']:.1f} | {r['peak_mib']:.0f} | {r['tiny_peak_mib']:.0f} | "
              f"{r['peak_mib'] - r['tiny_peak_mib']:.0f} |")
    json.dump(rows, open(os.path.join(out, "budget_formats.json"), "w"), indent=2)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", choices=["body", "zoom", "iso", "big", "formats"])
    p.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    p.add_argument("--out", default=None)
    p.add_argument("--work", default=None, help="where the stores go (default: a temporary folder)")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--dims", type=int, nargs=3, default=[4096, 4096, 2048])
    p.add_argument("--budget", default="4G")
    p.add_argument("--keep", action="store_true")
    p.add_argument("--zoom", action="store_true", help="big: also a close view of the head, refined (preview, refined frame, a session)")
    p.add_argument("--skip-orbit", action="store_true", help="big: no orbit")
    p.add_argument("--method", choices=["points", "raycast"], default="points", help="iso: the isosurface's method")
    p.add_argument("--file", action="store_true", help="body, zoom: the ct-body as one NRRD file, not a pyramid")
    p.add_argument("--extinction", action="store_true",
                   help="zoom: sat_cone shadows and sat_shells ambient occlusion (what reads the extinction SAT) instead of the CSSM")
    o = p.parse_args()
    cli = os.path.join(o.build, "penumbra")
    out = o.out or tempfile.mkdtemp(prefix="bench_budget_")
    os.makedirs(out, exist_ok=True)
    o.work = o.work or out
    {"body": body, "zoom": zoom, "iso": iso, "big": big, "formats": formats}[o.case](o, cli, out)
    print(f"\n(files in {out})")


if __name__ == "__main__":
    main()
