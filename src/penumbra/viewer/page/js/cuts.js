// The "Cuts" section of the side panel: clip planes (docs/scene-file.md "clip_planes") and slices
// ("slices[]"). Buttons add a plane or a slice across the x, y or z axis through the data's centre; each
// one then has a slider that moves it along its normal over the data's box (edits of
// clip_planes.N.point / slices.N.point, which rebuild only what they cut), a button that turns a clip
// plane round (its normal negated) and one that removes it; a slice also has an opacity slider.

import { $, el, clone, round6, V } from "./util.js";
import { viewer, queueEdit } from "./connection.js";

const AXES = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] };
const MAX_CLIP_PLANES = 6;

let signature = null;
let controls = [];

/** Rebuilds the rows when the number of planes or slices changes; syncs their values otherwise. */
export function updateCuts(state) {
  const doc = state.document || {};
  const clips = doc.clip_planes || [], slices = doc.slices || [];
  const next = JSON.stringify([clips.length, slices.length, clips.map((c) => c.normal), slices.map((s) => s.normal), state.bounds]);
  if (next !== signature) {
    signature = next;
    build(state);
  }
  for (const c of controls) c.sync(state);
}

function centre(state) {
  const b = state.bounds;
  return b ? V.scale(V.add(b.lo, b.hi), 0.5) : [0, 0, 0];
}

/** The range of x·n over the data's box (its eight corners). */
function extentAlong(state, n) {
  const b = state.bounds;
  if (!b) return [-1, 1];
  let lo = Infinity, hi = -Infinity;
  for (let k = 0; k < 8; ++k) {
    const p = [(k & 1) ? b.hi[0] : b.lo[0], (k & 2) ? b.hi[1] : b.lo[1], (k & 4) ? b.hi[2] : b.lo[2]];
    const d = V.dot(p, n);
    lo = Math.min(lo, d);
    hi = Math.max(hi, d);
  }
  return [lo, hi];
}

function build(state) {
  controls = [];
  const doc = state.document || {};
  const list = $("cut-list");
  list.replaceChildren();
  const hasVolume = (doc.volumes || []).length > 0;
  const addRow = el("div", { class: "row" }, el("label", { class: "key" }, "add"));
  for (const axis of Object.keys(AXES)) {
    const clip = el("button", { class: "btn", type: "button", title: "a clip plane across " + axis + " through the centre: removes the side its normal points to" }, "cut " + axis);
    clip.addEventListener("click", () => {
      const planes = clone(doc.clip_planes || []);
      planes.push({ point: centre(state).map(round6), normal: AXES[axis] });
      queueEdit({ clip_planes: planes });
    });
    clip.disabled = (doc.clip_planes || []).length >= MAX_CLIP_PLANES;
    addRow.append(clip);
    if (hasVolume) {
      const slice = el("button", { class: "btn", type: "button", title: "a slice of volume 0 across " + axis + ", coloured by its values (grey over the data range)" }, "slice " + axis);
      slice.addEventListener("click", () => {
        const slices = clone(doc.slices || []);
        slices.push({ volume: 0, point: centre(state).map(round6), normal: AXES[axis] });
        queueEdit({ slices });
      });
      addRow.append(slice);
    }
  }
  list.append(addRow);
  (doc.clip_planes || []).forEach((c, i) => list.append(track(state, "clip_planes", i, c, "clip plane " + i).root));
  (doc.slices || []).forEach((s, i) => list.append(track(state, "slices", i, s, "slice " + i + " · volume " + (s.volume || 0)).root));
}

/** One plane's row: a slider along its normal, flip (clip planes), remove. */
function track(state, kind, i, item, name) {
  const n = V.norm(item.normal || [0, 0, 1]);
  const [lo, hi] = extentAlong(state, n);
  const path = kind + "." + i + ".point";
  const slider = el("input", { type: "range", min: lo, max: hi, step: (hi - lo) / 500 || 1e-3, title: name + ": position along its normal" });
  const readout = el("span", { class: "readout" });
  slider.addEventListener("input", () => {
    const current = ((viewer.state.document || {})[kind] || [])[i] || item;
    const p = current.point || centre(viewer.state);
    const moved = V.add(p, V.scale(n, Number(slider.value) - V.dot(p, n)));  // along the normal only
    readout.textContent = round6(slider.value);
    queueEdit({ [path]: moved.map(round6) });
  });
  const remove = el("button", { class: "btn", type: "button", title: "remove " + name }, "×");
  remove.addEventListener("click", () => {
    const items = clone((viewer.state.document || {})[kind] || []);
    items.splice(i, 1);
    queueEdit({ [kind]: items });
  });
  const buttons = [remove];
  if (kind === "clip_planes") {
    const flip = el("button", { class: "btn", type: "button", title: "keep the other side" }, "flip");
    flip.addEventListener("click", () => queueEdit({ [kind + "." + i + ".normal"]: V.scale(n, -1).map(round6) }));
    buttons.unshift(flip);
  }
  // a slice's opacity: below 1 it is drawn over what lies behind it (and casts no shadow)
  const opacity = kind === "slices" ? el("input", { type: "range", class: "opacity", min: 0, max: 1, step: 0.01, title: name + ": opacity" }) : null;
  if (opacity) opacity.addEventListener("input", () => queueEdit({ [kind + "." + i + ".opacity"]: Number(opacity.value) }));
  const root = el("div", {}, el("div", { class: "sub" }, name),
                  el("div", { class: "row" }, slider, readout, ...buttons),
                  opacity && el("div", { class: "row" }, el("label", { class: "key" }, "opacity"), opacity));
  root.dataset.cut = kind + "." + i;
  return {
    root,
    sync(s) {
      const current = ((s.document || {})[kind] || [])[i];
      if (current && opacity && document.activeElement !== opacity) opacity.value = current.opacity === undefined ? 1 : current.opacity;
      if (!current || document.activeElement === slider) return;
      const d = V.dot(current.point || centre(s), n);
      slider.value = d;
      readout.textContent = round6(d);
    },
  };
}
