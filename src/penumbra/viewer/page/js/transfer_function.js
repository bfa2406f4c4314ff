// The transfer-function editor of a volume: its points over the volume's histogram (opacity on a √
// scale), with the colour strip and the value axis (round values, the unit where the state gives one)
// below, the selected point's colour, opacity and value, and the engine's presets. Click adds a point,
// drag moves one, right-click deletes one; every change is sent as the volume's points, a preset by name.

import { clamp, round6, el, capturePointer, findHistogram, objectName, linearRgbToHex, hexToLinearRgb,
         linearRgbToCss, niceTicks, formatValue } from "./util.js";
import { queueEdit } from "./connection.js";

const TF_W = 270, TF_H = 140, TF_PAD = 6, STRIP_H = 10, AXIS_H = 18, HIT_RADIUS = 7;   // CSS pixels

/** The TF's RGBA at `value`: piecewise linear between points, constant beyond the ends. */
export function tfColorAt(points, value) {
  if (!points.length) return [0, 0, 0, 0];
  if (value <= points[0][0]) return points[0].slice(1);
  const last = points[points.length - 1];
  if (value >= last[0]) return last.slice(1);
  let i = 1;
  while (points[i][0] < value) ++i;
  const a = points[i - 1], b = points[i];
  const t = b[0] > a[0] ? (value - a[0]) / (b[0] - a[0]) : 0;
  return [1, 2, 3, 4].map((c) => a[c] + (b[c] - a[c]) * t);
}

