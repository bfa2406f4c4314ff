// penumbra view's page: wires the server's messages to the modules and the page's controls to theirs.
// The modules: connection.js (WebSocket, protocol, edits), view.js (the image, camera and light
// drags), overlay.js (stats, error banner), panels.js, transfer_function.js and cuts.js (the side panel),
// time.js (the time slider), util.js (helpers).

import { $ } from "./util.js";
import { TOKEN_QUERY, viewer, start } from "./connection.js";
import { view, showFrame, followCamera, installViewInput, scheduleResize, sendResize } from "./view.js";
import { renderStats, noteRebuilt, showError, hideError } from "./overlay.js";
import { updatePanel, syncPanel, isPanelBusy, onPanelPointerDown, onWindowPointerUp, showSelectionError } from "./panels.js";
import { syncTime, frameShown, installTimeControls } from "./time.js";
import { updateCuts } from "./cuts.js";

function onState(state) {
  viewer.state = state;
  followCamera(state);
  updatePanel(state);
  updateCuts(state);
  syncTime(state);
}

function onFrameMeta(meta) {
  viewer.lastFrame = meta;
  frameShown(meta);
  noteRebuilt(meta.rebuilt);
  renderStats();
}

function onError(message) {
  if (!showSelectionError(message || "")) showError(message || "error");
  // A refused edit leaves the scene as it was: put the controls back to the last state.
  if (viewer.state && !isPanelBusy()) syncPanel(viewer.state);
}

function togglePanel() {
  document.body.classList.toggle("panel-hidden");
}

function init() {
  $("screenshot").href = "/screenshot.png" + TOKEN_QUERY;
  $("save-scene").href = "/scene.json" + TOKEN_QUERY;
  $("panel-toggle").addEventListener("click", togglePanel);
  $("error-close").addEventListener("click", hideError);
  $("panel").addEventListener("pointerdown", onPanelPointerDown);
  window.addEventListener("pointerup", onWindowPointerUp);
  window.addEventListener("pointercancel", onWindowPointerUp);
  window.addEventListener("blur", onWindowPointerUp);
  window.addEventListener("resize", scheduleResize);
  new ResizeObserver(scheduleResize).observe(view);   // also the panel being shown or hidden
  installViewInput();
  installTimeControls();
  renderStats();
  start({ onStatus: renderStats, onOpen: () => sendResize(true), onState, onFrameMeta, onFrameBytes: showFrame, onError });
}

init();
