"""penumbra from Python: scenes as dicts, files or NumPy arrays, the interactive engine, frames as arrays.

    import penumbra
    scene = penumbra.Scene.load("scenes/cranium.json", ["shadows.technique=cssm"])
    # or: scene = penumbra.Scene(); scene.add_volume(ct, spacing=(2.5, 0.7, 0.7), transfer_function="ct-bone")
    r = penumbra.Renderer(scene)
    image = r.render(width=512, height=512)          # (512, 512, 4) uint8 sRGB RGBA, row 0 at the top
    r.set("lights.0.direction", [0.2, -1, -0.4])     # the engine's edits: the paths of --set
    image = r.render(dtype="float32")                # premultiplied linear RGBA
    print(r.stats["rebuilt"])                        # [{'structure': 'lights.0.shadows', 'cause': 'lights.0.direction'}]

A scene is exactly the scene file's schema (docs/scene-file.md); it is checked when a renderer is made
from it or on scene.validate(), and errors raise penumbra.Error (a ValueError) with the CLI's message.
In Jupyter, a rendered frame (a penumbra.Image, an ndarray) shows itself; anything computed from it
(img[..., :3], img.mean(), img.astype(np.float32)) is a plain ndarray. penumbra.Widget(r) is the
viewer in the notebook, its state shared with r both ways (penumbra/widget.py; needs ipywidgets).
"""
import copy
import html
import json
import os
import struct
import sys
import threading
import warnings
import weakref
import zlib


def _built_for():
    """The interpreter the compiled module was built for (path, version): CMake's Python3_EXECUTABLE,
    written into _build_info.py beside this file when CMake assembles the package in build/release/python."""
    try:
        from ._build_info import PYTHON_EXECUTABLE, PYTHON_VERSION
        return PYTHON_EXECUTABLE, PYTHON_VERSION
    except ImportError:
        return None, None


def _wrong_interpreter(what, error):
    exe, version = _built_for()
    built = f"{exe} (Python {version})" if exe else "the python3 CMake found when it built the package (Debian's /usr/bin/python3)"
    return ImportError(
        f"penumbra: {what} ({error}). This interpreter is {sys.executable} (Python {sys.version.split()[0]}), "
        f"but penumbra was built for {built}: run that one (PYTHONPATH=build/release/python {exe or '/usr/bin/python3'} ...; "
        f"a pyenv or virtualenv python3 first on PATH lacks Debian's python3-numpy), or build the package for this one "
        f"(cmake -DPython3_EXECUTABLE={sys.executable}; docs/python.md)")


try:
    import numpy as np
except ImportError as e:
    raise _wrong_interpreter("NumPy cannot be imported", e) from e

try:
    from . import _penumbra
except ImportError as e:  # an interpreter of another Python version cannot load the compiled module
    raise _wrong_interpreter("the compiled module _penumbra cannot be loaded", e) from e

Error = _penumbra.Error

__all__ = ["Error", "Renderer", "Scene", "Viewer", "VolumeData", "Widget", "compare", "read_volume", "set_threads", "techniques", "threads",
           "view"]


def __getattr__(name):
    """penumbra.Widget is imported on first use: it needs ipywidgets, which the rest does not."""
    if name == "Widget":
        from .widget import Widget
        return Widget
    raise AttributeError(f"module 'penumbra' has no attribute {name!r}")

_VOLUME_DTYPES = (np.uint8, np.int16, np.uint16, np.float32)


