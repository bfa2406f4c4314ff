#!/usr/bin/env python3
"""Frame times of penumbra's one-scene pipeline, for docs/BENCHMARKS.md.

usage: scripts/bench_one_scene.py PENUMBRA [PENUMBRA_BEFORE]

1. Mixed scenes against the sum of their parts: each mixed scene (scenes/ct-implants.json,
   scenes/groel-density.json) is rendered whole and with only one kind of object at a time (the
   others removed, the floor kept in every part); the table gives the first frame (everything built)
   and a cached frame (camera moved: nothing rebuilt but view-dependent work), and the ratio of the
   whole to the sum of its parts.
2. Single-kind scenes (cranium, 1aon, ct-body) with PENUMBRA and, when given, PENUMBRA_BEFORE (a build
   of the commit before the one-scene change), interleaved run by run so that drift hits both alike.
Each figure is the median of `runs` runs of `--orbit 3` (frame 0: first; frames 1-2: cached).
"""
import json, os, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = 3


def frame_times(binary, scene, sets):
    with tempfile.TemporaryDirectory() as d:
        cmd = [binary, "render", os.path.join(ROOT, "scenes", scene), "-o", os.path.join(d, "f.png"), "--orbit", "3",
               "--stats", os.path.join(d, "s.json")]
        for s in sets:
            cmd += ["--set", s]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        frames = json.load(open(os.path.join(d, "s.json")))["frames"]
        totals = [f["timings_ms"]["total"] for f in frames]
        return totals[0], statistics.median(totals[1:])


def median_times(binary, scene, sets):
    runs = [frame_times(binary, scene, sets) for _ in range(RUNS)]
    return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)


MIXED = {
    "ct-implants.json": {
        "volume": ["particles=[]"],
        "spheres": ["volumes.0.visible=false", "volumes.0.transfer_function={\"preset\":\"ct-bone\"}"],
    },
    "groel-density.json": {
        "volume": ["particles=[]", "isosurfaces=[]"],
        "spheres": ["volumes.0.visible=false", "isosurfaces=[]"],
        "isosurface": ["volumes.0.visible=false", "particles=[]"],
    },
}


def main():
    after = sys.argv[1]
    before = sys.argv[2] if len(sys.argv) > 2 else None
    print("| mixed scene | whole: first / cached ms | parts (first / cached ms) | sum of parts: first / cached | whole ÷ sum |")
    print("|---|---:|---|---:|---:|")
    for scene, parts in MIXED.items():
        whole = median_times(after, scene, [])
        part_times = {k: median_times(after, scene, v) for k, v in parts.items()}
        s0 = sum(p[0] for p in part_times.values())
        s1 = sum(p[1] for p in part_times.values())
        desc = ", ".join(f"{k} {v[0]:.0f} / {v[1]:.0f}" for k, v in part_times.items())
        print(f"| {scene} | {whole[0]:.0f} / {whole[1]:.0f} | {desc} | {s0:.0f} / {s1:.0f} | {whole[0] / s0:.2f} / {whole[1] / s1:.2f} |")
    if not before:
        return
    print()
    print("| single-kind scene | before: first / cached ms | after: first / cached ms | after ÷ before (cached) |")
    print("|---|---:|---:|---:|")
    for scene in ["cranium.json", "1aon.json", "ct-body.json"]:
        b, a = [], []
        for _ in range(RUNS):  # interleaved
            b.append(frame_times(before, scene, []))
            a.append(frame_times(after, scene, []))
        bm = (statistics.median(x[0] for x in b), statistics.median(x[1] for x in b))
        am = (statistics.median(x[0] for x in a), statistics.median(x[1] for x in a))
        print(f"| {scene} | {bm[0]:.0f} / {bm[1]:.0f} | {am[0]:.0f} / {am[1]:.0f} | {am[1] / bm[1]:.2f} |")


if __name__ == "__main__":
    main()
