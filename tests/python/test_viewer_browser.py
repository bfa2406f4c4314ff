"""The viewer's page (`penumbra view`, docs/viewer.md) in a real browser: Debian's headless chromium
driven through Selenium. The page loads and shows frames; a drag on the view orbits the camera and a
click in the transfer-function editor adds a point, each changing the image; switching the shadow
technique shows what was rebuilt in the stats; a second tab follows the first; and the page's
screenshot link gives what `penumbra render` gives for its save-scene link. The page loads its
stylesheet and every script module, and the browser's console shows no error all along.

Set PENUMBRA_FIGURES to a folder to save a screenshot of the whole page there (viewer_page.png)."""
import json
import os
import shutil
import subprocess

import pytest

pytest.importorskip("selenium")  # Debian python3-selenium and chromium-driver (scripts/install-deps.sh)
if shutil.which("chromedriver") is None:
    pytest.skip("chromedriver is not installed", allow_module_level=True)

from selenium import webdriver  # noqa: E402
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402
from test_viewer_protocol import Viewer  # noqa: E402  (the server under test, started and stopped alike)

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
TIMEOUT = 60

SCENE = {
    "volumes": [{"procedural": {"name": "test-spheres", "size": 32}, "transfer_function": {"preset": "test-spheres"}}],
    "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
    "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
    "shadows": {"technique": "cssm", "resolution": 128},
}

# The TF editor's plot in CSS pixels (TF_W, TF_H, TF_PAD, HIT_RADIUS in page/js/transfer_function.js).
TF_W, TF_H, TF_PAD, HIT_RADIUS = 270, 140, 6, 7


def chrome():
    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1200,800"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # the console, for console_errors
    if os.path.exists("/usr/bin/chromedriver"):
        return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    return webdriver.Chrome(options=options)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """One server and one browser for the module's tests, which run in order and build on each other."""
    server = Viewer(tmp_path_factory.mktemp("viewer"), SCENE)
    try:
        driver = chrome()
    except Exception:
        server.close()
        raise
    try:
        driver.get(server.url)
        yield server, driver
    finally:
        driver.quit()
        assert server.close() == 0, "Ctrl-C must stop the server cleanly"


def console_errors(driver):
    """The console's errors since the last call (a script's exception, a file that failed to load, a
    refusal by the page's Content-Security-Policy)."""
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def js(driver, expression):
    return driver.execute_script("return " + expression)


def wait(driver, condition, message, timeout=TIMEOUT):
    return WebDriverWait(driver, timeout, poll_frequency=0.05).until(lambda d: condition(d), message)


# Records, as the page shows them, the frame each new image belongs to and every text of the stats:
# the img's src and the stats are set while a message is handled, and the observers run right after,
# before the next message, so the frame's header is still penumbraViewer.lastFrame.
RECORDERS = """
if (!window.testRecord) {
  const v = window.penumbraViewer, record = window.testRecord = { shown: null, stats: [] };
  new MutationObserver(() => {
    record.shown = Object.assign({ frames: v.frames }, v.lastFrame);
  }).observe(document.getElementById('view'), { attributes: true, attributeFilter: ['src'] });
  new MutationObserver(() => record.stats.push(document.getElementById('stats').textContent))
    .observe(document.getElementById('stats'), { childList: true, characterData: true, subtree: true });
}
"""


def wait_loaded(driver):
    wait(driver, lambda d: js(d, "document.getElementById('view').naturalWidth > 0 && window.penumbraViewer.frames >= 1"
                                 " && window.penumbraViewer.state !== null"), "no frame shown")
    driver.execute_script(RECORDERS)


# The image shown is that of a full-quality frame after the `frames`-th with at least `samples`
# accumulated samples, and has loaded.
FULL_FRAME_SHOWN = """
const shown = window.testRecord.shown, img = document.getElementById('view');
return !!shown && shown.quality === 'full' && shown.frames > arguments[0] && shown.samples >= arguments[1]
  && img.complete && img.naturalWidth === shown.width;
"""
MAX_SAMPLES = 16  # the server accumulates up to 16 samples while idle (docs/viewer.md)


def wait_full_frame(driver, frames, samples=1):
    wait(driver, lambda d: d.execute_script(FULL_FRAME_SHOWN, frames, samples), "no new full-quality frame shown")


