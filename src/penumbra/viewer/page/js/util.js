// Small helpers of every module: numbers, vectors, colours, DOM, the document's objects.

export const $ = (id) => document.getElementById(id);

export const clamp = (x, lo, hi) => Math.min(hi, Math.max(lo, x));
export const round6 = (x) => Number(Number(x).toPrecision(6));
export const clone = (x) => (x === undefined ? undefined : JSON.parse(JSON.stringify(x)));

export const V = {
  add: (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]],
  sub: (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]],
  scale: (a, s) => [a[0] * s, a[1] * s, a[2] * s],
  dot: (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
  cross: (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
  len: (a) => Math.hypot(a[0], a[1], a[2]),
  norm: (a) => { const l = V.len(a); return l > 1e-12 ? V.scale(a, 1 / l) : a.slice(); },
  angle: (a, b) => Math.acos(clamp(V.dot(V.norm(a), V.norm(b)), -1, 1)),
  /** Rodrigues: v turned by `angle` radians about `axis` (right-handed). */
  rotate(v, axis, angle) {
    const k = V.norm(axis), c = Math.cos(angle), s = Math.sin(angle);
    const kxv = V.cross(k, v), kv = V.dot(k, v);
    return [0, 1, 2].map((i) => v[i] * c + kxv[i] * s + k[i] * kv * (1 - c));
  },
  perpendicular(a) {
    const other = Math.abs(a[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    return V.norm(V.cross(a, other));
  },
};

export function linearToSrgb(l) {
  l = clamp(l, 0, 1);
  return l <= 0.0031308 ? 12.92 * l : 1.055 * Math.pow(l, 1 / 2.4) - 0.055;
}
export function srgbToLinear(s) {
  s = clamp(s, 0, 1);
  return s <= 0.04045 ? s / 12.92 : Math.pow((s + 0.055) / 1.055, 2.4);
}
export function linearRgbToHex(rgb) {
  return "#" + rgb.map((l) => Math.round(linearToSrgb(l) * 255).toString(16).padStart(2, "0")).join("");
}
export function hexToLinearRgb(hex) {
  const n = parseInt(hex.slice(1), 16);
  return [(n >> 16) & 255, (n >> 8) & 255, n & 255].map((c) => srgbToLinear(c / 255));
}
export function linearRgbToCss(rgb) {
  return "rgb(" + rgb.map((l) => Math.round(linearToSrgb(l) * 255)).join(",") + ")";
}

/** el("div", {class: "row"}, child, "text", ...): a DOM element. */
export function el(tag, attrs, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "class") node.className = v;
    else if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
    else if (k in node && typeof v !== "string") node[k] = v;
    else node.setAttribute(k, v);
  }
  for (const c of children) if (c != null) node.append(c);
  return node;
}

/** setPointerCapture, which throws for a pointer that is not active (synthetic events in tests). */
export function capturePointer(element, pointerId) {
  try { element.setPointerCapture(pointerId); } catch (e) { /* the drag still works inside the element */ }
}

export const basename = (path) => String(path).split(/[\\/]/).pop();
export const getPath = (obj, path) => path.split(".").reduce((o, k) => (o == null ? undefined : o[k]), obj);
export const findHistogram = (state, volume) => (state.histograms || []).find((h) => h.volume === volume);

export const KIND_LABEL = { volumes: "volume", particles: "particles", isosurfaces: "isosurface", planes: "plane" };

export function objectName(kind, i, obj) {
  let name = KIND_LABEL[kind] + " " + i;
  if (obj && obj.file) name += " · " + basename(obj.file);
  else if (obj && obj.procedural && obj.procedural.name) name += " · " + obj.procedural.name;
  return name;
}

/** About `count` round values (1, 2 or 5 × 10^k apart) inside [lo, hi], for axis labels. */
export function niceTicks(lo, hi, count) {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / Math.max(1, count);
  const power = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw);
  const ticks = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(round6(v));
  return ticks;
}

/** A value for a label: at most 4 significant digits, exponent form for very large or small ones. */
export function formatValue(v) {
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(1);
  return String(Number(v.toPrecision(4)));
}

/** The camera's frame: forward, right, the world up it keeps, the screen up, and the distance. */
export function cameraBasis(cam) {
  const toTarget = V.sub(cam.target, cam.eye);
  const forward = V.norm(toTarget);
  const up = V.norm(cam.up || [0, 1, 0]);
  let right = V.cross(forward, up);
  right = V.len(right) < 1e-6 ? V.perpendicular(up) : V.norm(right);
  return { forward, up, right, screenUp: V.cross(right, forward), distance: V.len(toTarget) };
}

/** A canvas's 2D context drawn in CSS pixels, its backing store sized to the element and the screen. */
export function sizedContext(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const r = canvas.getBoundingClientRect();
  const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  const g = canvas.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, r.width, r.height);
  return { g, width: r.width, height: r.height };
}
