// The colour legend over the view: the first visible volume's transfer function as a colour bar
// (brighter where more opaque) over its data range, with round values and the unit (HU for a CT,
// from the state's histogram). Rebuilt when a state arrives.

import { $, el, niceTicks, formatValue, findHistogram, linearRgbToCss, objectName } from "./util.js";
import { tfColorAt } from "./transfer_function.js";

const BAR_W = 200, BAR_H = 12;   // CSS pixels
const legend = $("legend");

export function updateLegend(state) {
  const tf = (state.transfer_functions || [])[0];
  const hist = tf && findHistogram(state, tf.volume);
  legend.hidden = !tf || !hist || !(hist.hi > hist.lo);
  if (legend.hidden) return;
  const vol = ((state.document || {}).volumes || [])[tf.volume];
  const unit = hist.unit || "";
  const dpr = window.devicePixelRatio || 1;
  const bar = el("canvas", { width: BAR_W * dpr, height: BAR_H * dpr });
  bar.style.width = BAR_W + "px";
  bar.style.height = BAR_H + "px";
  const g = bar.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  for (let x = 0; x < BAR_W; ++x) {
    const rgba = tfColorAt(tf.points, hist.lo + ((x + 0.5) / BAR_W) * (hist.hi - hist.lo));
    g.globalAlpha = Math.max(0.12, Math.sqrt(Math.min(1, Math.max(0, rgba[3]))));
    g.fillStyle = linearRgbToCss(rgba.slice(0, 3));
    g.fillRect(x, 0, 1, BAR_H);
  }
  const ticks = el("div", { class: "ticks" });
  ticks.style.width = BAR_W + "px";
  for (const v of niceTicks(hist.lo, hist.hi, 4)) {
    const label = el("span", {}, formatValue(v));
    label.style.left = ((v - hist.lo) / (hist.hi - hist.lo)) * BAR_W + "px";
    ticks.append(label);
  }
  legend.replaceChildren(
    el("div", { class: "title" }, objectName("volumes", tf.volume, vol) + " · " + (unit ? unit : "data value") +
       " " + formatValue(hist.lo) + " … " + formatValue(hist.hi)),
    bar, ticks);
}
