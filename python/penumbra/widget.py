"""penumbra's viewer inside a Jupyter notebook, as a widget over a Renderer: the page of `penumbra view`
(docs/viewer.md) in the output cell, its messages carried by the widget's comm instead of a WebSocket, so
the browser needs no other connection than the notebook's own. State flows both ways: what the page
edits (camera, light, time, transfer functions, selections, cuts) is edited in the Renderer, so
r.get("camera.eye") says where the user looks; and r.set(...), r.set_frame(ts) or r.update_particles(...)
from Python redraw the page.

    r = penumbra.Renderer(scene)
    w = penumbra.Widget(r)        # shown when it is a cell's last value, or display(w)
    r.set("time", 10)             # the page follows

The browser half is widget.js. Frames are rendered on a thread of the widget's own, as the viewer's
server renders them: a preview after each edit, then full frames accumulated while nothing changes; an
edit (from the page or from Python) stops a full frame in progress. Needs ipywidgets (Debian's
python3-ipywidgets 6, classic notebook)."""

import json
import os
import threading

import ipywidgets
import traitlets
from IPython.display import Javascript, display

from . import _penumbra, Error, _png, Renderer

__all__ = ["Widget"]

_WIDGET_JS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "widget.js")
_page_cache = None


def _page():
    """The viewer's page for the widget's iframe: index.html (its style inline, the main module's URL
    left as {{main_module}} for widget.js to fill in) and the text of each module of js/."""
    global _page_cache
    if _page_cache is None:
        files = _penumbra.viewer_page_files()
        html = files["/"]
        html = html.replace('<link rel="stylesheet" href="/style.css?token={{token}}">', "<style>\n" + files["/style.css"] + "</style>")
        html = html.replace('<script type="importmap" nonce="{{nonce}}">{{import_map}}</script>\n', "")
        html = html.replace('src="/js/main.js?token={{token}}"', 'src="{{main_module}}"')
        if "{{token}}" in html or "{{import_map}}" in html or "{{main_module}}" not in html:
            raise Error("Widget: the viewer's index.html no longer has the placeholders widget.py fills in")
        _page_cache = {"html": html, "modules": {p: t for p, t in files.items() if p.startswith("/js/")}}
    return _page_cache


