"""The viewer's server (`penumbra view`, docs/viewer.md) over its protocol: the token guards every
request, edits come back as state and frames to every client, files outside the data root are refused,
malformed, mutated, oversized and vanishing clients get errors or are dropped while the server keeps
serving, and the screenshot equals `penumbra render` of the saved scene."""
import json
import os
import pathlib
import posixpath
import random
import re
import signal
import socket
import subprocess
import time
import urllib.error
import urllib.request

import pytest

websocket = pytest.importorskip("websocket")  # Debian python3-websocket (scripts/install-deps.sh)

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")

SCENE = {
    "volumes": [{"procedural": {"name": "test-spheres", "size": 24}, "transfer_function": {"preset": "test-spheres"}}],
    "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
    "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
    "camera": {"width": 48, "height": 40},
    "shadows": {"technique": "cssm", "resolution": 64},
}


class Viewer:
    def __init__(self, folder, scene=SCENE, *args, prefix=(), env=None):
        """`prefix` runs the server under another command (prlimit); `env` is its environment."""
        self.folder = folder
        path = folder / "scene.json"
        path.write_text(json.dumps(scene))
        self.process = subprocess.Popen([*prefix, CLI, "view", str(path), "--port", "0", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                        text=True, env=env)
        self.url = self.process.stdout.readline().strip()
        assert self.url.startswith("http://127.0.0.1:"), self.url
        self.base, _, query = self.url.partition("/?")
        self.token = query.split("token=")[1]
        self.ws_url = self.base.replace("http://", "ws://") + "/ws?token=" + self.token

    def get(self, path, token=True):
        url = self.base + path + (("&" if "?" in path else "?") + "token=" + self.token if token else "")
        try:
            with urllib.request.urlopen(url, timeout=30) as r:
                return r.status, r.read(), r.headers
        except urllib.error.HTTPError as e:
            return e.code, e.read(), e.headers

    def connect(self):
        # a hang guard, not a timing check: a sanitizer build beside oversubscribed MPI tests can take
        # tens of seconds for a frame
        ws = websocket.create_connection(self.ws_url, timeout=180)
        return ws

    def alive(self):
        return self.process.poll() is None and self.get("/")[0] == 200

    def close(self):
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            raise
        return self.process.returncode


@pytest.fixture
def viewer(tmp_path):
    v = Viewer(tmp_path)
    yield v
    assert v.close() == 0, "Ctrl-C must stop the server cleanly"


def receive(ws, kind, timeout=180):
    """Messages until one of type `kind` (the binary JPEG after a frame header is returned with it)."""
    end = time.time() + timeout
    while time.time() < end:
        opcode, data = ws.recv_data()
        if opcode != websocket.ABNF.OPCODE_TEXT:
            continue
        m = json.loads(data)
        if m["type"] == kind:
            if kind == "frame":
                opcode, jpeg = ws.recv_data()
                assert opcode == websocket.ABNF.OPCODE_BINARY
                return m, jpeg
            return m
    raise AssertionError(f"no {kind} message within {timeout} s")


def test_every_request_needs_the_token(viewer):
    status, body, headers = viewer.get("/")
    assert status == 200 and b'id="view"' in body and headers["Content-Type"].startswith("text/html")
    assert viewer.get("/", token=False)[0] == 403
    assert viewer.get("/?token=wrong", token=False)[0] == 403
    assert viewer.get("/scene.json", token=False)[0] == 403
    assert viewer.get("/screenshot.png", token=False)[0] == 403
    with pytest.raises(websocket.WebSocketBadStatusException) as e:
        websocket.create_connection(viewer.ws_url.replace(viewer.token, "wrong"), timeout=10)
    assert e.value.status_code == 403
    # no file is ever served
    for path in ("/../../etc/passwd", "/etc/passwd", "/scene.json/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd"):
        assert viewer.get(path)[0] == 404, path


PAGE_DIR = pathlib.Path(os.environ.get("PENUMBRA_ROOT", pathlib.Path(__file__).resolve().parents[2])) / "src/penumbra/viewer/page"
PAGE_TYPES = {".html": "text/html", ".css": "text/css", ".js": "text/javascript"}


def test_the_page_its_stylesheet_and_its_modules_are_served_with_their_types(viewer):
    """Every file of src/penumbra/viewer/page is served at its path (index.html at /) with its type, only
    with the token; the page's links and its import map name them with the token, so that the modules'
    imports carry it; the policy lets scripts and style come from the server only."""
    files = sorted(p.relative_to(PAGE_DIR).as_posix() for p in PAGE_DIR.rglob("*") if p.is_file())
    assert "index.html" in files and "style.css" in files and "js/main.js" in files, files
    status, page, headers = viewer.get("/")
    assert status == 200
    page = page.decode()
    assert "{{" not in page, "a placeholder of index.html was not filled in"
    # the policy: scripts from the server, and the one inline script (the import map) by this answer's nonce
    csp = dict((d.split(" ", 1) + [""])[:2] for d in headers["Content-Security-Policy"].split("; "))
    nonce = re.search(r'<script type="importmap" nonce="([0-9a-f]{32})">', page).group(1)
    assert csp["script-src"] == f"'self' 'nonce-{nonce}'" and csp["style-src"] == "'self'", csp
    assert csp["default-src"] == "'none'" and "unsafe" not in headers["Content-Security-Policy"]
    assert re.search(r'nonce="([0-9a-f]{32})"', viewer.get("/")[1].decode()).group(1) != nonce, "a nonce is each answer's"
    token = "?token=" + viewer.token
    assert f'<link rel="stylesheet" href="/style.css{token}">' in page
    assert f'<script type="module" src="/js/main.js{token}"></script>' in page
    map_text = re.search(r'<script type="importmap"[^>]*>(.*?)</script>', page, re.S).group(1)
    import_map = json.loads(map_text)["imports"]
    source = (PAGE_DIR / "index.html").read_text()
    assert page == source.replace("{{token}}", viewer.token).replace("{{nonce}}", nonce).replace("{{import_map}}", map_text)
    modules = [f for f in files if f.endswith(".js")]
    assert import_map == {"/" + m: "/" + m + token for m in modules}
    imported = set()
    for f in files:
        if f == "index.html":
            continue
        status, body, headers = viewer.get("/" + f)
        assert status == 200, f
        assert headers["Content-Type"].split(";")[0] == PAGE_TYPES[pathlib.PurePosixPath(f).suffix], (f, headers["Content-Type"])
        assert headers["X-Content-Type-Options"] == "nosniff"
        assert body == (PAGE_DIR / f).read_bytes(), f"{f} is not served as it is in the source"
        assert viewer.get("/" + f, token=False)[0] == 403, f
        assert viewer.get("/" + f + "?token=wrong", token=False)[0] == 403, f
        # every module a module imports is in the import map (so its request carries the token)
        for spec in re.findall(r'^import .* from "([^"]+)";$', body.decode(), re.M):
            imported.add("/" + posixpath.normpath(posixpath.join(posixpath.dirname(f), spec)))
    assert imported and imported <= set(import_map), imported
    # only the table's files: no other path, no folder, no other spelling
    for path in ("/index.html", "/js/", "/js", "/style.css/", "/JS/main.js", "/js/nope.js", "/js/../style.css", "/favicon.ico"):
        assert viewer.get(path)[0] == 404, path


def test_edits_come_back_as_state_and_frames_to_every_client(viewer):
    a, b = viewer.connect(), viewer.connect()
    state = receive(a, "state")
    assert state["document"]["shadows"]["technique"] == "cssm"
    assert len(state["histograms"]) == 1 and len(state["histograms"][0]["counts"]) == 64
    assert state["transfer_functions"][0]["volume"] == 0 and len(state["transfer_functions"][0]["points"]) >= 2
    assert "cssm" in state["techniques"]["shadows"] and "offsets" in state["technique_keys"]["cssm"]
    frame, jpeg = receive(a, "frame")
    assert jpeg[:2] == b"\xff\xd8" and frame["view_width"] == 48 and frame["view_height"] == 40
    # a preview travels at its reduced size (the page scales it); a full frame at the view's
    assert frame["width"] == -(-48 // frame["divisor"]) and frame["height"] == -(-40 // frame["divisor"])
    while frame["quality"] != "full":  # until the first full frame, everything is built for the "first frame"
        frame, jpeg = receive(a, "frame")
    assert frame["width"] == 48 and frame["height"] == 40 and frame["divisor"] == 1
    receive(b, "state")
    a.send(json.dumps({"type": "edit", "set": {"lights.0.direction": [0.4, -1, 0.1]}}))
    for ws in (a, b):  # both tabs follow
        while True:
            s = receive(ws, "state")
            if s["document"]["lights"][0]["direction"] == [0.4, -1, 0.1]:
                break
    # the edit's preview says what it rebuilt and why; a frame not yet sent is replaced by a newer one
    # (by design), which then carries its edits and rebuilds: under load the preview's report can come
    # with the edit's full frame
    frame, _ = receive(a, "frame")
    while "lights.0.direction" not in frame["edits"]:
        frame, _ = receive(a, "frame")
    assert {"structure": "lights.0.shadows", "cause": "lights.0.direction"} in frame["rebuilt"]
    while frame["quality"] != "full":
        frame, _ = receive(a, "frame")
    a.send(json.dumps({"type": "resize", "width": 64, "height": 32}))
    while frame["view_width"] != 64:
        frame, _ = receive(a, "frame")
    assert frame["view_height"] == 32
    a.close()
    b.close()


def test_an_edit_without_preview_is_answered_by_its_full_frame_alone(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    frame, _ = receive(ws, "frame")
    while not (frame["quality"] == "full" and frame["samples"] >= 2):  # the first frames are done
        frame, _ = receive(ws, "frame")
    for fov in (31, 32, 33):  # a playback step: the page waits for its full frame anyway
        ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": fov}, "preview": False}))
        while True:  # no preview comes: every frame is full, the edit's first one included
            frame, _ = receive(ws, "frame")
            assert frame["quality"] == "full", frame
            # a frame this client had not read yet when the next was made hands its edits on to that
            # one (docs/viewer.md): under load the edit can arrive with its second sample
            if "camera.fov_deg" in frame["edits"]:
                break
    ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": 34}, "preview": "no"}))
    assert receive(ws, "error")["message"] == 'edit: "preview" must be true or false'
    ws.close()


def test_refused_edits_and_files_outside_the_data_root_get_errors(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    for edit, needle in [
        ({"volumes.0.file": "../../etc/passwd"}, "outside the data root"),
        ({"volumes.0.file": "/etc/passwd"}, "outside the data root"),
        ({"volumes.0.transfer_function": {"paraview": "/etc/passwd"}}, "outside the data root"),
        ({"volumes.0": {"file": "../secret.nrrd", "transfer_function": {"preset": "grayscale"}}}, "outside the data root"),
        ({"volumes.0.file": ["/etc/passwd", "/etc/shadow"]}, "outside the data root"),  # DICOM slices
        ({"volumes.0.files": ["../a.nrrd", "../b.nrrd"]}, "outside the data root"),  # a volume series
        ({"volumes.0.files": "../../run_%d.nrrd"}, "outside the data root"),
        ({"particles": [{"file": "../x.gro", "trajectory": "/etc/passwd"}]}, "outside the data root"),
        # one element of a list of files: a volume series' step, a DICOM slice, a trajectory's part
        ({"volumes.0.files.0": "/etc/passwd"}, "outside the data root"),
        ({"volumes.0.file.1": "../../etc/passwd"}, "outside the data root"),
        ({"particles.0.trajectory.0": "/etc/passwd"}, "outside the data root"),
        # a series made first, then its step pointed outside, in one message
        ({"volumes": [{"files": ["inside.nrrd"], "transfer_function": {"preset": "grayscale"}}],
          "volumes.0.files.0": "/etc/passwd"}, "outside the data root"),
        ({"shadows.bogus": 1}, "shadows.bogus"),
        ({"lights.0.direction": "up"}, "lights.0.direction"),
        ({"nonsense": 1}, "nonsense"),
    ]:
        ws.send(json.dumps({"type": "edit", "set": edit}))
        error = receive(ws, "error")
        assert needle in error["message"], (edit, error)
    ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": 40}}))  # and it still renders
    while receive(ws, "state")["document"]["camera"].get("fov_deg") != 40:
        pass
    ws.close()
    assert viewer.alive()


def mutations(rng, base):
    for _ in range(2000):
        text = bytearray(base.encode())
        kind = rng.randrange(5)
        if kind == 0:  # flip bytes
            for _ in range(rng.randrange(1, 6)):
                text[rng.randrange(len(text))] = rng.randrange(256)
        elif kind == 1:  # truncate
            text = text[: rng.randrange(len(text))]
        elif kind == 2:  # random bytes
            text = bytearray(rng.randrange(256) for _ in range(rng.randrange(1, 200)))
        elif kind == 3:  # wrong types in the right places
            text = json.dumps({"type": rng.choice(["edit", "resize", 3, None, "x"]),
                               "set": rng.choice([{}, [], 1, {"camera.eye": rng.choice([[1, 2], "a", None, [1e308, 0, 0]])}]),
                               "width": rng.choice([0, -1, 1e9, "10", 100]), "height": 100}).encode()
        else:  # deep nesting
            depth = rng.randrange(1, 3000)
            text = (b"[" * depth) + (b"]" * depth)
        yield bytes(text)


def test_thousands_of_mutated_messages_get_answers_and_the_server_lives(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    rng = random.Random(11)
    base = json.dumps({"type": "edit", "set": {"camera.eye": [1.5, 1.0, 1.8], "volumes.0.step": 0.6}})
    sent = 0
    for message in mutations(rng, base):
        try:
            ws.send(message.decode("utf-8", errors="replace"))
        except (BrokenPipeError, ConnectionResetError, websocket.WebSocketConnectionClosedException):
            ws = viewer.connect()  # a message that closed the connection (none should): reconnect
        sent += 1
    assert sent == 2000
    ws.close()
    assert viewer.alive()
    # an oversized message closes that connection only
    big = viewer.connect()
    receive(big, "state")
    big.send(json.dumps({"type": "edit", "set": {"camera.eye": [1] * 40000}}))
    with pytest.raises((websocket.WebSocketConnectionClosedException, ConnectionResetError, BrokenPipeError)):
        for _ in range(1000):
            big.recv_data()
    other = viewer.connect()
    assert receive(other, "state")["type"] == "state"
    other.close()


def test_a_client_vanishing_mid_frame_costs_nothing(viewer):
    for _ in range(5):
        raw = socket.create_connection(("127.0.0.1", int(viewer.base.rsplit(":", 1)[1])))
        ws = viewer.connect()
        receive(ws, "state")
        ws.send(json.dumps({"type": "edit", "set": {"camera.width": 96, "camera.height": 80}}))
        ws.sock.close()  # gone without a close frame, while frames are on their way
        raw.sendall(b"GET /ws?token=" + viewer.token.encode() + b" HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\n")
        raw.close()  # half a handshake, then gone
    assert viewer.alive()
    ws = viewer.connect()
    frame, jpeg = receive(ws, "frame")
    assert jpeg[:2] == b"\xff\xd8"
    ws.close()


def test_the_screenshot_equals_penumbra_render_of_the_saved_scene(viewer, tmp_path):
    ws = viewer.connect()
    receive(ws, "state")
    ws.send(json.dumps({"type": "edit", "set": {"lights.0.direction": [0.2, -1, -0.5], "volumes.0.transfer_function": {"preset": "test-spheres", "opacity_scale": 2}}}))
    while receive(ws, "state")["document"]["lights"][0]["direction"] != [0.2, -1, -0.5]:
        pass
    status, scene, _ = viewer.get("/scene.json")
    assert status == 200
    saved = tmp_path / "saved.json"
    saved.write_bytes(scene)
    status, png, headers = viewer.get("/screenshot.png")
    assert status == 200 and png[:8] == b"\x89PNG\r\n\x1a\n" and "attachment" in headers["Content-Disposition"]
    subprocess.run([CLI, "render", str(saved), "-o", str(tmp_path / "cli.png")], check=True, capture_output=True)
    assert (tmp_path / "cli.png").read_bytes() == png
    ws.close()


def test_penumbra_view_from_python_serves_the_scene_and_stops():
    import penumbra
    import numpy as np

    scene = penumbra.Scene({"camera": {"width": 40, "height": 32}, "shadows": {"technique": "cssm", "resolution": 64}})
    scene.add_volume(np.ascontiguousarray(np.linspace(0, 1, 16 * 16 * 16, dtype=np.float32).reshape(16, 16, 16)))
    viewer = penumbra.view(scene, width=500)
    assert viewer.url.startswith("http://127.0.0.1:") and "token=" in viewer.url
    assert f'src="{viewer.url}"' in viewer._repr_html_() and 'width="500"' in viewer._repr_html_()
    with urllib.request.urlopen(viewer.url, timeout=30) as r:
        assert r.status == 200 and b'id="view"' in r.read()
        # the notebook's inline frame may show it (a local Jupyter server), other sites may not
        assert "frame-ancestors http://localhost:* http://127.0.0.1:*" in r.headers["Content-Security-Policy"]
        assert r.headers["X-Frame-Options"] is None
    base, _, query = viewer.url.partition("/?")
    ws = websocket.create_connection(base.replace("http://", "ws://") + "/ws?" + query, timeout=30)
    state = receive(ws, "state")
    assert state["document"]["volumes"][0]["array"] == "volume0"
    frame, jpeg = receive(ws, "frame")
    assert jpeg[:2] == b"\xff\xd8"
    viewer.stop()
    with pytest.raises(urllib.error.URLError) as refused:  # stopped: its port is closed, not left unanswered
        urllib.request.urlopen(viewer.url, timeout=5)
    assert isinstance(refused.value.reason, ConnectionRefusedError), refused.value
    with pytest.raises((websocket.WebSocketConnectionClosedException, ConnectionResetError, BrokenPipeError)):
        for _ in range(1000):  # what was sent before, then the end: its clients were disconnected
            ws.recv_data()
    viewer.stop()  # twice is fine


def test_penumbra_view_frames_only_where_asked():
    import penumbra

    scene = {"volumes": [{"procedural": {"name": "test-spheres", "size": 8}}], "camera": {"width": 16, "height": 16}}
    viewer = penumbra.view(scene, frame_ancestors=())
    try:
        with urllib.request.urlopen(viewer.url, timeout=30) as r:
            assert "frame-ancestors 'none'" in r.headers["Content-Security-Policy"] and r.headers["X-Frame-Options"] == "DENY"
    finally:
        viewer.stop()
    with pytest.raises(penumbra.Error, match=r"frame ancestor \"http://evil; script-src \*\": expected http\(s\)://HOST"):
        penumbra.view(scene, frame_ancestors=["http://evil; script-src *"])


def test_penumbra_view_of_a_renderer_keeps_its_scene_folder(tmp_path, monkeypatch):
    """A scene loaded from another folder names its files relative to that folder: the Renderer's scene,
    and the viewer started on it, keep the folder (the data root and where the files are read)."""
    import penumbra

    folder = tmp_path / "study"
    folder.mkdir()
    volume = bytes(range(64)) * 8  # an 8³ uint8 volume, beside its scene
    (folder / "head.nrrd").write_bytes(b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n\n" + volume)
    (folder / "scene.json").write_text(json.dumps({"volumes": [{"file": "head.nrrd", "transfer_function": {"preset": "grayscale"}}],
                                                   "camera": {"width": 24, "height": 20}}))
    monkeypatch.chdir(tmp_path)  # not the scene's folder
    renderer = penumbra.Renderer(penumbra.Scene.load(folder / "scene.json"))
    assert os.path.samefile(renderer.scene.base_dir, folder)
    viewer = penumbra.view(renderer)
    base, _, query = viewer.url.partition("/?")
    ws = websocket.create_connection(base.replace("http://", "ws://") + "/ws?" + query, timeout=30)
    assert receive(ws, "state")["document"]["volumes"][0]["file"] == "head.nrrd"
    frame, jpeg = receive(ws, "frame")
    assert jpeg[:2] == b"\xff\xd8"
    ws.send(json.dumps({"type": "edit", "set": {"volumes.0.file": "../outside.nrrd"}}))  # the root is the scene's folder
    assert "outside the data root" in receive(ws, "error")["message"]
    ws.close()
    viewer.stop()


def test_a_selection_edit_comes_back_with_its_count_and_a_bad_one_with_its_position(tmp_path):
    """particles.N.select: the state carries the atoms selected (and the spheres drawn); a malformed
    selection is refused naming the key, the character and what was expected, and the scene stays."""
    (tmp_path / "atoms.xyz").write_text("4\natoms\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\nC 0 0 0.5\n")
    scene = {"particles": [{"file": "atoms.xyz", "radius": 0.2}], "camera": {"width": 32, "height": 32}}
    v = Viewer(tmp_path, scene)
    try:
        ws = v.connect()
        state = receive(ws, "state")
        assert [{k: p[k] for k in ("spheres", "selected", "visible")} for p in state["particles"]] == [{"spheres": 4, "selected": None, "visible": True}]
        ws.send(json.dumps({"type": "edit", "set": {"particles.0.select": "name C"}}))
        while state["document"]["particles"][0].get("select") != "name C":
            state = receive(ws, "state")
        assert [{k: p[k] for k in ("spheres", "selected", "visible")} for p in state["particles"]] == [{"spheres": 2, "selected": 2, "visible": True}]
        ws.send(json.dumps({"type": "edit", "set": {"particles.0.select": "name C and"}}))
        error = receive(ws, "error")
        assert "particles.0.select: at character 11: expected a selection" in error["message"], error
        ws.send(json.dumps({"type": "edit", "set": {"particles.0.select": "not name C"}}))
        while state["document"]["particles"][0].get("select") != "not name C":
            state = receive(ws, "state")
        assert [{k: p[k] for k in ("spheres", "selected", "visible")} for p in state["particles"]] == [{"spheres": 2, "selected": 2, "visible": True}]
        ws.close()
    finally:
        assert v.close() == 0
