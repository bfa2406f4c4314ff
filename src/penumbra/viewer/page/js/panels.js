// The side panel: rebuilt when the document's structure changes (which objects, which techniques),
// its values synced with every state otherwise. Transfer functions (transfer_function.js),
// isovalues, the shadow and ambient techniques with the keys each reads, each object's flags and, for
// particle sets, what colours them.

import { $, el, clone, round6, getPath, findHistogram, objectName } from "./util.js";
import { viewer, queueEdit } from "./connection.js";
import { createTfEditor } from "./transfer_function.js";

const OBJECT_KINDS = ["volumes", "particles", "isosurfaces", "planes"];
// particles[].color_by (docs/scene-file.md): a file's atoms, generated spheres
const COLOR_BY = { file: ["element", "chain", "residue", "scalar", "uniform"], procedural: ["hue", "uniform"] };

let panelBusy = false;        // a pointer is down in the panel (a slider or a TF point is dragged)
let deferredState = null;     // the latest state that arrived while the panel was busy
let panelSignature = null;
let panelControls = [];       // { sync(state) } of every control built

export function updatePanel(state) {
  if (panelBusy) { deferredState = state; return; }
  const signature = structureSignature(state);
  if (signature !== panelSignature) {
    panelSignature = signature;
    buildPanel(state);
  }
  syncPanel(state);
}

export function syncPanel(state) {
  for (const control of panelControls) control.sync(state);
}

/** What decides which controls exist (not their values). */
function structureSignature(state) {
  const doc = state.document || {};
  const objects = OBJECT_KINDS.map((kind) => (doc[kind] || []).map((o) => [
    o.file || "", (o.procedural && o.procedural.name) || "", o.visible !== false, o.volume || 0]));
  return JSON.stringify({
    objects,
    tfs: (state.transfer_functions || []).map((t) => t.volume),
    histograms: (state.histograms || []).map((h) => [h.volume, h.lo, h.hi]),
    techniques: state.techniques || null,
    keys: state.technique_keys || null,
    shadows: (doc.shadows && doc.shadows.technique) || "none",
    ambient: (doc.ambient && doc.ambient.technique) || "none",
  });
}

function buildPanel(state) {
  panelControls = [];
  selectionFields.length = 0;
  const doc = state.document || {};

  const tfList = $("tf-list");
  tfList.replaceChildren();
  for (const tf of state.transfer_functions || []) {
    const editor = createTfEditor(tf.volume, doc, state.transfer_function_presets || []);
    tfList.append(editor.root);
    panelControls.push(editor);
  }
  $("tf-section").hidden = !(state.transfer_functions || []).length;

  const isoList = $("iso-list");
  isoList.replaceChildren();
  (doc.isosurfaces || []).forEach((iso, n) => {
    const control = createIsoControl(n, iso, state);
    isoList.append(control.root);
    panelControls.push(control);
  });
  $("iso-section").hidden = !(doc.isosurfaces || []).length;

  for (const group of ["shadows", "ambient"]) {
    const control = createTechniqueControls(group, state);
    $(group).replaceChildren(control.root);
    panelControls.push(control);
  }

  const objects = $("objects");
  objects.replaceChildren();
  for (const kind of OBJECT_KINDS) {
    (doc[kind] || []).forEach((obj, i) => {
      const row = createObjectRow(kind, i, obj);
      objects.append(row.root);
      panelControls.push(row);
    });
  }
  if (!objects.children.length) objects.append(el("div", { class: "empty" }, "no objects"));
}

export const isPanelBusy = () => panelBusy;

/** Only what is dragged (a slider, a TF canvas) holds the panel still; selects and boxes do not. */
export function onPanelPointerDown(e) {
  if (e.target.matches("input[type=range], canvas")) panelBusy = true;
}

export function onWindowPointerUp() {
  if (!panelBusy) return;
  panelBusy = false;
  if (deferredState) {
    const state = deferredState;
    deferredState = null;
    updatePanel(state);
  }
}

// ---- isosurfaces ----------------------------------------------------------------------------

