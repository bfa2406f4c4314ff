"""The Scene builders (add_volume, add_particles, add_atoms, add_isosurface, add_plane, add_light) and
the renderer's data updates: a scene built from NumPy arrays renders byte-identically to the same scene
written as files and rendered by the CLI; volumes are views of the caller's array; bad arrays raise
penumbra.Error naming the argument."""
import json
import os
import subprocess
import warnings

import numpy as np
import pytest

import penumbra
from cli_outputs import read_pfm

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))


def cli_render(tmp_path, document):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(document))
    out = tmp_path / "cli.pfm"
    subprocess.run([CLI, "render", str(path), "-o", str(out)], check=True, capture_output=True)
    return read_pfm(out)


def blob(shape, dtype):
    """A lopsided blob (no symmetry between the axes, so a swapped axis shows) scaled to the dtype."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
    f = np.clip(1.0 - np.sqrt((x - 0.2) ** 2 + (1.6 * y) ** 2 + (z + 0.1) ** 2) + 0.15 * x * z, 0, 1)
    scale = {np.uint8: 250, np.uint16: 4000, np.int16: 3000, np.float32: 1}[dtype]
    return np.ascontiguousarray((f * scale).astype(dtype))


COMMON = {
    "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
    "shadows": {"technique": "cssm", "resolution": 64},
    "camera": {"width": 48, "height": 40},
}


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint16, np.float32])
def test_numpy_volume_renders_as_the_same_raw_file_through_the_cli(tmp_path, dtype):
    a = blob((18, 22, 27), dtype)  # z, y, x
    spacing_zyx, origin_zyx = (0.09, 0.07, 0.05), (-0.8, -0.75, -0.6)
    tf = {"points": [[float(a.min()), 0, 0, 0, 0], [float(a.max()), 1, 0.7, 0.4, 0.3]]}
    scene = penumbra.Scene(COMMON)
    path = scene.add_volume(a, spacing=spacing_zyx, origin=origin_zyx, transfer_function=tf)
    assert path == "volumes.0"
    scene.add_plane(point=(0, -0.8, 0), size=3)
    image = penumbra.Renderer(scene).render(dtype="float32")

    a.tofile(tmp_path / "blob.raw")  # x fastest: the raw reader's order
    document = dict(COMMON)
    document["volumes"] = [{"file": "blob.raw", "raw": {"dims": [27, 22, 18], "type": np.dtype(dtype).name, "spacing": [0.05, 0.07, 0.09]},
                            "origin": [-0.6, -0.75, -0.8], "transfer_function": tf}]
    document["planes"] = [{"point": [0, -0.8, 0], "normal": [0, 1, 0], "size": 3}]
    assert np.array_equal(image[..., :3], cli_render(tmp_path, document))
    assert image[..., :3].std() > 0.01  # the volume is in view, not a blank frame


def test_isosurface_plane_and_light_builders_match_the_file_scene(tmp_path):
    a = blob((20, 20, 24), np.float32)
    scene = penumbra.Scene({"camera": {"width": 40, "height": 40}, "shadows": {"technique": "shadow_map", "resolution": 128}})
    v = scene.add_volume(a, spacing=0.05, visible=False)
    assert scene.add_isosurface(v, 0.4, color=[0.9, 0.6, 0.3]) == "isosurfaces.0"
    assert scene.add_plane(point=(0, -0.1, 0), size=4) == "planes.0"
    assert scene.add_light(direction=np.array([-0.4, -1.0, 0.2])) == "lights.0"
    image = penumbra.Renderer(scene).render(dtype="float32")

    a.tofile(tmp_path / "blob.raw")
    document = {"camera": {"width": 40, "height": 40}, "shadows": {"technique": "shadow_map", "resolution": 128},
                "volumes": [{"file": "blob.raw", "raw": {"dims": [24, 20, 20], "type": "float32", "spacing": [0.05, 0.05, 0.05]},
                             "origin": [0, 0, 0], "visible": False}],
                "isosurfaces": [{"volume": 0, "value": 0.4, "color": [0.9, 0.6, 0.3]}],
                "planes": [{"point": [0, -0.1, 0], "normal": [0, 1, 0], "size": 4}],
                "lights": [{"type": "directional", "direction": [-0.4, -1.0, 0.2]}]}
    assert np.array_equal(image[..., :3], cli_render(tmp_path, document))


def test_the_volume_is_a_view_of_the_array_not_a_copy():
    a = blob((16, 16, 16), np.float32)
    tf = [[0, 0, 0, 0, 0], [1, 1, 0.9, 0.8, 0.4]]  # in data units: halving the data shows
    scene = penumbra.Scene(COMMON)
    path = scene.add_volume(a, transfer_function=tf)
    r = penumbra.Renderer(scene)
    assert r._engine.volume_address(0) == a.ctypes.data
    before = r.render(dtype="float32")
    a *= 0.5  # changed in place: the renderer sees it once told
    r.update_volume(path)
    assert r._engine.volume_address(0) == a.ctypes.data
    after = r.render(dtype="float32")
    assert {"structure": "volumes.0.gradients", "cause": "volumes.0"} in r.stats["rebuilt"]
    assert before[..., :3].std() > 0.01 and not np.array_equal(before, after)
    fresh = penumbra.Scene(COMMON)
    fresh.add_volume(a.copy(), transfer_function=tf)
    assert np.array_equal(after, penumbra.Renderer(fresh).render(dtype="float32"))


def test_a_non_contiguous_array_is_copied_with_a_warning():
    a = blob((16, 16, 32), np.float32)
    strided = a[:, :, ::2]
    scene = penumbra.Scene(COMMON)
    with pytest.warns(UserWarning, match="not C-contiguous"):
        scene.add_volume(strided)
    contiguous = penumbra.Scene(COMMON)
    contiguous.add_volume(np.ascontiguousarray(strided))
    assert np.array_equal(penumbra.Renderer(scene).render(), penumbra.Renderer(contiguous).render())


def write_xyz(path, symbols, positions):
    lines = [str(len(positions)), "written by the test"]
    lines += [f"{s} {x:.9g} {y:.9g} {z:.9g}" for s, (x, y, z) in zip(symbols, positions.astype(np.float32))]
    path.write_text("\n".join(lines) + "\n")


def particle_common():
    return {"lights": [{"type": "directional", "direction": [-0.45, -0.8, -0.4]}],
            "shadows": {"technique": "issm", "resolution": 128},
            "ambient": {"technique": "particle_ao", "directions": 8, "max_distance": 3},
            "camera": {"width": 48, "height": 40}}


def test_numpy_particles_render_as_the_same_xyz_file_through_the_cli(tmp_path):
    rng = np.random.default_rng(3)
    positions = rng.uniform(-4, 4, size=(300, 3)).astype(np.float32)
    scene = penumbra.Scene(particle_common())
    assert scene.add_particles(positions, radii=0.6, colors=(0.8, 0.3, 0.2)) == "particles.0"
    image = penumbra.Renderer(scene).render(dtype="float32")

    write_xyz(tmp_path / "p.xyz", ["C"] * len(positions), positions)
    document = particle_common()
    document["particles"] = [{"file": "p.xyz", "radius": 0.6, "color_by": "uniform", "color": [0.8, 0.3, 0.2]}]
    assert np.array_equal(image[..., :3], cli_render(tmp_path, document))


class FakeAtoms:
    """What add_atoms reads of an MDAnalysis AtomGroup."""

    def __init__(self, positions, elements):
        self.positions = positions
        self.elements = np.asarray(elements)


def test_atoms_take_element_radii_and_cpk_colours_like_the_file_reader(tmp_path):
    rng = np.random.default_rng(5)
    positions = rng.uniform(-6, 6, size=(200, 3)).astype(np.float32)
    symbols = rng.choice(["C", "N", "O", "S", "H", "Fe"], size=200)
    scene = penumbra.Scene(particle_common())
    scene.add_atoms(FakeAtoms(positions, symbols))
    image = penumbra.Renderer(scene).render(dtype="float32")
    write_xyz(tmp_path / "atoms.xyz", symbols, positions)
    document = particle_common()
    document["particles"] = [{"file": "atoms.xyz"}]
    assert np.array_equal(image[..., :3], cli_render(tmp_path, document))
    # without hydrogens
    scene = penumbra.Scene(particle_common())
    scene.add_atoms(FakeAtoms(positions, symbols), hydrogens=False)
    document["particles"] = [{"file": "atoms.xyz", "hydrogens": False}]
    assert np.array_equal(penumbra.Renderer(scene).render(dtype="float32")[..., :3], cli_render(tmp_path, document))


def test_moving_particles_rebuilds_their_shadows_and_matches_a_fresh_renderer():
    rng = np.random.default_rng(7)
    positions = rng.uniform(-4, 4, size=(200, 3))
    scene = penumbra.Scene(particle_common())
    path = scene.add_particles(positions, radii=0.7, colors=rng.uniform(0, 1, size=(200, 3)))
    r = penumbra.Renderer(scene)
    first = r.render(dtype="float32")
    moved = positions + rng.normal(0, 0.3, size=positions.shape)
    r.update_particles(path, positions=moved)
    second = r.render(dtype="float32")
    rebuilt = {e["structure"]: e["cause"] for e in r.stats["rebuilt"]}
    for structure in ("spheres", "casters", "ambient", "lights.0.shadows"):
        assert rebuilt.get(structure) == path, (structure, r.stats["rebuilt"])
    assert not np.array_equal(first, second)
    # the camera stays where the first spheres framed it (a fresh renderer would frame the moved ones)
    camera = {k: r.get(f"camera.{k}") for k in ("eye", "target", "width", "height")}
    assert not r.is_set("camera.eye")
    fresh = penumbra.Scene(particle_common() | {"camera": camera})
    fresh.add_particles(moved, radii=0.7, colors=scene._particles["particles0"][1])
    assert np.array_equal(second, penumbra.Renderer(fresh).render(dtype="float32"))


def test_uint8_colours_are_srgb_bytes():
    positions = np.zeros((1, 3))
    a = penumbra.Scene(particle_common())
    a.add_particles(positions, colors=np.array([[255, 128, 0]], dtype=np.uint8))
    b = penumbra.Scene(particle_common())
    b.add_particles(positions, colors=[[1.0, ((128 / 255 + 0.055) / 1.055) ** 2.4, 0.0]])
    assert np.array_equal(penumbra.Renderer(a).render(), penumbra.Renderer(b).render())


@pytest.mark.parametrize("array, message", [
    (np.zeros((4, 4, 4), dtype=np.float64), "dtype float64"),
    (np.zeros((4, 4, 4), dtype=np.int32), "dtype int32"),
    (np.zeros((4, 4), dtype=np.float32), "2 dimensions"),
    (np.zeros((4, 4, 4, 2), dtype=np.float32), "4 dimensions"),
    (np.zeros((4, 4, 4), dtype=">f4"), "native byte order"),
])
def test_bad_volume_arrays_raise_errors_naming_what_was_expected(array, message):
    with pytest.raises(penumbra.Error, match=message):
        penumbra.Scene().add_volume(array)


def test_bad_particles_and_keys_raise_errors_naming_them():
    positions = np.zeros((5, 3))
    positions[3, 1] = np.nan
    with pytest.raises(penumbra.Error, match=r"positions: row 3 is \[0.0, nan, 0.0\]"):
        penumbra.Scene().add_particles(positions)
    with pytest.raises(penumbra.Error, match=r"shape \(5, 2\)"):
        penumbra.Scene().add_particles(np.zeros((5, 2)))
    with pytest.raises(penumbra.Error, match=r"radii\[2\] is -1"):
        penumbra.Scene().add_particles(np.zeros((3, 3)), radii=[1, 1, -1])
    with pytest.raises(penumbra.Error, match="colors has shape"):
        penumbra.Scene().add_particles(np.zeros((3, 3)), colors=np.zeros((2, 3)))
    scene = penumbra.Scene(COMMON)
    scene.add_volume(np.ones((4, 4, 4), dtype=np.float32), opacity=0.5)
    with pytest.raises(penumbra.Error, match="volumes.0.*opacity"):
        scene.validate()
    r = penumbra.Renderer(particle_common() | {"particles": [{"procedural": {"name": "random-spheres", "count": 10}}]})
    with pytest.raises(penumbra.Error, match="not added from an array"):
        r.update_particles("particles.0", np.zeros((10, 3)))
    scene = penumbra.Scene(particle_common())
    p = scene.add_particles(np.zeros((4, 3)))
    r = penumbra.Renderer(scene)
    with pytest.raises(penumbra.Error, match="positions has 3 rows; particles.0 has 4 spheres"):
        r.update_particles(p, np.zeros((3, 3)))
    with pytest.raises(penumbra.Error, match="row 1"):
        r.update_particles(p, np.array([[0, 0, 0], [np.inf, 0, 0], [0, 0, 0], [0, 0, 0]]))
    r.render()  # the renderer kept its spheres


def test_a_scene_file_cannot_name_an_array(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"volumes": [{"array": "volume0", "transfer_function": {"preset": "grayscale"}}]}))
    result = subprocess.run([CLI, "render", str(path), "-o", str(tmp_path / "x.png")], capture_output=True, text=True)
    assert result.returncode != 0
    assert "volumes.0.array" in result.stderr and "Python" in result.stderr


def test_a_trajectory_from_mdanalysis_moves_the_atoms_frame_by_frame():
    mda = pytest.importorskip("MDAnalysis")
    if not all(os.path.exists(os.path.join(DATA, f)) for f in ("md_1tii_chainD.tpr", "md_1tii_chainD.xtc")):
        pytest.skip(f"missing data: the staged MD trajectory is not in {DATA} (set PENUMBRA_DATA_DIR)")
    u = mda.Universe(os.path.join(DATA, "md_1tii_chainD.tpr"), os.path.join(DATA, "md_1tii_chainD.xtc"))
    protein = u.select_atoms("protein")
    common = particle_common() | {"camera": {"width": 48, "height": 40, "direction": [0.2, 0.3, 1]}}
    scene = penumbra.Scene(common)
    path = scene.add_atoms(protein)
    r = penumbra.Renderer(scene)
    images = []
    for ts in u.trajectory[:3]:
        r.update_particles(path, protein.positions)
        images.append(r.render(dtype="float32"))
    assert not np.array_equal(images[0], images[2])
    u.trajectory[2]  # frame 2 equals a renderer made at frame 2
    assert np.allclose(u.atoms.positions[0], [31.97, 43.5, 12.36], atol=2.0)  # PROVENANCE: atom 0 near (32.11, 43.68, 12.22) at t = 0
    fresh = penumbra.Scene(common | {"camera": {k: r.get(f"camera.{k}") for k in ("eye", "target", "width", "height")}})
    fresh.add_atoms(protein)
    assert np.array_equal(images[2], penumbra.Renderer(fresh).render(dtype="float32"))


def test_a_clip_plane_cuts_the_volume_and_moves_by_path(tmp_path):
    a = blob((20, 20, 24), np.float32)
    scene = penumbra.Scene({"camera": {"width": 40, "height": 40}, "shadows": {"technique": "ray_traced"}})
    scene.add_volume(a, spacing=0.05)
    scene.add_plane(point=(0, -0.1, 0), size=4)
    assert scene.add_clip_plane(point=(0.6, 0, 0), normal=(1, 0, 0)) == "clip_planes.0"
    r = penumbra.Renderer(scene)
    cut = r.render(dtype="float32")
    # moving the plane past the data gives the uncut frame; only what it cuts is rebuilt
    r.set("clip_planes.0.point", [5.0, 0.0, 0.0])
    uncut = r.render(dtype="float32")
    rebuilt = {e["structure"] for e in r.stats["rebuilt"]}
    assert "casters" in rebuilt and "volumes.0.gradients" not in rebuilt, r.stats["rebuilt"]
    fresh = penumbra.Scene({"camera": {"width": 40, "height": 40}, "shadows": {"technique": "ray_traced"}})
    fresh.add_volume(a, spacing=0.05)
    fresh.add_plane(point=(0, -0.1, 0), size=4)
    assert np.array_equal(uncut, penumbra.Renderer(fresh).render(dtype="float32"))
    assert not np.array_equal(cut, uncut)


def test_the_default_light_is_edited_by_path():
    scene = penumbra.Scene({"camera": {"width": 32, "height": 32}, "shadows": {"technique": "ray_traced"}})
    scene.add_volume(blob((16, 16, 16), np.float32), spacing=0.05)
    r = penumbra.Renderer(scene)
    before = r.render(dtype="float32")
    r.set("lights.0.direction", [0.3, -1.0, 0.1])
    after = r.render(dtype="float32")
    assert [e["structure"] for e in r.stats["rebuilt"]] == ["lights.0.shadows"]
    assert not np.array_equal(before, after)


def test_a_preset_name_is_accepted_by_set_as_by_add_volume():
    a = blob((16, 16, 16), np.float32)
    scene = penumbra.Scene({"camera": {"width": 32, "height": 32}})
    v = scene.add_volume(a, spacing=0.05, transfer_function="grayscale")
    r = penumbra.Renderer(scene)
    r.render(dtype="float32")
    r.set(v + ".transfer_function", "mri-head")
    by_name = r.render(dtype="float32")
    r.set(v + ".transfer_function", {"preset": "mri-head"})
    assert np.array_equal(by_name, r.render(dtype="float32"))
    with pytest.raises(penumbra.Error, match="not a known preset"):
        r.set(v + ".transfer_function", "no-such-preset")
