// The orientation triad: the world's x (red), y (green) and z (blue) axes as the state's camera sees
// them, drawn in a corner canvas when a state arrives.

import { $, V, cameraBasis, sizedContext } from "./util.js";

const canvas = $("axes");
const AXES = [{ name: "x", dir: [1, 0, 0], color: "#ff6b6b" },
              { name: "y", dir: [0, 1, 0], color: "#6bdc6b" },
              { name: "z", dir: [0, 0, 1], color: "#6ba8ff" }];

/** Each axis's end on the screen, (dx, dy) from the centre in units of the arm, and its depth. */
export function axisEnds(cam) {
  const b = cameraBasis(cam);
  return AXES.map((a) => ({ ...a, dx: V.dot(a.dir, b.right), dy: -V.dot(a.dir, b.screenUp), depth: V.dot(a.dir, b.forward) }));
}

export function drawAxes(state) {
  const { g, width, height } = sizedContext(canvas);
  if (!state || !state.camera) return;
  const cx = width / 2, cy = height / 2, arm = Math.min(width, height) * 0.34;
  // the farthest first, so that the nearer arms cover them
  const ends = axisEnds(state.camera).sort((p, q) => q.depth - p.depth);
  g.lineWidth = 2;
  g.font = "bold 11px system-ui, sans-serif";
  g.textAlign = "center";
  g.textBaseline = "middle";
  for (const a of ends) {
    const x = cx + a.dx * arm, y = cy + a.dy * arm;
    g.globalAlpha = a.depth > 0 ? 0.55 : 1;   // pointing away from the viewer: dimmer
    g.strokeStyle = g.fillStyle = a.color;
    g.beginPath(); g.moveTo(cx, cy); g.lineTo(x, y); g.stroke();
    g.fillText(a.name, cx + a.dx * (arm + 10), cy + a.dy * (arm + 10));
  }
  g.globalAlpha = 1;
}
