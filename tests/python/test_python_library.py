"""The Python package as a library (issue 41): frames that behave like NumPy arrays, colours and colour
maps as scientists write them, Ctrl-C during a frame, defaults told from typos, a camera that stays
still while particles move, and arrays changed in place without update_volume."""
import os
import signal
import struct
import threading
import time
import zlib

import numpy as np
import pytest

import penumbra


def small_scene(size=40):
    return {
        "volumes": [{"procedural": {"name": "test-spheres", "size": 24}, "transfer_function": {"preset": "test-spheres"}}],
        "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
        "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
        "camera": {"width": size, "height": size - 8},
        "shadows": {"technique": "cssm", "resolution": 64},
    }


def decode_png(data):
    """(H, W, 4) uint8 of an 8-bit RGBA PNG without filters (what penumbra writes)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color = struct.unpack(">IIBB", body[:10])
            assert (depth, color) == (8, 6)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(height, 1 + width * 4)
    assert np.all(raw[:, 0] == 0)
    return raw[:, 1:].reshape(height, width, 4)


# ------------------------------------------------------------------------------------------ frames

def test_the_frame_displays_itself_and_its_png_decodes_to_its_pixels():
    r = penumbra.Renderer(small_scene())
    img = r.render()
    assert isinstance(img, np.ndarray) and img.shape == (32, 40, 4)
    assert np.array_equal(decode_png(img._repr_png_()), np.asarray(img))
    linear = r.render(dtype="float32")
    decoded = decode_png(linear._repr_png_())
    assert np.max(np.abs(decoded.astype(int) - np.asarray(img).astype(int))) <= 1
    assert img.copy()._repr_png_() == img._repr_png_()


@pytest.mark.parametrize("derive", [
    lambda a: a[..., 0], lambda a: a[..., :3], lambda a: a[0], lambda a: a[2:10, 3:9],
    lambda a: a.astype(np.float32) / 255, lambda a: a + 1, lambda a: a.sum(axis=2), lambda a: a.reshape(-1, 4),
    lambda a: a.T, lambda a: np.flipud(a), lambda a: np.concatenate([a, a]), lambda a: a.view(np.uint32),
])
def test_what_is_computed_from_a_frame_is_a_plain_ndarray(derive):
    img = penumbra.Renderer(small_scene()).render()
    out = derive(img)
    assert type(out) is np.ndarray
    assert np.array_equal(out, derive(np.asarray(img)))


def test_reductions_are_numbers():
    img = penumbra.Renderer(small_scene()).render()
    plain = np.asarray(img)
    assert img.mean() == plain.mean() and type(img.mean()) is type(plain.mean())
    assert img.max() == plain.max() and np.std(img) == np.std(plain)


def test_help_of_the_package_is_short():
    import pydoc
    text = pydoc.render_doc(penumbra, renderer=pydoc.plaintext)
    assert len(text.splitlines()) < 800
    assert "Image" in penumbra.__doc__


# ------------------------------------------------------------------------------------------ colours

def sphere_colour(colors):
    scene = penumbra.Scene({"camera": {"width": 24, "height": 24}, "shading": {"ambient": 1.0}, "lights": [{"intensity": 0}]})
    scene.add_particles([[0, 0, 0]], radii=1.0, colors=colors)
    img = penumbra.Renderer(scene).render()
    return np.asarray(img)[12, 12, :3]


def test_integer_colours_are_8bit_srgb_whatever_their_integer_type():
    as_uint8 = sphere_colour(np.array([200, 30, 90], dtype=np.uint8))
    assert np.array_equal(sphere_colour(np.array([200, 30, 90], dtype=np.int64)), as_uint8)
    assert np.array_equal(sphere_colour([200, 30, 90]), as_uint8)  # Python ints
    floats = sphere_colour(((np.array([200, 30, 90]) / 255 + 0.055) / 1.055) ** 2.4)
    assert np.max(np.abs(floats.astype(int) - as_uint8.astype(int))) <= 1


@pytest.mark.parametrize("colors, message", [
    ([300, 0, 0], "expected 8-bit sRGB 0-255"),
    ([1, 0, 0], "ambiguous"),
    ([200.0, 30.0, 90.0], "pass them as integers"),
    ([-0.1, 0.5, 0.5], "expected linear RGB in [0, 1]"),
])
def test_colours_out_of_range_are_refused_not_clamped(colors, message):
    scene = penumbra.Scene()
    with pytest.raises(penumbra.Error, match=message.replace("[", r"\[").replace("]", r"\]")):
        scene.add_particles([[0, 0, 0]], colors=colors)


def test_scene_file_colours_above_one_name_the_key_and_the_8bit_reading():
    with pytest.raises(penumbra.Error, match=r"planes.0.color: .*\[255,0,0\].*bytes / 255"):
        penumbra.Renderer({"planes": [{"color": [255, 0, 0]}]})


@pytest.mark.parametrize("name", ["viridis", "magma", "inferno", "plasma", "cividis", "turbo", "coolwarm", "Viridis"])
def test_matplotlib_colour_maps_are_transfer_functions_slices_and_particle_maps(name):
    matplotlib = pytest.importorskip("matplotlib")
    cmap = matplotlib.colormaps[name.lower()]
    # a slice coloured by the map over a ramp volume shows the map's colours (opaque, unlit)
    ramp = np.tile(np.linspace(0, 1, 64, dtype=np.float32), (2, 8, 1))
    scene = penumbra.Scene({"camera": {"width": 64, "height": 16, "eye": [31.5, 3.5, 200.5], "target": [31.5, 3.5, 0.5],
                                       "fov_deg": float(np.degrees(2 * np.arctan(8 / 200)))},
                            "shading": {"ambient": 1.0}, "lights": [{"intensity": 0}]})
    v = scene.add_volume(ramp, transfer_function=name, visible=False)
    scene.add_slice(v, point=[31.5, 3.5, 0.5], normal=[0, 0, 1], color_map=name)
    r = penumbra.Renderer(scene)
    row = np.asarray(r.render(width=64, height=16))[8, :, :3].astype(float)
    expected = np.array([cmap(x)[:3] for x in np.linspace(0, 1, 64)]) * 255
    assert np.median(np.abs(row - expected)) < 6
    r.set("volumes.0.transfer_function", name)  # the name set() takes is the one add_volume took


def test_an_unknown_colour_map_lists_the_known_ones():
    with pytest.raises(penumbra.Error, match="not a known preset.*viridis"):
        penumbra.Renderer(penumbra.Scene().add_volume and {"volumes": [{"procedural": {"name": "test-spheres", "size": 8}, "transfer_function": "viridiss"}]})


# ------------------------------------------------------------------------------------------ Ctrl-C

def test_ctrl_c_cancels_a_frame_and_leaves_the_renderer_whole():
    scene = {"volumes": [{"procedural": {"name": "test-spheres", "size": 160}, "transfer_function": {"preset": "test-spheres"}}],
             "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}], "camera": {"width": 1200, "height": 1000},
             "shadows": {"technique": "ray_traced"}}
    r = penumbra.Renderer(scene)
    r.render(width=48, height=40)  # the volume's structures, built once
    r.set("lights.0.direction", [0.3, -1, 0.2])
    sent = []
    timer = threading.Timer(0.3, lambda: (sent.append(time.perf_counter()), os.kill(os.getpid(), signal.SIGINT)))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        r.render(width=1200, height=1000)  # ~35 s uninterrupted on 2 cores; ~50 ms to stop (docs/BENCHMARKS.md)
    latency = time.perf_counter() - sent[0]
    timer.join()
    assert latency < 10, f"the frame went on for {latency:.1f} s after Ctrl-C"  # a hang guard, not a timing check
    scene["lights"][0]["direction"] = [0.3, -1, 0.2]
    assert np.array_equal(r.render(width=48, height=40), penumbra.Renderer(scene).render(width=48, height=40))


# ------------------------------------------------------------------------------------------ get: defaults and typos

def test_get_answers_defaults_and_refuses_typos_naming_the_keys():
    r = penumbra.Renderer({"volumes": [{"procedural": {"name": "test-spheres", "size": 16}}], "camera": {"width": 40, "height": 30}})
    assert r.get("camera.width") == 40 and r.is_set("camera.width")
    assert r.get("lights.0.direction") == [-0.4, -1.0, -0.3] and not r.is_set("lights.0.direction")
    assert r.get("camera.fov_deg") == 35.0
    assert r.get("shadows.technique") == "none" and isinstance(r.get("shadows.resolution"), int)
    assert r.get("volumes.0.step") == 0.5
    assert "points" in r.get("volumes.0.transfer_function")  # chosen from the data
    with pytest.raises(penumbra.Error, match=r"camera.fovv: not a key of the scene \(camera has: .*fov_deg"):
        r.get("camera.fovv")
    with pytest.raises(penumbra.Error, match=r"lights.0.directon: .*lights.0 has: color, direction"):
        r.is_set("lights.0.directon")
    with pytest.raises(penumbra.Error, match=r"volumes.3.step: no such element \(volumes has 1\)"):
        r.get("volumes.3.step")
    # the default follows the scene: the framed eye moves with the camera's direction
    eye = r.get("camera.eye")
    r.set("camera.direction", [0, 0, 1])
    assert r.get("camera.eye") != eye and not r.is_set("camera.eye")
    r.set("lights.0.direction", [0.1, -1, 0])
    assert r.get("lights.0.direction") == [0.1, -1, 0] and r.is_set("lights.0.direction")


# ------------------------------------------------------------------------------------------ arrays changed in place

def test_a_volume_changed_in_place_without_update_volume_is_found_and_rebuilt():
    scene_doc = small_scene()
    ramp = np.zeros((24, 24, 24), dtype=np.float32)
    ramp[6:18, 6:18, 6:18] = 0.6
    scene = penumbra.Scene(scene_doc)
    del scene.document["volumes"]
    scene.add_volume(ramp, spacing=1 / 24, origin=-0.5, transfer_function="test-spheres")
    r = penumbra.Renderer(scene)
    before = r.render()
    ramp[6:18, 6:18, 6:18] = 0.8  # in place, no update_volume
    with pytest.warns(UserWarning, match=r"volumes.0: its array changed .*update_volume\('volumes.0'\)"):
        changed = r.render()
    assert not np.array_equal(changed, before)
    assert any(s["cause"] == "volumes.0" for s in r.stats["rebuilt"])
    fresh = penumbra.Scene(scene_doc)
    del fresh.document["volumes"]
    fresh.add_volume(ramp.copy(), spacing=1 / 24, origin=-0.5, transfer_function="test-spheres")
    assert np.array_equal(changed, penumbra.Renderer(fresh).render())
    import warnings as w
    with w.catch_warnings():
        w.simplefilter("error")  # unchanged: no warning, nothing rebuilt
        r.render()
    assert r.stats["rebuilt"] == []


def test_the_digest_sees_one_byte_and_a_swap():
    a = np.arange(1 << 20, dtype=np.uint8).reshape(64, 128, 128) % 251
    d = penumbra._penumbra.digest(a)
    b = a.copy()
    b[63, 127, 127] ^= 1
    assert penumbra._penumbra.digest(b) != d
    c = a.copy()
    c.reshape(-1)[[8, 16]] = c.reshape(-1)[[16, 8]]
    c.reshape(-1)[8:16], c.reshape(-1)[16:24] = a.reshape(-1)[16:24].copy(), a.reshape(-1)[8:16].copy()
    assert penumbra._penumbra.digest(c) != d
    assert penumbra._penumbra.digest(a.copy()) == d


# ------------------------------------------------------------------------------------------ MDAnalysis

DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data"))


def staged_run():
    gro, xtc = os.path.join(DATA, "md_1tii_chainD.gro"), os.path.join(DATA, "md_1tii_chainD.xtc")
    if not (os.path.exists(gro) and os.path.exists(xtc)):
        pytest.skip(f"missing data: the staged MD run is not in {DATA} (set PENUMBRA_DATA_DIR)")
    return gro, xtc


def test_an_atom_group_follows_its_universe_with_a_still_camera_as_the_own_reader_plays_it():
    mda = pytest.importorskip("MDAnalysis")
    gro, xtc = staged_run()
    u = mda.Universe(gro, xtc)
    protein = u.select_atoms("protein")
    common = {"camera": {"width": 64, "height": 48}, "shadows": {"technique": "issm", "resolution": 256}}
    scene = penumbra.Scene(common)
    path = scene.add_atoms(protein)
    r = penumbra.Renderer(scene)
    eye = r.get("camera.eye")
    r.set_frame(u.trajectory[75])  # a Timestep, as `for ts in u.trajectory` gives
    assert u.trajectory.ts.frame == 75
    moved = r.render()
    assert r.get("camera.eye") == eye, "the camera must not follow the atoms"
    # penumbra's own reader of the same files at frame 75, through the same camera: the same frame
    own = penumbra.Renderer(common | {"camera": {k: r.get(f"camera.{k}") for k in ("eye", "target", "width", "height")},
                                      "particles": [{"file": gro, "trajectory": xtc, "select": "protein"}], "time": 75})
    assert np.array_equal(moved, own.render())
    r.set_frame(0)
    assert not np.array_equal(r.render(), moved)
    with pytest.raises(penumbra.Error, match="frame 151 of a trajectory of 151 frames"):
        r.set_frame(151)


def test_an_updating_selection_is_evaluated_again_at_each_frame():
    mda = pytest.importorskip("MDAnalysis")
    gro, xtc = staged_run()
    u = mda.Universe(gro, xtc)
    near = u.select_atoms("resname SOL and around 3.5 protein", updating=True)
    scene = penumbra.Scene({"camera": {"width": 32, "height": 24}})
    scene.add_atoms(near)
    r = penumbra.Renderer(scene)
    counts = []
    for k in (0, 150):
        r.set_frame(k)
        r.render()
        counts.append((len(near), r.stats["particles"][0]["spheres"]))
    assert all(n == spheres for n, spheres in counts)
    assert counts[0][0] != counts[1][0]  # the water shell changes between the first and last frames


# ------------------------------------------------------------------------------------------ memory

def test_gradients_on_the_fly_draw_the_same_frame_without_their_memory():
    vol = np.zeros((40, 40, 40), dtype=np.uint8)
    z, y, x = np.mgrid[0:40, 0:40, 0:40]
    vol[(x - 20) ** 2 + (y - 20) ** 2 + (z - 20) ** 2 < 150] = 200
    vol[(x - 12) ** 2 + (y - 26) ** 2 + (z - 18) ** 2 < 40] = 120
    images, stats = [], []
    for mode in ("stored", "on_the_fly"):
        scene = penumbra.Scene({"camera": {"width": 64, "height": 48}, "shadows": {"technique": "cssm", "resolution": 64}})
        scene.add_volume(vol, spacing=0.05, origin=-1, transfer_function=[[0, 0, 0, 0, 0], [100, 0.9, 0.5, 0.3, 0.3], [255, 1, 1, 1, 0.9]],
                         gradients=mode)
        r = penumbra.Renderer(scene)
        images.append(r.render(dtype="float32"))
        stats.append(r.stats)
    assert np.array_equal(images[0], images[1])  # the same arithmetic, per sample instead of per voxel
    assert [s["gradients"] for s in stats] == [["stored"], ["on_the_fly"]]
    saved = stats[0]["memory_bytes"]["volume_structures"] - stats[1]["memory_bytes"]["volume_structures"]
    assert saved == 4 * vol.size
    assert stats[0]["memory_bytes"]["volume"] == vol.nbytes or stats[0]["memory_bytes"]["volume"] >= 0


def test_gradients_auto_stores_small_volumes_and_the_mode_is_an_edit():
    scene = penumbra.Scene({"camera": {"width": 32, "height": 24}})
    scene.add_volume(np.ones((8, 8, 8), dtype=np.float32))
    r = penumbra.Renderer(scene)
    r.render()
    assert r.stats["gradients"] == ["stored"] and r.get("volumes.0.gradients") == "auto"
    r.set("volumes.0.gradients", "on_the_fly")
    r.render()
    assert r.stats["gradients"] == ["on_the_fly"]
    assert {"structure": "volumes.0.gradients", "cause": "volumes.0.gradients"} in r.stats["rebuilt"]
    with pytest.raises(penumbra.Error, match=r"volumes.0.gradients: unknown value 'never' \(expected auto, stored or on_the_fly\)"):
        r.set("volumes.0.gradients", "never")


# ------------------------------------------------------------------------------------------ mixed scenes

def test_a_camera_move_in_a_mixed_scene_rebuilds_nothing():
    """Spheres with particle AO beside a translucent volume (issue 42's cliff): an orbit frame rebuilds
    no structure, and the volume samples' ambient lattice is reused (docs/BENCHMARKS.md times it)."""
    rng = np.random.default_rng(3)
    scene = penumbra.Scene({"ambient": {"technique": "particle_ao"}, "shadows": {"technique": "issm", "resolution": 128},
                            "camera": {"width": 48, "height": 40}})
    scene.add_particles(rng.uniform(-0.4, 0.4, size=(300, 3)), radii=0.05)
    z, y, x = np.mgrid[0:24, 0:24, 0:24].astype(np.float32) / 23 - 0.5
    scene.add_volume(np.ascontiguousarray(np.clip(1 - np.sqrt(x * x + y * y + z * z) / 0.5, 0, 1), dtype=np.float32),
                     spacing=1 / 23, origin=-0.5, transfer_function=[[0, 0.2, 0.4, 1, 0], [1, 0.2, 0.4, 1, 0.05]])
    r = penumbra.Renderer(scene)
    r.render()
    for direction in ([1, 0.5, 0.3], [0.2, 0.5, 1], [-1, 0.3, 0.2]):
        r.set("camera.direction", direction)
        r.render()
        assert r.stats["rebuilt"] == [], r.stats["rebuilt"]


def test_a_light_move_shades_the_last_frames_surfaces_and_draws_a_fresh_frames_image():
    """A light or shading edit keeps the list of visible surface points (stats["surfaces_kept"]); a colour
    or camera edit lists them again; each image is the one a new renderer draws."""
    rng = np.random.default_rng(4)
    centres = rng.uniform(-0.4, 0.4, size=(200, 3))
    doc = {"shadows": {"technique": "issm", "resolution": 128}, "camera": {"width": 48, "height": 40}}
    scene = penumbra.Scene(doc)
    scene.add_particles(centres, radii=0.06)
    r = penumbra.Renderer(scene)
    r.render()
    assert r.stats["surfaces_kept"] is False
    for path, value, kept in (("lights.0.direction", [0.3, -1, 0.2], True), ("shading.ambient", 0.3, True),
                              ("camera.direction", [0.2, 0.5, 1], False), ("lights.0.direction", [-0.4, -1, 0.1], True)):
        r.set(path, value)
        image = r.render()
        assert r.stats["surfaces_kept"] is kept, path
        np.testing.assert_array_equal(np.asarray(image), np.asarray(penumbra.Renderer(r.scene).render()), err_msg=path)


# ------------------------------------------------------------------------------------------ throughput

def test_the_frame_counts_its_volume_samples_the_same_for_any_thread_count():
    scene = small_scene(64)
    counts = []
    for threads in (1, 2):
        penumbra.set_threads(threads)
        try:
            r = penumbra.Renderer(scene)
            r.render()
            counts.append(r.stats["counts"])
        finally:
            penumbra.set_threads(0)
    assert counts[0] == counts[1]
    assert counts[0]["volume_samples"] > counts[0]["volume_shaded_samples"] > 0
    assert r.stats["throughput"]["samples_per_second"] > 0
    # a transfer function that shows nothing: empty space is skipped, nothing is sampled
    clear = small_scene(64)
    clear["volumes"][0]["transfer_function"] = {"points": [[0, 0, 0, 0, 0], [1, 0, 0, 0, 0]]}
    r = penumbra.Renderer(clear)
    r.render()
    assert r.stats["counts"]["volume_samples"] == 0 and r.stats["throughput"]["samples_per_second"] == 0
