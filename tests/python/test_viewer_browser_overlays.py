"""The viewer page's reading aids and controls in headless chromium (docs/viewer.md "The page"): the
standard views and reset, the orientation triad, the data's box, the colour legend and the histogram's
value axis (in HU for a CT), transfer-function presets, the refinement's progress, undo and redo, the
keyboard shortcuts and their list, a refused value put back in its field, and the banner while the
connection is down; the probe; a particle set's colour-by choice. Each test checks what the page draws
or sends, so that a broken feature fails it. With PENUMBRA_FIGURES set, it saves viewer_tools.png there."""
import contextlib
import json
import math
import os
import struct
import subprocess
import time

import pytest

from test_viewer_browser import By, Keys, ActionChains, CLI, Viewer, chrome, console_errors, js, wait, wait_loaded, SCENE  # noqa: F401

STATE = "window.penumbraViewer.state"


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    server = Viewer(tmp_path_factory.mktemp("viewer"), SCENE)
    try:
        driver = chrome()
    except Exception:
        server.close()
        raise
    try:
        driver.get(server.url)
        wait_loaded(driver)
        yield server, driver
    finally:
        driver.quit()
        assert server.close() == 0, "Ctrl-C must stop the server cleanly"


@contextlib.contextmanager
def opened_page(folder, scene):
    """A server on `scene` and chromium showing its page, loaded; both closed after (the server by Ctrl-C,
    which must stop it cleanly)."""
    server = Viewer(folder, scene)
    driver = None
    try:
        driver = chrome()
        driver.get(server.url)
        wait_loaded(driver)
        yield driver
    finally:
        if driver:
            driver.quit()
        assert server.close() == 0


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def camera_direction(driver):
    cam = js(driver, STATE + ".camera")
    return norm(sub(cam["eye"], cam["target"]))


def wait_direction(driver, expected, message):
    wait(driver, lambda d: all(abs(x - y) < 1e-3 for x, y in zip(camera_direction(d), expected)), message)


def pixel(driver, canvas_id, x, y):
    """The RGBA of a canvas at (x, y) in CSS pixels."""
    return driver.execute_script(
        "const c = document.getElementById(arguments[0]), k = c.width / c.getBoundingClientRect().width;"
        "return Array.from(c.getContext('2d').getImageData(Math.round(arguments[1] * k), Math.round(arguments[2] * k), 1, 1).data)",
        canvas_id, x, y)


def painted(driver, canvas_id):
    """How many pixels of a canvas are not transparent."""
    return driver.execute_script(
        "const c = document.getElementById(arguments[0]); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
        "let n = 0; for (let i = 3; i < d.length; i += 4) n += d[i] > 0; return n", canvas_id)


def press(driver, *keys):
    """Keys sent to the page with no field focused."""
    driver.execute_script("document.activeElement && document.activeElement.blur()")
    chain = ActionChains(driver)
    modifiers = [k for k in keys if k in (Keys.CONTROL, Keys.SHIFT)]
    for m in modifiers:
        chain.key_down(m)
    chain.send_keys(*[k for k in keys if k not in modifiers])
    for m in reversed(modifiers):
        chain.key_up(m)
    chain.perform()


def test_the_standard_views_reset_and_the_triad_follow_the_camera(session):
    server, driver = session
    opening = js(driver, STATE + ".camera")
    for name, direction in (("+x", [1, 0, 0]), ("-y", [0, -1, 0]), ("iso", norm([1, 1, 1])), ("+z", [0, 0, 1])):
        driver.find_element(By.CSS_SELECTOR, f"#views [data-view='{name}']").click()
        wait_direction(driver, direction, f"the {name} view did not reach the camera")
    # looking from +Z with y up: the triad's x arm points right (red) and its y arm up (green)
    size = js(driver, "document.getElementById('axes').getBoundingClientRect().width")
    c = size / 2
    wait(driver, lambda d: (lambda p: p[0] > 150 and p[1] < 140)(pixel(d, "axes", c + size * 0.25, c)), "no red x arm to the right")
    green = pixel(driver, "axes", c, c - size * 0.25)
    assert green[1] > 150 and green[0] < 140, green
    # the framed distance fits the bounding sphere as the scene's own framing does
    cam = js(driver, STATE + ".camera")
    distance = math.dist(cam["eye"], cam["target"])
    radius = js(driver, STATE + ".radius")
    assert distance == pytest.approx(radius / math.sin(math.radians(cam["fov_deg"]) / 2) * 1.05, rel=1e-3)
    press(driver, "r")
    wait(driver, lambda d: math.dist(js(d, STATE + ".camera.eye"), opening["eye"]) < 1e-4, "R did not reset the camera")
    press(driver, "1")
    wait_direction(driver, [1, 0, 0], "the key 1 did not look from +X")
    assert console_errors(driver) == []


