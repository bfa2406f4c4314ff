// Undo and redo of the user's edits: each entry is the paths an edit set with their values before
// and after. The edits of one gesture (a drag sends the same paths many times a second) make one
// entry. Undo sends the values before, redo those after, as ordinary edits. `time` is not recorded
// (playing steps it), and a path whose value before is unknown (absent from the document) is left out.

import { $, clone, getPath } from "./util.js";
import { viewer, queueEdit } from "./connection.js";

const GESTURE_MS = 600;       // edits of the same paths this close together are one entry
const REFUSAL_MS = 2000;      // an error this soon after an entry is taken as that entry's refusal
const UNRECORDED = new Set(["time"]);

const undoStack = [];         // { before: {path: value}, after: {path: value}, at }
const redoStack = [];

/** The value at `path` in the current state: the resolved camera for camera paths, else the document. */
function currentValue(path) {
  const state = viewer.state || {};
  const camera = /^camera\.(eye|target|up|fov_deg)$/.exec(path);
  if (camera && state.camera) return state.camera[camera[1]];
  return getPath(state.document || {}, path);
}

export function recordEdit(set) {
  const paths = Object.keys(set).filter((p) => !UNRECORDED.has(p));
  if (!paths.length) return;
  const now = performance.now();
  const last = undoStack[undoStack.length - 1];
  const key = paths.slice().sort().join("\n");
  if (last && last.key === key && now - last.at < GESTURE_MS) {
    for (const p of paths) last.after[p] = clone(set[p]);
    last.at = now;
    return;
  }
  const before = {}, after = {};
  for (const p of paths) {
    const value = currentValue(p);
    if (value === undefined) continue;
    before[p] = clone(value);
    after[p] = clone(set[p]);
  }
  if (!Object.keys(before).length) return;
  undoStack.push({ before, after, at: now, key });
  redoStack.length = 0;
  renderButtons();
}

export function undo() {
  const entry = undoStack.pop();
  if (!entry) return;
  redoStack.push(entry);
  queueEdit(clone(entry.before), false);
  renderButtons();
}

export function redo() {
  const entry = redoStack.pop();
  if (!entry) return;
  entry.at = 0;   // a later edit of the same paths starts a new entry
  undoStack.push(entry);
  queueEdit(clone(entry.after), false);
  renderButtons();
}

/** A refused edit leaves the scene as it was: its entry, when it is the newest and recent, goes. */
export function forgetRefused() {
  const last = undoStack[undoStack.length - 1];
  if (last && performance.now() - last.at < REFUSAL_MS) {
    undoStack.pop();
    renderButtons();
  }
}

function renderButtons() {
  $("undo").disabled = !undoStack.length;
  $("redo").disabled = !redoStack.length;
}
