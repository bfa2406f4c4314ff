"""penumbra.Widget's kernel half (issue 41): the viewer's protocol (docs/viewer.md) spoken over a widget's
comm, driven here as the page would drive it, with the comm replaced by a list of what was sent. State
flows both ways: the page's edits land in the Renderer, and the Renderer's edits from Python reach the
page. The browser half is tested against a real notebook server in test_widget_notebook.py."""
import io
import json
import re
import threading
import time

import numpy as np
import pytest

pytest.importorskip("ipywidgets")  # Debian python3-ipywidgets (scripts/install-deps.sh)
from PIL import Image as PilImage  # noqa: E402  (python3-pil, with matplotlib)

import penumbra  # noqa: E402
from penumbra import widget as widget_module  # noqa: E402

TIMEOUT = 60

SCENE = {
    "volumes": [{"procedural": {"name": "test-spheres", "size": 24}, "transfer_function": {"preset": "test-spheres"}}],
    "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
    "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
    "camera": {"width": 96, "height": 64},
    "shadows": {"technique": "cssm", "resolution": 64},
}


class Page:
    """A widget with its comm replaced: `sent` holds (message dict, buffer or None) in order."""

    def __init__(self, scene=SCENE, max_samples=3):
        self.renderer = penumbra.Renderer(penumbra.Scene(json.loads(json.dumps(scene))))
        self.widget = penumbra.Widget(self.renderer, height=300, max_samples=max_samples)
        self.sent = []
        self.lock = threading.Lock()
        self.widget.send = self._record

    def _record(self, content, buffers=None):
        with self.lock:
            if "page" in content:
                self.sent.append((content, None))
            else:
                self.sent.append((json.loads(content["message"]), buffers[0] if buffers else None))

    def say(self, message):
        self.widget._on_page_message(self.widget, {"message": json.dumps(message)}, [])

    def messages(self, kind=None):
        with self.lock:
            return [(m, b) for m, b in self.sent if kind is None or m.get("type") == kind]

    def wait(self, condition, what):
        deadline = time.monotonic() + TIMEOUT
        while not condition():
            assert time.monotonic() < deadline, f"timed out waiting for {what}; sent: {[m.get('type') for m, _ in self.messages()]}"
            time.sleep(0.01)

    def wait_idle(self, samples):
        """Until the full frame of `samples` samples has come (the refinement's end)."""
        self.wait(lambda: any(m.get("quality") == "full" and m.get("samples") == samples for m, _ in self.messages("frame")),
                  f"a full frame of {samples} samples")

    def clear(self):
        with self.lock:
            self.sent.clear()

    def close(self):
        self.widget.close()


@pytest.fixture
def page():
    p = Page()
    yield p
    p.close()


def test_page_files_are_complete():
    """The iframe's page: its style inline, no placeholder left but the main module's, and every module
    a module imports is among those sent (widget.js turns each into a blob URL)."""
    page = widget_module._page()
    html, modules = page["html"], page["modules"]
    assert html.count("{{main_module}}") == 1
    assert "{{" not in html.replace("{{main_module}}", "")
    assert "<style>" in html and 'rel="stylesheet"' not in html
    assert "/js/main.js" in modules
    for path, text in modules.items():
        for name in re.findall(r'from\s*"\.\/([\w-]+\.js)"', text):
            assert "/js/" + name in modules, f"{path} imports {name}, which the widget does not send"
        assert "import(" not in text, f"{path}: a dynamic import, which widget.js does not rewrite"


def test_page_request_answers_with_the_page(page):
    page.say({"type": "page"})
    page.wait(lambda: page.messages(), "the page")
    content, _ = page.messages()[0]
    assert content["page"]["html"] == widget_module._page()["html"]


def test_nothing_renders_before_a_page_says_hello(page):
    """No page, no frames: a widget nobody shows (a notebook run headless) costs no rendering."""
    page.renderer.set("lights.0.intensity", 1.5)
    time.sleep(0.5)
    assert page.messages("frame") == []


