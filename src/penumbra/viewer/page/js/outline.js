// The data's bounding box (the state's "bounds") and the periodic cell of every visible particle set
// whose file stores one (the state's particles[i].box, VMD's `pbc box`) drawn over the image on a 2D
// canvas, projected with the state's camera as the renderer projects (vertical fov_deg, the image
// stretched over the view). Drawn when a state arrives or the view changes size, never per frame; the
// toolbar's Box shows them.

import { $, V, cameraBasis, sizedContext } from "./util.js";

const canvas = $("outline");
const NEAR = 1e-4;   // a corner this close to the eye's plane (in units of the distance) is not drawn

let shown = false;
let lastState = null;

export const isOutlineShown = () => shown;

export function toggleOutline() {
  shown = !shown;
  $("outline-toggle").setAttribute("aria-pressed", String(shown));
  drawOutline(lastState);
}

/** Maps a world point to view CSS pixels, or null behind the eye. */
export function projector(cam, width, height) {
  const b = cameraBasis(cam);
  const tanHalf = Math.tan(((cam.fov_deg || 35) * Math.PI) / 360);
  const aspect = cam.width && cam.height ? cam.width / cam.height : width / height;
  return (p) => {
    const d = V.sub(p, cam.eye);
    const z = V.dot(d, b.forward);
    if (z <= NEAR * b.distance) return null;
    const x = V.dot(d, b.right) / (z * tanHalf * aspect), y = V.dot(d, b.screenUp) / (z * tanHalf);
    return [(x + 1) * 0.5 * width, (1 - y) * 0.5 * height];
  };
}

const EDGES = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

/** The 12 edges of the parallelepiped with corner k at corner(k) (k's bits: along a, b, c). */
function strokeBox(g, project, corner, style) {
  const corners = [0, 1, 2, 3, 4, 5, 6, 7].map((k) => project(corner(k)));
  g.strokeStyle = style;
  g.lineWidth = 1.25;
  g.beginPath();
  for (const [a, b] of EDGES) {
    if (!corners[a] || !corners[b]) continue;
    g.moveTo(corners[a][0], corners[a][1]);
    g.lineTo(corners[b][0], corners[b][1]);
  }
  g.stroke();
}

export function drawOutline(state) {
  lastState = state;
  const { g, width, height } = sizedContext(canvas);
  if (!shown || !state || !state.camera) return;
  const project = projector(state.camera, width, height);
  if (state.bounds) {
    const { lo, hi } = state.bounds;
    strokeBox(g, project, (k) => [(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]], "rgba(255, 214, 102, 0.85)");
  }
  for (const p of state.particles || []) {
    if (!p.visible || !p.box) continue;
    const { origin, a, b, c } = p.box;
    strokeBox(g, project, (k) => V.add(V.add(V.add(origin, V.scale(a, k & 1)), V.scale(b, (k >> 1) & 1)), V.scale(c, (k >> 2) & 1)),
              "rgba(110, 205, 255, 0.85)");
  }
}