class Widget(ipywidgets.DOMWidget):
    """The viewer over `renderer` in a notebook cell, `height` pixels tall (its width is the cell's).
    max_samples: full-quality samples accumulated while nothing changes. close() stops its thread."""

    _view_name = traitlets.Unicode("PenumbraView").tag(sync=True)
    _view_module = traitlets.Unicode("penumbra-widget").tag(sync=True)
    height = traitlets.Int(640).tag(sync=True)

    def __init__(self, renderer, height=640, max_samples=16):
        if not isinstance(renderer, Renderer):
            raise Error(f"Widget: expected a penumbra.Renderer, got {type(renderer).__name__}")
        if isinstance(height, bool) or not isinstance(height, int) or not 64 <= height <= 4096:
            raise Error(f"Widget: height {height!r} (expected an int of pixels, 64 to 4096)")
        if isinstance(max_samples, bool) or not isinstance(max_samples, int) or not 1 <= max_samples <= 1024:
            raise Error(f"Widget: max_samples {max_samples!r} (expected an int, 1 to 1024)")
        super().__init__(height=height)
        self.renderer = renderer
        self.max_samples = max_samples
        self.frames_sent = 0
        self.frames_cancelled = 0   # frames an edit stopped (or stopped before they began)
        self._rendering = False     # inside a frame (tests wait for it)
        self._wake = threading.Condition()
        self._jobs = []             # (kind, payload) from the page and from Python, in order
        self._closed = False
        self._shown = False         # a page said hello: until then nothing is rendered
        self._editing = 0           # edits from Python in progress: no frame starts until they are done
        self.on_msg(self._on_page_message)
        renderer._watchers.add(self)
        self._thread = threading.Thread(target=self._render_loop, name="penumbra-widget", daemon=True)
        self._thread.start()

    def _ipython_display_(self, **kwargs):
        with open(_WIDGET_JS, encoding="utf-8") as f:
            display(Javascript(f.read()))  # defines the view's module before the view is made
        super()._ipython_display_(**kwargs)

    def close(self):
        """Stops the widget's render thread and closes its views."""
        if not hasattr(self, "_thread"):  # refused by __init__ (ipywidgets closes it when it is collected)
            super().close()
            return
        with self._wake:
            self._closed = True
            self._wake.notify()
        self.renderer._engine.cancel_frame()
        if self._thread is not threading.current_thread():
            self._thread.join()
        self.renderer._watchers.discard(self)
        super().close()

    # -- from the renderer: Python changed the scene ------------------------------------------------

    def _interrupt(self):
        """Before an edit from Python: a frame in progress stops and no other starts until the edit is
        done (_scene_changed), so the edit never waits behind a frame."""
        if threading.current_thread() is self._thread:
            return  # the widget's own edits, from the page
        with self._wake:
            self._editing += 1
        self.renderer._engine.cancel_frame()

    def _scene_changed(self):
        """After an edit from Python (applied or refused): redraw, if a page shows the widget."""
        if threading.current_thread() is self._thread:
            return
        with self._wake:
            self._editing -= 1
            if self._shown:
                self._jobs.append(("changed", None))
            self._wake.notify()

    # -- from the page -----------------------------------------------------------------------------

    def _on_page_message(self, _widget, content, _buffers):
        text = content.get("message") if isinstance(content, dict) else None
        if not isinstance(text, str):
            return
        try:
            m = json.loads(text)
        except ValueError:
            self._send_text({"type": "error", "message": "message: not JSON"})
            return
        kind = m.get("type") if isinstance(m, dict) else None
        if kind == "page":
            self.send({"page": _page()})
        elif kind == "hello":
            self._shown = True
            self._queue(("hello", None))
        elif kind == "edit":
            edits = m.get("set")
            if not isinstance(edits, dict) or not edits:
                self._send_text({"type": "error", "message": 'edit: expected "set": {"PATH": VALUE, ...} with at least one path'})
                return
            preview = m.get("preview", True)
            if not isinstance(preview, bool):
                self._send_text({"type": "error", "message": 'edit: "preview" must be true or false'})
                return
            self.renderer._engine.cancel_frame()
            self._queue(("edit", (edits, preview)))
        elif kind == "resize":
            w, h = m.get("width"), m.get("height")
            if not all(isinstance(v, int) and not isinstance(v, bool) and 16 <= v <= 4096 for v in (w, h)):
                self._send_text({"type": "error", "message": 'resize: "width" and "height" must be integers in [16, 4096]'})
                return
            self.renderer._engine.cancel_frame()
            self._queue(("edit", ({"camera.width": w, "camera.height": h}, True)))
        elif kind in ("probe", "download"):
            self._queue((kind, m if kind == "download" else text))
        else:
            self._send_text({"type": "error", "message": f"message: unknown type {kind!r} (expected edit, resize, probe or download)"})

    def _queue(self, job):
        with self._wake:
            self._jobs.append(job)
            self._wake.notify()

    # -- to the page -------------------------------------------------------------------------------

    def _send_text(self, message, buffer=None):
        text = message if isinstance(message, str) else json.dumps(message)
        self.send({"message": text}, buffers=[buffer] if buffer is not None else None)

    def _download(self, m):
        what = m.get("what")
        if what == "screenshot":
            image = self.renderer.render()
            self._send_text({"type": "download", "name": "penumbra.png", "mime": "image/png"}, _png(image))
        elif what == "scene":
            text = self.renderer._engine.saved_document(self.renderer._base_dir)
            self._send_text({"type": "download", "name": "scene.json", "mime": "application/json"}, text.encode())
        else:
            self._send_text({"type": "error", "message": f'download: "what" {what!r} (expected "screenshot" or "scene")'})

    def _render_loop(self):
        """The viewer server's render loop (viewer_server.cpp) over the renderer: apply what came, send
        the state when the scene changed, then a preview, then full frames up to max_samples."""
        need_preview = need_full = False
        samples = self.max_samples
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._closed or (self._editing == 0 and (
                    self._jobs or need_preview or need_full or samples < self.max_samples)))
                if self._closed:
                    return
                jobs, self._jobs = self._jobs, []
            changed = preview = False
            for kind, payload in jobs:
                try:
                    if kind == "edit":
                        self.renderer.edit(payload[0])
                        changed, preview = True, preview or payload[1]
                    elif kind == "changed":
                        changed = preview = True
                    elif kind == "hello":
                        changed = True
                    elif kind == "probe":
                        self._send_text(self.renderer._engine.probe(payload))
                    elif kind == "download":
                        self._download(payload)
                        if payload.get("what") == "screenshot":
                            need_full, samples = True, 0  # the screenshot rendered sample 0 again
                except Exception as e:  # an edit the scene refuses: the page says so and keeps its scene
                    self._send_text({"type": "error", "message": str(e)})
            if changed:
                self._send_text(self.renderer._engine.viewer_state())
                need_preview, need_full, samples = need_preview or preview, True, 0
            with self._wake:
                if self._jobs or self._editing:
                    continue  # more came, or Python is editing: that first
                generation = self.renderer._engine.cancel_generation()  # an edit after this stops the frame
            if not (need_preview or need_full or samples < self.max_samples):
                continue  # a probe, a download or a refused edit: the frame shown stays
            self._rendering = True
            try:
                if need_preview:
                    frame = self.renderer._engine.frame_message(True, False, self.max_samples, generation)
                    need_preview = False
                else:
                    frame = self.renderer._engine.frame_message(False, True, self.max_samples, generation)
                    if frame is not None:
                        need_full, samples = False, (1 if need_full else samples + 1)
            except Exception as e:  # a frame that fails stops the refinement; the page says why
                self._send_text({"type": "error", "message": f"frame failed: {e}"})
                need_preview = need_full = False
                samples = self.max_samples
                continue
            finally:
                self._rendering = False
            if frame is None:
                self.frames_cancelled += 1
                continue  # cancelled by an edit: the loop takes it next
            meta, jpeg = frame
            self.frames_sent += 1
            message = json.loads(meta)
            message["id"] = self.frames_sent
            self._send_text(message, jpeg)
