// The colour legend over the view, rebuilt when a state arrives. A block per coloured thing shown:
// the first visible volume's transfer function as a colour bar (brighter where more opaque) over its
// data range, with round values and the unit (HU for a CT, from the state's histogram); and per
// visible particle set its colour key (the state's particles[i].color_key): a swatch per colour with
// the elements, chains or residues it stands for and how many spheres have it, or for a scalar
// colouring the colour map as a bar over the quantity's range. Sets coloured by a hashed hue have none.

import { $, el, niceTicks, formatValue, findHistogram, linearRgbToCss, objectName } from "./util.js";
import { tfColorAt } from "./transfer_function.js";

const BAR_W = 200, BAR_H = 12;   // CSS pixels
const MAX_SWATCHES = 12;         // per particle set; the rest are counted in one line
const legend = $("legend");

export function updateLegend(state) {
  const blocks = [volumeBlock(state), ...particleBlocks(state)].filter(Boolean);
  legend.hidden = blocks.length === 0;
  legend.replaceChildren(...blocks);
}

/** A canvas of BAR_W × BAR_H CSS pixels painted by `paint(g)` at the screen's resolution. */
function barCanvas(paint) {
  const dpr = window.devicePixelRatio || 1;
  const bar = el("canvas", { width: BAR_W * dpr, height: BAR_H * dpr });
  bar.style.width = BAR_W + "px";
  bar.style.height = BAR_H + "px";
  const g = bar.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  paint(g);
  return bar;
}

function tickRow(lo, hi) {
  const ticks = el("div", { class: "ticks" });
  ticks.style.width = BAR_W + "px";
  for (const v of niceTicks(lo, hi, 4)) {
    const label = el("span", {}, formatValue(v));
    label.style.left = (hi > lo ? (v - lo) / (hi - lo) : 0.5) * BAR_W + "px";
    ticks.append(label);
  }
  return ticks;
}

function volumeBlock(state) {
  const tf = (state.transfer_functions || [])[0];
  const hist = tf && findHistogram(state, tf.volume);
  if (!tf || !hist || !(hist.hi > hist.lo)) return null;
  const vol = ((state.document || {}).volumes || [])[tf.volume];
  const unit = hist.unit || "";
  const bar = barCanvas((g) => {
    for (let x = 0; x < BAR_W; ++x) {
      const rgba = tfColorAt(tf.points, hist.lo + ((x + 0.5) / BAR_W) * (hist.hi - hist.lo));
      g.globalAlpha = Math.max(0.12, Math.sqrt(Math.min(1, Math.max(0, rgba[3]))));
      g.fillStyle = linearRgbToCss(rgba.slice(0, 3));
      g.fillRect(x, 0, 1, BAR_H);
    }
  });
  return el("div", { class: "block volume-key" },
    el("div", { class: "title" }, objectName("volumes", tf.volume, vol) + " · " + (unit ? unit : "data value") +
       " " + formatValue(hist.lo) + " … " + formatValue(hist.hi)),
    bar, tickRow(hist.lo, hist.hi));
}

const QUANTITY = { b_factor: "B-factor (Å²)", occupancy: "occupancy", index: "atom index" };

function particleBlocks(state) {
  const docs = (state.document || {}).particles || [];
  return (state.particles || []).map((p, i) => {
    const key = p.color_key;
    if (!p.visible || !key) return null;
    const title = objectName("particles", i, docs[i]) + " · by " + key.by;
    if (key.ramp && key.ramp.length > 1) {
      const bar = barCanvas((g) => {
        for (let x = 0; x < BAR_W; ++x) {
          const t = (x + 0.5) / BAR_W * (key.ramp.length - 1), k = Math.min(key.ramp.length - 2, Math.floor(t)), f = t - k;
          g.fillStyle = linearRgbToCss(key.ramp[k].map((c, j) => c + (key.ramp[k + 1][j] - c) * f));
          g.fillRect(x, 0, 1, BAR_H);
        }
      });
      return el("div", { class: "block particle-key", "data-particles": String(i) },
        el("div", { class: "title" }, objectName("particles", i, docs[i]) + " · " + (QUANTITY[key.quantity] || key.quantity) +
           " " + formatValue(key.lo) + " … " + formatValue(key.hi)),
        bar, tickRow(key.lo, key.hi));
    }
    const entries = key.entries || [];
    if (entries.length === 0) return null;
    const shown = entries.slice(0, MAX_SWATCHES);
    const rows = shown.map((e) => el("div", { class: "entry", title: e.count + " spheres" },
      swatch(e.color), el("span", { class: "label" }, e.label), el("span", { class: "count" }, " " + e.count)));
    if (entries.length > shown.length) {
      const rest = entries.slice(shown.length).reduce((n, e) => n + e.count, 0);
      rows.push(el("div", { class: "entry more" }, "+" + (entries.length - shown.length) + " more colours (" + rest + " spheres)"));
    }
    return el("div", { class: "block particle-key", "data-particles": String(i) },
      el("div", { class: "title" }, title), el("div", { class: "swatches" }, ...rows));
  });
}

function swatch(rgb) {
  const s = el("span", { class: "swatch" });
  s.style.background = linearRgbToCss(rgb);
  return s;
}
