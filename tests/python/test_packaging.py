"""The package as users install and type-check it (issue 41): `pip install --no-build-isolation .` into a
fresh virtual environment puts the module, its stubs and the `penumbra` command there, importable from
any folder with no PYTHONPATH; the stubs pass `mypy --strict` on examples/python; the examples run.

The wheel is packed by the in-tree backend (python/build_backend/penumbra_build.py) from the build tree
the suite already built (config settings build-dir and prebuilt: nothing is rebuilt under the other
tests' feet), so this checks the packaging, not a second compile.
"""
import os
import shutil
import subprocess
import sys
import zipfile

import pytest

ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
BUILD_DIR = os.path.dirname(os.path.abspath(shutil.which(CLI) or CLI))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
EXAMPLES = os.path.join(ROOT, "examples", "python")


def run(command, **kw):
    result = subprocess.run(command, capture_output=True, text=True, timeout=900, **kw)
    assert result.returncode == 0, f"{' '.join(map(str, command))}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    pytest.importorskip("pip")
    pytest.importorskip("venv")
    if not os.path.exists(os.path.join(BUILD_DIR, "CMakeCache.txt")):
        pytest.skip(f"{CLI} is not in a CMake build tree")
    env_dir = tmp_path_factory.mktemp("env")
    # --system-site-packages: NumPy (and MDAnalysis) from Debian, as the package's one dependency
    run([sys.executable, "-m", "venv", "--system-site-packages", str(env_dir)])
    wheels = tmp_path_factory.mktemp("wheels")
    run([str(env_dir / "bin" / "pip"), "wheel", "--no-build-isolation", "--no-index", "--no-deps", "-w", str(wheels),
         "--config-settings", f"build-dir={BUILD_DIR}", "--config-settings", "prebuilt=1", ROOT], cwd=str(wheels))
    wheel = next(wheels.glob("penumbra-*.whl"))
    run([str(env_dir / "bin" / "pip"), "install", "--no-index", "--no-deps", str(wheel)])
    return env_dir, wheel


def test_the_wheel_holds_the_module_its_stubs_and_the_command(venv):
    _, wheel = venv
    names = zipfile.ZipFile(wheel).namelist()
    assert "penumbra/__init__.py" in names and "penumbra/__init__.pyi" in names and "penumbra/py.typed" in names
    assert any(n.startswith("penumbra/_penumbra") and n.endswith(".so") for n in names)
    assert any(n.endswith(".data/scripts/penumbra") for n in names)
    assert any(n.endswith(".dist-info/RECORD") for n in names)


def test_the_installed_package_imports_from_any_folder_and_the_command_runs(venv, tmp_path):
    env_dir, _ = venv
    environment = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PENUMBRA_CLI")}
    out = run([str(env_dir / "bin" / "python"), "-c",
               "import penumbra, numpy as np; r = penumbra.Renderer({'camera': {'width': 16, 'height': 12}, "
               "'volumes': [{'procedural': {'name': 'test-spheres', 'size': 16}}]}); img = r.render(); "
               "print(penumbra.__file__); print(img.shape, type(img[..., 0]).__name__)"], cwd=str(tmp_path), env=environment)
    location, shape = out.stdout.splitlines()[:2]
    assert location.startswith(str(env_dir)), location
    assert shape == "(12, 16, 4) ndarray"
    version = run([str(env_dir / "bin" / "penumbra"), "--version"], cwd=str(tmp_path), env=environment)
    assert version.stdout.startswith("penumbra 0."), version.stdout


def mypy_sees_the_package(monkeypatch):
    monkeypatch.setenv("MYPYPATH", os.path.join(BUILD_DIR, "python"))  # the stubs beside the built module


def test_the_stubs_pass_mypy_strict_on_the_examples(monkeypatch):
    mypy = pytest.importorskip("mypy.api")
    mypy_sees_the_package(monkeypatch)
    stdout, stderr, status = mypy.run(["--config-file", os.path.join(EXAMPLES, "mypy.ini"), "--cache-dir", "/dev/null", EXAMPLES])
    assert status == 0, stdout + stderr


def test_the_stubs_match_the_module(monkeypatch):
    """mypy's stubtest: every public name of the stubs exists at run time with the same arguments."""
    stubtest = pytest.importorskip("mypy.stubtest")
    mypy_sees_the_package(monkeypatch)
    monkeypatch.setattr(sys, "argv", ["stubtest", "penumbra", "--ignore-missing-stub"])
    assert stubtest.main() == 0


def test_a_stub_error_is_caught(tmp_path, monkeypatch):
    """mypy must fail on a wrong call (a test that cannot pass without the stubs being read)."""
    mypy = pytest.importorskip("mypy.api")
    mypy_sees_the_package(monkeypatch)
    bad = tmp_path / "bad.py"
    bad.write_text("import penumbra\nr = penumbra.Renderer({})\nr.render(width='wide')\nx: str = r.is_set('camera.eye')\n")
    stdout, stderr, status = mypy.run(["--config-file", os.path.join(EXAMPLES, "mypy.ini"), "--cache-dir", "/dev/null", str(bad)])
    assert status == 1
    assert 'Argument "width"' in stdout and "bool" in stdout, stdout


def test_the_examples_run(tmp_path):
    run([sys.executable, os.path.join(EXAMPLES, "numpy_volume.py"), str(tmp_path / "v.png")])
    assert (tmp_path / "v.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    gro, xtc = os.path.join(DATA, "md_1tii_chainD.gro"), os.path.join(DATA, "md_1tii_chainD.xtc")
    if not os.path.exists(xtc):
        pytest.skip(f"missing data: {xtc}")
    pytest.importorskip("MDAnalysis")
    out = run([sys.executable, os.path.join(EXAMPLES, "md_trajectory.py"), gro, xtc]).stdout
    assert out.count("frame ") == 4, out