class Scene:
    """A scene document: the scene file's schema as a dict, with the folder its relative paths use, and
    the NumPy arrays that its builders added (named in the document by "array")."""

    def __init__(self, document=None, base_dir="."):
        if document is None:
            document = {}
        if not isinstance(document, dict):
            raise Error(f"Scene: expected a dict with the scene file's keys (docs/scene-file.md), got {type(document).__name__}")
        self.document = copy.deepcopy(document)
        self.base_dir = os.fspath(base_dir)
        self._volumes = {}    # array name -> the ndarray the renderer views
        self._particles = {}  # array name -> (spheres (N, 4) float32, linear RGB colours (N, 3) float32)
        self._atoms = {}      # "particles.N" -> (AtomGroup, radius_scale, hydrogens): groups add_atoms tied

    @classmethod
    def load(cls, path, overrides=()):
        """A scene file with `--set` overrides ("path=value") applied."""
        if isinstance(overrides, str):
            raise Error("Scene.load: overrides must be a list of 'path=value' strings, not one string")
        text, base_dir = _penumbra.load_document(os.fspath(path), list(overrides))
        return cls(json.loads(text), base_dir or ".")

    def validate(self):
        """Reads the scene exactly as the scene-file reader does (loading its data); raises Error naming the key."""
        _penumbra.validate(_dumps(self.document, "scene"), self.base_dir, self._volumes, self._particles)
        return self

    def to_dict(self):
        """The document (objects added from arrays name them by "array"; only a Renderer of this Scene knows them)."""
        return copy.deepcopy(self.document)

    # ------------------------------------------------------------------------------------ builders
    def add_volume(self, array, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), transfer_function=None, **keys):
        """Adds a volume that views a 3-D NumPy array in place (no copy) and returns its path ("volumes.N").

        The array's axes are (z, y, x), as napari, scikit-image and most Python imaging code hold them:
        array[k, j, i] is voxel (i, j, k), at world position origin + (i, j, k) * spacing. `spacing` and
        `origin` are given in the array's axis order too, (z, y, x), like napari's scale and translate.
        dtype: uint8, int16, uint16 or float32 (anything else raises Error: convert with astype). A
        C-contiguous array is shared, not copied: change it in place, then call
        Renderer.update_volume(path) (a full frame finds a change made without it, by a digest of the
        array's bytes, and rebuilds with a warning). A non-contiguous one (a slice with steps, a transpose) is copied
        once, with a warning. `transfer_function`: a preset name ("ct-bone"), a list of [value, r, g, b,
        alpha] points, or the scene file's dict; default: one chosen from the data (a CT in Hounsfield
        units gets ct-bone, anything else a ramp over its histogram). Other
        keywords are the scene file's volume keys (step, compositing, visible, casts_shadows, ...)."""
        a = _volume_array(array, "add_volume")
        name = self._name("volume", self._volumes)
        entry = {"array": name, "spacing": _axes_zyx(spacing, "spacing"), "origin": _axes_zyx(origin, "origin")}
        if transfer_function is not None:
            entry["transfer_function"] = _transfer_function(transfer_function)
        entry.update(keys)
        self._volumes[name] = a
        return self._append("volumes", entry)

    def add_particles(self, positions, radii=1.0, colors=(0.8, 0.8, 0.8), **keys):
        """Adds spheres and returns their path ("particles.N"). positions: (N, 3) world x, y, z; radii:
        one number or N; colors: one colour or one per sphere, (N, 3) or (N, 4) floats in [0, 1] as
        linear RGB (the scene file's colours) or integers 0-255 (uint8, int64, ...) as 8-bit sRGB (alpha is ignored). The spheres
        are packed once (16 bytes each); Renderer.update_particles moves them, frame by frame.
        Other keywords: casts_shadows, receives_shadows."""
        name = self._name("particles", self._particles)
        self._particles[name] = _pack_particles(positions, radii, colors, "add_particles")
        entry = {"array": name}
        entry.update(keys)
        return self._append("particles", entry)

    def add_atoms(self, atoms, radius_scale=1.0, hydrogens=True, **keys):
        """Adds an MDAnalysis AtomGroup (anything with .positions and .elements or .types) as spheres with
        van der Waals radii and CPK colours, and returns the path. The group stays tied to the path: a
        Renderer's set_frame(ts) moves its Universe to that frame and redraws the group there (an
        updating selection, u.select_atoms(..., updating=True), is evaluated anew), with the camera
        framed once, on the first frame, as penumbra's own trajectory reader does."""
        positions, radii, colors = _atom_spheres(atoms, radius_scale, hydrogens)
        path = self.add_particles(positions, radii, colors, **keys)
        self._atoms[path] = (atoms, float(radius_scale), bool(hydrogens))
        return path

    def add_isosurface(self, volume, value, **keys):
        """Adds the isosurface f = value of a volume (its path "volumes.N" or index) and returns its path.
        Other keywords: method, color, collapse, casts_shadows, receives_shadows."""
        entry = {"volume": _index_of(volume, "volumes", "add_isosurface"), "value": value}
        entry.update(keys)
        return self._append("isosurfaces", entry)

    def add_plane(self, point=(0.0, -0.6, 0.0), normal=(0.0, 1.0, 0.0), **keys):
        """Adds an opaque plane (keywords: color, size, casts_shadows, receives_shadows, clip); returns its path."""
        entry = {"point": point, "normal": normal}
        entry.update(keys)
        return self._append("planes", entry)

    def add_clip_plane(self, point, normal):
        """Adds a clip plane: it removes the half-space `normal` points into from every volume, isosurface
        and particle set (and from planes that say clip=True), for the eye and for every light. Returns
        its path, e.g. "clip_planes.0"; r.set("clip_planes.0.point", [...]) moves it."""
        return self._append("clip_planes", {"point": list(point), "normal": list(normal)})

    def add_slice(self, volume, point=None, normal=(0.0, 0.0, 1.0), **keys):
        """Adds a slice through a volume (its path or index): a plane cut to the volume's box, coloured by
        its values (keywords: color_map, a transfer function; window=[lo, hi], grey; casts_shadows,
        receives_shadows). It receives the scene's shadows. Returns its path, e.g. "slices.0"."""
        entry = {"volume": _index_of(volume, "volumes", "add_slice"), "normal": list(normal)}
        if point is not None:
            entry["point"] = list(point)
        entry.update(keys)
        return self._append("slices", entry)

    def add_light(self, type="directional", **keys):
        """Adds a light (keywords: direction, position, color, intensity, angle_deg, softness) and returns
        its path. The first one replaces the default light from above."""
        entry = {"type": type}
        entry.update(keys)
        return self._append("lights", entry)

    def _append(self, kind, entry):
        items = self.document.setdefault(kind, [])
        if not isinstance(items, list):
            raise Error(f"{kind}: expected a list, got {type(items).__name__}")
        items.append(entry)
        return f"{kind}.{len(items) - 1}"

    def _name(self, stem, taken):
        i = len(taken)
        while f"{stem}{i}" in taken:
            i += 1
        return f"{stem}{i}"

    def __repr__(self):
        kinds = [f"{len(self.document[k])} {k}" for k in ("volumes", "particles", "isosurfaces", "planes") if self.document.get(k)]
        return f"penumbra.Scene({', '.join(kinds) or 'empty'})"


