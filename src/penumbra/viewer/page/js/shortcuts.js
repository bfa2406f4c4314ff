// Keyboard shortcuts: main.js gives the table (keys, what they do, the action); this module listens,
// ignores keys typed into fields, and builds the "?" overlay that lists the table.

import { $, el } from "./util.js";

let table = [];               // { keys: ["r"], label, run }

/** The key as the table names it: "r", "?", "Ctrl+Z", "Ctrl+Shift+Z", "Escape". */
function keyName(e) {
  if (e.ctrlKey || e.metaKey) return "Ctrl+" + (e.shiftKey ? "Shift+" : "") + e.key.toUpperCase();
  return e.key;
}

function onKeyDown(e) {
  if (e.altKey || e.target.matches("input, select, textarea")) return;
  const name = keyName(e);
  const binding = table.find((b) => b.keys.includes(name));
  if (!binding) return;
  e.preventDefault();
  binding.run();
}

export function installShortcuts(bindings) {
  table = bindings;
  $("help").replaceChildren(
    el("h2", {}, "Keyboard shortcuts"),
    el("table", {}, ...table.map((b) => el("tr", {},
      el("td", {}, ...b.keys.flatMap((k, i) => [i ? " or " : null, el("kbd", {}, k)])), el("td", {}, b.label)))));
  window.addEventListener("keydown", onKeyDown);
}

export function toggleHelp(show = $("help").hidden) {
  $("help").hidden = !show;
}