def test_the_box_outline_is_drawn_where_the_camera_projects_the_bounds(session):
    server, driver = session
    driver.find_element(By.CSS_SELECTOR, "#views [data-view='iso']").click()
    wait_direction(driver, norm([1, 1, 1]), "the iso view did not reach the camera")
    assert painted(driver, "outline") == 0, "the box is drawn before it is asked for"
    driver.find_element(By.ID, "outline-toggle").click()
    wait(driver, lambda d: painted(d, "outline") > 100, "the box was not drawn")
    # the corner nearest the eye, projected here as the renderer projects (vertical fov, stretched view)
    state = js(driver, STATE)
    cam, hi = state["camera"], state["bounds"]["hi"]
    w, h = js(driver, "[document.getElementById('view').getBoundingClientRect().width,"
                      " document.getElementById('view').getBoundingClientRect().height]")
    forward = norm(sub(cam["target"], cam["eye"]))
    up = norm(cam["up"])
    right = norm([forward[1] * up[2] - forward[2] * up[1], forward[2] * up[0] - forward[0] * up[2], forward[0] * up[1] - forward[1] * up[0]])
    screen_up = [right[1] * forward[2] - right[2] * forward[1], right[2] * forward[0] - right[0] * forward[2], right[0] * forward[1] - right[1] * forward[0]]
    d = sub(hi, cam["eye"])
    z = sum(a * b for a, b in zip(d, forward))
    t = math.tan(math.radians(cam["fov_deg"]) / 2)
    x = (sum(a * b for a, b in zip(d, right)) / (z * t * cam["width"] / cam["height"]) + 1) / 2 * w
    y = (1 - sum(a * b for a, b in zip(d, screen_up)) / (z * t)) / 2 * h
    near = driver.execute_script(
        "const c = document.getElementById('outline'), k = c.width / c.getBoundingClientRect().width;"
        "const d = c.getContext('2d').getImageData(Math.round((arguments[0] - 3) * k), Math.round((arguments[1] - 3) * k),"
        " Math.round(7 * k), Math.round(7 * k)).data; let n = 0; for (let i = 3; i < d.length; i += 4) n += d[i] > 0; return n", x, y)
    assert near > 0, f"no line at the projected corner ({x:.0f}, {y:.0f})"
    press(driver, "b")
    wait(driver, lambda d: painted(d, "outline") == 0, "B did not hide the box")


def test_the_legend_and_the_histograms_axis_give_the_data_range(session):
    server, driver = session
    legend = driver.find_element(By.ID, "legend")
    assert legend.is_displayed()
    hist = js(driver, STATE + ".histograms[0]")
    assert "data value" in legend.text and "HU" not in legend.text
    labels = [e.text for e in legend.find_elements(By.CSS_SELECTOR, ".ticks span")]
    assert len(labels) >= 3 and all(hist["lo"] <= float(v) <= hist["hi"] for v in labels), labels
    # the histogram's value axis has tick marks and labels (grey pixels) under the colour strip
    assert driver.execute_script(
        "const c = document.querySelector('#tf-list canvas.axis'); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
        "let n = 0; for (let i = 3; i < d.length; i += 4) n += d[i] > 0; return n") > 50