class Image(np.ndarray):
    """A rendered frame: the (H, W, 4) ndarray Renderer.render returns, which shows itself in Jupyter.

    Only the frame itself knows what its numbers mean (uint8 sRGB with straight alpha, or float32
    premultiplied linear RGBA), so only it displays itself. Everything computed from it is a plain
    ndarray: img[..., :3], img.mean(), img.astype(np.float32) / 255, np.flipud(img)."""

    _encoding = None  # "srgb8" or "linear": set by Renderer.render on the frame alone

    def __array_finalize__(self, obj):
        self._encoding = None  # a view or copy made by NumPy: numbers of unknown meaning

    def __getitem__(self, key):
        return np.asarray(self)[key]

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        inputs = tuple(_plain(x) for x in inputs)
        if "out" in kwargs:
            kwargs["out"] = tuple(_plain(x) for x in kwargs["out"])
        return getattr(ufunc, method)(*inputs, **kwargs)

    def __array_function__(self, func, types, args, kwargs):
        return func(*(_plain(a) for a in args), **{k: _plain(v) for k, v in kwargs.items()})

    def astype(self, *args, **kwargs):
        return np.asarray(self).astype(*args, **kwargs)

    def view(self, *args, **kwargs):
        return np.asarray(self).view(*args, **kwargs)

    def reshape(self, *args, **kwargs):
        return np.asarray(self).reshape(*args, **kwargs)

    def transpose(self, *axes):
        return np.asarray(self).transpose(*axes)

    @property
    def T(self):
        return np.asarray(self).T

    def copy(self, order="C"):
        """A copy of the frame that still shows itself."""
        out = np.asarray(self).copy(order).view(Image)
        out._encoding = self._encoding
        return out

    def __reduce__(self):  # pickles as the plain array it holds
        return np.asarray(self).copy().__reduce__()

    def _repr_png_(self):
        if self._encoding is None or self.ndim != 3 or self.shape[2] != 4:
            return None
        return _png(np.asarray(self))


def _plain(x):
    if isinstance(x, Image):
        return np.asarray(x)
    if isinstance(x, (list, tuple)):
        return type(x)(_plain(v) for v in x)
    return x


