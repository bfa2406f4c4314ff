// penumbra view's page: wires the server's messages to the modules and the page's controls to theirs.
// The modules: connection.js (WebSocket, protocol, edits), view.js (the image, camera and light
// drags), standard_views.js (reset and the axis views), overlay.js (stats, banners, progress),
// legend.js (colour legend), axes.js (orientation triad), outline.js (the data's box), probe.js (the
// value under the pointer), history.js (undo, redo), shortcuts.js (keys, their help), panels.js,
// transfer_function.js and cuts.js (the side panel), time.js (the time slider), util.js (helpers).

import { $ } from "./util.js";
import { TOKEN_QUERY, viewer, start, observeEdits, connectionStatus, reconnectAttempts, inNotebook, sendMessage } from "./connection.js";
import { view, showFrame, followCamera, setCamera, installViewInput, scheduleResize, sendResize } from "./view.js";
import { renderStats, renderProgress, renderConnectionBanner, noteRebuilt, showError, hideError } from "./overlay.js";
import { updatePanel, syncPanel, isPanelBusy, onPanelPointerDown, onWindowPointerUp, showSelectionError } from "./panels.js";
import { syncTime, frameShown, installTimeControls } from "./time.js";
import { updateCuts } from "./cuts.js";
import { noteOpeningCamera, standardCamera } from "./standard_views.js";
import { updateLegend } from "./legend.js";
import { drawAxes } from "./axes.js";
import { drawOutline, toggleOutline } from "./outline.js";
import { drawHandles, toggleHandles } from "./handles.js";
import { recordEdit, undo, redo, forgetRefused } from "./history.js";
import { installShortcuts, toggleHelp } from "./shortcuts.js";
import { installProbe, showProbe } from "./probe.js";

function onState(state) {
  viewer.state = state;
  noteOpeningCamera(state);
  followCamera(state);
  updatePanel(state);
  updateCuts(state);
  syncTime(state);
  updateLegend(state);
  drawAxes(state);
  drawOutline(state);
  drawHandles(state);
}

function onFrameMeta(meta) {
  viewer.lastFrame = meta;
  frameShown(meta);
  noteRebuilt(meta.rebuilt);
  renderStats();
  renderProgress(meta);
}

function onError(message) {
  if (!showSelectionError(message || "")) showError(message || "error");
  forgetRefused();
  // A refused edit leaves the scene as it was: put the controls back to the last state, the field
  // that sent the refused value too.
  const field = document.activeElement;
  if (field && $("panel").contains(field) && field.matches("input:not(.selection), select")) field.blur();
  if (viewer.state && !isPanelBusy()) syncPanel(viewer.state);
}

function onConnection() {
  renderStats();
  renderConnectionBanner(connectionStatus(), reconnectAttempts());
}

function togglePanel() {
  document.body.classList.toggle("panel-hidden");
}

function toggleFullscreen() {
  if (document.fullscreenElement) document.exitFullscreen().catch(() => {});
  else document.documentElement.requestFullscreen().catch(() => {});
}

function showView(name) {
  const cam = standardCamera(name, viewer.state);
  if (cam) setCamera(cam);
}

const VIEW_KEYS = { reset: "r", "+x": "1", "-x": "2", "+y": "3", "-y": "4", "+z": "5", "-z": "6", iso: "0" };

const SHORTCUTS = [
  ...Object.entries(VIEW_KEYS).map(([name, key]) => ({
    keys: [key], label: name === "reset" ? "reset the camera" : name === "iso" ? "isometric view" : "look from " + name.toUpperCase(),
    run: () => showView(name) })),
  { keys: ["b"], label: "show or hide the data's box and periodic cells", run: toggleOutline },
  { keys: ["h"], label: "show or hide the handles (drag the sun: turn the light; a clip plane's knob: move it, its arrow's tip: turn it)", run: toggleHandles },
  { keys: ["f"], label: "fullscreen", run: toggleFullscreen },
  { keys: ["p"], label: "show or hide the panel", run: togglePanel },
  { keys: ["Ctrl+Z"], label: "undo", run: undo },
  { keys: ["Ctrl+Shift+Z", "Ctrl+Y"], label: "redo", run: redo },
  { keys: ["?"], label: "this list", run: () => toggleHelp() },
  { keys: ["Escape"], label: "close this list", run: () => toggleHelp(false) },
];

// The notebook's downloads come over the comm (the kernel has no URL of its own): a "download" message
// ({name, mime}) and its bytes, saved as the browser saves a link's file.
function onDownload(meta, bytes) {
  const link = document.createElement("a");
  link.href = URL.createObjectURL(new Blob([bytes], { type: meta.mime }));
  link.download = meta.name;
  document.body.appendChild(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(link.href), 60000);
  viewer.downloads = (viewer.downloads || 0) + 1;
}

// In the notebook a click on the view must take the keyboard into this page: the view's drags cancel the
// pointer's default, which leaves the focus in the notebook, whose command-mode keys ("1", "r", "y")
// would then edit its cells instead of turning the view.
function installNotebookFocus() {
  if (inNotebook()) window.addEventListener("pointerdown", () => window.focus(), { capture: true });
}

function installDownloads() {
  if (!inNotebook()) {
    $("screenshot").href = "/screenshot.png" + TOKEN_QUERY;
    $("save-scene").href = "/scene.json" + TOKEN_QUERY;
    return;
  }
  for (const [id, what] of [["screenshot", "screenshot"], ["save-scene", "scene"]]) {
    $(id).href = "#";
    $(id).addEventListener("click", (event) => { event.preventDefault(); sendMessage({ type: "download", what }); });
  }
}

function init() {
  installDownloads();
  installNotebookFocus();
  $("panel-toggle").addEventListener("click", togglePanel);
  $("help-toggle").addEventListener("click", () => toggleHelp());
  $("fullscreen").addEventListener("click", toggleFullscreen);
  $("outline-toggle").addEventListener("click", toggleOutline);
  $("handles-toggle").addEventListener("click", toggleHandles);
  $("undo").addEventListener("click", undo);
  $("redo").addEventListener("click", redo);
  for (const button of document.querySelectorAll("#views [data-view]")) {
    button.addEventListener("click", () => showView(button.dataset.view));
  }
  $("error-close").addEventListener("click", hideError);
  $("panel").addEventListener("pointerdown", onPanelPointerDown);
  window.addEventListener("pointerup", onWindowPointerUp);
  window.addEventListener("pointercancel", onWindowPointerUp);
  window.addEventListener("blur", onWindowPointerUp);
  window.addEventListener("resize", scheduleResize);
  new ResizeObserver(() => {   // also the panel being shown or hidden
    scheduleResize();
    drawOutline(viewer.state);
    drawHandles(viewer.state);
  }).observe(view);
  installViewInput();
  installTimeControls();
  installShortcuts(SHORTCUTS);
  installProbe();
  observeEdits(recordEdit);
  renderStats();
  start({ onStatus: onConnection, onOpen: () => sendResize(true), onState, onFrameMeta, onFrameBytes: showFrame, onError, onProbe: showProbe, onDownload });
}

init();
