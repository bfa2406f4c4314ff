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
