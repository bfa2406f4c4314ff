"""The viewer's server (`penumbra view`) attacked from outside, one test per guarantee of docs/viewer.md's
Security section: another site's page (Origin), a DNS-rebinding name (Host), framing, sizes the page
limits sent by a client that skips the page, a client that stops reading, a flood of idle connections
under a small descriptor limit, bytes that are not UTF-8, NUL bytes, where the data lies, weak or
visible tokens, an all-interfaces URL, and a data file naming a file outside the data root. After each
attack the server still serves a good client. Times are hang guards only, never what passes or fails.

    PENUMBRA_CLI=build/release/penumbra /usr/bin/python3 -m pytest -q tests/python/test_viewer_security.py"""
import json
import os
import pathlib
import shutil
import socket
import subprocess
import threading
import time

import pytest

websocket = pytest.importorskip("websocket")  # Debian python3-websocket (scripts/install-deps.sh)

from test_viewer_protocol import CLI, SCENE, Viewer, receive  # noqa: E402  (the same server, started the same way)


@pytest.fixture
def viewer(tmp_path):
    v = Viewer(tmp_path)
    yield v
    assert v.close() == 0, "Ctrl-C must stop the server cleanly"


def port_of(viewer):
    return int(viewer.base.rsplit(":", 1)[1])


