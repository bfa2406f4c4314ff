// The view: the frame's image, its size sent to the server, and the camera and light that drags on it
// change (left drag orbits, right or middle drag pans, the wheel zooms, shift-drag turns the light; a
// left drag that starts on a handle (handles.js) drags that handle instead).

import { $, V, clamp, clone, capturePointer, cameraBasis } from "./util.js";
import { viewer, isOpen, queueEdit, sendMessage } from "./connection.js";
import { handleAt, dragHandle } from "./handles.js";

const DEFAULT_LIGHT_DIRECTION = [-0.4, -1, -0.3];   // the scene's light when the document has no "lights"
const ROTATE_PER_VIEW_HEIGHT = Math.PI;   // a drag over the view's height turns half a turn
const MIN_POLAR = 0.01;                   // radians kept between a turned vector and the up axis
const CAMERA_HOLD_MS = 400;               // states this soon after a local camera change keep our camera

export const view = $("view");

let camera = null;            // local copy of state.camera, changed by the mouse
let cameraHoldUntil = 0;
let drag = null;              // { mode: "orbit" | "pan" | "light" | "handle", x, y, id, handle }
let lightDrag = null;         // { light, asArray } while shift-dragging
let frameUrl = null;

/** Shows a frame's JPEG bytes. */
export function showFrame(buffer) {
  viewer.frames += 1;
  const previous = frameUrl;
  frameUrl = URL.createObjectURL(new Blob([buffer], { type: "image/jpeg" }));
  view.src = frameUrl;
  if (previous) URL.revokeObjectURL(previous);
}

/** Takes the state's camera, unless the user is moving (or has just moved) the local one. */
export function followCamera(state) {
  if (state.camera && !cameraHeld()) camera = clone(state.camera);
}

// ---------------------------------------------------------------------------------------------
// View size: sent on connect and (debounced) whenever the view changes size
// ---------------------------------------------------------------------------------------------

let resizeTimer = 0;
let lastSize = "";

function viewSize() {
  const r = view.getBoundingClientRect();
  return [clamp(Math.round(r.width), 16, 4096), clamp(Math.round(r.height), 16, 4096)];
}

export function scheduleResize() {
  clearTimeout(resizeTimer);
  resizeTimer = setTimeout(() => sendResize(false), 150);
}

export function sendResize(force) {
  const [width, height] = viewSize();
  const key = width + "x" + height;
  if (!force && key === lastSize) return;
  if (!isOpen()) return;
  lastSize = key;
  sendMessage({ type: "resize", width, height });
}

// ---------------------------------------------------------------------------------------------
// Camera and light interaction on #view
// ---------------------------------------------------------------------------------------------

const cameraHeld = () => drag !== null || performance.now() < cameraHoldUntil;
const viewHeight = () => Math.max(1, view.getBoundingClientRect().height);

/**
 * A turntable rotation fitted to `v`: `azimuth` about `up`, then `elevation` about `right` (turned
 * with the azimuth), the elevation shortened so that v never comes within MIN_POLAR of the up
 * axis. Returns the rotation as a function, so that other vectors can follow v.
 */
function turntable(v, up, right, azimuth, elevation) {
  const rightAxis = V.rotate(right, up, azimuth);
  const turned = V.rotate(v, up, azimuth);
  const poleDistance = (u) => { const polar = V.angle(u, up); return Math.min(polar, Math.PI - polar); };
  const before = poleDistance(turned);
  let el = elevation;
  for (let i = 0; i < 16; ++i, el /= 2) {
    const after = poleDistance(V.rotate(turned, rightAxis, el));
    if (after > MIN_POLAR || after > before) break;   // clear of the poles, or moving away from one
    if (i === 15) el = 0;
  }
  return (u) => V.rotate(V.rotate(u, up, azimuth), rightAxis, el);
}

/** Moves the camera to `cam` ({eye, target, up}) at once, as a drag would. */
export function setCamera(cam) {
  if (!camera) return;
  camera = Object.assign(clone(camera), clone(cam));
  queueCameraEdit();
}

function queueCameraEdit() {
  cameraHoldUntil = performance.now() + CAMERA_HOLD_MS;
  queueEdit({ "camera.eye": camera.eye, "camera.target": camera.target, "camera.up": camera.up });
}

function orbit(dx, dy) {
  const b = cameraBasis(camera);
  const k = ROTATE_PER_VIEW_HEIGHT / viewHeight();
  const offset = V.sub(camera.eye, camera.target);
  // The scene follows the hand: drag right turns the eye left, drag down raises it.
  const rotation = turntable(offset, b.up, b.right, -dx * k, -dy * k);
  camera.eye = V.add(camera.target, rotation(offset));
  queueCameraEdit();
}

