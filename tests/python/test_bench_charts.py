"""scripts/bench_charts.py: `penumbra bench` draws, per scene, its techniques' error against frame time,
each point sized by memory; without matplotlib it says so and succeeds."""
import importlib.util
import json
import os
import subprocess
import sys

import pytest

ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(ROOT, "scripts", "bench_charts.py")
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))


def load_script():
    spec = importlib.util.spec_from_file_location("bench_charts", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_points_come_from_every_suite_with_their_reference_time_and_memory():
    bench = {
        "datasets": {"a": {"ray_traced_ms": 90.0, "runs": [
            {"technique": "cssm", "resolution": 512, "render_ms": 10.0, "psnr": 35.0, "memory_bytes": 1048576}]}},
        "extinction": {"frames": {"b": {"plain_ms": 5.0, "shadows_ms": 6.0, "ao_ms": 5.5, "lit_ms": 6.5,
                                        "reference_ms": 900.0,
                                        "psnr": {"plain_vs_ray": 20.0, "cone_vs_ray": 40.0, "ao_vs_sampled": 50.0,
                                                 "lit_vs_reference": 38.0},
                                        "memory_bytes": {"ao": 2097152, "shadows": 1048576, "lit": 3145728}}}},
        "particles": {"datasets": {"c": {"configs": {"issm": {"cached_ms": 3.0, "shadow_bytes": 1048576}},
                                         "error": {"issm_vs_ray_traced": {"psnr": "inf"}}}}},
    }
    scenes = {(suite, scene): (pts, ref) for suite, scene, pts, ref in load_script().all_scenes(bench)}
    assert set(scenes) == {("cssm", "a"), ("extinction", "b"), ("particles", "c")}
    pts, ref = scenes[("cssm", "a")]
    assert ref == ("ray_traced", 90.0) and pts[0]["mib"] == 1.0 and pts[0]["psnr"] == 35.0
    lit = [p for p in scenes[("extinction", "b")][0] if p["label"] == "sat_cone + sat_shells"][0]
    assert (lit["ms"], lit["psnr"], lit["mib"], lit["reference"]) == (6.5, 38.0, 3.0, "ray_traced + sampled_ao")
    assert scenes[("particles", "c")][0][0]["psnr"] == float("inf")  # equal to the reference: drawn on its line


def test_bench_writes_one_chart_per_scene(tmp_path):
    pytest.importorskip("matplotlib")
    cli = os.environ.get("PENUMBRA_CLI")
    if not cli:
        pytest.skip("PENUMBRA_CLI not set")
    out = subprocess.run([cli, "bench", "--quick", "-o", str(tmp_path)], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"]})
    assert out.returncode == 0, out.stderr
    charts = sorted(p.name for p in tmp_path.glob("chart_*.png"))
    # --quick runs the particles suite on the staged 1tii when it is there
    suites = ("cssm", "dsm", "extinction") + (("particles",) if os.path.exists(os.path.join(DATA, "1tii.pdb")) else ())
    for suite in suites:
        assert any(name.startswith("chart_" + suite + "_") for name in charts), (suite, charts, out.stderr)
    listed = (tmp_path / "charts.md").read_text()
    for name in charts:
        assert "(" + name + ")" in listed
        assert os.path.getsize(tmp_path / name) > 5000


def test_without_matplotlib_it_says_so_and_succeeds(tmp_path):
    (tmp_path / "bench.json").write_text(json.dumps({"datasets": {}}))
    blocker = tmp_path / "block"
    (blocker / "matplotlib").mkdir(parents=True)
    (blocker / "matplotlib" / "__init__.py").write_text("raise ImportError('blocked for the test')\n")
    out = subprocess.run([sys.executable, SCRIPT, str(tmp_path)], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "PYTHONPATH": str(blocker)})
    assert out.returncode == 0, out.stderr
    assert "matplotlib not installed" in out.stdout
    assert not list(tmp_path.glob("chart_*"))


def test_an_unreadable_bench_file_is_named(tmp_path):
    out = subprocess.run([sys.executable, SCRIPT, str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert out.returncode != 0 and "bench.json" in out.stderr
