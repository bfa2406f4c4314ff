// Handles drawn over the view and dragged with the left button, as ParaView's plane and light widgets:
// - the light: a sun on the side the first light comes from, joined to the data's centre; dragging it
//   turns the light as shift-drag does;
// - each clip plane: its outline across the data's box, a knob where the data's centre projects onto
//   it, and an arrow along its normal (the side it removes); dragging the knob moves the plane along
//   its normal (edits of clip_planes.N.point), dragging the arrow's tip turns the normal
//   (clip_planes.N.normal).
// Drawn on a 2D canvas from the state's camera (as outline.js), when a state arrives or the view
// changes size; `H` or the toolbar's Handles hides them. The handles drawn, with their positions in
// CSS pixels of the view, are window.penumbraViewer.handles (for tests).

import { $, V, cameraBasis, clone, sizedContext, round6 } from "./util.js";
import { viewer, queueEdit } from "./connection.js";
import { projector } from "./outline.js";

const canvas = $("handles");
const GRAB_PX = 10;              // a press this close to a knob takes it
const SUN_DISTANCE = 0.8;        // the sun's distance from the centre, in the data's radius (in view when it is framed)
const ARROW_LENGTH = 0.45;       // a clip plane's arrow, in the data's radius
const DEFAULT_LIGHT_DIRECTION = [-0.4, -1, -0.3];   // the scene's light when the document has no "lights"

let shown = true;
let lastState = null;
let handles = [];                // { kind: "light" | "move" | "turn", index, at: [x, y], ... }
viewer.handles = handles;

export function toggleHandles() {
  shown = !shown;
  $("handles-toggle").setAttribute("aria-pressed", String(shown));
  drawHandles(lastState);
}

function centre(state) {
  return state.light_target || (state.bounds ? V.scale(V.add(state.bounds.lo, state.bounds.hi), 0.5) : [0, 0, 0]);
}

/** The first light's direction (it shines along it), or null when it has none to turn. */
function lightDirection(state) {
  const doc = state.document || {};
  if (!("lights" in doc)) return DEFAULT_LIGHT_DIRECTION;
  const light = (doc.lights || [])[0];
  if (!light || (light.type && light.type !== "directional")) return null;
  return light.direction || DEFAULT_LIGHT_DIRECTION;
}

/** Where the plane (point p, normal n) cuts the box: its corners in order around the plane. */
function planeInBox(p, n, box) {
  const corner = (k) => [(k & 1) ? box.hi[0] : box.lo[0], (k & 2) ? box.hi[1] : box.lo[1], (k & 4) ? box.hi[2] : box.lo[2]];
  const points = [];
  for (let a = 0; a < 8; ++a)
    for (const bit of [1, 2, 4]) {
      if (a & bit) continue;
      const b = a | bit, pa = corner(a), pb = corner(b);
      const da = V.dot(V.sub(pa, p), n), db = V.dot(V.sub(pb, p), n);
      if ((da < 0) === (db < 0) || da === db) continue;
      points.push(V.add(pa, V.scale(V.sub(pb, pa), da / (da - db))));
    }
  if (points.length < 3) return [];
  const mid = V.scale(points.reduce((s, q) => V.add(s, q), [0, 0, 0]), 1 / points.length);
  const u = V.norm(V.sub(points[0], mid)), w = V.cross(n, u);
  return points.sort((x, y) => Math.atan2(V.dot(V.sub(x, mid), w), V.dot(V.sub(x, mid), u)) -
                               Math.atan2(V.dot(V.sub(y, mid), w), V.dot(V.sub(y, mid), u)));
}

