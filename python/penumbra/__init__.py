"""penumbra from Python: scenes as dicts or files, the interactive engine, frames as NumPy arrays.

    import penumbra
    scene = penumbra.Scene.load("scenes/cranium.json", ["shadows.technique=cssm"])
    r = penumbra.Renderer(scene)
    image = r.render(width=512, height=512)          # (512, 512, 4) uint8 sRGB RGBA, row 0 at the top
    r.set("lights.0.direction", [0.2, -1, -0.4])     # the engine's edits: the paths of --set
    image = r.render(dtype="float32")                # premultiplied linear RGBA
    print(r.stats["rebuilt"])                        # [{'structure': 'lights.0.shadows', 'cause': 'lights.0.direction'}]

A scene is exactly the scene file's schema (docs/scene-file.md); it is checked when a renderer is made
from it or on scene.validate(), and errors raise penumbra.Error (a ValueError) with the CLI's message.
In Jupyter, a rendered image shows itself.
"""
import copy
import json
import os
import struct
import zlib

import numpy as np

from . import _penumbra

Error = _penumbra.Error

__all__ = ["Error", "Image", "Renderer", "Scene", "compare"]


class Scene:
    """A scene document: the scene file's schema as a dict, with the folder its relative paths use."""

    def __init__(self, document=None, base_dir="."):
        if document is None:
            document = {}
        if not isinstance(document, dict):
            raise Error(f"Scene: expected a dict with the scene file's keys (docs/scene-file.md), got {type(document).__name__}")
        self.document = copy.deepcopy(document)
        self.base_dir = os.fspath(base_dir)

    @classmethod
    def load(cls, path, overrides=()):
        """A scene file with `--set` overrides ("path=value") applied."""
        if isinstance(overrides, str):
            raise Error("Scene.load: overrides must be a list of 'path=value' strings, not one string")
        text, base_dir = _penumbra.load_document(os.fspath(path), list(overrides))
        return cls(json.loads(text), base_dir or ".")

    def validate(self):
        """Reads the scene exactly as the scene-file reader does (loading its data); raises Error naming the key."""
        _penumbra.validate(_dumps(self.document, "scene"), self.base_dir)
        return self

    def to_dict(self):
        return copy.deepcopy(self.document)

    def __repr__(self):
        kinds = [f"{len(self.document[k])} {k}" for k in ("volumes", "particles", "isosurfaces", "planes") if self.document.get(k)]
        return f"penumbra.Scene({', '.join(kinds) or 'empty'})"


class Image(np.ndarray):
    """A rendered frame: an (H, W, 4) ndarray that shows itself in Jupyter."""

    def _repr_png_(self):
        return _png(self)


class Renderer:
    """The interactive engine over a scene: edits by path, frames as arrays, stats of what was rebuilt."""

    def __init__(self, scene):
        if isinstance(scene, dict):
            scene = Scene(scene)
        if not isinstance(scene, Scene):
            raise Error(f"Renderer: expected a penumbra.Scene or a dict, got {type(scene).__name__}")
        self._engine = _penumbra.Engine(_dumps(scene.document, "scene"), scene.base_dir)
        self.stats = {}

    def set(self, path, value):
        """One edit: `path` as in --set ("lights.0.direction"), `value` anything JSON can hold."""
        self.edit({path: value})

    def edit(self, edits):
        """Several edits at once ({path: value}); all are refused together when one is invalid."""
        if not isinstance(edits, dict):
            raise Error(f"edit: expected a dict {{path: value}}, got {type(edits).__name__}")
        self._engine.edit([(str(p), _dumps(v, p)) for p, v in edits.items()])

    def get(self, path):
        return json.loads(self._engine.get(path))

    @property
    def scene(self):
        return Scene(json.loads(self._engine.document()))

    def render(self, width=None, height=None, dtype="uint8", quality="full", accumulate=False, transparent=False):
        """A frame as an (H, W, 4) array, row 0 at the top: "uint8" sRGB RGBA (straight alpha) or
        "float32" linear RGBA with premultiplied alpha. quality "preview" is what follows the user's
        hand; accumulate=True averages this frame with the previous ones while nothing changed."""
        sizes = {}  # a new size is a camera edit: nothing is rebuilt
        if width is not None and _positive_int(width, "width") != self._engine.width:
            sizes["camera.width"] = int(width)
        if height is not None and _positive_int(height, "height") != self._engine.height:
            sizes["camera.height"] = int(height)
        if sizes:
            self.edit(sizes)
        if dtype not in ("uint8", "float32", np.uint8, np.float32):
            raise Error(f"render: dtype {dtype!r} (expected 'uint8' or 'float32')")
        if quality not in ("full", "preview"):
            raise Error(f"render: quality {quality!r} (expected 'full' or 'preview')")
        out = np.empty((self._engine.height, self._engine.width, 4), dtype=np.dtype(dtype)).view(Image)
        self.stats = json.loads(self._engine.render_into(out, quality == "preview", bool(accumulate), bool(transparent)))
        return out


def compare(a, b):
    """RMSE, PSNR (dB) and largest difference of two (H, W, 3|4) images on [0, 1] (uint8 is scaled)."""
    return _penumbra.compare(_unit(a), _unit(b))


def _unit(a):
    a = np.asarray(a)
    if a.dtype == np.uint8:
        return a.astype(np.float32) / 255.0
    return a.astype(np.float32, copy=False)


def _positive_int(v, name):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= int(v) <= 16384:
        raise Error(f"render: {name} {v!r} (expected an integer in [1, 16384])")
    return int(v)


def _dumps(value, where):
    try:
        return json.dumps(value, allow_nan=False, default=_json_default)
    except (TypeError, ValueError) as e:
        raise Error(f"{where}: {e}") from None


def _json_default(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    raise TypeError(f"a {type(v).__name__} is not a JSON value")


def _png(image):
    """PNG bytes of an (H, W, 4) image (uint8 as it is; float32 as premultiplied linear RGBA)."""
    a = np.asarray(image)
    if a.dtype != np.uint8:
        alpha = np.clip(a[..., 3:4], 0, 1)
        rgb = np.where(alpha > 0, np.clip(a[..., :3] / np.maximum(alpha, 1e-12), 0, 1), 0)
        srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * np.power(rgb, 1 / 2.4) - 0.055)
        a = np.concatenate([np.round(srgb * 255), np.round(alpha * 255)], axis=2).astype(np.uint8)
    h, w = a.shape[:2]
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
