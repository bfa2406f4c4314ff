"""The Python package (python/penumbra): scenes as dicts and files, the engine's edits, frames as
NumPy arrays, errors as exceptions. Run by ctest (the `python` test) with the built package on
PYTHONPATH; PENUMBRA_CLI is the built command-line tool the images are checked against."""
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import penumbra
from cli_outputs import read_pfm

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))


def small_scene(technique="cssm"):
    return {
        "volumes": [{"procedural": {"name": "test-spheres", "size": 24}, "transfer_function": {"preset": "test-spheres", "opacity_scale": 3}}],
        "planes": [{"point": [0, -0.6, 0], "normal": [0, 1, 0], "size": 3}],
        "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
        "shadows": {"technique": technique, "resolution": 64},
        "camera": {"width": 40, "height": 32},
    }


def test_dict_scene_renders_what_the_cli_renders_from_the_same_file(tmp_path):
    scene = small_scene()
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    subprocess.run([CLI, "render", str(path), "-o", str(tmp_path / "cli.pfm")], check=True, capture_output=True)
    cli = read_pfm(tmp_path / "cli.pfm")
    image = penumbra.Renderer(penumbra.Scene(scene)).render(dtype="float32")
    assert image.shape == (32, 40, 4)
    assert np.all(image[..., 3] == 1)
    assert np.array_equal(image[..., :3], cli), "the Python frame differs from the CLI's"
    # a file loaded from Python is the same scene
    loaded = penumbra.Renderer(penumbra.Scene.load(path)).render(dtype="float32")
    assert np.array_equal(loaded, image)


def test_load_applies_overrides_and_resolves_paths():
    scene = penumbra.Scene.load(os.path.join(ROOT, "scenes", "test-spheres.json"), ["camera.width=24", "camera.height=20"])
    assert scene.document["camera"]["width"] == 24
    image = penumbra.Renderer(scene).render()
    assert image.shape == (20, 24, 4) and image.dtype == np.uint8


def test_edits_rebuild_what_they_change_and_match_a_fresh_renderer():
    r = penumbra.Renderer(small_scene())
    r.render()
    r.set("lights.0.direction", [0.3, -1, 0.1])
    edited = r.render(dtype="float32")
    assert r.stats["rebuilt"] == [{"structure": "lights.0.shadows", "cause": "lights.0.direction"}]
    assert r.stats["edits"] == ["lights.0.direction"]
    fresh_scene = small_scene()
    fresh_scene["lights"][0]["direction"] = [0.3, -1, 0.1]
    assert np.array_equal(edited, penumbra.Renderer(fresh_scene).render(dtype="float32"))
    r.set("camera.direction", [1, 0.2, 0.3])
    r.render()
    assert r.stats["rebuilt"] == []
    assert r.get("camera.direction") == [1, 0.2, 0.3]


def test_uint8_is_srgb_of_the_float_frame_and_shows_itself_in_jupyter():
    r = penumbra.Renderer(small_scene())
    linear = r.render(dtype="float32")
    srgb = r.render(dtype="uint8")
    expected = np.where(linear[..., :3] <= 0.0031308, 12.92 * linear[..., :3], 1.055 * np.power(np.clip(linear[..., :3], 0, 1), 1 / 2.4) - 0.055)
    assert np.max(np.abs(srgb[..., :3].astype(float) - np.clip(expected, 0, 1) * 255)) <= 1.0
    png = srgb._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 100
    assert penumbra.compare(srgb, srgb)["rmse"] == 0
    assert penumbra.compare(linear, penumbra.Renderer(small_scene("none")).render(dtype="float32"))["psnr"] < 40


def test_transparent_background_has_zero_alpha():
    scene = small_scene()
    scene["planes"] = []
    image = penumbra.Renderer(scene).render(dtype="float32", transparent=True)
    assert image[0, 0, 3] == 0 and np.all(image[0, 0, :3] == 0)
    assert image[..., 3].max() > 0.5


def test_size_arguments_resize_without_rebuilding():
    r = penumbra.Renderer(small_scene())
    r.render()
    image = r.render(width=64, height=48)
    assert image.shape == (48, 64, 4)
    assert r.stats["rebuilt"] == []