def settled_view(driver, frames=0):
    """The view's screenshot once the server has stopped refining: the same scene gives the same bytes,
    so that a change in the image is the edit's and not the accumulation's."""
    wait_full_frame(driver, frames, MAX_SAMPLES)
    # An element's screenshot shows what lies over it too: the stats (whose frame time changes) and
    # the toolbar are hidden meanwhile.
    overlays = "for (const e of document.querySelectorAll('#main > :not(#view)')) e.style.visibility = arguments[0]"
    driver.execute_script(overlays, "hidden")
    try:
        return driver.find_element(By.ID, "view").screenshot_as_png
    finally:
        driver.execute_script(overlays, "")


def test_the_page_loads_and_shows_frames(session):
    server, driver = session
    wait_loaded(driver)
    assert driver.title == "penumbra view"
    state = js(driver, "window.penumbraViewer.state")
    assert state["document"]["shadows"]["technique"] == "cssm"
    assert js(driver, "document.getElementById('view').src").startswith("blob:")
    wait_full_frame(driver, 0)
    assert "connected" in driver.find_element(By.ID, "stats").text


def test_the_page_loads_its_stylesheet_and_modules_with_no_console_errors(session):
    server, driver = session
    wait_loaded(driver)
    assert console_errors(driver) == []
    # the stylesheet applies (the page's background and the panel's width are its)
    assert js(driver, "getComputedStyle(document.body).backgroundColor") == "rgb(18, 18, 21)"
    assert js(driver, "document.getElementById('panel').getBoundingClientRect().width") == 304
    # every module of page/js came, each with the token (the import map's URL)
    page = os.path.join(os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", "..")),
                        "src", "penumbra", "viewer", "page")
    modules = sorted("/js/" + f for f in os.listdir(os.path.join(page, "js")) if f.endswith(".js"))
    loaded = js(driver, "performance.getEntriesByType('resource').map((r) => new URL(r.name))"
                        ".map((u) => [u.pathname, u.searchParams.get('token')])")
    assert sorted(p for p, t in loaded if p.startswith("/js/") and t == server.token) == modules
    assert ["/style.css", server.token] in loaded


def test_a_left_drag_orbits_the_camera_and_changes_the_image(session):
    server, driver = session
    wait_loaded(driver)
    before = settled_view(driver)
    # The scene gives no eye: the state's camera is the framed one, which the drag turns.
    eye = js(driver, "window.penumbraViewer.state.camera.eye")
    assert len(eye) == 3
    frames = js(driver, "window.penumbraViewer.frames")
    view = driver.find_element(By.ID, "view")
    src = view.get_attribute("src")
    actions = ActionChains(driver).move_to_element(view).click_and_hold()
    for _ in range(4):
        actions.move_by_offset(30, 0).pause(0.05)
    actions.release().perform()
    moved = "const eye = window.penumbraViewer.state.document.camera.eye; return Array.isArray(eye) && eye.length === 3" \
            " && eye.some((x, i) => Math.abs(x - arguments[0][i]) > 1e-3)"
    wait(driver, lambda d: d.execute_script(moved, eye), "the camera did not move")
    wait_full_frame(driver, frames)
    assert view.get_attribute("src") != src
    changed = settled_view(driver, frames) != before
    assert changed, "the image did not change"


def tf_click_point(state):
    """A spot in the upper middle of the TF plot (CSS pixels from its top left) that hits no point."""
    hist = state["histograms"][0]
    lo, hi = hist["lo"], hist["hi"]
    points = state["transfer_functions"][0]["points"]

    def xy(p):
        x = TF_PAD + (p[0] - lo) / (hi - lo) * (TF_W - 2 * TF_PAD)
        return min(max(x, TF_PAD), TF_W - TF_PAD), TF_H - TF_PAD - min(max(p[4], 0), 1) ** 0.5 * (TF_H - 2 * TF_PAD)

    y = 35
    for x in (135, 115, 155, 95, 175, 75, 195):
        if all(((x - px) ** 2 + (y - py) ** 2) ** 0.5 > 2 * HIT_RADIUS for px, py in map(xy, points)):
            return x, y
    raise AssertionError(f"no free spot in the TF plot: {points}")