def test_a_preset_replaces_the_transfer_function(session):
    server, driver = session
    presets = js(driver, STATE + ".transfer_function_presets")
    assert "ct-bone" in presets and "grayscale" in presets
    select = driver.find_element(By.CSS_SELECTOR, "#tf-list select.preset")
    from selenium.webdriver.support.ui import Select
    before = js(driver, STATE + ".document.volumes[0].transfer_function")
    Select(select).select_by_value("grayscale")
    wait(driver, lambda d: js(d, STATE + ".document.volumes[0].transfer_function") == "grayscale", "the preset was not applied")
    press(driver, Keys.CONTROL, "z")
    wait(driver, lambda d: js(d, STATE + ".document.volumes[0].transfer_function") == before, "undo did not bring the points back")


def test_refining_shows_its_progress_and_hides_when_done(session):
    server, driver = session
    driver.execute_script("window.progressSeen = []; new MutationObserver(() => window.progressSeen.push("
                          "document.getElementById('progress-text').textContent)).observe(document.getElementById('progress'),"
                          " { childList: true, characterData: true, subtree: true })")
    driver.find_element(By.CSS_SELECTOR, "#views [data-view='-x']").click()
    wait(driver, lambda d: (js(d, "window.penumbraViewer.lastFrame") or {}).get("samples") == 16
         and js(d, "document.getElementById('progress').hidden"), "the progress did not end hidden at 16 samples")
    seen = js(driver, "window.progressSeen")
    assert any(s.startswith("refining ") and s.endswith("/16") for s in seen), seen


def shown_with(needle):
    """A wait condition: the frame shown and the stats' lines, read in one script (a preview that comes
    next replaces both), with the first line holding `needle`; False while none does."""
    def condition(driver):
        frame, text = driver.execute_script(
            "return [window.penumbraViewer.lastFrame, document.getElementById('stats').textContent]")
        lines = text.splitlines()
        found = [x for x in lines if needle in x]
        return (frame, lines, found[0]) if found else False
    return condition


def test_a_pyramid_under_a_budget_says_which_finer_level_it_draws(tmp_path):
    """An OME-Zarr pyramid opened at level 1 under a small memory budget, looked at closely: the full frame
    draws the part in view from level 0, and the stats say so (the frame message carries what it held)."""
    subprocess.run([CLI, "convert", "--procedural", json.dumps({"name": "ct-body", "dims": [64, 64, 96]}), "-o",
                    str(tmp_path / "body.zarr"), "--chunk", "16"], check=True, capture_output=True)
    scene = {"volumes": [{"file": "body.zarr"}], "memory_budget": 600000,
             "camera": {"direction": [0.45, 0.4, 1.0], "distance": 450, "target": [0, 0, 650], "width": 160, "height": 120}}
    with opened_page(tmp_path, scene) as driver:
        frame, lines, line = wait(driver, shown_with("level 0 box"), "the stats do not name the finer level drawn")
        assert line.startswith("level 0 box ") and line.endswith(" of level 1"), line
        held = lines[lines.index(line) + 1]
        assert held.startswith("  held ") and held.split()[2] == "MB", held
        r = frame["refinement"][0]
        assert (r["opened_level"], r["level"]) == (1, 0) and 0 < r["held_bytes"] <= 600000, r
        assert console_errors(driver) == []


def test_a_finer_level_that_cannot_be_read_is_named_over_the_coarser_frame(tmp_path):
    """The same pyramid with level 0's chunks cut short: full frames still arrive, drawn from level 1, and
    the stats over the view name the box and the chunk that failed."""
    subprocess.run([CLI, "convert", "--procedural", json.dumps({"name": "ct-body", "dims": [64, 64, 96]}), "-o",
                    str(tmp_path / "body.zarr"), "--chunk", "16"], check=True, capture_output=True)
    for chunk in (tmp_path / "body.zarr" / "0").rglob("*"):
        if chunk.is_file() and not chunk.name.startswith(".") and chunk.name != "zarr.json":
            chunk.write_bytes(chunk.read_bytes()[:3])
    scene = {"volumes": [{"file": "body.zarr"}], "memory_budget": 600000,
             "camera": {"direction": [0.45, 0.4, 1.0], "distance": 450, "target": [0, 0, 650], "width": 160, "height": 120}}
    with opened_page(tmp_path, scene) as driver:
        frame, _, line = wait(driver, shown_with("level 1 shown: level 0 box"), "the stats do not say the finer box failed")
        assert "chunk" in line and "body.zarr" in line, line
        assert frame["quality"] == "full" and frame["refinement"][0]["held_bytes"] == 0, frame
        # the chunk is named below the data root, never with the server's own folders
        assert str(tmp_path) not in json.dumps(frame), frame
        assert console_errors(driver) == []