@pytest.mark.parametrize("make, message", [
    (lambda: penumbra.Renderer({"camera": {"nonsense": 1}}), "camera.nonsense"),
    (lambda: penumbra.Renderer({"volumes": [{"procedural": {"name": "nope"}}]}), "volumes.0"),
    (lambda: penumbra.Scene([1, 2]), "expected a dict"),
    (lambda: penumbra.Scene.load("/no/such/scene.json"), "/no/such/scene.json"),
    (lambda: penumbra.Scene.load(os.path.join(ROOT, "scenes", "test-spheres.json"), "camera.width=3"), "list of 'path=value'"),
    (lambda: penumbra.Scene({"shadows": {"technique": "magic"}}).validate(), "shadows.technique"),
    (lambda: penumbra.Renderer(small_scene()).set("nonsense.path", 1), "nonsense.path"),
    (lambda: penumbra.Renderer(small_scene()).set("camera.fov_deg", "wide"), "camera.fov_deg"),
    (lambda: penumbra.Renderer(small_scene()).set("camera.fov_deg", float("nan")), "camera.fov_deg"),
    (lambda: penumbra.Renderer(small_scene()).set("camera.eye", object()), "camera.eye"),
    (lambda: penumbra.Renderer(small_scene()).render(dtype="int64"), "dtype"),
    (lambda: penumbra.Renderer(small_scene()).render(width=0), "width"),
    (lambda: penumbra.Renderer(small_scene()).render(quality="best"), "quality"),
    (lambda: penumbra.compare(np.zeros((4, 4, 3)), np.zeros((5, 4, 3))), "differ in size"),
])
def test_bad_input_raises_an_error_naming_it(make, message):
    with pytest.raises(penumbra.Error) as e:
        make()
    assert message in str(e.value)
    assert isinstance(e.value, ValueError)


def test_a_refused_edit_leaves_the_renderer_as_it_was():
    r = penumbra.Renderer(small_scene())
    before = r.render(dtype="float32")
    with pytest.raises(penumbra.Error):
        r.edit({"camera.fov_deg": 40, "volumes.0.step": -3})
    assert r.get("camera") == small_scene()["camera"]
    assert np.array_equal(r.render(dtype="float32"), before)


def test_the_gil_is_released_while_a_frame_renders():
    scene = small_scene("ray_traced")
    scene["camera"] = {"width": 200, "height": 200}
    scene["shadows"] = {"technique": "ray_traced", "light_angle": 4, "area_rays": 128}
    r = penumbra.Renderer(scene)
    ticks = [0]
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks[0] += 1

    # the counter's rate alone, then during a frame: without the GIL released it would stop for the
    # whole frame (it could run at most one switch interval, 5 ms)
    t = threading.Thread(target=count)
    t.start()
    time.sleep(0.1)
    rate = ticks[0] / 0.1
    before = ticks[0]
    start = time.perf_counter()
    try:
        r.render()
    finally:
        elapsed = time.perf_counter() - start
        during = ticks[0] - before
        done.set()
        t.join()
    assert elapsed > 0.2, f"the frame took {elapsed:.3f} s: too short to tell"
    assert during > rate * 0.03, f"{during} ticks in a {elapsed:.2f} s frame (alone: {rate:.0f}/s): the GIL was held"


def test_memory_stays_flat_over_many_renders():
    def resident_kb():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024

    r = penumbra.Renderer(small_scene())
    for _ in range(50):
        r.render()
    warm = resident_kb()
    for i in range(1000):
        if i % 100 == 0:
            r.set("lights.0.direction", [0.1 * (i % 7) - 0.3, -1, 0.2])
        r.render()
    assert resident_kb() - warm < 20_000, "resident memory grew over 1000 renders"


def test_techniques_and_the_set_docstring_come_from_the_declarations():
    listed = {(t["family"], t["name"]): t for t in penumbra.techniques()}
    cssm = listed[("shadows", "cssm")]
    offsets = next(k for k in cssm["keys"] if k["key"] == "offsets")
    assert offsets["type"] == "integer" and offsets["default"] == 13 and offsets["allowed"] == "7, 13 or 21"
    assert ("ambient", "ray_traced_ao") in listed
    # every key the CLI lists for a technique is in help(Renderer.set)
    out = subprocess.run([CLI, "techniques"], capture_output=True, text=True, check=True).stdout
    for t in penumbra.techniques():
        assert f"{t['family']}.technique = {t['name']}" in out
        for k in t["keys"]:
            if t["name"] != "none":
                assert f"{t['family']}.{k['key']} ({k['type']}" in penumbra.Renderer.set.__doc__
    # a value the declaration refuses is refused by an edit, naming the key
    r = penumbra.Renderer(penumbra.Scene(small_scene()))
    with pytest.raises(penumbra.Error, match="shadows.offsets"):
        r.set("shadows.offsets", 9)


