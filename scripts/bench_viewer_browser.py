#!/usr/bin/env python3
"""End-to-end latency of `penumbra view` in a real browser, for docs/BENCHMARKS.md.

usage: scripts/bench_viewer_browser.py PENUMBRA [SCENE ...]   (default scenes/cranium.json scenes/1aon.json)

Debian's headless chromium (python3-selenium, chromium-driver) opens the page. For each edit type
(orbit, light drag, transfer function; the edits of scripts/bench_viewer.py) the page's own socket
sends 10 single edits. The time runs from the send, in the page, to the `load` event of the <img
id="view"> that shows the first frame carrying the edit (decoded and on the page), and to the first
full-quality frame. A continuous drag (edits every 16 ms for 4 s) counts the frames shown per second.
The page's pointer handlers add at most one animation frame (16 ms) before the send.
"""
import json
import math
import os
import statistics
import subprocess
import sys
import time

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_viewer import edits_for, p95  # noqa: E402  (same edits as the WebSocket benchmark)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Installed once per page: records, for the edit sent at window.__t0 with path window.__path, the time
# to the first image load whose frame carries the path, and to the first full-quality one after it.
PROBE = """
const img = document.getElementById('view');
window.__shown = 0;
img.addEventListener('load', () => {
  window.__shown += 1;
  const f = window.penumbraViewer.lastFrame;
  if (!window.__path || !f) return;
  const now = performance.now();
  if (window.__preview === null && (f.edits || []).includes(window.__path)) window.__preview = now - window.__t0;
  if (window.__preview !== null && window.__full === null && f.quality === 'full') window.__full = now - window.__t0;
});
"""


def edit_in_page(driver, paths):
    key = next(iter(paths))
    driver.execute_script("window.__path = arguments[0]; window.__preview = null; window.__full = null;"
                          "window.__t0 = performance.now(); window.penumbraViewer.send({type: 'edit', set: arguments[1]});", key, paths)
    end = time.time() + 120
    while time.time() < end:
        preview, full = driver.execute_script("return [window.__preview, window.__full];")
        if full is not None:
            return preview, full
        time.sleep(0.005)
    raise RuntimeError("no full frame within 120 s")


def drag_in_page(driver, make, seconds=4.0):
    edits = [make(k) for k in range(1, int(seconds * 60) + 1)]
    return driver.execute_async_script("""
      const [edits, seconds, done] = arguments;
      const start = performance.now(), shown = window.__shown;
      let k = 0;
      const timer = setInterval(() => {
        if (k < edits.length) window.penumbraViewer.send({type: 'edit', set: edits[k++]});
        if (performance.now() - start >= seconds * 1000) {
          clearInterval(timer);
          done((window.__shown - shown) / ((performance.now() - start) / 1000));
        }
      }, 16);
    """, edits, seconds)


def main():
    cli = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "release", "penumbra")
    scenes = sys.argv[2:] or ["scenes/cranium.json", "scenes/1aon.json"]
    options = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1200,800"):
        options.add_argument(a)
    rows = []
    for name in scenes:
        server = subprocess.Popen([cli, "view", os.path.join(ROOT, name), "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
        driver.set_script_timeout(120)
        try:
            driver.get(server.stdout.readline().strip())
            driver.execute_script(PROBE)
            end = time.time() + 120
            while not driver.execute_script("const v = window.penumbraViewer; return v && v.state && v.lastFrame && v.lastFrame.quality === 'full' && v.lastFrame.samples >= 2;"):
                if time.time() > end:
                    raise RuntimeError("the page showed no full frame")
                time.sleep(0.05)
            state = driver.execute_script("return window.penumbraViewer.state;")
            size = driver.execute_script("const f = window.penumbraViewer.lastFrame; return f.width + 'x' + f.height;")
            for kind, make in edits_for(state).items():
                previews, fulls = [], []
                for k in range(1, 11):
                    p, f = edit_in_page(driver, make(k))
                    previews.append(p)
                    fulls.append(f)
                fps = drag_in_page(driver, make)
                edit_in_page(driver, make(1))  # settle
                rows.append((os.path.basename(name), size, kind, statistics.median(previews), p95(previews), statistics.median(fulls), p95(fulls), fps))
                print(rows[-1], file=sys.stderr)
        finally:
            driver.quit()
            server.terminate()
            server.wait()
    print("| scene | view | edit | to the preview on the page, median / p95 ms | to the full frame, median / p95 ms | frames shown per second while dragging |")
    print("|---|---|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.0f} / {r[4]:.0f} | {r[5]:.0f} / {r[6]:.0f} | {r[7]:.1f} |")


if __name__ == "__main__":
    main()
