"""scripts/bench_peers.py runs end to end without the peers (they are not installed in CI): it reports
penumbra's frames with their error against the exact references and says the peer is missing."""
import json
import os
import subprocess
import sys

ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))


def test_the_peers_benchmark_runs_and_measures_penumbra_against_its_references(tmp_path):
    build = os.path.dirname(os.path.dirname(os.path.abspath(__import__("penumbra").__file__)))
    out = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "bench_peers.py"), "--quick", "--penumbra-only",
                          "--build", build, "--out", str(tmp_path), "--reference-width", "160"],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    report = json.loads((tmp_path / "peers.json").read_text())
    assert report["tachyon"] is None and "not run" in out.stdout
    for name in ("issm", "issm + particle_ao"):
        frames = report["penumbra"][name]
        assert frames["cached"]["build"] < frames["moving"]["build"]  # the cached frame rebuilt no map
        assert 20 < report["error"][name]["psnr_db"] < 80  # close to the reference, not equal to it
        assert os.path.getsize(tmp_path / ("penumbra_" + name.replace(" + ", "_") + ".png")) > 1000
    volume = report["volume"]
    assert volume["paraview"] is None and set(volume["penumbra"]) == {"unshadowed", "cssm shadows"}
    assert all(v["frame_ms"] > 0 for v in volume["penumbra"].values())
