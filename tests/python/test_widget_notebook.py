"""penumbra.Widget in a real notebook (issue 41): a notebook executed headless as nbconvert would, and a
classic Jupyter Notebook server started here, driven by headless Chromium, where state flows both ways:
what the user does in the widget's page lands in the kernel's Renderer, and r.set(...) in the kernel
redraws the page. The kernel half alone is tested in test_widget.py."""
import json
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request

import pytest

pytest.importorskip("ipywidgets")      # Debian python3-ipywidgets
nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("notebook")        # Debian jupyter-notebook: the server of the browser test
pytest.importorskip("selenium")
if shutil.which("chromedriver") is None:
    pytest.skip("chromedriver is not installed", allow_module_level=True)

from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402
from test_viewer_browser import chrome, js, wait  # noqa: E402

TOKEN = "penumbra-widget-test-0123456789"
SCENE = {
    "volumes": [{"procedural": {"name": "test-spheres", "size": 32}, "transfer_function": {"preset": "test-spheres"}}],
    "planes": [{"point": [0, -0.52, 0], "normal": [0, 1, 0], "size": 4}],
    "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}],
    "shadows": {"technique": "cssm", "resolution": 128},
}
SETUP = f"""import json
import penumbra
r = penumbra.Renderer(penumbra.Scene({json.dumps(SCENE)}))
w = penumbra.Widget(r, height=420, max_samples=4)
w"""


def notebook(*cells):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell(c) for c in cells]
    return nb


def test_notebook_runs_headless(tmp_path):
    """Executed without a browser (nbclient, as `jupyter nbconvert --execute`): the widget displays its
    view and the script that defines it, and Python's edits work with no page to draw them."""
    nb = notebook(SETUP, "r.set('lights.0.direction', [0.3, -1, 0.2])\nprint(json.dumps(r.get('lights.0.direction')))",
                  "w.close()\nprint(w._thread.is_alive(), w.frames_sent)")
    client = nbclient.NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    # Debian 12's nbclient 0.7 reads widget state in the message format of ipywidgets 7 and fails on any
    # ipywidgets 6 widget (KeyError 'state'); without its widget handler it records outputs as they are.
    client.comm_open_handlers = {}
    client.execute()
    outputs = [o for cell in nb.cells for o in cell.outputs]
    data = [o.get("data", {}) for o in outputs if o.output_type == "display_data"]
    assert any("application/javascript" in d and "penumbra-widget" in d["application/javascript"] for d in data)
    assert any("application/vnd.jupyter.widget-view+json" in d for d in data)
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "[0.3, -1, 0.2]" in text
    assert "False 0" in text, "no page ever said hello: nothing rendered, and close() stopped the thread"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A notebook server on 127.0.0.1 with its token, serving a folder with the test's notebook; its
    kernels inherit this process's environment (PYTHONPATH names the built penumbra)."""
    folder = tmp_path_factory.mktemp("notebooks")
    nbformat.write(notebook(SETUP), str(folder / "widget.ipynb"))
    port = free_port()
    env = dict(os.environ, JUPYTER_RUNTIME_DIR=str(folder / ".runtime"), JUPYTER_CONFIG_DIR=str(folder / ".config"))
    log = open(folder / "server.log", "w")
    process = subprocess.Popen([sys.executable, "-m", "notebook", "--no-browser", "--ip=127.0.0.1", f"--port={port}",
                                f"--NotebookApp.token={TOKEN}", f"--notebook-dir={folder}", "--allow-root"],
                               stdout=log, stderr=subprocess.STDOUT, env=env)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(f"{url}/api/status?token={TOKEN}", timeout=2).read()
                break
            except OSError:
                assert process.poll() is None and time.monotonic() < deadline, (folder / "server.log").read_text()
                time.sleep(0.2)
        yield url, folder
    finally:
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
        log.close()


# Runs Python in the page's kernel and resolves with what it printed (the last argument of an async script).
KERNEL_EVAL = """
const code = arguments[0], done = arguments[arguments.length - 1];
let out = "";
Jupyter.notebook.kernel.execute(code, { iopub: { output: (msg) => {
  if (msg.msg_type === "stream") out += msg.content.text;
  else if (msg.msg_type === "error") out += "ERROR " + msg.content.ename + ": " + msg.content.evalue;
} }, shell: { reply: () => setTimeout(() => done(out), 50) } });
"""


def kernel(driver, code):
    driver.switch_to.default_content()
    return driver.execute_async_script(KERNEL_EVAL, code)


def in_widget(driver):
    driver.switch_to.default_content()
    driver.switch_to.frame(driver.find_element(By.CSS_SELECTOR, "iframe.penumbra-widget"))


def frames(driver):
    in_widget(driver)
    return js(driver, "window.penumbraViewer ? window.penumbraViewer.frames : 0")