function createIsoControl(n, iso, state) {
  const volume = iso.volume || 0;
  const hist = findHistogram(state, volume);
  const path = "isosurfaces." + n + ".value";
  const readout = el("span", { class: "readout" });
  let input;
  if (hist && hist.hi > hist.lo) {
    const step = (hist.hi - hist.lo) / 1000;
    // The isovalue must lie in (min, max]: the slider starts one step above the minimum.
    input = el("input", { type: "range", min: hist.lo + step, max: hist.hi, step });
    input.addEventListener("input", () => {
      readout.textContent = round6(input.value);
      queueEdit({ [path]: round6(input.value) });
    });
  } else {
    input = el("input", { type: "number", step: "any" });
    input.addEventListener("change", () => { if (input.value !== "") queueEdit({ [path]: Number(input.value) }); });
  }
  const root = el("div", {},
    el("div", { class: "sub" }, "isosurface " + n + " · volume " + volume),
    el("div", { class: "row" }, el("label", { class: "key" }, "value"), input, input.type === "range" ? readout : null));
  return {
    root,
    sync(s) {
      const current = getPath(s.document || {}, path);
      if (typeof current !== "number" || document.activeElement === input && input.type === "number") return;
      input.value = current;
      readout.textContent = round6(current);
    },
  };
}

// ---- shadow and ambient techniques ----------------------------------------------------------

function createTechniqueControls(group, state) {
  const doc = state.document || {};
  const conf = doc[group] || {};
  const current = conf.technique || "none";
  const names = ((state.techniques && state.techniques[group]) || ["none"]).slice();
  if (!names.includes(current)) names.push(current);

  const select = el("select", {}, ...names.map((name) => el("option", { value: name }, name)));
  select.addEventListener("change", () => queueEdit({ [group + ".technique"]: select.value }));
  const root = el("div", {}, el("div", { class: "row" }, el("label", { class: "key" }, "technique"), select));

  // One field per key the technique declares (the server sends every declaration:
  // technique_parameters, from lighting/technique_info.h): a list for a choice, a number field with the
  // declared range otherwise; empty shows the declared default.
  const declared = (state.technique_parameters && state.technique_parameters[group]) || {};
  const keys = ((state.technique_keys && state.technique_keys[current]) || []).filter((k) => k !== "technique");
  const fields = keys.map((key) => {
    const path = group + "." + key;
    const spec = declared[key] || {};
    const title = path + (spec.meaning ? ": " + spec.meaning : "") + (spec.unit ? " (" + spec.unit + ")" : "") +
                  (spec.allowed ? "; allowed: " + spec.allowed : "");
    let input;
    if (spec.type === "choice") {
      input = el("select", {}, el("option", { value: "" }, "default (" + spec.default + ")"),
                 ...(spec.choices || []).map((c) => el("option", { value: c }, c)));
    } else {
      const attrs = { type: "number", step: spec.type === "integer" ? "1" : "any",
                      placeholder: spec.default === undefined ? "default" : String(spec.default) };
      input = el("input", attrs);
    }
    input.addEventListener("change", () => {
      const text = String(input.value).trim();
      if (text === "") return;   // an edit sets a value; it cannot remove a key
      queueEdit({ [path]: spec.type === "choice" ? text : Number(text) });
    });
    root.append(el("div", { class: "row" }, el("label", { class: "key", title }, key), input));
    return { path, input };
  });

  return {
    root,
    sync(s) {
      const d = s.document || {};
      if (document.activeElement !== select) select.value = getPath(d, group + ".technique") || "none";
      for (const { path, input } of fields) {
        if (document.activeElement === input) continue;
        const value = getPath(d, path);
        input.value = value === undefined || value === null ? "" : value;
      }
    },
  };
}

// ---- objects: visibility and shadow flags ---------------------------------------------------