def _serialised(method):
    """Runs the method holding the renderer's lock: threads sharing a Renderer take turns, a frame
    never interleaves with an edit (the engine's own lock does the same for _penumbra.Engine)."""
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    locked.__name__, locked.__qualname__, locked.__doc__ = method.__name__, method.__qualname__, method.__doc__
    return locked


def _edits_scene(method):
    """An edit of the renderer's scene, serialised as _serialised does. The widgets watching the renderer
    (penumbra.Widget) stop a frame in progress first, so the edit need not wait for it, and redraw after."""
    def edited(self, *args, **kwargs):
        watchers = list(self._watchers)
        for w in watchers:
            w._interrupt()
        try:
            with self._lock:
                return method(self, *args, **kwargs)
        finally:
            for w in watchers:
                w._scene_changed()
    edited.__name__, edited.__qualname__, edited.__doc__ = method.__name__, method.__qualname__, method.__doc__
    return edited


class Renderer:
    """The interactive engine over a scene: edits by path, frames as arrays, stats of what was rebuilt.
    A Renderer may be shared by threads: its calls are serialised (one frame or edit at a time, each
    whole), and render() releases the GIL while the frame is computed."""

    def __init__(self, scene):
        if isinstance(scene, dict):
            scene = Scene(scene)
        if not isinstance(scene, Scene):
            raise Error(f"Renderer: expected a penumbra.Scene or a dict, got {type(scene).__name__}")
        self._volumes = dict(scene._volumes)
        self._particles = dict(scene._particles)
        self._base_dir = scene.base_dir  # where the scene's relative file names lie
        self._atoms = dict(scene._atoms)
        self._digests = {name: _penumbra.digest(a) for name, a in self._volumes.items()}  # see _refresh_changed_volumes
        self._engine = _penumbra.Engine(_dumps(scene.document, "scene"), self._base_dir, self._volumes, self._particles)
        self._lock = threading.RLock()
        self._watchers = weakref.WeakSet()  # the penumbra.Widgets showing this renderer
        self.stats = {}

    @_serialised
    def set(self, path, value):
        """One edit: `path` as in --set ("lights.0.direction"), `value` anything JSON can hold."""
        self.edit({path: value})

    @_edits_scene
    def edit(self, edits):
        """Several edits at once ({path: value}); all are refused together when one is invalid."""
        if not isinstance(edits, dict):
            raise Error(f"edit: expected a dict {{path: value}}, got {type(edits).__name__}")
        self._engine.edit([(str(p), _dumps(v, p)) for p, v in edits.items()])

    @_edits_scene
    def update_particles(self, path, positions=None, radii=None, colors=None):
        """New positions (N, 3), radii or colours for the spheres added at `path` ("particles.N"); the
        sphere shadows and ambient occlusion are rebuilt for the next frame (a trajectory frame)."""
        name = self._array_name(path, "particles")
        spheres, packed = self._particles[name]
        n = len(spheres)
        new_spheres = spheres.copy()
        if positions is not None:
            p = _float_rows(positions, 3, "update_particles: positions")
            if len(p) != n:
                raise Error(f"update_particles: positions has {len(p)} rows; {path} has {n} spheres")
            new_spheres[:, :3] = p
        if radii is not None:
            new_spheres[:, 3] = _radii(radii, n, "update_particles")
        if colors is not None:
            packed = _pack_colors(colors, n, "update_particles")
        self._engine.replace_particles(name, new_spheres, packed)
        self._particles[name] = (new_spheres, packed)

    @_edits_scene
    def set_frame(self, frame):
        """Moves the trajectories of the AtomGroups Scene.add_atoms tied to this renderer to `frame` (an
        index, or an MDAnalysis Timestep) and redraws each group there: `for ts in u.trajectory:
        r.set_frame(ts); r.render()`. Updating selections are evaluated at the new frame (their atom
        count may change). The camera stays where the first frame framed it."""
        index = getattr(frame, "frame", frame)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise Error(f"set_frame: {frame!r} (expected a frame index or an MDAnalysis Timestep)")
        if not self._atoms:
            raise Error("set_frame: no AtomGroup is tied to this renderer (Scene.add_atoms ties them; "
                        "scene-file trajectories play with set('time', k))")
        for path, (atoms, radius_scale, hydrogens) in self._atoms.items():
            trajectory = atoms.universe.trajectory
            if not 0 <= int(index) < len(trajectory):
                raise Error(f"set_frame: frame {int(index)} of a trajectory of {len(trajectory)} frames ({path})")
            if trajectory.ts.frame != int(index):
                trajectory[int(index)]
            positions, radii, colors = _atom_spheres(atoms, radius_scale, hydrogens)
            name = self._array_name(path, "particles")
            spheres, packed = _pack_particles(positions, radii, colors, "set_frame")
            self._engine.replace_particles(name, spheres, packed)
            self._particles[name] = (spheres, packed)

    @_edits_scene
    def update_volume(self, path, array=None):
        """The volume at `path` ("volumes.N") after its array changed in place, or a new array for it
        (same rules as Scene.add_volume); what depends on the data is rebuilt for the next frame."""
        name = self._array_name(path, "volumes")
        a = self._volumes[name] if array is None else _volume_array(array, "update_volume")
        self._engine.replace_volume(name, a)
        self._volumes[name] = a
        self._digests[name] = _penumbra.digest(a)

    def _refresh_changed_volumes(self):
        """Before a full frame: a volume array changed in place without update_volume would draw its new
        voxels with its old shadows and gradients. Its digest (a hash of every byte, ~30 ms per 500 MB
        on 2 cores) tells, and what depends on it is rebuilt, with a warning."""
        for name, a in self._volumes.items():
            digest = _penumbra.digest(a)
            if digest != self._digests[name]:
                path = self._path_of_array(name, "volumes")
                warnings.warn(f"{path}: its array changed since it was given, without Renderer.update_volume('{path}'); "
                              f"rebuilt what depends on its voxels", stacklevel=3)
                self._engine.replace_volume(name, a)
                self._digests[name] = digest

    def _path_of_array(self, name, kind):
        items = json.loads(self._engine.document()).get(kind, [])
        return next((f"{kind}.{i}" for i, o in enumerate(items) if isinstance(o, dict) and o.get("array") == name), name)

    def _array_name(self, path, kind):
        index = _index_of(path, kind, f"update_{kind.rstrip('s')}" if kind == "volumes" else "update_particles")
        try:
            name = self.get(f"{kind}.{index}.array")
        except Error:
            name = None
        if name is None:
            raise Error(f"{kind}.{index}: not added from an array (its data comes from a file or a generator)")
        return name

    @_serialised
    def get(self, path):
        """The value at `path` ("lights.0.direction"): what the scene sets, else the default it takes
        (as the reader worked it out for this scene: the framed camera's eye, the transfer function
        chosen from the data; None for an optional key without one, such as a volume's "file").
        is_set(path) tells which. An unknown path (a typo) raises Error naming the keys its object has."""
        return json.loads(self._engine.get(path))

    @_serialised
    def is_set(self, path):
        """Whether the scene sets `path` itself (False where a default applies; Error for an unknown path)."""
        return self._engine.is_set(path)

    @property
    def frames(self):
        """Frames of the scene's trajectories and volume series (0 when nothing moves): r.set("time", k)
        for k in range(r.frames) plays them, each frame reading only its data."""
        return self._engine.frames

    @property
    def scene(self):
        """The scene as edited so far (with the arrays it views)."""
        scene = Scene(json.loads(self._engine.document()), self._base_dir)
        scene._volumes, scene._particles, scene._atoms = dict(self._volumes), dict(self._particles), dict(self._atoms)
        return scene

    @_serialised
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
        if quality == "full":
            self._refresh_changed_volumes()
        out = np.empty((self._engine.height, self._engine.width, 4), dtype=np.dtype(dtype))
        self.stats = json.loads(self._engine.render_into(out, quality == "preview", bool(accumulate), bool(transparent)))
        for r in self.stats.get("refinement", []):
            if "error" in r:  # a finer box that could not be read: the frame shows the opened level there
                warnings.warn(f"volumes.{r['volume']}: {r['error']}; drawn from the opened level {r['opened_level']}", stacklevel=3)
        frame = out.view(Image)
        frame._encoding = "srgb8" if out.dtype == np.uint8 else "linear"
        return frame