def settled(driver):
    """Until the page shows the last full frame of the refinement (4 samples)."""
    in_widget(driver)
    wait(driver, lambda d: js(d, "!!(penumbraViewer.lastFrame && penumbraViewer.lastFrame.quality === 'full' && "
                                 "penumbraViewer.lastFrame.samples === 4)"), "the refined frame")


@pytest.fixture(scope="module")
def page(server):
    url, folder = server
    driver = chrome()
    driver.set_script_timeout(60)
    try:
        driver.get(f"{url}/notebooks/widget.ipynb?token={TOKEN}")
        wait(driver, lambda d: js(d, "!!(window.Jupyter && Jupyter.notebook && Jupyter.notebook.kernel && "
                                     "Jupyter.notebook.kernel.is_connected())"), "the kernel")
        js(driver, "Jupyter.notebook.execute_all_cells()")
        wait(driver, lambda d: js(d, "document.querySelector('iframe.penumbra-widget') !== null"), "the widget's iframe")
        in_widget(driver)
        wait(driver, lambda d: js(d, "!!(window.penumbraViewer && penumbraViewer.frames > 0)"), "a first frame")
        yield driver
    finally:
        driver.switch_to.default_content()
        driver.save_screenshot(str(folder / "notebook.png"))
        shutil.copy(folder / "notebook.png", os.environ.get("PENUMBRA_WIDGET_SCREENSHOT", str(folder / "last.png")))
        driver.quit()


def test_the_page_shows_the_renderers_scene(page):
    settled(page)
    state = js(page, "penumbraViewer.state")
    assert state["document"]["shadows"]["technique"] == "cssm"
    meta = js(page, "penumbraViewer.lastFrame")
    view = page.find_element(By.ID, "view")
    assert (meta["width"], meta["height"]) == (meta["view_width"], meta["view_height"])
    assert abs(meta["width"] - view.size["width"]) <= 2 and abs(meta["height"] - view.size["height"]) <= 2
    src = js(page, "document.getElementById('view').src")
    assert src.startswith("blob:")
    # the camera's size is the page's: the renderer renders what the page shows
    assert json.loads(kernel(page, "print(json.dumps([r.get('camera.width'), r.get('camera.height')]))")) == [meta["width"], meta["height"]]


def test_camera_moved_in_the_page_is_the_renderers(page):
    settled(page)
    in_widget(page)
    # a click puts the keyboard in the widget's page, whose keys then never reach the notebook's own
    # shortcuts (in the notebook's command mode "1" would turn the cell into a heading)
    ActionChains(page).move_to_element(page.find_element(By.ID, "view")).click().perform()
    ActionChains(page).send_keys("1").perform()  # look from +X (standard_views.js)
    wait(page, lambda d: js(d, "penumbraViewer.state.camera.eye[0] > 0.5 && "
                               "Math.abs(penumbraViewer.state.camera.eye[2] - penumbraViewer.state.camera.target[2]) < 1e-3"), "the +X view")
    eye = js(page, "penumbraViewer.state.camera.eye")
    assert json.loads(kernel(page, "print(json.dumps(r.get('camera.eye')))")) == pytest.approx(eye)
    assert js(page, "Jupyter.notebook.get_cell(0).cell_type") == "code"


def test_transfer_function_chosen_in_the_page_is_the_renderers(page):
    settled(page)
    in_widget(page)
    Select(page.find_element(By.CSS_SELECTOR, "#panel select.preset")).select_by_value("ct-bone")
    wait(page, lambda d: js(d, "penumbraViewer.state.document.volumes[0].transfer_function") == "ct-bone", "the preset in the state")
    assert json.loads(kernel(page, "print(json.dumps(r.get('volumes.0.transfer_function')))")) == "ct-bone"


def test_python_edits_redraw_the_page(page):
    settled(page)
    before = frames(page)
    out = kernel(page, "r.set('lights.0.direction', [0.4, -1, 0.3]); print('ok')")
    assert out.strip() == "ok", out
    in_widget(page)
    wait(page, lambda d: js(d, "JSON.stringify(penumbraViewer.state.document.lights[0].direction)") == "[0.4,-1,0.3]",
         "the light in the page's state")
    settled(page)
    assert frames(page) > before, "the page shows frames of the edited scene"


def test_screenshot_button_downloads_over_the_comm(page):
    settled(page)
    in_widget(page)
    page.find_element(By.ID, "screenshot").click()
    wait(page, lambda d: js(d, "penumbraViewer.downloads || 0") >= 1, "the screenshot's download")


def test_no_errors_from_the_widget(page):
    page.switch_to.default_content()
    errors = [e["message"] for e in page.get_log("browser") if e["level"] == "SEVERE"]
    ours = [m for m in errors if "blob:" in m or "penumbra" in m.lower()]
    assert ours == [], ours