function pan(dx, dy) {
  const b = cameraBasis(camera);
  const fov = ((camera.fov_deg || 35) * Math.PI) / 180;
  const perPixel = (b.distance * Math.tan(fov / 2) * 2) / viewHeight();
  const shift = V.add(V.scale(b.right, -dx * perPixel), V.scale(b.screenUp, dy * perPixel));
  camera.eye = V.add(camera.eye, shift);
  camera.target = V.add(camera.target, shift);
  queueCameraEdit();
}

function zoom(deltaY) {
  const b = cameraBasis(camera);
  const radius = (viewer.state && viewer.state.radius) || 0;
  let distance = b.distance * Math.pow(1.1, deltaY / 100);
  if (radius > 0) distance = clamp(distance, 0.02 * radius, 50 * radius);
  camera.eye = V.add(camera.target, V.scale(b.forward, -distance));
  queueCameraEdit();
}

/** The first light to drag, or null when the scene has none ("lights": []). */
function beginLightDrag() {
  const doc = (viewer.state && viewer.state.document) || {};
  if (!("lights" in doc)) {
    return { light: { type: "directional", direction: DEFAULT_LIGHT_DIRECTION.slice() }, asArray: true };
  }
  if (!Array.isArray(doc.lights) || doc.lights.length === 0) return null;
  return { light: clone(doc.lights[0]), asArray: false };
}

function moveLight(dx, dy) {
  const light = lightDrag.light;
  const b = cameraBasis(camera);
  const k = ROTATE_PER_VIEW_HEIGHT / viewHeight();
  // The light follows the hand: drag right moves it right, drag up moves it up.
  const type = light.type || "directional";
  const set = {};
  if (type === "directional") {
    const direction = light.direction || DEFAULT_LIGHT_DIRECTION;
    light.direction = turntable(direction, b.up, b.right, dx * k, dy * k)(direction);
    set["lights.0.direction"] = light.direction;
  } else if (Array.isArray(light.position)) {
    const pivot = (viewer.state && viewer.state.light_target) || camera.target;
    const offset = V.sub(light.position, pivot);
    const rotation = turntable(offset, b.up, b.right, dx * k, dy * k);
    light.position = V.add(pivot, rotation(offset));
    set["lights.0.position"] = light.position;
    // A spot light with an explicit axis keeps pointing the same way relative to the pivot.
    if (type === "spot" && Array.isArray(light.direction)) {
      light.direction = rotation(light.direction);
      set["lights.0.direction"] = light.direction;
    }
  } else {
    return;
  }
  // Without a "lights" key the path lights.0 has no array to index: send the whole array instead.
  queueEdit(lightDrag.asArray ? { lights: [light] } : set);
}

function onViewPointerDown(e) {
  if (drag || !camera) return;
  let mode = null;
  const r = view.getBoundingClientRect();
  const handle = e.button === 0 && !e.shiftKey ? handleAt(e.clientX - r.left, e.clientY - r.top) : null;
  if (handle) mode = handle.kind === "light" ? "light" : "handle";  // the sun turns the light as shift-drag does
  else if (e.button === 0) mode = e.shiftKey ? "light" : "orbit";
  else if (e.button === 1 || e.button === 2) mode = "pan";
  if (!mode) return;
  e.preventDefault();
  if (mode === "light") {
    lightDrag = beginLightDrag();
    if (!lightDrag) return;
  }
  capturePointer(view, e.pointerId);
  view.classList.add("dragging");
  drag = { mode, x: e.clientX, y: e.clientY, id: e.pointerId, handle };
}

function onViewPointerMove(e) {
  if (!drag || e.pointerId !== drag.id) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (dx === 0 && dy === 0) return;
  if (drag.mode === "orbit") orbit(dx, dy);
  else if (drag.mode === "pan") pan(dx, dy);
  else if (drag.mode === "handle") dragHandle(drag.handle, dx, dy, camera);
  else moveLight(dx, dy);
}

function onViewPointerUp(e) {
  if (!drag || e.pointerId !== drag.id) return;
  drag = null;
  lightDrag = null;
  view.classList.remove("dragging");
  cameraHoldUntil = performance.now() + CAMERA_HOLD_MS;
}

function onViewWheel(e) {
  e.preventDefault();
  if (!camera) return;
  const unit = e.deltaMode === 1 ? 40 : e.deltaMode === 2 ? 800 : 1;
  zoom(e.deltaY * unit);
}

export function installViewInput() {
  view.addEventListener("pointerdown", onViewPointerDown);
  view.addEventListener("pointermove", onViewPointerMove);
  view.addEventListener("pointerup", onViewPointerUp);
  view.addEventListener("pointercancel", onViewPointerUp);
  view.addEventListener("wheel", onViewWheel, { passive: false });
  view.addEventListener("contextmenu", (e) => e.preventDefault());
  view.addEventListener("dragstart", (e) => e.preventDefault());
  view.addEventListener("auxclick", (e) => e.preventDefault());
}