def raw_request(viewer, request_line, headers, read_timeout=30):
    """The answer's status line and headers to a request written byte for byte (Host as given)."""
    with socket.create_connection(("127.0.0.1", port_of(viewer)), timeout=read_timeout) as s:
        s.sendall((request_line + "\r\n" + "".join(f"{k}: {v}\r\n" for k, v in headers.items()) + "Connection: close\r\n\r\n").encode())
        answer = b""
        while b"\r\n\r\n" not in answer:
            chunk = s.recv(65536)
            if not chunk:
                break
            answer += chunk
    head = answer.split(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")
    return int(head[0].split()[1]), {k.lower(): v for k, v in (line.split(": ", 1) for line in head[1:])}


def volume_file(name):
    """An edit making volume 0 (procedural in SCENE) the file `name`."""
    return {"volumes.0": {"file": name, "transfer_function": {"preset": "grayscale"}}}


def serves_a_good_client(viewer):
    ws = viewer.connect()
    assert receive(ws, "state")["type"] == "state"
    frame, jpeg = receive(ws, "frame")
    assert jpeg[:2] == b"\xff\xd8"
    ws.close()
    return True


# ------------------------------------------------------------------------ cross-site requests
def test_a_websocket_from_another_sites_page_is_refused(viewer):
    for origin in ("http://evil.example", "http://127.0.0.1.evil.example", "null", f"http://127.0.0.1:{port_of(viewer) + 1}"):
        with pytest.raises(websocket.WebSocketBadStatusException) as e:
            websocket.create_connection(viewer.ws_url, timeout=30, origin=origin)
        assert e.value.status_code == 403, origin
    # the page's own origin is what a browser sends from the page
    ws = websocket.create_connection(viewer.ws_url, timeout=180, origin=viewer.base)
    assert receive(ws, "state")["type"] == "state"
    ws.close()
    assert serves_a_good_client(viewer)


def test_allow_origin_admits_that_page_and_its_host(tmp_path):
    v = Viewer(tmp_path, SCENE, "--allow-origin", "http://localhost:9000", "--allow-origin", "https://viz.example.org")
    try:
        for origin in ("http://localhost:9000", "https://viz.example.org"):
            ws = websocket.create_connection(v.ws_url, timeout=180, origin=origin)
            assert receive(ws, "state")["type"] == "state"
            ws.close()
        with pytest.raises(websocket.WebSocketBadStatusException):
            websocket.create_connection(v.ws_url, timeout=30, origin="http://evil.example")
        # an ssh tunnel's port, or a proxy's name, is in Host too
        assert raw_request(v, f"GET /?token={v.token} HTTP/1.1", {"Host": "viz.example.org:8443"})[0] == 403  # another port: not the origin
        assert raw_request(v, f"GET /?token={v.token} HTTP/1.1", {"Host": "localhost:9000"})[0] == 200
    finally:
        assert v.close() == 0
    bad = subprocess.run([CLI, "view", str(tmp_path / "scene.json"), "--allow-origin", "evil.example/path"], capture_output=True, text=True, timeout=60)
    assert bad.returncode != 0 and "--allow-origin" in bad.stderr and "http(s)://HOST[:PORT]" in bad.stderr, bad.stderr


def test_a_request_naming_another_host_is_refused_dns_rebinding(viewer):
    port = port_of(viewer)
    token = viewer.token
    for host in ("evil.example", f"evil.example:{port}", f"127.0.0.1.nip.io:{port}", f"127.0.0.1:{port + 1}", "127.0.0.1", ""):
        assert raw_request(viewer, f"GET /?token={token} HTTP/1.1", {"Host": host})[0] == 403, host
        assert raw_request(viewer, f"GET /ws?token={token} HTTP/1.1", {"Host": host, "Upgrade": "websocket", "Connection": "Upgrade",
                                                                       "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==", "Sec-WebSocket-Version": "13"})[0] == 403, host
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LocalHost:{port}"):
        assert raw_request(viewer, f"GET /?token={token} HTTP/1.1", {"Host": host})[0] == 200, host
    assert serves_a_good_client(viewer)


def test_no_site_may_frame_the_page(viewer):
    for path in ("/", "/js/main.js", "/style.css", "/nope"):
        status, _, headers = viewer.get(path)
        assert headers["X-Frame-Options"] == "DENY", path
        assert "frame-ancestors 'none'" in headers["Content-Security-Policy"], path
    status, _, headers = viewer.get("/", token=False)
    assert status == 403 and headers["X-Frame-Options"] == "DENY"


# ---------------------------------------------------------------------------- sizes and queues
def test_sizes_the_page_limits_are_limited_by_the_server(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    for edit, key in [({"camera.width": 16384}, "camera.width"), ({"camera.height": 16384}, "camera.height"),
                      ({"camera": {"width": 16384, "height": 40}}, "camera.width"), ({"camera.width": 8}, "camera.width"),
                      ({"camera.height": 1e12}, "camera.height")]:
        ws.send(json.dumps({"type": "edit", "set": edit}))
        error = receive(ws, "error")
        assert key in error["message"] and "16..4096" in error["message"], (edit, error)
    ws.send(json.dumps({"type": "edit", "set": {"camera.width": 64}}))  # inside the limit: applied
    while receive(ws, "state")["document"]["camera"]["width"] != 64:
        pass
    ws.close()
    assert serves_a_good_client(viewer)


def resident_kb(pid):
    for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def large_transfer_function(step):
    # ~50 KB of JSON (under the 64 KiB message limit): every state message carries it back
    return {"points": [[round(i / 1500, 5), 0.5, round(step / 1000, 4), 0.75, 0.01] for i in range(1501)]}


def test_a_client_that_stops_reading_costs_bounded_memory(viewer):
    stalled = viewer.connect()  # connected, and never reads again
    stalled.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    editor = viewer.connect()
    receive(editor, "state")

    def edit_and_wait(first, last, marker):
        for step in range(first, last):
            editor.send(json.dumps({"type": "edit", "set": {"volumes.0.transfer_function": large_transfer_function(step)}}))
        editor.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": marker}}))
        while receive(editor, "state")["document"]["camera"].get("fov_deg") != marker:
            pass

    edit_and_wait(0, 40, 41)  # the allocator's working set, and the stalled socket's buffers, filled
    before = resident_kb(viewer.process.pid)
    edit_and_wait(40, 440, 42)
    grown_mb = (resident_kb(viewer.process.pid) - before) / 1024
    assert grown_mb < 15, f"the server grew by {grown_mb:.1f} MB over 400 edits with a client that does not read"
    editor.close()
    stalled.sock.close()
    assert serves_a_good_client(viewer)


def open_sockets(pid):
    """The process's sockets; a descriptor closed while they are counted (the server's threads go on)
    is not one."""
    count = 0
    for fd in pathlib.Path(f"/proc/{pid}/fd").iterdir():
        try:
            count += os.readlink(fd).startswith("socket:")
        except FileNotFoundError:
            pass
    return count


def test_a_client_that_stops_reading_is_closed_after_the_stall_limit(tmp_path):
    v = Viewer(tmp_path, SCENE, "--stall-limit", "2")
    try:
        stalled = v.connect()  # connected, and never reads
        stalled.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        editor = v.connect()
        receive(editor, "state")
        with_both = open_sockets(v.process.pid)
        # states of ~50 KB fill the stalled socket's buffers, and 2 s after its write stalled the server
        # lets it go; the editor reads each answer before it edits again (an editor that left its own
        # answers unread for 2 s would be closed as well). Guards: 2000 edits, 20 s (the default limit is 30).
        began = time.time()
        step = 0
        while open_sockets(v.process.pid) == with_both and step < 2000 and time.time() - began < 20:
            marker = 30 + step / 1000
            editor.send(json.dumps({"type": "edit", "set": {"volumes.0.transfer_function": large_transfer_function(step), "camera.fov_deg": marker}}))
            while receive(editor, "state")["document"]["camera"].get("fov_deg") != marker:
                pass
            step += 1
        assert open_sockets(v.process.pid) == with_both - 1, f"the server kept a client that read nothing for {time.time() - began:.0f} s (--stall-limit 2)"
        # the editor and new clients are served on
        editor.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": 33}}))
        while receive(editor, "state")["document"]["camera"].get("fov_deg") != 33:
            pass
        editor.close()
        stalled.sock.close()
        assert serves_a_good_client(v)
    finally:
        assert v.close() == 0


def test_a_client_whose_reading_is_paused_is_kept_until_its_messages_are_applied(viewer):
    # A client that sends faster than the render thread applies has its reading paused (at most a few
    # of its messages wait) and nothing in flight once it has read what came: it must be kept, and read
    # on, not dropped. Bursts of edits and of probes (a probe is a message as an edit is), each ended
    # by a marker that must come back.
    ws = viewer.connect()
    receive(ws, "state")
    for burst in range(6):
        for step in range(40):
            if burst % 2:
                ws.send(json.dumps({"type": "probe", "pixel": [1 + step, 2 + step]}))
            else:
                ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": 30 + step / 10}}))
        marker = 50 + burst
        ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": marker}}))
        while receive(ws, "state")["document"]["camera"].get("fov_deg") != marker:
            pass
    ws.send(json.dumps({"type": "probe", "pixel": [3, 4]}))
    assert "hit" in receive(ws, "probe")
    ws.close()
    assert serves_a_good_client(viewer)


def cpu_seconds(pid):
    fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


@pytest.mark.skipif(shutil.which("prlimit") is None, reason="prlimit (util-linux) not found")
def test_idle_connections_past_the_descriptor_limit_neither_spin_nor_block_a_real_request(tmp_path):
    v = Viewer(tmp_path, SCENE, prefix=("prlimit", "--nofile=64:64", "--"))
    idle = []
    try:
        serves_a_good_client(v)  # the first frame rendered: what follows measures the network thread alone
        for _ in range(200):  # connected, and never a byte sent
            idle.append(socket.create_connection(("127.0.0.1", port_of(v)), timeout=30))
        time.sleep(1)
        start = cpu_seconds(v.process.pid)
        time.sleep(2)
        spent = cpu_seconds(v.process.pid) - start
        assert spent < 0.5, f"the server spent {spent:.2f} s of CPU in 2 s with nothing to do"
        # a real request is served although 200 connections hold their places (hang guard: 20 s, where
        # idle connections would only time out after 30)
        began = time.time()
        with socket.create_connection(("127.0.0.1", port_of(v)), timeout=20) as s:
            s.sendall(f"GET /?token={v.token} HTTP/1.1\r\nHost: 127.0.0.1:{port_of(v)}\r\nConnection: close\r\n\r\n".encode())
            assert s.recv(64).startswith(b"HTTP/1.1 200"), "no answer"
        assert time.time() - began < 20
        assert serves_a_good_client(v)
    finally:
        for s in idle:
            s.close()
        assert v.close() == 0


# ------------------------------------------------------------------------- bytes and names
def test_bytes_that_are_not_utf8_fail_only_that_connection_and_escapes_get_an_error_reply(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    # RFC 6455 (8.1) requires failing a connection whose text message is not UTF-8: close code 1007
    ws.send(b'{"type": "edit", "set": {"camera.fov_deg": "\xff\xfe"}}', opcode=websocket.ABNF.OPCODE_TEXT)
    while True:
        opcode, data = ws.recv_data(control_frame=True)
        if opcode == websocket.ABNF.OPCODE_CLOSE:
            break
    assert int.from_bytes(data[:2], "big") == 1007, data
    # valid UTF-8 naming a lone surrogate: an error reply, and the connection goes on
    ws = viewer.connect()
    receive(ws, "state")
    ws.send('{"type": "edit", "set": {"volumes.0.file": "\\udc80.nrrd"}}')
    assert receive(ws, "error")["message"].startswith("message"), "the parser's error, naming the message"
    ws.send(json.dumps({"type": "edit", "set": {"camera.fov_deg": 39}}))
    while receive(ws, "state")["document"]["camera"].get("fov_deg") != 39:
        pass
    ws.close()
    assert serves_a_good_client(viewer)


def test_a_nul_byte_in_a_name_is_refused_and_shown_escaped(viewer):
    ws = viewer.connect()
    receive(ws, "state")
    ws.send(json.dumps({"type": "edit", "set": {"volumes.0.file": "in\u0000side.nrrd"}}))
    error = receive(ws, "error")["message"]
    assert "in\\u0000side.nrrd" in error and "volumes.0.file" in error, error
    ws.send(json.dumps({"type": "edit", "set": {"volumes.0\u0000.file": "a.nrrd"}}))
    error = receive(ws, "error")["message"]
    assert "volumes.0\\u0000.file" in error, error
    ws.close()
    assert serves_a_good_client(viewer)


def test_refusals_name_paths_relative_to_the_data_root(viewer, tmp_path):
    root = str(tmp_path.resolve())
    ws = viewer.connect()
    receive(ws, "state")
    (tmp_path / "broken.nrrd").write_bytes(b"NRRD0004\ntype: uchar\n")
    for name, needle in [("missing.nrrd", "missing.nrrd"), ("broken.nrrd", "broken.nrrd"), ("../outside.nrrd", "outside the data root")]:
        edit = volume_file(name)
        ws.send(json.dumps({"type": "edit", "set": edit}))
        error = receive(ws, "error")["message"]
        assert needle in error, (edit, error)
        assert root not in error and str(tmp_path) not in error, (edit, error)
    ws.close()
    assert serves_a_good_client(viewer)


# --------------------------------------------------------------------------------- the token
def test_a_short_token_is_refused(tmp_path):
    (tmp_path / "scene.json").write_text(json.dumps(SCENE))
    for token in ("x", "abcdefghijklmno"):  # 1 and 15 characters
        r = subprocess.run([CLI, "view", str(tmp_path / "scene.json"), "--token", token], capture_output=True, text=True, timeout=60)
        assert r.returncode != 0 and "at least 16" in r.stderr, r.stderr
    r = subprocess.run([CLI, "view", str(tmp_path / "scene.json"), "--token", "a" * 15 + "!"], capture_output=True, text=True, timeout=60)
    assert r.returncode != 0 and "'-' and '_'" in r.stderr, r.stderr


def test_the_token_from_a_file_or_the_environment_stays_out_of_ps(tmp_path):
    secret = "file-token_0123456789abcdef"
    (tmp_path / "token").write_text(secret + "\n")
    v = Viewer(tmp_path, SCENE, "--token-file", str(tmp_path / "token"))
    try:
        assert v.token == secret
        assert secret.encode() not in pathlib.Path(f"/proc/{v.process.pid}/cmdline").read_bytes()
        assert v.get("/")[0] == 200
    finally:
        assert v.close() == 0
    env = dict(os.environ, PENUMBRA_VIEW_TOKEN="env-token_0123456789abcdef")
    v = Viewer(tmp_path, SCENE, env=env)
    try:
        assert v.token == "env-token_0123456789abcdef"
        assert serves_a_good_client(v)
    finally:
        assert v.close() == 0
    r = subprocess.run([CLI, "view", str(tmp_path / "scene.json"), "--token-file", str(tmp_path / "none")], capture_output=True, text=True, timeout=60)
    assert r.returncode != 0 and "--token-file" in r.stderr and "none" in r.stderr, r.stderr


def test_all_interfaces_prints_a_url_that_opens(tmp_path):
    v = Viewer(tmp_path, SCENE, "--host", "0.0.0.0")  # Viewer checks it starts http://127.0.0.1:
    try:
        assert v.get("/")[0] == 200
        assert serves_a_good_client(v)
    finally:
        assert v.close() == 0
    assert "all interfaces" in v.process.stderr.read()


# ------------------------------------------------------------------ files that files name
NHDR = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\ndata file: {}\n\n"


def test_a_data_file_naming_a_file_outside_the_data_root_is_refused(tmp_path):
    root = tmp_path / "root"
    root.mkdir()
    voxels = bytes(range(256)) * 2
    (tmp_path / "secret.raw").write_bytes(voxels)
    (root / "inside.raw").write_bytes(voxels)
    (root / "evil.nhdr").write_text(NHDR.format("../secret.raw"))
    (root / "evil_absolute.nhdr").write_text(NHDR.format(tmp_path / "secret.raw"))
    (root / "good.nhdr").write_text(NHDR.format("inside.raw"))
    os.symlink(tmp_path / "secret.raw", root / "link.raw")
    (root / "evil_link.nhdr").write_text(NHDR.format("link.raw"))
    (root / "dicom").mkdir()
    os.symlink(tmp_path / "secret.raw", root / "dicom" / "IM0001")  # a slice that is a link out of the root
    v = Viewer(root)
    try:
        ws = v.connect()
        receive(ws, "state")
        for name in ("evil.nhdr", "evil_absolute.nhdr", "evil_link.nhdr", "dicom"):
            ws.send(json.dumps({"type": "edit", "set": volume_file(name)}))
            error = receive(ws, "error")["message"]
            assert "outside the data root" in error and name in error, (name, error)
            assert str(root) not in error, error
        ws.send(json.dumps({"type": "edit", "set": volume_file("good.nhdr")}))  # the same, inside: read
        while receive(ws, "state")["document"]["volumes"][0].get("file") != "good.nhdr":
            pass
        ws.close()
        assert serves_a_good_client(v)
    finally:
        assert v.close() == 0
