#!/usr/bin/env python3
"""The viewer server's memory over a long run of scripted edits (issue 40), for docs/BENCHMARKS.md.

usage: scripts/bench_viewer_memory.py PENUMBRA [--minutes M] [--scene SCENE.json]

A server is started on the scene (default: the staged GROMACS run with ISSM, its trajectory played)
and two clients connect: one edits as a user would — orbits, light moves, transfer-function or
colour-by changes, time steps, probes — waiting for each edit's full frame; the other connects and
never reads (its queue must stay bounded). The server's resident memory (VmRSS) is sampled every 10 s.
Reported: RSS after the first minute, at the end, the peak, and the growth per hour from a
least-squares line through the samples after the first minute.
"""
import argparse
import json
import math
import os
import pathlib
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))


def rss_mb(pid):
    for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def edit_for(k, frames):
    angle = k * 0.21
    kind = k % 4
    if kind == 0:
        return {"camera.eye": [60 * math.sin(angle), 20, 60 * math.cos(angle)]}
    if kind == 1:
        return {"lights.0.direction": [math.sin(angle), -1, math.cos(angle)]}
    if kind == 2:
        return {"particles.0.color_by": ["element", "chain", "residue"][k % 3]}
    return {"time": k % frames}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("penumbra")
    parser.add_argument("--minutes", type=float, default=10)
    args = parser.parse_args()
    os.environ["PENUMBRA_CLI"] = os.path.abspath(args.penumbra)  # read when the test helpers are imported
    import test_viewer_protocol as protocol

    scene = {"particles": [{"file": os.path.join(DATA, "md_1tii_chainD.gro"), "trajectory": os.path.join(DATA, "md_1tii_chainD.xtc")}],
             "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
             "shadows": {"technique": "issm"}, "camera": {"eye": [0, 20, 60], "target": [32, 32, 32], "width": 896, "height": 657}}
    with tempfile.TemporaryDirectory() as folder:
        server = protocol.Viewer(pathlib.Path(folder), scene, "--data-root", os.path.abspath(DATA))
        try:
            silent = server.connect()  # never reads
            editor = server.connect()
            state = protocol.receive(editor, "state")
            frames = state["time"]["frames"]
            samples, edits = [], 0
            began = time.time()
            next_sample = began
            while time.time() - began < args.minutes * 60:
                edit = edit_for(edits, frames)
                editor.send(json.dumps({"type": "edit", "set": edit}))
                if edits % 7 == 0:
                    editor.send(json.dumps({"type": "probe", "pixel": [100 + edits % 600, 100 + edits % 400]}))
                path = next(iter(edit))
                while True:  # this edit's full frame
                    meta, _ = protocol.receive(editor, "frame")
                    if meta["quality"] == "full" and (path in meta["edits"] or meta["samples"] > 1):
                        break
                edits += 1
                if time.time() >= next_sample:
                    samples.append((time.time() - began, rss_mb(server.process.pid)))
                    next_sample += 10
            samples.append((time.time() - began, rss_mb(server.process.pid)))
            silent.close()
            editor.close()
        finally:
            server.close()
    late = [(t, m) for t, m in samples if t >= 60] or samples
    n = len(late)
    mt, mm = sum(t for t, _ in late) / n, sum(m for _, m in late) / n
    slope = sum((t - mt) * (m - mm) for t, m in late) / max(1e-9, sum((t - mt) ** 2 for t, _ in late))
    print(f"{edits} edits in {samples[-1][0] / 60:.1f} min ({edits / samples[-1][0]:.1f} a second)")
    print(f"RSS after 1 min {late[0][1]:.0f} MB, at the end {samples[-1][1]:.0f} MB, peak {max(m for _, m in samples):.0f} MB, "
          f"trend {slope * 3600:+.1f} MB/hour")
    print(json.dumps({"edits": edits, "samples": samples}))


if __name__ == "__main__":
    main()