def set_threads(threads):
    """The worker threads every frame uses from now on: a count, or 0 for one per core (the default).
    Frames are the same bytes for any count."""
    if not isinstance(threads, (int, np.integer)) or isinstance(threads, bool):
        raise Error(f"set_threads: expected an int, got {type(threads).__name__}")
    _penumbra.set_threads(int(threads))


def threads():
    """The worker threads a frame uses now (set_threads)."""
    return _penumbra.threads()


def techniques():
    """The shadow and ambient techniques and the keys each reads, from the techniques' own declarations
    (the same as `penumbra techniques` and docs/scene-file.md): a list of dicts with name, family
    ("shadows" or "ambient"), casters, summary and keys (each: key, type, default, allowed, unit,
    meaning). Set a key with Renderer.set("shadows.<key>", value) or in the scene's document."""
    return _penumbra.techniques()


def _technique_keys_doc():
    lines = []
    for t in _penumbra.techniques():
        if t["name"] == "none":
            continue
        lines.append(f"    {t['family']}.technique = {t['name']}: {t['summary']}")
        for k in t["keys"]:
            unit = f" {k['unit']}" if k["unit"] else ""
            lines.append(f"        {t['family']}.{k['key']} ({k['type']}, default {k['default']}, {k['allowed']}{unit}): {k['meaning']}")
    return "\n".join(lines)