export function drawHandles(state) {
  lastState = state;
  handles.length = 0;
  const { g, width, height } = sizedContext(canvas);
  if (!shown || !state || !state.camera) return;
  const project = projector(state.camera, width, height);
  const c = centre(state), radius = state.radius || 1;
  const direction = lightDirection(state);
  if (direction) {
    const sun = V.add(c, V.scale(V.norm(direction), -SUN_DISTANCE * radius));
    const [a, b] = [project(c), project(sun)];
    if (a && b && inside(b, width, height)) {
      line(g, a, b, "rgba(255, 226, 120, 0.7)", [4, 4]);
      knob(g, b, 7, "rgba(255, 214, 80, 0.95)", true);
      handles.push({ kind: "light", index: 0, at: b });
    }
  }
  const planes = (state.document || {}).clip_planes || [];
  planes.forEach((plane, i) => {
    const n = V.norm(plane.normal || [0, 0, 1]);
    const p = plane.point || c;
    const q = V.sub(c, V.scale(n, V.dot(V.sub(c, p), n)));   // the data's centre on the plane
    const tip = V.add(q, V.scale(n, ARROW_LENGTH * radius));
    if (state.bounds) {
      const outline = planeInBox(p, n, state.bounds).map(project);
      if (outline.length >= 3 && outline.every(Boolean)) {
        g.beginPath();
        outline.forEach((s, k) => (k ? g.lineTo(s[0], s[1]) : g.moveTo(s[0], s[1])));
        g.closePath();
        g.fillStyle = "rgba(120, 200, 255, 0.10)";
        g.fill();
        g.strokeStyle = "rgba(120, 200, 255, 0.8)";
        g.lineWidth = 1.25;
        g.stroke();
      }
    }
    const [a, b] = [project(q), project(tip)];
    if (!a || !b || !inside(a, width, height)) return;
    line(g, a, b, "rgba(120, 200, 255, 0.95)", []);
    knob(g, a, 6, "rgba(120, 200, 255, 0.95)", true);
    knob(g, b, 6, "rgba(120, 200, 255, 0.95)", false);
    handles.push({ kind: "move", index: i, at: a, tip: b, length: ARROW_LENGTH * radius });
    handles.push({ kind: "turn", index: i, at: b });
  });
}

const inside = (at, width, height) => at[0] >= 0 && at[1] >= 0 && at[0] <= width && at[1] <= height;

function line(g, a, b, style, dash) {
  g.save();
  g.setLineDash(dash);
  g.strokeStyle = style;
  g.lineWidth = 1.5;
  g.beginPath();
  g.moveTo(a[0], a[1]);
  g.lineTo(b[0], b[1]);
  g.stroke();
  g.restore();
}

function knob(g, at, r, style, filled) {
  g.beginPath();
  g.arc(at[0], at[1], r, 0, 2 * Math.PI);
  g.lineWidth = 2;
  g.strokeStyle = style;
  g.fillStyle = style;
  if (filled) g.fill();
  g.stroke();
}

/** The handle under (x, y), CSS pixels of the view (a turn tip before the knob it sits near). */
export function handleAt(x, y) {
  let best = null, bestDistance = GRAB_PX;
  for (const h of handles) {
    const d = Math.hypot(h.at[0] - x, h.at[1] - y);
    if (d <= bestDistance) { best = h; bestDistance = d; }
  }
  return best;
}

/**
 * A drag of a clip plane's `handle` by (dx, dy) pixels, with the camera `camera`: a knob moves its plane
 * along the normal by the drag's share along the arrow on the screen; a tip turns the normal so that
 * the arrow's tip follows the pointer. The plane dragged is kept with the handle (states arrive later than the drag moves).
 */
export function dragHandle(handle, dx, dy, camera) {
  if (!handle.plane) handle.plane = clone(((viewer.state.document || {}).clip_planes || [])[handle.index]);
  const plane = handle.plane;
  if (!plane) return;
  const n = V.norm(plane.normal || [0, 0, 1]);
  const b = cameraBasis(camera);
  const viewHeight = Math.max(1, canvas.getBoundingClientRect().height);
  if (handle.kind === "move") {
    const s = [handle.tip[0] - handle.at[0], handle.tip[1] - handle.at[1]];
    const s2 = s[0] * s[0] + s[1] * s[1];
    // the arrow seen end-on: move by the vertical drag, a view height for the data's diameter
    const along = s2 > 16 ? ((dx * s[0] + dy * s[1]) / s2) * handle.length : (-dy / viewHeight) * 2 * (viewer.state.radius || 1);
    plane.point = V.add(plane.point || centre(viewer.state), V.scale(n, along));
    queueEdit({ ["clip_planes." + handle.index + ".point"]: plane.point.map(round6) });
  } else {
    // the arrow's tip follows the pointer, at its depth: the normal points from the knob to it
    const c = centre(viewer.state), radius = viewer.state.radius || 1;
    const q = V.sub(c, V.scale(n, V.dot(V.sub(c, plane.point || c), n)));
    const tip = V.add(q, V.scale(n, ARROW_LENGTH * radius));
    const depth = Math.max(1e-6, V.dot(V.sub(tip, camera.eye), b.forward));
    const perPixel = (2 * depth * Math.tan(((camera.fov_deg || 35) * Math.PI) / 360)) / viewHeight;
    const moved = V.add(tip, V.add(V.scale(b.right, dx * perPixel), V.scale(b.screenUp, -dy * perPixel)));
    plane.normal = V.norm(V.sub(moved, q));
    queueEdit({ ["clip_planes." + handle.index + ".normal"]: plane.normal.map(round6) });
  }
}