def test_an_interpreter_without_numpy_is_told_which_one_penumbra_was_built_for():
    # NumPy made unimportable, as under a pyenv or virtualenv python3 without Debian's python3-numpy
    code = "import sys; sys.modules['numpy'] = None; import penumbra"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=os.environ)
    assert run.returncode != 0
    assert "NumPy cannot be imported" in run.stderr
    from penumbra._build_info import PYTHON_EXECUTABLE
    assert f"penumbra was built for {PYTHON_EXECUTABLE}" in run.stderr, run.stderr


def test_one_renderer_shared_by_threads_renders_whole_frames_and_never_crashes():
    r = penumbra.Renderer(penumbra.Scene(small_scene()))
    directions = ([-0.3, -1, -0.2], [0.4, -1, 0.3])
    references = []
    for d in directions:
        r.set("lights.0.direction", d)
        references.append(r.render(dtype="float32"))
    assert not np.array_equal(references[0], references[1])
    failures, frames = [], []

    def renderer_thread():
        try:
            for _ in range(12):
                frames.append(r.render(dtype="float32"))
        except Exception as e:  # noqa: BLE001 - any error is the test's failure
            failures.append(repr(e))

    def editor_thread():
        try:
            for k in range(12):
                r.set("lights.0.direction", directions[k % 2])
                frames.append(r.render(dtype="float32"))
        except Exception as e:  # noqa: BLE001
            failures.append(repr(e))

    threads = [threading.Thread(target=renderer_thread), threading.Thread(target=renderer_thread), threading.Thread(target=editor_thread)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert failures == []
    assert len(frames) == 36
    # every frame is one state's whole frame: equal to one of the two references, never a mix
    for f in frames:
        assert any(np.array_equal(f, ref) for ref in references)


def test_set_threads_changes_the_workers_and_not_the_frame():
    before = penumbra.threads()
    try:
        penumbra.set_threads(1)
        assert penumbra.threads() == 1
        one = penumbra.Renderer(penumbra.Scene(small_scene())).render(dtype="float32")
        penumbra.set_threads(2)
        assert penumbra.threads() == 2
        two = penumbra.Renderer(penumbra.Scene(small_scene())).render(dtype="float32")
        assert np.array_equal(one, two)
        with pytest.raises(penumbra.Error, match="set_threads"):
            penumbra.set_threads(-1)
    finally:
        penumbra.set_threads(0)
    assert penumbra.threads() == before


def test_a_selection_edit_draws_only_the_selected_atoms(tmp_path):
    """r.set("particles.0.select", …) rebuilds the spheres (and what hangs off them), the stats count
    the atoms selected and the spheres drawn, and a malformed selection raises naming the key."""
    (tmp_path / "atoms.xyz").write_text("4\natoms\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\nC 0 0 0.5\n")
    scene = {"particles": [{"file": "atoms.xyz", "radius": 0.2}], "camera": {"width": 40, "height": 32},
             "shadows": {"technique": "ray_traced"}}
    r = penumbra.Renderer(penumbra.Scene(scene, base_dir=str(tmp_path)))
    everything = r.render()
    assert r.stats["particles"] == [{"spheres": 4, "visible": True, "selected": None}]
    r.set("particles.0.select", "name C")
    carbons = r.render()
    assert r.stats["particles"] == [{"spheres": 2, "visible": True, "selected": 2}]
    assert {"structure": "spheres", "cause": "particles.0.select"} in r.stats["rebuilt"]
    assert not np.array_equal(everything, carbons)
    # hidden: read, counted, not drawn; shown again: the same frame, the file not read again
    r.set("particles.0.visible", False)
    hidden = r.render()
    assert r.stats["particles"] == [{"spheres": 0, "visible": False, "selected": 2}]
    assert not np.array_equal(hidden, carbons)
    r.set("particles.0.visible", True)
    assert np.array_equal(r.render(), carbons)
    with pytest.raises(penumbra.Error, match=r"particles\.0\.select: at character 11: expected a selection"):
        r.set("particles.0.select", "name C and")
    assert r.get("particles.0.select") == "name C"