Renderer.set.__doc__ += "\n\n    The techniques' keys, from their declarations (penumbra.techniques()):\n" + _technique_keys_doc()


class Viewer:
    """A running `penumbra view` server (docs/viewer.md) over its own copy of a scene. In Jupyter it shows
    itself as an IFrame; `url` opens it in any browser (token included); stop() ends it."""

    def __init__(self, server, width, height):
        self._server = server
        self.url = server.url
        self.width, self.height = width, height

    def stop(self):
        """Stops the server (the page's connection closes); the Viewer cannot be started again."""
        self._server.stop()

    def _repr_html_(self):
        return (f'<iframe src="{html.escape(self.url)}" width="{int(self.width)}" height="{int(self.height)}" '
                f'style="border: 0"></iframe>')

    def __repr__(self):
        return f"penumbra.Viewer({self.url})"


_LOCAL_NOTEBOOKS = ("http://localhost:*", "http://127.0.0.1:*", "https://localhost:*", "https://127.0.0.1:*")


def view(scene, host="127.0.0.1", port=0, data_root=None, token="", width=960, height=640, frame_ancestors=_LOCAL_NOTEBOOKS):
    """Starts the viewer on a scene (a Scene, a dict, or a Renderer's current scene) and returns it; in
    Jupyter the returned Viewer shows the page inline. It binds 127.0.0.1 unless `host` says otherwise;
    `data_root` (default: the scene's folder) is the only folder edits may name files in.
    `frame_ancestors`: the pages that may show the viewer in a frame (CSP sources such as
    "http://localhost:*"; default: notebook servers on this machine, so the inline frame shows; () for
    none). The page still needs its token, which only the URL this returns holds."""
    if isinstance(scene, Renderer):
        scene = scene.scene
    if isinstance(scene, dict):
        scene = Scene(scene)
    if not isinstance(scene, Scene):
        raise Error(f"view: expected a penumbra.Scene, a dict or a Renderer, got {type(scene).__name__}")
    root = os.fspath(data_root) if data_root is not None else os.path.abspath(scene.base_dir)
    server = _penumbra.Viewer(_dumps(scene.document, "scene"), scene.base_dir, scene._volumes, scene._particles,
                              host, int(port), root, token, [str(a) for a in frame_ancestors])
    return Viewer(server, width, height)


class VolumeData:
    """A volume read from a file: ``array`` (axes z, y, x), ``spacing`` and ``origin`` in the same axis
    order (z, y, x), as Scene.add_volume takes them, and ``info`` (format, affine: the file's voxel
    index (i, j, k) to world transform in LPS as three rows [linear | offset] or None, orientation, DICOM
    series, TIFF channels and the reader's notes). The array is the file's voxels placed on the world's
    axes (docs/volume-formats.md)."""

    def __init__(self, array, spacing, origin, info):
        self.array, self.spacing, self.origin, self.info = array, spacing, origin, info

    def __repr__(self):
        z, y, x = self.array.shape
        return (f"VolumeData({self.info['format']}, {x} x {y} x {z} {self.array.dtype}, "
                f"spacing {self.spacing}, origin {self.origin})")


