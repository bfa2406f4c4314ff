#!/usr/bin/env python3
"""Edit-to-frame latency of `penumbra view` over its WebSocket, for docs/BENCHMARKS.md.

usage: scripts/bench_viewer.py PENUMBRA [SCENE[:WxH] ...]   (default scenes/cranium.json scenes/1aon.json)

For each scene a server is started and a client (python3-websocket) plays what a page sends:
- orbit: camera.eye turning about the target;
- light drag: the first light's direction turning;
- transfer function: the first visible volume's points with the opacity scaled.
Each of 10 single edits waits for the frames to settle (full quality). It measures the time from
sending the edit to the first frame that carries it, with its JPEG received (the preview), and to the
first full-quality frame. Then a continuous drag sends 60 edits a second for 4 s and counts the frames
that arrive (previews a second). The figures exclude the browser's JPEG decode and paint (about 1–3 ms
at these sizes).
"""
import json
import math
import os
import statistics
import subprocess
import sys
import time

import websocket

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def turned(v, a, up=(0, 1, 0)):  # v rotated by a about the axis up (Rodrigues)
    ux, uy, uz = up
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / n, uy / n, uz / n
    c, s = math.cos(a), math.sin(a)
    d = ux * v[0] + uy * v[1] + uz * v[2]
    cx, cy, cz = uy * v[2] - uz * v[1], uz * v[0] - ux * v[2], ux * v[1] - uy * v[0]
    return [v[0] * c + cx * s + ux * d * (1 - c), v[1] * c + cy * s + uy * d * (1 - c), v[2] * c + cz * s + uz * d * (1 - c)]


class Client:
    def __init__(self, url):
        base, _, query = url.partition("/?")
        self.ws = websocket.create_connection(base.replace("http://", "ws://") + "/ws?" + query, timeout=120)
        self.state = None

    def next(self):
        while True:
            op, data = self.ws.recv_data()
            if op != websocket.ABNF.OPCODE_TEXT:
                continue
            m = json.loads(data)
            if m["type"] == "state":
                self.state = m
            elif m["type"] == "frame":
                self.ws.recv_data()  # the JPEG
                return m
            elif m["type"] == "error":
                raise RuntimeError(m["message"])

    def settle(self):
        while True:
            f = self.next()
            if f["quality"] == "full":
                return f

    def edit(self, paths):
        self.ws.send(json.dumps({"type": "edit", "set": paths}))


def edits_for(state):
    cam = state["camera"]
    eye, target, up = cam["eye"], cam["target"], cam["up"]
    rel = [eye[i] - target[i] for i in range(3)]
    doc = state["document"]
    out = {"orbit": lambda k: {"camera.eye": [target[i] + turned(rel, 0.05 * k, up)[i] for i in range(3)]}}
    lights = doc.get("lights")
    if lights and lights[0].get("type", "directional") != "point":
        d = lights[0].get("direction", [-0.4, -1, -0.3])
        out["light drag"] = lambda k: {"lights.0.direction": turned(d, 0.05 * k, up)}
    if state["transfer_functions"]:
        tf = state["transfer_functions"][0]
        pts = tf["points"]
        out["transfer function"] = lambda k: {f"volumes.{tf['volume']}.transfer_function": {"points": [[p[0], p[1], p[2], p[3], min(1.0, p[4] * (1 + 0.05 * (k % 7)))] for p in pts]}}
    return out


def measure(client, make, steps=10):
    preview, full = [], []
    for k in range(1, steps + 1):
        paths = make(k)
        key = next(iter(paths))
        t0 = time.perf_counter()
        client.edit(paths)
        got_preview = None
        while True:
            f = client.next()
            if key in f.get("edits", []) and got_preview is None:
                got_preview = 1e3 * (time.perf_counter() - t0)
            if got_preview is not None and f["quality"] == "full":
                full.append(1e3 * (time.perf_counter() - t0))
                break
        preview.append(got_preview)
    return preview, full


def drag(client, make, seconds=4.0, rate=60):
    frames, k, start = 0, 0, time.perf_counter()
    client.ws.settimeout(0.001)
    next_send = start
    while time.perf_counter() - start < seconds:
        now = time.perf_counter()
        if now >= next_send:
            k += 1
            client.edit(make(k))
            next_send += 1.0 / rate
        try:
            op, data = client.ws.recv_data()
            if op == websocket.ABNF.OPCODE_BINARY:
                frames += 1
        except websocket.WebSocketTimeoutException:
            pass
    client.ws.settimeout(120)
    fps = frames / (time.perf_counter() - start)
    client.settle()
    return fps


def p95(v):
    return sorted(v)[min(len(v) - 1, int(math.ceil(0.95 * len(v))) - 1)]


def main():
    cli = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "release", "penumbra")
    scenes = sys.argv[2:] or ["scenes/cranium.json", "scenes/1aon.json"]
    rows = []
    for spec in scenes:
        name, _, size = spec.partition(":")
        args = [cli, "view", os.path.join(ROOT, name) if not os.path.isabs(name) else name, "--port", "0"]
        if size:
            w, h = size.split("x")
            args += ["--set", f"camera.width={w}", "--set", f"camera.height={h}"]
        server = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            client = Client(server.stdout.readline().strip())
            client.settle()
            for kind, make in edits_for(client.state).items():
                preview, full = measure(client, make)
                fps = drag(client, make)
                rows.append((os.path.basename(name), kind, statistics.median(preview), p95(preview), statistics.median(full), p95(full), fps))
                print(rows[-1], file=sys.stderr)
        finally:
            server.terminate()
            server.wait()
    print("| scene | edit | preview median / p95 ms | full median / p95 ms | previews per second while dragging |")
    print("|---|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.0f} / {r[3]:.0f} | {r[4]:.0f} / {r[5]:.0f} | {r[6]:.1f} |")


if __name__ == "__main__":
    main()