function createObjectRow(kind, i, obj) {
  const prefix = kind + "." + i + ".";
  const checkbox = (label, onChange) => {
    const input = el("input", { type: "checkbox" });
    input.addEventListener("change", () => onChange(input.checked));
    return { input, label: el("label", {}, input, label) };
  };
  const visible = kind === "volumes" || kind === "particles" ? checkbox("visible", (on) => setVisible(kind, i, on)) : null;
  const casts = checkbox("casts", (on) => queueEdit({ [prefix + "casts_shadows"]: on }));
  const receives = checkbox("receives", (on) => queueEdit({ [prefix + "receives_shadows"]: on }));
  const selection = kind === "particles" && obj && obj.file ? createSelectionField(prefix, i) : null;
  const colorBy = kind === "particles" && obj && (obj.file || obj.procedural) ? createColorByField(prefix, i, obj) : null;
  const root = el("div", { class: "object" },
    el("div", { class: "name", title: (obj && obj.file) || "" }, objectName(kind, i, obj)),
    el("div", { class: "flags" }, visible && visible.label, casts.label, receives.label),
    colorBy && colorBy.root, selection && selection.root);
  return {
    root,
    sync(s) {
      if (selection) selection.sync(s);
      if (colorBy) colorBy.sync(s);
      const o = ((s.document || {})[kind] || [])[i] || {};
      const shown = o.visible !== false;
      if (visible) visible.input.checked = shown;
      casts.input.checked = o.casts_shadows !== false;
      receives.input.checked = o.receives_shadows !== false;
      // A hidden volume or particle set takes no shadow flags (the scene reader refuses them).
      const flagsOff = !!visible && !shown;
      for (const c of [casts, receives]) {
        c.input.disabled = flagsOff;
        c.label.classList.toggle("disabled", flagsOff);
      }
    },
  };
}

/**
 * particles.i.select: a text field (MDAnalysis's selection language, docs/selections.md) sent on Enter
 * or when it loses focus; beside it the atoms selected (the state's particles[i].selected) or, after a
 * refused edit, the error, inline.
 */
function createSelectionField(prefix, i) {
  const input = el("input", { type: "text", class: "selection", placeholder: "all", spellcheck: "false",
                              title: "atoms to draw, in MDAnalysis's selection language" });
  const readout = el("span", { class: "readout selection-count" });
  const error = el("div", { class: "selection-error", role: "alert" });
  error.hidden = true;
  let sent = null;
  const send = () => {
    const text = input.value.trim() || "all";
    if (text === sent) return;
    sent = text;
    queueEdit({ [prefix + "select"]: text });
  };
  input.addEventListener("keydown", (e) => { if (e.key === "Enter") send(); });
  input.addEventListener("change", send);
  selectionFields.push({ key: prefix + "select", showError(message) {
    error.textContent = message;
    error.hidden = false;
    sent = null;
  } });
  return {
    root: el("div", { class: "selection-row" }, el("label", {}, "select ", input), readout, error),
    sync(s) {
      const o = ((s.document || {}).particles || [])[i] || {};
      if (document.activeElement !== input && error.hidden) input.value = o.select || "";
      const info = (s.particles || [])[i] || {};
      readout.textContent = info.selected === null || info.selected === undefined
        ? (info.spheres || 0) + " atoms" : info.selected + " selected";
      if (o.select === sent) error.hidden = true;
    },
  };
}

/** particles.i.color_by: a list of the ways the set's spheres may be coloured. */
function createColorByField(prefix, i, obj) {
  const choices = COLOR_BY[obj.file ? "file" : "procedural"];
  const fallback = choices[0];
  const select = el("select", { class: "color-by", title: "what colours the spheres (particles[].color_by)" },
    ...choices.map((c) => el("option", { value: c }, c)));
  select.addEventListener("change", () => queueEdit({ [prefix + "color_by"]: select.value }));
  return {
    root: el("div", { class: "row" }, el("label", { class: "key" }, "colour by"), select),
    sync(s) {
      const o = ((s.document || {}).particles || [])[i] || {};
      if (document.activeElement !== select) select.value = o.color_by || fallback;
    },
  };
}

const selectionFields = [];   // { key, showError } of the selection fields built

/** A refused selection edit shows its message under its field; returns whether one took it. */
export function showSelectionError(message) {
  const field = selectionFields.find((f) => message.startsWith(f.key + ":") || message.includes(" " + f.key + ":"));
  if (!field) return false;
  field.showError(message);
  return true;
}

/**
 * volumes.i.visible, particles.i.visible. Hiding an object whose document entry carries shadow flags
 * would be refused (a hidden object takes neither), so then the whole entry is sent without them.
 */
function setVisible(kind, i, on) {
  const obj = clone((((viewer.state || {}).document || {})[kind] || [])[i]);
  if (!on && obj && ("casts_shadows" in obj || "receives_shadows" in obj)) {
    delete obj.casts_shadows;
    delete obj.receives_shadows;
    obj.visible = false;
    queueEdit({ [kind + "." + i]: obj });
  } else {
    queueEdit({ [kind + "." + i + ".visible"]: on });
  }
}