def read_volume(path, series=None, channel=None, grid=None, level=None, dataset=None, memory_budget=None):
    """Reads a volume as penumbra does: .nrrd, .nhdr, .nii(.gz), .tif(f), .vti, .vtk, .vdb, .h5/.hdf5
    (``dataset``: its path in the file), a Zarr v2 or v3 store (an array, or an OME-Zarr 0.4 or 0.5 image), a folder of
    DICOM slices or a list of .dcm files.
    ``series`` picks a DICOM series (SeriesInstanceUID or index; default the one with the most slices),
    ``channel`` a TIFF, OME-Zarr or HDF5 channel, ``level`` an OME-Zarr pyramid level (0 the finest; default
    the finest whose voxels fit ``memory_budget``, bytes or a size such as "4G", else a quarter of the
    memory; an NRRD, HDF5 or raw file over the budget is read reduced by the finest power of two that
    fits, each voxel its block's mean, a slab at a time), ``grid`` an OpenVDB grid (name or index; default
    'density', else the first float grid; the array is dense: NumPy has no sparse layout). Returns a
    VolumeData, whose array goes to
    Scene.add_volume(v.array, spacing=v.spacing, origin=v.origin)."""
    paths = [os.fspath(p) for p in path] if isinstance(path, (list, tuple)) else [os.fspath(path)]
    if channel is not None and (not isinstance(channel, int) or channel < 0):
        raise Error(f"read_volume: channel {channel!r} (expected an integer from 0)")
    if level is not None and (isinstance(level, bool) or not isinstance(level, int) or level < 0):
        raise Error(f"read_volume: level {level!r} (expected an integer from 0)")
    array, spacing, origin, info = _penumbra.read_volume(paths, "" if series is None else str(series),
                                                         -1 if channel is None else channel,
                                                         "" if grid is None else str(grid), -1 if level is None else level,
                                                         "" if dataset is None else str(dataset),
                                                         "" if memory_budget is None else str(memory_budget))
    return VolumeData(array, tuple(reversed(spacing)), tuple(reversed(origin)), json.loads(info))


def compare(a, b):
    """RMSE, PSNR (dB) and largest difference of two (H, W, 3|4) images on [0, 1] (uint8 is scaled)."""
    return _penumbra.compare(_unit(a), _unit(b))


def _unit(a):
    a = np.asarray(a)
    if a.dtype == np.uint8:
        return a.astype(np.float32) / 255.0
    return a.astype(np.float32, copy=False)


def _volume_array(array, where):
    a = np.asarray(array)
    if a.ndim != 3:
        raise Error(f"{where}: the array has {a.ndim} dimensions, shape {a.shape} (expected 3: z, y, x)")
    if a.dtype.newbyteorder("=") not in _VOLUME_DTYPES or not a.dtype.isnative:
        raise Error(f"{where}: dtype {a.dtype} (expected uint8, int16, uint16 or float32 in native byte order; "
                    f"convert with array.astype(np.float32))")
    if not a.flags.c_contiguous:
        warnings.warn(f"{where}: the array is not C-contiguous (strides {a.strides}); penumbra renders a copy "
                      f"({a.nbytes / 2**20:.1f} MiB): pass np.ascontiguousarray(array) to share it", stacklevel=3)
        a = np.ascontiguousarray(a)
    return a


def _axes_zyx(v, name):
    t = np.asarray(v, dtype=np.float64).reshape(-1)
    if t.size == 1:
        t = np.repeat(t, 3)
    if t.size != 3 or not np.all(np.isfinite(t)):
        raise Error(f"add_volume: {name} {v!r} (expected three finite numbers in the array's axis order z, y, x)")
    return [float(t[2]), float(t[1]), float(t[0])]


def _transfer_function(tf):
    if isinstance(tf, str):
        return {"preset": tf}
    if isinstance(tf, dict):
        return tf
    return {"points": np.asarray(tf, dtype=np.float64).tolist()}


def _float_rows(values, columns, where):
    a = np.asarray(values)
    if a.dtype.kind not in "fiu":
        raise Error(f"{where}: dtype {a.dtype} (expected numbers)")
    if a.ndim != 2 or a.shape[1] != columns:
        raise Error(f"{where}: shape {a.shape} (expected (N, {columns}))")
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise Error(f"{where}: row {row} is {a[row].tolist()} (expected finite numbers; {int(bad.sum())} rows are not)")
    return a.astype(np.float32)