def test_undo_and_redo_restore_edits(session):
    server, driver = session
    field = driver.find_element(By.XPATH, "//div[@id='shadows']//label[text()='resolution']/following-sibling::input")
    start = js(driver, STATE + ".document.shadows.resolution")
    field.send_keys(Keys.CONTROL, "a")
    field.send_keys("64\n")
    wait(driver, lambda d: js(d, STATE + ".document.shadows.resolution") == 64, "the edit did not arrive")
    press(driver, Keys.CONTROL, "z")
    wait(driver, lambda d: js(d, STATE + ".document.shadows.resolution") == start, "Ctrl+Z did not undo")
    assert field.get_attribute("value") == str(start)
    press(driver, Keys.CONTROL, Keys.SHIFT, "z")
    wait(driver, lambda d: js(d, STATE + ".document.shadows.resolution") == 64, "Ctrl+Shift+Z did not redo")
    driver.find_element(By.ID, "undo").click()
    wait(driver, lambda d: js(d, STATE + ".document.shadows.resolution") == start, "the Undo button did not undo")
    # a camera move is one entry, undone as a whole
    before = js(driver, STATE + ".camera.eye")
    driver.find_element(By.CSS_SELECTOR, "#views [data-view='+y']").click()
    wait_direction(driver, [0, 1, 0], "the +y view did not reach the camera")
    driver.find_element(By.ID, "undo").click()
    wait(driver, lambda d: math.dist(js(d, STATE + ".camera.eye"), before) < 1e-4, "undo did not put the camera back")


def test_a_refused_value_is_put_back_in_its_field(session):
    server, driver = session
    field = driver.find_element(By.XPATH, "//div[@id='shadows']//label[text()='resolution']/following-sibling::input")
    current = js(driver, STATE + ".document.shadows.resolution")
    field.send_keys(Keys.CONTROL, "a")
    field.send_keys("-5\n")
    wait(driver, lambda d: d.find_element(By.ID, "error").is_displayed(), "no error for a refused value")
    wait(driver, lambda d: field.get_attribute("value") == str(current), f"the field kept {field.get_attribute('value')!r}")
    assert js(driver, STATE + ".document.shadows.resolution") == current


def test_the_question_mark_lists_the_shortcuts(session):
    server, driver = session
    help = driver.find_element(By.ID, "help")
    assert not help.is_displayed()
    press(driver, "?")
    wait(driver, lambda d: help.is_displayed(), "? did not show the list")
    assert "Ctrl+Z" in help.text and "reset the camera" in help.text and "look from +X" in help.text
    press(driver, Keys.ESCAPE)
    wait(driver, lambda d: not help.is_displayed(), "Escape did not close the list")
    assert driver.find_element(By.ID, "hint").text.startswith("left drag: orbit")
    # the icon is inline: the browser asks the server for no /favicon.ico (which would be refused)
    assert js(driver, "document.querySelector('link[rel=icon]').href").startswith("data:image/svg+xml,")
    assert not any("favicon" in r for r in js(driver, "performance.getEntriesByType('resource').map((r) => r.name)"))


def test_a_dropped_connection_shows_a_banner_and_reconnects(session):
    server, driver = session
    banner = driver.find_element(By.ID, "connection-banner")
    assert not banner.is_displayed()
    driver.execute_script("window.penumbraViewer.state = null; window.penumbraViewer.dropConnection()")
    wait(driver, lambda d: banner.is_displayed() and "reconnecting" in banner.text, "no banner when the connection dropped")
    wait(driver, lambda d: not banner.is_displayed() and js(d, STATE) is not None, "the page did not reconnect")
    assert "connected" in driver.find_element(By.ID, "stats").text
    assert console_errors(driver) == []