export function createTfEditor(volume, doc, presets) {
  const vol = (doc.volumes || [])[volume];
  const dpr = window.devicePixelRatio || 1;
  const plot = el("canvas", { class: "plot", width: TF_W * dpr, height: TF_H * dpr });
  const strip = el("canvas", { class: "strip", width: TF_W * dpr, height: STRIP_H * dpr });
  const axis = el("canvas", { class: "axis", width: TF_W * dpr, height: AXIS_H * dpr });
  plot.style.width = strip.style.width = axis.style.width = TF_W + "px";
  plot.style.height = TF_H + "px";
  strip.style.height = STRIP_H + "px";
  axis.style.height = AXIS_H + "px";
  const preset = el("select", { class: "preset", title: "replace the points by one of the engine's presets" },
    el("option", { value: "" }, "preset…"), ...presets.map((name) => el("option", { value: name }, name)));
  preset.addEventListener("change", () => {
    if (preset.value) queueEdit({ ["volumes." + volume + ".transfer_function"]: preset.value });
    preset.value = "";
  });

  const color = el("input", { type: "color", title: "colour of the selected point (sRGB; sent as linear RGB)" });
  const alphaRange = el("input", { type: "range", min: 0, max: 1, step: 0.001 });
  const alphaNumber = el("input", { type: "number", min: 0, max: 1, step: 0.01, title: "opacity of one voxel" });
  const valueNumber = el("input", { type: "number", step: "any", title: "data value of the selected point" });
  const selectedBox = el("div", {},
    el("div", { class: "row" }, el("label", { class: "key" }, "colour"), color),
    el("div", { class: "row" }, el("label", { class: "key" }, "opacity"), alphaRange, alphaNumber),
    el("div", { class: "row" }, el("label", { class: "key" }, "value"), valueNumber));

  const editor = {
    root: el("div", { class: "tf" },
      el("div", { class: "row" }, el("div", { class: "sub" }, objectName("volumes", volume, vol)), preset),
      plot, strip, axis,
      el("div", { class: "caption" }, "opacity on a √ scale · click: add · drag: move · right-click: delete"),
      selectedBox),
    volumeIndex: volume, points: [], hist: null, lo: 0, hi: 1, selected: -1, dragging: -1,
    sync: (state) => syncTf(editor, state),
  };

  const xOf = (v) => TF_PAD + ((v - editor.lo) / (editor.hi - editor.lo)) * (TF_W - 2 * TF_PAD);
  const yOf = (a) => TF_H - TF_PAD - Math.sqrt(clamp(a, 0, 1)) * (TF_H - 2 * TF_PAD);
  const valueAt = (x) => editor.lo + ((x - TF_PAD) / (TF_W - 2 * TF_PAD)) * (editor.hi - editor.lo);
  const alphaAt = (y) => Math.pow(clamp((TF_H - TF_PAD - y) / (TF_H - 2 * TF_PAD), 0, 1), 2);
  const px = (v) => clamp(xOf(v), TF_PAD, TF_W - TF_PAD);   // points outside the histogram sit at its edge

  function draw() {
    drawTfPlot(plot, editor, px, yOf);
    drawTfStrip(strip, editor, valueAt);
    drawTfAxis(axis, editor, xOf);
  }

  function commit() {
    const points = editor.points.map((p) => p.map(round6));
    queueEdit({ ["volumes." + volume + ".transfer_function"]: { points } });
  }

  function hitPoint(x, y) {
    let best = -1, bestDistance = HIT_RADIUS;
    editor.points.forEach((p, i) => {
      const d = Math.hypot(px(p[0]) - x, yOf(p[4]) - y);
      if (d <= bestDistance) { best = i; bestDistance = d; }
    });
    return best;
  }

  /** Moves point i to (value, alpha), its value kept between its neighbours'. */
  function movePoint(i, value, alpha) {
    const pts = editor.points;
    const lower = i > 0 ? pts[i - 1][0] : Math.min(editor.lo, pts[i][0]);
    const upper = i < pts.length - 1 ? pts[i + 1][0] : Math.max(editor.hi, pts[i][0]);
    pts[i][0] = clamp(value, lower, Math.max(lower, upper));
    pts[i][4] = clamp(alpha, 0, 1);
  }

  function addPoint(value, alpha) {
    const pts = editor.points;
    let i = 0;
    while (i < pts.length && pts[i][0] <= value) ++i;
    const rgb = tfColorAt(pts, value).slice(0, 3);
    pts.splice(i, 0, [value, ...rgb, clamp(alpha, 0, 1)]);
    return i;
  }

  function localXY(e) {
    const r = plot.getBoundingClientRect();
    return [((e.clientX - r.left) * TF_W) / r.width, ((e.clientY - r.top) * TF_H) / r.height];
  }

  plot.addEventListener("contextmenu", (e) => e.preventDefault());
  plot.addEventListener("pointerdown", (e) => {
    const [x, y] = localXY(e);
    let hit = hitPoint(x, y);
    if (e.button === 2) {
      if (hit >= 0 && editor.points.length > 2) {
        editor.points.splice(hit, 1);
        if (editor.selected >= editor.points.length || editor.selected === hit) editor.selected = -1;
        else if (editor.selected > hit) editor.selected -= 1;
        commit();
      }
    } else if (e.button === 0) {
      if (hit < 0) { hit = addPoint(valueAt(x), alphaAt(y)); commit(); }
      editor.selected = hit;
      editor.dragging = hit;
      capturePointer(plot, e.pointerId);
    }
    draw();
    showSelected();
  });
  plot.addEventListener("pointermove", (e) => {
    if (editor.dragging < 0) return;
    const [x, y] = localXY(e);
    movePoint(editor.dragging, valueAt(x), alphaAt(y));
    commit();
    draw();
    showSelected();
  });
  const endDrag = () => { editor.dragging = -1; };
  plot.addEventListener("pointerup", endDrag);
  plot.addEventListener("pointercancel", endDrag);

  function showSelected() {
    const p = editor.points[editor.selected];
    selectedBox.hidden = !p;
    if (!p) return;
    if (document.activeElement !== color) color.value = linearRgbToHex(p.slice(1, 4));
    if (document.activeElement !== alphaNumber) alphaNumber.value = round6(p[4]);
    alphaRange.value = p[4];
    if (document.activeElement !== valueNumber) valueNumber.value = round6(p[0]);
  }

  function editSelected(change) {
    const p = editor.points[editor.selected];
    if (!p) return;
    change(p);
    commit();
    draw();
    showSelected();
  }

  color.addEventListener("input", () => editSelected((p) => p.splice(1, 3, ...hexToLinearRgb(color.value))));
  alphaRange.addEventListener("input", () => editSelected((p) => { p[4] = clamp(Number(alphaRange.value), 0, 1); }));
  alphaNumber.addEventListener("input", () => {
    if (alphaNumber.value !== "") editSelected((p) => { p[4] = clamp(Number(alphaNumber.value), 0, 1); });
  });
  valueNumber.addEventListener("change", () => {
    if (valueNumber.value === "") return;
    editSelected((p) => movePoint(editor.selected, Number(valueNumber.value), p[4]));
  });

  editor.draw = draw;
  editor.showSelected = showSelected;
  return editor;
}