def _radii(radii, n, where):
    r = np.asarray(radii, dtype=np.float64)
    if r.ndim == 0:
        r = np.full(n, float(r))
    if r.shape != (n,):
        raise Error(f"{where}: radii has shape {r.shape} (expected one number or {n})")
    if not np.all(np.isfinite(r) & (r > 0)):
        row = int(np.flatnonzero(~(np.isfinite(r) & (r > 0)))[0])
        raise Error(f"{where}: radii[{row}] is {r[row]} (expected a positive number)")
    return r.astype(np.float32)


def _pack_colors(colors, n, where):
    c = np.asarray(colors)
    if c.ndim == 1:
        c = np.broadcast_to(c, (n, c.shape[0]))
    if c.ndim != 2 or c.shape[0] != n or c.shape[1] not in (3, 4):
        raise Error(f"{where}: colors has shape {np.shape(colors)} (expected one colour (3,) or (N, 3|4) with N = {n})")
    if c.dtype.kind in "iu":  # 8-bit sRGB, as image libraries write colours; never linear numbers clamped
        if c.dtype != np.uint8:
            if c.size and (c.min() < 0 or c.max() > 255):
                raise Error(f"{where}: integer colors from {c.min()} to {c.max()} (expected 8-bit sRGB 0-255, or floats in [0, 1] as linear RGB)")
            if c.size and c.max() <= 1:
                raise Error(f"{where}: integer colors of only 0 and 1 are ambiguous (write 1.0 for linear RGB in [0, 1], or 255 for 8-bit sRGB)")
        s = c[:, :3].astype(np.float64) / 255.0
        linear = np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)
    elif c.dtype.kind == "f":
        linear = c[:, :3].astype(np.float64)
        if not np.all(np.isfinite(linear)):
            raise Error(f"{where}: colors holds NaN or infinite values (expected linear RGB in [0, 1])")
        if linear.size and (linear.min() < 0 or linear.max() > 1):
            hint = "; 8-bit colours: pass them as integers (e.g. np.uint8)" if linear.max() > 1 and linear.max() <= 255 else ""
            raise Error(f"{where}: float colors from {linear.min():g} to {linear.max():g} (expected linear RGB in [0, 1]{hint})")
    else:
        raise Error(f"{where}: colors dtype {c.dtype} (expected floats in [0, 1] or integers 0-255)")
    return np.ascontiguousarray(linear, dtype=np.float32)


def _pack_particles(positions, radii, colors, where):
    p = _float_rows(positions, 3, f"{where}: positions")
    if len(p) == 0:
        raise Error(f"{where}: positions holds no particles")
    spheres = np.empty((len(p), 4), dtype=np.float32)
    spheres[:, :3] = p
    spheres[:, 3] = _radii(radii, len(p), where)
    return spheres, _pack_colors(colors, len(p), where)


def _atom_spheres(atoms, radius_scale, hydrogens):
    """Positions, radii and linear colours of an AtomGroup's atoms (hydrogens dropped unless asked for)."""
    symbols = _element_symbols(atoms)
    radii, colors = _penumbra.element_style(list(symbols))
    keep = np.ones(len(symbols), dtype=bool) if hydrogens else ~np.isin(np.char.upper(symbols), ["H", "D", "T"])
    if not keep.any():
        raise Error(f"add_atoms: the group's {len(symbols)} atoms are all hydrogens, and hydrogens=False")
    return np.asarray(atoms.positions)[keep], radii[keep] * float(radius_scale), colors[keep]


def _element_symbols(atoms):
    for attr in ("elements", "types"):
        try:
            symbols = np.asarray(getattr(atoms, attr), dtype=str)
        except Exception:  # MDAnalysis raises NoDataError (an AttributeError/ValueError) without the attribute
            continue
        if symbols.size == len(atoms.positions) and np.all(symbols != ""):
            return symbols
    raise Error("add_atoms: expected an AtomGroup with .positions and .elements (or .types) per atom")


def _index_of(path_or_index, kind, where):
    if isinstance(path_or_index, (int, np.integer)) and not isinstance(path_or_index, bool):
        return int(path_or_index)
    if isinstance(path_or_index, str):
        head, _, tail = path_or_index.partition(".")
        if head == kind and tail.isdigit():
            return int(tail)
    raise Error(f"{where}: {path_or_index!r} (expected \"{kind}.N\" or an index)")


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
