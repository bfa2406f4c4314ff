"""View-dependent refinement (issue 43, render/view_refinement.h) on an OME-Zarr pyramid written by
python3-zarr (anisotropic voxels, a translation, two channels, block-mean levels): a close view of a
pyramid opened coarse under a memory budget is drawn, in the full frame, from the finest level's box
that covers it; the frame is the finest level's frame held in memory, the refined box stays within what
the budget leaves, and --stats says what was loaded, read and evicted as the camera moves."""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from cli_outputs import held_bytes, read_pfm

zarr = pytest.importorskip("zarr")  # Debian python3-zarr
numcodecs = pytest.importorskip("numcodecs")

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
SCALE = (0.5, 0.4, 0.3)  # z, y, x
TRANSLATION = (4.0, -7.0, 2.5)


def blobs(shape, seed):
    """Soft balls with fine ripples that a coarser level smooths away."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    rng = np.random.default_rng(seed)
    field = np.zeros(shape)
    for _ in range(5):
        c = rng.uniform(-0.6, 0.6, 3)
        field += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) * rng.uniform(4, 12))
    field *= 1 + 0.25 * np.sin(40 * x) * np.sin(37 * y)
    return (field / field.max() * 4000).astype(np.uint16)


def block_means(a):
    z, y, x = (n // 2 * 2 for n in a.shape)
    b = a[:z, :y, :x].astype(np.float64)
    return b.reshape(z // 2, 2, y // 2, 2, x // 2, 2).mean(axis=(1, 3, 5)).round().astype(a.dtype)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("refine") / "image.zarr"
    root = zarr.open_group(str(path), mode="w")
    levels = [np.stack([blobs((64, 96, 80), seed) for seed in (1, 2)])]
    for _ in range(2):
        levels.append(np.stack([block_means(c) for c in levels[-1]]))
    datasets = []
    for level, data in enumerate(levels):
        f = 2 ** level
        root.create_dataset(str(level), data=data, chunks=(1, 16, 16, 16),
                            compressor=numcodecs.Blosc(cname="zstd", clevel=3, shuffle=numcodecs.Blosc.SHUFFLE))
        # block means: a coarser voxel's centre is the mean of the finer centres it covers
        shift = [(f - 1) * s / 2 for s in SCALE]
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": [1.0] + [s * f for s in SCALE]},
            {"type": "translation", "translation": [0.0] + [t + d for t, d in zip(TRANSLATION, shift)]}]})
    root.attrs["multiscales"] = [{"version": "0.4", "name": "blobs",
                                  "axes": [{"name": "c", "type": "channel"}] + [{"name": n, "type": "space"} for n in "zyx"],
                                  "datasets": datasets}]
    return path, [l.shape[1:] for l in levels]


def scene(path, eye, target, budget=None, level=None, refine=True, shadows="none"):
    v = {"file": str(path), "channel": 1, "step": 0.5, "jitter": False, "refine": refine,
         "transfer_function": {"points": [[0, 0.1, 0.2, 0.8, 0], [1200, 0.2, 0.5, 0.9, 0.0], [2000, 0.9, 0.6, 0.3, 0.08],
                                          [4000, 1.0, 0.95, 0.9, 0.5]]}}
    if level is not None:
        v["level"] = level
    s = {"volumes": [v], "lights": [{"type": "directional", "direction": [-0.4, -1.0, -0.3]}],
         "shadows": {"technique": shadows},
         "camera": {"eye": eye, "target": target, "fov_deg": 20, "width": 80, "height": 64}}
    if budget:
        s["memory_budget"] = budget
    return s


def render(tmp_path, doc, name, *extra):
    scene_file, image, stats = tmp_path / f"{name}.json", tmp_path / f"{name}.pfm", tmp_path / f"{name}.stats.json"
    scene_file.write_text(json.dumps(doc))
    r = subprocess.run([CLI, "render", str(scene_file), "-o", str(image), "--stats", str(stats), *extra],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return read_pfm(image), json.loads(stats.read_text())


# The volume's box: x 2.5 .. 26.2, y -7 .. 31, z 4 .. 35.5 (world units; x, y, z)
CENTRE = [14.35, 12.0, 19.75]
EYE = [14.0, 16.0, -6.0]
TARGET = [12.0, 14.0, 12.0]


def test_a_close_view_is_drawn_from_the_finest_level(store, tmp_path):
    path, shapes = store
    # level 1 (with its gradients) fits, level 0 does not: the pyramid opens at level 1
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    assert budget < held_bytes(shapes[0], 2)
    refined, stats = render(tmp_path, scene(path, EYE, TARGET, budget=budget), "refined")
    assert stats["volumes"][0]["dims"] == list(reversed(shapes[1]))
    [r] = stats["refinement"]
    assert (r["opened_level"], r["level"]) == (1, 0)
    assert 0 < r["held_bytes"] == r["loaded_bytes"] and r["read_bytes"] > 0 and r["evicted_bytes"] == 0
    assert np.prod(r["dims"]) < np.prod(shapes[0])  # a box, not the level
    assert stats["memory_budget"]["held"] <= budget  # the box within what the budget leaves
    assert "volumes.0.refined" in stats["rebuilt"]

    finest, _ = render(tmp_path, scene(path, EYE, TARGET, level=0), "finest")
    opened, _ = render(tmp_path, scene(path, EYE, TARGET, budget=budget, refine=False), "opened")
    refined_error = np.abs(refined - finest).max()
    opened_error = np.abs(opened - finest).max()
    # the eye pass samples the same voxels; the table and shading weights span the box's and the
    # opened level's value range, not the whole finest level's: not always bit for bit
    assert refined_error < 5e-3, refined_error
    assert opened_error > 5 * refined_error and opened_error > 0.05, (opened_error, refined_error)
    assert refined.std() > 0.05


def test_the_box_is_kept_while_the_view_stays_in_it(store, tmp_path):
    path, shapes = store
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    edits = [{"set": {"camera.target": [12.2, 14.0, 12.0]}},   # a small pan: inside the box's margin
             {"set": {"camera.eye": [14.0, 16.0, -400.0]}},    # far away: the opened level is enough
             {"set": {"camera.eye": EYE}}]                      # back: drawn from the box kept
    (tmp_path / "edits.json").write_text(json.dumps(edits))
    _, stats = render(tmp_path, scene(path, EYE, TARGET, budget=budget), "orbit", "--edits", str(tmp_path / "edits.json"))
    first, pan, away, back = [s["refinement"] for s in [stats] + stats["edits"]]
    assert first[0]["loaded_bytes"] > 0
    assert pan[0]["loaded_bytes"] == 0 and pan[0]["held_bytes"] == first[0]["held_bytes"]
    assert away[0]["held_bytes"] == 0 and away[0]["kept_bytes"] == first[0]["held_bytes"] and away[0]["evicted_bytes"] == 0
    assert back[0]["loaded_bytes"] == 0 and back[0]["read_bytes"] == 0 and back[0]["level"] == 0
    assert back[0]["held_bytes"] == first[0]["held_bytes"] and back[0]["kept_bytes"] == 0


def test_python_stats_say_what_was_refined(store):
    penumbra = pytest.importorskip("penumbra")
    path, shapes = store
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    r = penumbra.Renderer(penumbra.Scene(scene(path, EYE, TARGET, budget=budget)))
    r.render()
    [x] = r.stats["refinement"]
    assert (x["opened_level"], x["level"]) == (1, 0) and x["loaded_bytes"] > 0
    assert r.stats["memory_bytes"]["refined"] == x["held_bytes"]
    r.render(quality="preview")
    assert r.stats["refinement"] == []  # previews draw the opened level


def test_refine_false_and_an_explicit_level_draw_the_level_opened(store, tmp_path):
    path, shapes = store
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    _, stats = render(tmp_path, scene(path, EYE, TARGET, budget=budget, refine=False), "off")
    assert stats["refinement"] == [] and stats["memory_bytes"]["refined"] == 0
    _, stats = render(tmp_path, scene(path, EYE, TARGET, budget=budget, level=1), "level")
    assert stats["refinement"] == []


def test_shadows_are_cast_from_the_refined_box(store, tmp_path):
    """The CSSM of a full frame is built from the box where it lies (from the opened level elsewhere):
    the refined frame with CSSM shadows is much closer to the finest level's than the opened level's is."""
    path, shapes = store
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    refined, stats = render(tmp_path, scene(path, EYE, TARGET, budget=budget, shadows="cssm"), "cssm_refined")
    assert stats["refinement"][0]["level"] == 0
    finest, _ = render(tmp_path, scene(path, EYE, TARGET, level=0, shadows="cssm"), "cssm_finest")
    opened, _ = render(tmp_path, scene(path, EYE, TARGET, budget=budget, refine=False, shadows="cssm"), "cssm_opened")
    rmse = lambda a: float(np.sqrt(((a - finest) ** 2).mean()))  # noqa: E731
    assert rmse(refined) < 0.5 * rmse(opened), (rmse(refined), rmse(opened))


def test_a_corrupt_chunk_of_the_finer_level(store, tmp_path):
    """Level 0's chunks cut short (as a copy interrupted would leave them): `penumbra render` exits 1 naming
    the volume, the box and the chunk, and writes no image; the Python renderer draws the opened level
    there with a warning and the error in its stats, as the viewer does."""
    path, shapes = store
    broken = tmp_path / "broken.zarr"
    shutil.copytree(path, broken)
    for chunk in (broken / "0").iterdir():
        if not chunk.name.startswith("."):
            chunk.write_bytes(chunk.read_bytes()[:5])
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1])) + 550_000
    doc = scene(broken, EYE, TARGET, budget=budget)
    (tmp_path / "broken.json").write_text(json.dumps(doc))
    r = subprocess.run([CLI, "render", str(tmp_path / "broken.json"), "-o", str(tmp_path / "broken.png")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 1, r.stderr
    assert "volumes.0: level 0 box " in r.stderr and "chunk" in r.stderr and "broken.zarr" in r.stderr, r.stderr
    assert not (tmp_path / "broken.png").exists()

    penumbra = pytest.importorskip("penumbra")
    renderer = penumbra.Renderer(penumbra.Scene(doc))
    with pytest.warns(UserWarning, match="volumes.0: level 0 box .*chunk.*; drawn from the opened level 1"):
        image = renderer.render(dtype="float32")
    [x] = renderer.stats["refinement"]
    assert "chunk" in x["error"] and x["held_bytes"] == 0 and x["level"] == 1
    opened = penumbra.Renderer(penumbra.Scene(scene(broken, EYE, TARGET, budget=budget, refine=False))).render(dtype="float32")
    assert np.array_equal(np.asarray(image), np.asarray(opened))