def test_a_ct_has_its_legend_and_axis_in_hounsfield_units(tmp_path):
    """An int16 volume from air (-1000) to bone (+1000): the state calls its unit HU and the page says so."""
    n = 8
    voxels = [int(-1000 + 2000 * i / (n ** 3 - 1)) for i in range(n ** 3)]
    header = f"NRRD0004\ntype: short\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\nendian: little\n\n"
    (tmp_path / "ct.nrrd").write_bytes(header.encode() + struct.pack(f"<{n ** 3}h", *voxels))
    with opened_page(tmp_path, {"volumes": [{"file": "ct.nrrd"}], "camera": {"width": 64, "height": 48}}) as driver:
        assert js(driver, STATE + ".histograms[0].unit") == "HU"
        legend = driver.find_element(By.ID, "legend")
        wait(driver, lambda d: "HU" in legend.text, "the legend does not say HU")
        assert any(s.text == "-1000" for s in legend.find_elements(By.CSS_SELECTOR, ".ticks span"))
        assert console_errors(driver) == []


def test_the_probe_gives_the_value_where_the_pixels_ray_first_meets_the_visible_data(session):
    """The pointer resting over the data shows the value of the first visible sample along its pixel's
    ray; the position answered lies on that ray (it projects back to the pixel) and inside the data's box."""
    server, driver = session
    driver.find_element(By.CSS_SELECTOR, "#views [data-view='iso']").click()
    wait_direction(driver, norm([1, 1, 1]), "the iso view did not reach the camera")
    view = driver.find_element(By.ID, "view")
    readout = driver.find_element(By.ID, "probe")
    ActionChains(driver).move_to_element(view).move_by_offset(3, 2).perform()
    wait(driver, lambda d: readout.is_displayed() and readout.text.startswith("probe: "), "no probe readout")
    wait(driver, lambda d: " · volume 0 at (" in readout.text, f"the probe met nothing: {readout.text!r}")
    value = float(readout.text.split()[1])
    hist = js(driver, STATE + ".histograms[0]")
    points = js(driver, STATE + ".transfer_functions[0].points")
    assert hist["lo"] <= value <= hist["hi"]
    figures = os.environ.get("PENUMBRA_FIGURES")
    if figures:  # docs/viewer.md's picture of the reading aids: the box on, the probe's readout
        driver.execute_script("document.getElementById('error').hidden = true;"  # an earlier test's refusal
                              " document.getElementById('outline-toggle').click()")  # the pointer stays on the view
        wait(driver, lambda d: painted(d, "outline") > 100, "the box was not drawn")
        os.makedirs(figures, exist_ok=True)
        with open(os.path.join(figures, "viewer_tools.png"), "wb") as f:
            f.write(driver.get_screenshot_as_png())
        driver.execute_script("document.getElementById('outline-toggle').click()")
    # the same request over the protocol: the position projects back to the pixel and lies in the box
    ws = server.connect()
    try:
        state = None
        while state is None:
            m = ws.recv()
            if isinstance(m, str) and json.loads(m)["type"] == "state":
                state = json.loads(m)
        cam = state["camera"]
        px, py = cam["width"] / 2 + 3, cam["height"] / 2 + 2
        ws.send(json.dumps({"type": "probe", "pixel": [px, py]}))
        answer = None
        while answer is None:
            m = ws.recv()
            if isinstance(m, str) and json.loads(m)["type"] == "probe":
                answer = json.loads(m)
        assert answer["hit"] and answer["volume"] == 0
        lo, hi = state["bounds"]["lo"], state["bounds"]["hi"]
        assert all(a - 1e-3 <= p <= b + 1e-3 for a, p, b in zip(lo, answer["position"], hi))
        forward = norm(sub(cam["target"], cam["eye"]))
        right = norm([forward[1] * cam["up"][2] - forward[2] * cam["up"][1], forward[2] * cam["up"][0] - forward[0] * cam["up"][2],
                      forward[0] * cam["up"][1] - forward[1] * cam["up"][0]])
        up = [right[1] * forward[2] - right[2] * forward[1], right[2] * forward[0] - right[0] * forward[2], right[0] * forward[1] - right[1] * forward[0]]
        d = sub(answer["position"], cam["eye"])
        z = sum(a * b for a, b in zip(d, forward))
        t = math.tan(math.radians(cam["fov_deg"]) / 2)
        x = (sum(a * b for a, b in zip(d, right)) / (z * t * cam["width"] / cam["height"]) + 1) / 2 * cam["width"]
        y = (1 - sum(a * b for a, b in zip(d, up)) / (z * t)) / 2 * cam["height"]
        assert (x, y) == (pytest.approx(px, abs=0.05), pytest.approx(py, abs=0.05))
        # and the sample is visible: the transfer function's opacity there is above the probe's 0.01
        alpha = next((a[4] + (b[4] - a[4]) * (answer["value"] - a[0]) / (b[0] - a[0])
                      for a, b in zip(points, points[1:]) if a[0] <= answer["value"] <= b[0] and b[0] > a[0]), None)
        assert alpha is None or alpha > 0.01
        # a corner pixel sees only the floor and the sky: nothing of the volume
        ws.send(json.dumps({"type": "probe", "pixel": [0.5, 0.5]}))
        while True:
            m = ws.recv()
            if isinstance(m, str) and json.loads(m)["type"] == "probe":
                assert json.loads(m)["hit"] is False
                break
        ws.send(json.dumps({"type": "probe", "pixel": ["a", 1]}))
        while True:
            m = ws.recv()
            if isinstance(m, str) and json.loads(m)["type"] == "error":
                assert "probe: expected" in json.loads(m)["message"]
                break
    finally:
        ws.close()
    assert console_errors(driver) == []


