#!/usr/bin/env python3
"""Trajectory playback in `penumbra view`, in a real browser (issue 40), for docs/BENCHMARKS.md.

usage: scripts/bench_viewer_playback.py PENUMBRA [--seconds S] [--runs N]

The staged GROMACS run (../shared/data/md_1tii_chainD.gro + .xtc, 18,182 atoms, 151 frames) opens in
Debian's headless chromium at the page's default view (a 1200×800 window). For each shadow setup the
page's Play runs for S seconds at its own pace (10 steps a second) and, to find the ceiling, asking for
a step as soon as the last one's full frame is shown (fps 1000: everything not rendered in time is
skipped). Reported: full frames shown per second, the steps skipped, and the view's size. The page
never queues steps (time.js), so a slow setup plays at its true pace with fewer frames.
"""
import argparse
import json
import os
import pathlib
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))

SETUPS = [
    ("local lighting", {"technique": "none"}, {"technique": "none"}),
    ("issm", {"technique": "issm"}, {"technique": "none"}),
    ("issm + particle_ao", {"technique": "issm"}, {"technique": "particle_ao"}),
]


def play(browser, driver, fps, seconds):
    By, js = browser.By, browser.js
    driver.execute_script(f"window.penumbraViewer.playback.fps = {fps}")
    driver.find_element(By.ID, "play").click()
    time.sleep(seconds)
    driver.find_element(By.ID, "play").click()
    p = js(driver, "window.penumbraViewer.playback")
    time.sleep(1)  # the last step's frame
    return {"shown_per_s": p["shown"] / seconds, "skipped": p["skipped"], "steps": p["step"]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("penumbra")
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    os.environ["PENUMBRA_CLI"] = os.path.abspath(args.penumbra)  # read when the test helpers are imported
    import test_viewer_browser as browser

    topology, trajectory = os.path.join(DATA, "md_1tii_chainD.gro"), os.path.join(DATA, "md_1tii_chainD.xtc")
    rows = []
    for name, shadows, ambient in SETUPS:
        scene = {"particles": [{"file": topology, "trajectory": trajectory}],
                 "lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
                 "shadows": shadows, "ambient": ambient}
        paced, ceiling = [], []
        for _ in range(args.runs):  # interleaved: a fresh server and page each run
            with tempfile.TemporaryDirectory() as folder:
                server = browser.Viewer(pathlib.Path(folder), scene, "--data-root", os.path.abspath(DATA))
                driver = browser.chrome()
                try:
                    driver.get(server.url)
                    browser.wait_loaded(driver)
                    time.sleep(2)  # the first full frame and its refinement
                    view = browser.js(driver, "[window.penumbraViewer.state.camera.width, window.penumbraViewer.state.camera.height]")
                    paced.append(play(browser, driver, 10, args.seconds))
                    ceiling.append(play(browser, driver, 1000, args.seconds))
                finally:
                    driver.quit()
                    server.close()
        rows.append({"setup": name, "view": view,
                     "paced_fps": [round(r["shown_per_s"], 1) for r in paced], "paced_skipped": [r["skipped"] for r in paced],
                     "ceiling_fps": [round(r["shown_per_s"], 1) for r in ceiling]})
    print("| setup | view | fps at the page's 10/s (runs) | skipped | ceiling fps (runs) |")
    print("|---|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r['setup']} | {r['view'][0]}×{r['view'][1]} | {' / '.join(map(str, r['paced_fps']))} | "
              f"{' / '.join(map(str, r['paced_skipped']))} | {' / '.join(map(str, r['ceiling_fps']))} "
              f"(median {statistics.median(r['ceiling_fps'])}) |")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