def test_hello_gets_state_preview_and_refined_frames(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    kinds = [(m["type"], m.get("quality"), m.get("samples")) for m, _ in page.messages()]
    assert kinds[0] == ("state", None, None)
    assert kinds[1:] == [("frame", "full", 1), ("frame", "full", 2), ("frame", "full", 3)]
    state = page.messages("state")[0][0]
    assert state["document"]["camera"]["width"] == 96
    time.sleep(0.3)
    assert len(page.messages("frame")) == 3, "refinement stops at max_samples"


def test_frames_are_the_renderers_image(page):
    """The JPEG the page shows is the frame the renderer makes (to JPEG's precision), at the camera's size."""
    page.say({"type": "hello"})
    page.wait_idle(3)
    meta, jpeg = page.messages("frame")[0]
    shown = np.asarray(PilImage.open(io.BytesIO(jpeg)).convert("RGB"), dtype=np.float64)
    assert shown.shape == (64, 96, 3) and (meta["width"], meta["height"]) == (96, 64)
    rendered = page.renderer.render()[..., :3].astype(np.float64)  # sample 0 at full quality, as the first frame
    rmse = np.sqrt(np.mean((shown - rendered) ** 2))
    assert rmse < 4.0, f"the page's frame differs from the renderer's by RMSE {rmse:.2f} of 255"


def test_page_edits_land_in_the_renderer(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    page.clear()
    page.say({"type": "edit", "set": {"camera.eye": [0.5, 1.0, 3.0], "volumes.0.transfer_function": "ct-bone"}})
    page.wait_idle(3)
    assert page.renderer.get("camera.eye") == [0.5, 1.0, 3.0]
    assert page.renderer.is_set("volumes.0.transfer_function")
    kinds = [(m["type"], m.get("quality")) for m, _ in page.messages()]
    assert kinds[:2] == [("state", None), ("frame", "preview")]
    assert page.messages("state")[0][0]["document"]["camera"]["eye"] == [0.5, 1.0, 3.0]


def test_python_edits_reach_the_page(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    page.clear()
    page.renderer.set("lights.0.direction", [0.3, -1, 0.2])
    page.wait_idle(3)
    state = page.messages("state")[-1][0]
    assert state["document"]["lights"][0]["direction"] == [0.3, -1, 0.2]
    frames = page.messages("frame")
    assert frames[0][0]["quality"] == "preview" and "lights.0.direction" in frames[0][0]["edits"]


def test_playback_steps_skip_the_preview(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    page.clear()
    page.say({"type": "edit", "set": {"lights.0.intensity": 1.2}, "preview": False})
    page.wait_idle(3)
    assert [m.get("quality") for m, _ in page.messages("frame")][0] == "full"


def test_resize_sets_the_camera(page):
    page.say({"type": "hello"})
    page.say({"type": "resize", "width": 120, "height": 80})
    page.wait(lambda: any(m.get("width") == 120 and m.get("quality") == "full" for m, _ in page.messages("frame")), "a 120-wide frame")
    assert (page.renderer.get("camera.width"), page.renderer.get("camera.height")) == (120, 80)


@pytest.mark.parametrize("message, expected", [
    ({"type": "edit", "set": {"camera.fov": 40}}, "camera.fov: unknown key"),
    ({"type": "edit", "set": {}}, "at least one path"),
    ({"type": "edit", "set": {"camera.zoom": 2}, "preview": "yes"}, '"preview" must be true or false'),
    ({"type": "resize", "width": 8, "height": 80}, "integers in [16, 4096]"),
    ({"type": "teleport"}, "unknown type 'teleport'"),
    ({"type": "download", "what": "everything"}, "expected \"screenshot\" or \"scene\""),
    ({"type": "probe", "x": "left"}, 'probe: expected "pixel": [x, y]'),
])
def test_bad_messages_get_an_error_and_keep_the_scene(page, message, expected):
    page.say({"type": "hello"})
    page.wait_idle(3)
    before = page.renderer.scene.document
    page.clear()
    page.say(message)
    page.wait(lambda: page.messages("error"), "an error")
    assert expected in page.messages("error")[0][0]["message"]
    time.sleep(0.3)
    assert page.messages("frame") == [], "a refused message renders nothing"
    assert page.renderer.scene.document == before


def test_probe_answers_with_the_value_under_the_pointer(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    page.say({"type": "probe", "pixel": [48, 40]})  # the middle of the view: the spheres
    page.say({"type": "probe", "pixel": [2, 2]})    # the top left corner: the background
    page.wait(lambda: len(page.messages("probe")) == 2, "two probe answers")
    middle, corner = (m for m, _ in page.messages("probe"))
    assert middle["hit"] and middle["volume"] == 0 and middle["pixel"] == [48, 40]
    assert not corner["hit"]


def test_downloads(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    page.clear()
    page.say({"type": "download", "what": "scene"})
    page.wait(lambda: page.messages("download"), "the scene")
    meta, data = page.messages("download")[0]
    assert meta["name"] == "scene.json" and json.loads(data)["camera"]["width"] == 96
    page.clear()
    page.say({"type": "download", "what": "screenshot"})
    page.wait(lambda: page.messages("download"), "the screenshot")
    meta, data = page.messages("download")[0]
    assert meta == {"type": "download", "name": "penumbra.png", "mime": "image/png"}
    assert PilImage.open(io.BytesIO(data)).size == (96, 64)


def test_python_edit_does_not_wait_for_a_long_frame():
    """An edit from Python stops the widget's full frame in progress instead of queueing behind it, and
    the frame it stopped is never sent."""
    scene = dict(SCENE, camera={"width": 1280, "height": 960}, shadows={"technique": "cssm", "resolution": 512})
    p = Page(scene, max_samples=1000)
    try:
        p.say({"type": "hello"})
        p.wait(lambda: any(m.get("quality") == "full" for m, _ in p.messages("frame")), "a first full frame")
        full_ms = max(m["ms"] for m, _ in p.messages("frame") if m.get("quality") == "full")
        p.wait(lambda: p.widget._rendering, "a frame in progress")
        t0 = time.monotonic()
        p.renderer.set("lights.0.intensity", 1.3)
        waited_ms = (time.monotonic() - t0) * 1000
        sent_before = len(p.messages())
        print(f"full frame {full_ms:.0f} ms; edit waited {waited_ms:.0f} ms")  # the figure; not a pass/fail
        assert p.renderer.get("lights.0.intensity") == 1.3
        p.wait(lambda: any(m.get("quality") == "preview" for m, _ in p.messages("frame")), "the edit's preview")
        # what came after the edit: its state, then its preview; never the stale frame it interrupted
        after = [(m["type"], m.get("quality"), m.get("edits")) for m, _ in p.messages()[sent_before:]]
        assert after[0][0] == "state" and after[1][:2] == ("frame", "preview"), after
        assert "lights.0.intensity" in after[1][2]
        assert p.widget.frames_cancelled >= 1, "the frame in progress when Python edited was not stopped"
    finally:
        p.close()
    ids = [m["id"] for m, _ in p.messages("frame")]
    assert ids == sorted(ids) and len(set(ids)) == len(ids)


def test_close_stops_the_thread(page):
    page.say({"type": "hello"})
    page.wait_idle(3)
    thread = page.widget._thread
    page.close()
    assert not thread.is_alive()
    assert page.widget not in list(page.renderer._watchers)


def test_bad_arguments():
    r = penumbra.Renderer(penumbra.Scene(json.loads(json.dumps(SCENE))))
    with pytest.raises(penumbra.Error, match="expected a penumbra.Renderer"):
        penumbra.Widget("scene.json")
    with pytest.raises(penumbra.Error, match="height 10"):
        penumbra.Widget(r, height=10)
    with pytest.raises(penumbra.Error, match="max_samples 0"):
        penumbra.Widget(r, max_samples=0)


def test_a_trajectory_played_from_mdanalysis_plays_in_the_page():
    """The issue's case: a scene driven by MDAnalysis showed one frame in the notebook. Each set_frame(ts)
    now sends the page the moved atoms: a state, then a preview and the refined frames of that frame."""
    mda = pytest.importorskip("MDAnalysis")
    from MDAnalysis.coordinates.memory import MemoryReader
    rng = np.random.default_rng(7)
    frames = np.cumsum(rng.normal(0, 0.4, (3, 40, 3)), axis=0).astype(np.float32) + rng.uniform(0, 12, (1, 40, 3)).astype(np.float32)
    u = mda.Universe.empty(40, trajectory=True)
    u.add_TopologyAttr("elements", ["C", "N", "O", "S"] * 10)
    u.load_new(frames, format=MemoryReader)
    scene = penumbra.Scene({"camera": {"width": 64, "height": 48}, "shadows": {"technique": "issm"}})
    scene.add_atoms(u.atoms)
    r = penumbra.Renderer(scene)
    w = penumbra.Widget(r, max_samples=2)
    sent = []
    w.send = lambda content, buffers=None: sent.append((json.loads(content["message"]), buffers[0] if buffers else None))
    try:
        w._on_page_message(w, {"message": json.dumps({"type": "hello"})}, [])
        deadline = time.monotonic() + TIMEOUT
        jpegs = []
        for ts in u.trajectory:
            r.set_frame(ts)
            while not any(m.get("quality") == "full" and m.get("samples") == 2 for m, _ in sent):
                assert time.monotonic() < deadline, [m.get("type") for m, _ in sent]
                time.sleep(0.01)
            assert [m["type"] for m, _ in sent][:2] == ["state", "frame"] or ts.frame == 0
            jpegs.append([b for m, b in sent if m.get("quality") == "full"][-1])
            sent.clear()
        assert len(jpegs) == 3 and len({bytes(j) for j in jpegs}) == 3, "each frame of the trajectory shows different atoms"
    finally:
        w.close()