def test_a_particle_sets_colour_by_choice_reaches_the_scene_and_the_image(tmp_path):
    (tmp_path / "atoms.xyz").write_text("4\natoms\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\nC 0 0 0.5\n")
    with opened_page(tmp_path, {"particles": [{"file": "atoms.xyz", "radius": 0.2}], "camera": {"width": 64, "height": 48}}) as driver:
        from selenium.webdriver.support.ui import Select
        select = Select(driver.find_element(By.CSS_SELECTOR, "select.color-by"))
        assert [o.get_attribute("value") for o in select.options] == ["element", "chain", "residue", "scalar", "uniform"]
        assert select.first_selected_option.get_attribute("value") == "element"
        frames = js(driver, "window.penumbraViewer.frames")
        select.select_by_value("uniform")
        wait(driver, lambda d: js(d, STATE + ".document.particles[0].color_by") == "uniform", "color_by did not reach the scene")
        wait(driver, lambda d: js(d, "window.penumbraViewer.frames") > frames, "no frame after the change")
        assert Select(driver.find_element(By.CSS_SELECTOR, "select.color-by")).first_selected_option.get_attribute("value") == "uniform"
        assert console_errors(driver) == []


def test_a_molecules_legend_its_periodic_cell_and_its_visibility_box(tmp_path):
    # a GRO file: 3 atoms of ALA, 2 of water, one sodium; a 2 nm cubic box
    (tmp_path / "small.gro").write_text(
        "small\n6\n    1ALA      N    1   0.500   0.500   0.500\n    1ALA     CA    2   0.650   0.500   0.500\n"
        "    1ALA      C    3   0.800   0.500   0.500\n    2SOL     OW    4   1.200   1.200   1.200\n"
        "    3SOL     OW    5   1.400   1.200   1.200\n    4NA      NA    6   1.500   0.600   1.500\n   2.00000   2.00000   2.00000\n")
    with opened_page(tmp_path, {"particles": [{"file": "small.gro"}], "camera": {"width": 96, "height": 72}}) as driver:
        legend = driver.find_element(By.ID, "legend")
        wait(driver, lambda d: legend.is_displayed() and "by element" in legend.text, "no legend for the molecule")
        entries = {e.find_element(By.CSS_SELECTOR, ".label").text: int(e.find_element(By.CSS_SELECTOR, ".count").text)
                   for e in legend.find_elements(By.CSS_SELECTOR, ".particle-key .entry")}
        assert entries == {"O": 2, "C": 2, "N": 1, "Na": 1}, entries
        # the swatch is the colour the spheres are drawn in: oxygen red (Jmol CPK)
        oxygen = next(e for e in legend.find_elements(By.CSS_SELECTOR, ".particle-key .entry") if e.text.startswith("O"))
        rgb = driver.execute_script("return getComputedStyle(arguments[0]).backgroundColor", oxygen.find_element(By.CSS_SELECTOR, ".swatch"))
        channels = [int(c) for c in rgb[rgb.index("(") + 1:rgb.index(")")].split(",")]
        assert all(abs(c - e) <= 2 for c, e in zip(channels, (255, 13, 13))), rgb
        # by residue: every non-standard residue shares the grey, and says which
        from selenium.webdriver.support.ui import Select
        Select(driver.find_element(By.CSS_SELECTOR, "select.color-by")).select_by_value("residue")
        wait(driver, lambda d: "by residue" in legend.text, "the legend did not follow color_by")
        labels = [e.find_element(By.CSS_SELECTOR, ".label").text for e in legend.find_elements(By.CSS_SELECTOR, ".particle-key .entry")]
        assert labels == ["ALA", "SOL, NA"], labels
        # the periodic cell: 20 Å along each axis from the origin, drawn with the data's box
        box = js(driver, STATE + ".particles[0].box")
        for key, expected in (("a", [20, 0, 0]), ("b", [0, 20, 0]), ("c", [0, 0, 20]), ("origin", [0, 0, 0])):
            assert box[key] == pytest.approx(expected, abs=1e-5), box
        assert painted(driver, "outline") == 0
        driver.find_element(By.ID, "outline-toggle").click()
        wait(driver, lambda d: painted(d, "outline") > 100, "neither the box nor the cell was drawn")
        cell_blue = driver.execute_script(
            "const c = document.getElementById('outline'); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            "let n = 0; for (let i = 0; i < d.length; i += 4) n += d[i + 3] > 0 && d[i + 2] > d[i] + 60; return n")
        assert cell_blue > 50, "the periodic cell is not drawn"
        # the set's visibility box: hidden, nothing is drawn of it and its legend goes
        frames = js(driver, "window.penumbraViewer.frames")
        visible = next(l for l in driver.find_elements(By.CSS_SELECTOR, "#objects label") if l.text == "visible")
        visible.click()
        wait(driver, lambda d: js(d, STATE + ".document.particles[0].visible") is False, "visible did not reach the scene")
        wait(driver, lambda d: js(d, STATE + ".particles[0].spheres") == 0, "a hidden set still has spheres drawn")
        wait(driver, lambda d: js(d, "window.penumbraViewer.frames") > frames, "no frame after hiding")
        assert legend.find_elements(By.CSS_SELECTOR, ".particle-key") == []
        assert console_errors(driver) == []


def test_playback_keeps_the_wall_clock_and_skips_steps_rather_than_queueing_them(tmp_path):
    # a 40-frame XYZ trajectory of 30 atoms drifting along x
    atoms = 30
    frames = []
    for f in range(40):
        lines = [str(atoms), f"frame {f}"] + [f"C {0.3 * (i % 6) + 0.02 * f:.3f} {0.3 * (i // 6):.3f} 0.000" for i in range(atoms)]
        frames.append("\n".join(lines) + "\n")
    (tmp_path / "top.xyz").write_text(frames[0])
    (tmp_path / "run.xyz").write_text("".join(frames))
    with opened_page(tmp_path, {"particles": [{"file": "top.xyz", "trajectory": "run.xyz", "radius": 0.12}],
                                "shadows": {"technique": "issm"}, "camera": {"width": 96, "height": 72}}) as driver:
        wait(driver, lambda d: not driver.find_element(By.ID, "time-section").get_attribute("hidden"), "no time controls for a trajectory")
        # far faster than any frame can be rendered, sent and shown: rendering falls behind
        driver.execute_script("window.penumbraViewer.playback.fps = 400")
        driver.find_element(By.ID, "play").click()
        time.sleep(3)
        driver.find_element(By.ID, "play").click()  # pause
        p = js(driver, "window.penumbraViewer.playback")
        assert p["shown"] >= 3, p
        assert p["skipped"] > 0, f"steps were not skipped although rendering fell behind: {p}"
        # the steps asked for kept the wall clock: the last is the one due when it was asked (~3 s × 400)
        assert p["step"] >= 0.5 * 3 * 400, p
        assert p["shown"] + p["skipped"] <= p["step"] + 1, p  # each step shown or skipped, none twice
        # the last step asked for is the frame the scene ends on
        wait(driver, lambda d: js(d, STATE + ".time.frame") == (p["first"] + p["step"]) % 40, "the last step asked for was not applied")
        assert console_errors(driver) == []


def drag_from(driver, at, by, steps=8):
    """A left-button drag on the view from `at` (CSS pixels of the view) by `by`, in steps."""
    view = driver.find_element(By.ID, "view")
    w, h = js(driver, "[document.getElementById('view').getBoundingClientRect().width,"
                      " document.getElementById('view').getBoundingClientRect().height]")
    chain = ActionChains(driver).move_to_element_with_offset(view, round(at[0] - w / 2), round(at[1] - h / 2)).click_and_hold()
    for _ in range(steps):
        chain.move_by_offset(round(by[0] / steps), round(by[1] / steps)).pause(0.03)
    chain.release().perform()


def test_handles_move_and_turn_a_clip_plane_and_turn_the_light(tmp_path):
    scene = dict(SCENE, clip_planes=[{"point": [0, 0, 0], "normal": [1, 0, 0]}], camera={"width": 320, "height": 240})
    with opened_page(tmp_path, scene) as driver:
        wait(driver, lambda d: {h["kind"] for h in js(d, "window.penumbraViewer.handles")} == {"light", "move", "turn"},
             "the light's and the plane's handles are not drawn")
        assert painted(driver, "handles") > 100
        handles = {h["kind"]: h for h in js(driver, "window.penumbraViewer.handles")}
        # the knob dragged along the arrow moves the plane along its normal, the normal kept
        move = handles["move"]
        arrow = [move["tip"][0] - move["at"][0], move["tip"][1] - move["at"][1]]
        length = math.hypot(*arrow)
        drag_from(driver, move["at"], [40 * arrow[0] / length, 40 * arrow[1] / length])
        wait(driver, lambda d: js(d, STATE + ".document.clip_planes[0].point")[0] > 0.05, "dragging the knob did not move the plane")
        plane = js(driver, STATE + ".document.clip_planes[0]")
        assert plane["normal"] == [1, 0, 0] and abs(plane["point"][1]) < 1e-6 and abs(plane["point"][2]) < 1e-6, plane
        # the tip dragged across the arrow turns the normal; it stays a unit vector
        wait(driver, lambda d: js(d, "window.penumbraViewer.handles.length") == 3, "the handles were not drawn again")
        handles = {h["kind"]: h for h in js(driver, "window.penumbraViewer.handles")}
        turn = handles["turn"]
        drag_from(driver, turn["at"], [0, 40])
        wait(driver, lambda d: js(d, STATE + ".document.clip_planes[0].normal")[0] < 0.99, "dragging the tip did not turn the plane")
        normal = js(driver, STATE + ".document.clip_planes[0].normal")
        assert abs(math.hypot(*normal) - 1) < 1e-4, normal
        # the sun turns the light
        before = js(driver, STATE + ".document.lights[0].direction")
        handles = {h["kind"]: h for h in js(driver, "window.penumbraViewer.handles")}
        drag_from(driver, handles["light"]["at"], [50, 0])
        wait(driver, lambda d: js(d, STATE + ".document.lights[0].direction") != before, "dragging the sun did not turn the light")
        # H hides them; a drag where the knob was orbits the camera instead
        press(driver, "h")
        wait(driver, lambda d: painted(d, "handles") == 0 and js(d, "window.penumbraViewer.handles.length") == 0, "H did not hide the handles")
        assert console_errors(driver) == []