function syncTf(editor, state) {
  const tf = (state.transfer_functions || []).find((t) => t.volume === editor.volumeIndex);
  if (!tf) return;
  const editing = editor.dragging >= 0 || editor.root.contains(document.activeElement);
  if (!editing) editor.points = (tf.points || []).map((p) => p.slice());
  editor.hist = findHistogram(state, tf.volume) || null;
  editor.unit = (editor.hist && editor.hist.unit) || "";
  let lo, hi;
  if (editor.hist) { lo = editor.hist.lo; hi = editor.hist.hi; }
  else {
    const values = editor.points.map((p) => p[0]);
    lo = Math.min(...values, 0);
    hi = Math.max(...values, 1);
  }
  if (!(hi > lo)) hi = lo + 1;
  editor.lo = lo;
  editor.hi = hi;
  if (editor.selected >= editor.points.length) editor.selected = -1;
  editor.draw();
  editor.showSelected();
}

function drawTfPlot(canvas, editor, xOf, yOf) {
  const dpr = canvas.width / TF_W;
  const g = canvas.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.fillStyle = "#17171a";
  g.fillRect(0, 0, TF_W, TF_H);

  // Histogram: log-scaled bars over [lo, hi].
  const counts = (editor.hist && editor.hist.counts) || [];
  const max = Math.max(0, ...counts);
  if (counts.length && max > 0) {
    g.fillStyle = "rgba(150, 150, 156, 0.45)";
    const w = (TF_W - 2 * TF_PAD) / counts.length;
    counts.forEach((c, i) => {
      const h = (Math.log1p(c) / Math.log1p(max)) * (TF_H - 2 * TF_PAD);
      g.fillRect(TF_PAD + i * w, TF_H - TF_PAD - h, Math.max(1, w - 0.5), h);
    });
  }

  // Guide lines at opacity 0.1, 0.25, 0.5 and 1 (on the √ scale).
  g.strokeStyle = "rgba(255, 255, 255, 0.08)";
  g.lineWidth = 1;
  for (const a of [0.1, 0.25, 0.5, 1]) {
    const y = Math.round(yOf(a)) + 0.5;
    g.beginPath(); g.moveTo(TF_PAD, y); g.lineTo(TF_W - TF_PAD, y); g.stroke();
  }

  // The opacity polyline and the points in their colours.
  const pts = editor.points;
  if (!pts.length) return;
  g.strokeStyle = "#e8e8ec";
  g.lineWidth = 1.5;
  g.beginPath();
  pts.forEach((p, i) => (i ? g.lineTo(xOf(p[0]), yOf(p[4])) : g.moveTo(xOf(p[0]), yOf(p[4]))));
  g.stroke();
  pts.forEach((p, i) => {
    g.beginPath();
    g.arc(xOf(p[0]), yOf(p[4]), i === editor.selected ? 5.5 : 4.5, 0, 2 * Math.PI);
    g.fillStyle = linearRgbToCss(p.slice(1, 4));
    g.fill();
    g.lineWidth = i === editor.selected ? 2 : 1;
    g.strokeStyle = i === editor.selected ? "#7aa7f0" : "#000";
    g.stroke();
  });
}

/** Ticks at round values of the histogram's range, labelled, the unit after the last. */
function drawTfAxis(canvas, editor, xOf) {
  const dpr = canvas.width / TF_W;
  const g = canvas.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, TF_W, AXIS_H);
  g.strokeStyle = g.fillStyle = "#8b8b94";
  g.font = "10px ui-monospace, monospace";
  g.textBaseline = "top";
  const ticks = niceTicks(editor.lo, editor.hi, 5);
  ticks.forEach((v, i) => {
    const x = Math.round(xOf(v)) + 0.5;
    g.beginPath(); g.moveTo(x, 0); g.lineTo(x, 4); g.stroke();
    const label = formatValue(v) + (i === ticks.length - 1 && editor.unit ? " " + editor.unit : "");
    const w = g.measureText(label).width;
    g.fillText(label, clamp(x - w / 2, 0, TF_W - w), 5);
  });
}

function drawTfStrip(canvas, editor, valueAt) {
  const dpr = canvas.width / TF_W;
  const g = canvas.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, TF_W, STRIP_H);
  if (!editor.points.length) return;
  for (let x = 0; x < TF_W; ++x) {
    g.fillStyle = linearRgbToCss(tfColorAt(editor.points, valueAt(x + 0.5)).slice(0, 3));
    g.fillRect(x, 0, 1, STRIP_H);
  }
}
