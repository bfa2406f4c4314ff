// The probe: where the pointer rests over the view (not while dragging), the page asks the server what
// lies under that pixel ({"type": "probe", "pixel": [x, y]} in the camera's pixels) and shows the
// answer: the value of the first visible sample along the pixel's ray, with its unit and position.

import { $, findHistogram, formatValue } from "./util.js";
import { viewer, sendMessage } from "./connection.js";

const REST_MS = 120;          // the pointer rests this long before a probe is sent
const readout = $("probe");
const view = $("view");

let timer = 0;

function onPointerMove(e) {
  clearTimeout(timer);
  if (e.buttons) return;      // dragging: the view is moving
  timer = setTimeout(() => sendProbe(e.clientX, e.clientY), REST_MS);
}

function sendProbe(clientX, clientY) {
  const cam = viewer.state && viewer.state.camera;
  if (!cam) return;
  const r = view.getBoundingClientRect();
  const x = ((clientX - r.left) / r.width) * cam.width, y = ((clientY - r.top) / r.height) * cam.height;
  sendMessage({ type: "probe", pixel: [x, y] });
}

/** Shows a probe answer. */
export function showProbe(msg) {
  readout.hidden = false;
  if (!msg.hit) { readout.textContent = "probe: nothing visible here"; return; }
  const hist = findHistogram(viewer.state || {}, msg.volume);
  const unit = hist && hist.unit ? " " + hist.unit : "";
  readout.textContent = "probe: " + formatValue(msg.value) + unit + " · volume " + msg.volume +
    " at (" + msg.position.map(formatValue).join(", ") + ")";
}

export function installProbe() {
  view.addEventListener("pointermove", onPointerMove);
  view.addEventListener("pointerleave", () => { clearTimeout(timer); readout.hidden = true; });
}