def test_a_click_in_the_transfer_function_editor_adds_a_point_and_changes_the_image(session):
    server, driver = session
    wait_loaded(driver)
    state = js(driver, "window.penumbraViewer.state")
    count = len(state["transfer_functions"][0]["points"])
    before = settled_view(driver)
    frames = js(driver, "window.penumbraViewer.frames")
    view = driver.find_element(By.ID, "view")
    src = view.get_attribute("src")
    plot = driver.find_element(By.CSS_SELECTOR, "#tf-list canvas.plot")
    x, y = tf_click_point(state)
    # Offsets are from the element's centre (W3C actions).
    ActionChains(driver).move_to_element_with_offset(plot, x - TF_W // 2, y - TF_H // 2).click().perform()

    def edited(d):
        tf = js(d, "window.penumbraViewer.state.document.volumes[0].transfer_function")
        return isinstance(tf, dict) and list(tf) == ["points"] and len(tf["points"]) == count + 1

    wait(driver, edited, "the TF edit did not reach the document")
    assert len(js(driver, "window.penumbraViewer.state.transfer_functions[0].points")) == count + 1
    wait_full_frame(driver, frames)
    assert view.get_attribute("src") != src
    changed = settled_view(driver, frames) != before
    assert changed, "the image did not change"
    figures = os.environ.get("PENUMBRA_FIGURES")
    if figures:
        os.makedirs(figures, exist_ok=True)
        with open(os.path.join(figures, "viewer_page.png"), "wb") as f:
            f.write(driver.get_screenshot_as_png())


def test_a_technique_switch_shows_what_was_rebuilt_and_a_second_tab_follows(session):
    server, driver = session
    wait_loaded(driver)
    first = driver.current_window_handle
    driver.switch_to.new_window("tab")
    second = driver.current_window_handle
    driver.get(server.url)
    wait_loaded(driver)
    assert js(driver, "window.penumbraViewer.state.document.shadows.technique") == "cssm"
    driver.switch_to.window(first)
    wait_loaded(driver)
    # cssm rebuilds the light's shadows every sample ("lights.0.shadows (sample)"), and the stats show
    # only the last frame that rebuilt anything: look for the switch as the cause, in every text shown.
    expected = "lights.0.shadows (shadows.technique)"
    shown = "window.testRecord.stats.concat([document.getElementById('stats').textContent])"
    assert not any(expected in text for text in js(driver, shown))
    select = Select(driver.find_element(By.CSS_SELECTOR, "#shadows select"))
    assert select.first_selected_option.get_attribute("value") == "cssm"
    assert "shadow_map" in [o.get_attribute("value") for o in select.options]
    select.select_by_value("shadow_map")
    wait(driver, lambda d: js(d, "window.penumbraViewer.state.document.shadows.technique") == "shadow_map",
         "the technique did not change")
    wait(driver, lambda d: any(expected in text for text in js(d, shown)),
         "the stats do not say what the switch rebuilt")
    driver.switch_to.window(second)
    wait(driver, lambda d: js(d, "window.penumbraViewer.state.document.shadows.technique") == "shadow_map",
         "the second tab did not follow")
    select = Select(driver.find_element(By.CSS_SELECTOR, "#shadows select"))
    assert select.first_selected_option.get_attribute("value") == "shadow_map"
    assert console_errors(driver) == []
    driver.close()
    driver.switch_to.window(first)


def test_the_screenshot_link_equals_penumbra_render_of_the_save_scene_link(session, tmp_path):
    server, driver = session
    wait_loaded(driver)
    links = {}
    for id, path in (("screenshot", "/screenshot.png"), ("save-scene", "/scene.json")):
        href = driver.find_element(By.ID, id).get_attribute("href")
        assert href.startswith(server.base + path + "?") and "token=" + server.token in href, href
        links[id] = href[len(server.base):]
    status, png, _ = server.get(links["screenshot"], token=False)  # the link carries the token
    assert status == 200
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    scene = tmp_path / "saved.json"
    status, saved, _ = server.get(links["save-scene"], token=False)
    assert status == 200
    scene.write_bytes(saved)
    assert json.loads(scene.read_text())["shadows"]["technique"] == "shadow_map"
    subprocess.run([CLI, "render", str(scene), "-o", str(tmp_path / "cli.png")], check=True, capture_output=True)
    same = (tmp_path / "cli.png").read_bytes() == png
    assert same, "the screenshot is not what penumbra render makes of the saved scene"
    assert console_errors(driver) == [], "the console showed errors while the page was used"


def test_the_technique_fields_follow_each_techniques_declared_keys(session):
    server, driver = session
    wait_loaded(driver)
    declared = js(driver, "window.penumbraViewer.state.technique_parameters.shadows")
    assert declared["dsm_layout"]["choices"] == ["per_channel", "shared_depth"]
    select = Select(driver.find_element(By.CSS_SELECTOR, "#shadows select"))
    select.select_by_value("deep_shadow_map")
    wait(driver, lambda d: js(d, "window.penumbraViewer.state.document.shadows.technique") == "deep_shadow_map",
         "the technique did not change")
    labels = lambda: [e.text for e in driver.find_elements(By.CSS_SELECTOR, "#shadows label.key")]
    wait(driver, lambda d: "dsm_layout" in labels(), "no field for deep_shadow_map's dsm_layout")
    assert set(labels()) == {"technique", "resolution", "bias", "step", "nodes", "dsm_layout"}
    nodes = driver.find_element(By.XPATH, "//div[@id='shadows']//label[text()='nodes']/following-sibling::input")
    assert nodes.get_attribute("placeholder") == "3" and nodes.get_attribute("step") == "1"
    layout = Select(driver.find_element(By.XPATH, "//div[@id='shadows']//label[text()='dsm_layout']/following-sibling::select"))
    assert [o.get_attribute("value") for o in layout.options] == ["", "per_channel", "shared_depth"]
    layout.select_by_value("shared_depth")
    wait(driver, lambda d: js(d, "window.penumbraViewer.state.document.shadows.dsm_layout") == "shared_depth",
         "the choice did not reach the scene")
    Select(driver.find_element(By.CSS_SELECTOR, "#shadows select")).select_by_value("shadow_map")
    wait(driver, lambda d: js(d, "window.penumbraViewer.state.document.shadows.technique") == "shadow_map",
         "the technique did not change back")
    assert console_errors(driver) == []


def test_the_time_slider_and_play_step_through_a_series(tmp_path):
    """A scene with frames (a generated volume series) shows the time section; Play steps through every
    frame and wraps, each step waiting for its full frame; Pause stops; the slider jumps to a frame."""
    scene = {
        "volumes": [{"procedural": {"name": "sphere", "size": 24, "radius": 0.15, "frames": 4},
                     "transfer_function": {"preset": "test-spheres"}}],
        "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
        "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
        "shadows": {"technique": "cssm", "resolution": 64},
        "camera": {"width": 160, "height": 120},
    }
    server = Viewer(tmp_path, scene)
    driver = None
    try:
        driver = chrome()
        driver.get(server.url)
        wait(driver, lambda d: d.find_element(By.ID, "time-section").is_displayed(), "the time section never showed")
        assert js(driver, "document.getElementById('time').max") == "3"
        driver.find_element(By.ID, "play").click()
        seen = set()

        def advanced(d):
            frame = js(d, "window.penumbraViewer.lastFrame")
            if frame and frame.get("quality") == "full":
                seen.add(frame.get("time"))
            return seen >= {0, 1, 2, 3} and frame.get("time") == 0 and len(seen) == 4

        wait(driver, advanced, f"playing did not go through every frame and wrap (seen {seen})")
        driver.find_element(By.ID, "play").click()
        assert driver.find_element(By.ID, "play").text == "Play"
        js(driver, "(() => { const t = document.getElementById('time'); t.value = 2;"
                   " t.dispatchEvent(new Event('input')); return true; })()")
        wait(driver, lambda d: (js(d, "window.penumbraViewer.lastFrame") or {}).get("time") == 2
             and js(d, "window.penumbraViewer.lastFrame").get("quality") == "full", "the slider did not show frame 2")
        assert "frame 2 / 3" in driver.find_element(By.ID, "time-readout").text
        assert console_errors(driver) == []
    finally:
        if driver:
            driver.quit()
        assert server.close() == 0


def test_cuts_add_move_flip_and_remove_clip_planes_and_slices(session):
    server, driver = session
    wait_loaded(driver)
    doc = lambda key: js(driver, f"window.penumbraViewer.state.document.{key} || []")
    before = settled_view(driver)
    frames = js(driver, "window.penumbraViewer.frames")
    driver.find_element(By.XPATH, "//div[@id='cut-list']//button[text()='cut x']").click()
    wait(driver, lambda d: len(doc("clip_planes")) == 1, "the clip plane did not reach the scene")
    assert doc("clip_planes")[0]["normal"] == [1, 0, 0]
    cut = settled_view(driver, frames)
    assert cut != before, "the cut did not change the image"
    # the slider moves the plane along its normal, nothing else
    point = doc("clip_planes")[0]["point"]
    slider = driver.find_element(By.CSS_SELECTOR, "[data-cut='clip_planes.0'] input[type=range]")
    driver.execute_script("arguments[0].value = arguments[0].min; arguments[0].dispatchEvent(new Event('input'))", slider)
    wait(driver, lambda d: doc("clip_planes")[0]["point"][0] < point[0] - 1e-6, "the slider did not move the plane")
    assert doc("clip_planes")[0]["point"][1:] == point[1:]
    driver.find_element(By.CSS_SELECTOR, "[data-cut='clip_planes.0'] button[title='keep the other side']").click()
    wait(driver, lambda d: doc("clip_planes")[0]["normal"] == [-1, 0, 0], "flip did not turn the plane")
    driver.find_element(By.XPATH, "//div[@id='cut-list']//button[text()='slice z']").click()
    wait(driver, lambda d: len(doc("slices")) == 1, "the slice did not reach the scene")
    # its opacity slider: translucent, the slice is drawn over what lies behind it
    opaque_slice = settled_view(driver)
    opacity = driver.find_element(By.CSS_SELECTOR, "[data-cut='slices.0'] input.opacity")
    assert float(opacity.get_attribute("value")) == 1
    frames = js(driver, "window.penumbraViewer.frames")
    driver.execute_script("arguments[0].value = 0.4; arguments[0].dispatchEvent(new Event('input'))", opacity)
    wait(driver, lambda d: doc("slices")[0].get("opacity") == 0.4, "the opacity did not reach the scene")
    assert settled_view(driver, frames) != opaque_slice, "a translucent slice looks the same"
    for kind in ("clip_planes", "slices"):
        driver.find_element(By.CSS_SELECTOR, f"[data-cut='{kind}.0'] button[title^='remove']").click()
        wait(driver, lambda d: len(doc(kind)) == 0, f"the {kind} entry was not removed")
    assert console_errors(driver) == []


def test_the_selection_field_shows_the_count_and_errors_inline(tmp_path):
    """A particle file's row has a selection field: Enter sends particles.N.select, the readout shows
    the atoms selected, and a malformed selection shows its message under the field, not in the banner."""
    (tmp_path / "atoms.xyz").write_text("4\natoms\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\nC 0 0 0.5\n")
    scene = {"particles": [{"file": "atoms.xyz", "radius": 0.2}], "camera": {"width": 64, "height": 48}}
    server = Viewer(tmp_path, scene)
    driver = None
    try:
        driver = chrome()
        driver.get(server.url)
        wait(driver, lambda d: d.find_elements(By.CSS_SELECTOR, "input.selection"), "no selection field")
        field = driver.find_element(By.CSS_SELECTOR, "input.selection")
        count = driver.find_element(By.CSS_SELECTOR, ".selection-count")
        wait(driver, lambda d: count.text == "4 atoms", f"readout {count.text!r}")
        field.send_keys("name C\n")
        wait(driver, lambda d: count.text == "2 selected", f"readout {count.text!r} after 'name C'")
        field.send_keys(Keys.CONTROL, "a")  # typed over, as a user would (clear() would send "all" on its change)
        field.send_keys("name C and\n")
        error = driver.find_element(By.CSS_SELECTOR, ".selection-error")
        wait(driver, lambda d: error.is_displayed(), "the error did not show under the field")
        assert "at character 11: expected a selection" in error.text
        assert not driver.find_element(By.ID, "error").is_displayed(), "the error went to the banner too"
        assert count.text == "2 selected"
        field.send_keys(Keys.CONTROL, "a")
        field.send_keys("name O\n")
        wait(driver, lambda d: count.text == "1 selected" and not error.is_displayed(), "a good selection did not clear the error")
        assert console_errors(driver) == []
    finally:
        if driver:
            driver.quit()
        assert server.close() == 0
