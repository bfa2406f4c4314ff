"""Playing a trajectory from Python and from the command line (issue 18): the staged GROMACS run
(topology .gro + trajectory .xtc) as a scene whose `time` is an edit; frames read one at a time."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import penumbra

ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
GRO = os.path.join(DATA, "md_1tii_chainD.gro")
XTC = os.path.join(DATA, "md_1tii_chainD.xtc")
CLI = os.environ.get("PENUMBRA_CLI", "penumbra")

needs_md = pytest.mark.skipif(not (os.path.exists(GRO) and os.path.exists(XTC)), reason="missing data: the staged MD trajectory")


def md_scene():
    return {
        "particles": [{"file": GRO, "trajectory": XTC}],
        "lights": [{"type": "directional", "direction": [0.3, -1, -0.4]}],
        "shadows": {"technique": "issm", "resolution": 256},
        "camera": {"width": 96, "height": 72},
    }


@needs_md
def test_set_time_plays_the_trajectory_and_rebuilds_only_the_spheres():
    r = penumbra.Renderer(md_scene())
    assert r.frames == 151
    first = r.render().copy()
    r.set("time", 150)
    last = r.render()
    rebuilt = {e["structure"] for e in r.stats["rebuilt"]}
    assert {"spheres", "lights.0.shadows"} <= rebuilt
    assert all(e["cause"] == "time" for e in r.stats["rebuilt"])
    assert np.abs(first.astype(int) - last.astype(int)).max() > 20  # 30 ps later the water has moved
    r.set("time", 0)
    assert np.array_equal(r.render(), first)  # back to frame 0: the same image
    with pytest.raises(penumbra.Error, match="151 frames"):
        r.set("time", 151)


@needs_md
def test_render_frames_writes_a_sequence_with_per_frame_stats(tmp_path):
    scene = tmp_path / "md.json"
    scene.write_text(json.dumps(md_scene()))
    out = subprocess.run([CLI, "render", str(scene), "--frames", "10:40:15", "-o", str(tmp_path / "md.png"),
                          "--stats", str(tmp_path / "stats.json")], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    frames = json.loads((tmp_path / "stats.json").read_text())["frames"]
    assert [f["time"] for f in frames] == [10, 25, 40]
    assert [round(f["time_ps"], 3) for f in frames] == [2.0, 5.0, 8.0]  # the XTC's dt is 0.2 ps
    assert all(os.path.getsize(tmp_path / f"md_{i:03d}.png") > 1000 for i in range(3))
    bad = subprocess.run([CLI, "render", str(scene), "--frames", "0:151", "-o", str(tmp_path / "x.png")],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode != 0 and "151 frames" in bad.stderr


@needs_md
def test_the_playback_benchmark_runs(tmp_path):
    build = os.path.dirname(os.path.abspath(CLI))
    out = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "bench_playback.py"),
                          "--build", build, "--frames", "0:6:3", "--size", "64x48", "--out", str(tmp_path)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    results = json.loads((tmp_path / "playback.json").read_text())["results"]
    assert set(results) == {"local lighting", "issm", "issm + particle_ao", "issm 512²", "issm 512² + particle_ao",
                            "issm + particle_ao reuse 0.25", "issm + particle_ao reuse 0.5"}
    assert all(r["frames"] == 2 and r["fps"] > 0 and r["read_ms"] > 0 for r in results.values())
    assert "spheres" in results["issm"]["rebuilt"] and "lights.0.shadows" in results["issm"]["rebuilt"]
    # the reuse rows are compared with the frames traced anew (this run's water moves too far: nothing kept)
    reuse = results["issm + particle_ao reuse 0.5"]
    assert reuse["psnr_worst"] > 20 and reuse["max_pixel_difference"] >= 0 and len(reuse["ambient_kept"]) == 2


@needs_md
def test_ambient_reuse_keeps_the_cones_of_atoms_that_moved_little():
    scene = md_scene()
    scene["ambient"] = {"technique": "particle_ao", "reuse": 1.0}
    r = penumbra.Renderer(scene)
    r.render()
    assert r.stats["counts"]["ambient_kept"] == 0  # the first build traces every cone
    r.set("time", 1)
    kept = r.render().copy()
    assert r.stats["counts"]["ambient_kept"] > 0.5 * r.stats["particles"][0]["spheres"]
    r.set("ambient.reuse", 0.0)  # an edit of the AO's settings starts afresh
    fresh = r.render()
    assert r.stats["counts"]["ambient_kept"] == 0
    scene["ambient"] = {"technique": "particle_ao"}
    scene["time"] = 1
    assert np.array_equal(fresh, penumbra.Renderer(scene).render())
    diff = np.abs(kept.astype(int) - fresh.astype(int))
    assert diff.max() < 64 and diff.mean() < 1.0  # the cones kept from frame 0 stay close to frame 1's


def series_scene():
    return {
        "volumes": [{"procedural": {"name": "sphere", "size": 20, "radius": 0.15, "frames": 5},
                     "transfer_function": {"points": [[0, 0, 0, 0, 0], [0.5, 0.9, 0.5, 0.3, 0], [1, 0.9, 0.5, 0.3, 0.9]]}}],
        "planes": [{"point": [0, -0.6, 0], "normal": [0, 1, 0], "size": 3}],
        "shadows": {"technique": "cssm", "resolution": 64},
        "camera": {"width": 48, "height": 32},
    }


def test_video_is_encoded_with_ffmpeg_or_refused_clearly_without_it(tmp_path):
    """--video encodes the sequence through Debian's ffmpeg; without ffmpeg it is an error before
    anything is rendered (the frames alone need no ffmpeg)."""
    import shutil
    scene = tmp_path / "series.json"
    scene.write_text(json.dumps(series_scene()))
    out = subprocess.run([CLI, "render", str(scene), "--frames", "0:4", "-o", str(tmp_path / "s.png"),
                          "--video", str(tmp_path / "s.mp4")], capture_output=True, text=True, timeout=300)
    if shutil.which("ffmpeg") is None:
        assert out.returncode != 0 and "ffmpeg not found" in out.stderr
        assert not (tmp_path / "s_000.png").exists()
        return
    assert out.returncode == 0, out.stderr
    probe = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-show_entries", "stream=nb_read_frames,width,height",
                            "-of", "json", str(tmp_path / "s.mp4")], capture_output=True, text=True, timeout=60)
    stream = json.loads(probe.stdout)["streams"][0]
    assert (int(stream["nb_read_frames"]), stream["width"], stream["height"]) == (5, 48, 32)
