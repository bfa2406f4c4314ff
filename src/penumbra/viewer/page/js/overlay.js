// What lies over the view: the stats (frame time, quality, size, the finer level a pyramid is drawn
// from, what was rebuilt, the connection),
// the refinement's progress ("refining k/16" and a bar), the banner while the connection is down, and
// the error banner.

import { $, el } from "./util.js";
import { connectionStatus, viewer } from "./connection.js";

let lastRebuilt = null;       // the rebuilt list of the last frame that rebuilt anything
let errorTimer = 0;

/** Keeps what a frame rebuilt, when it rebuilt anything, for the stats. */
export function noteRebuilt(rebuilt) {
  if (Array.isArray(rebuilt) && rebuilt.length) lastRebuilt = rebuilt;
}

export function renderStats() {
  const f = viewer.lastFrame, connection = connectionStatus();
  const lines = [];
  if (f) {
    const quality = f.quality === "full" ? "full ×" + (f.samples || 1) : "preview";
    const ms = typeof f.ms === "number" ? f.ms.toFixed(1) + " ms" : "– ms";
    lines.push(ms + "  " + quality);
    const mem = typeof f.memory_mb === "number" ? "  " + Math.round(f.memory_mb) + " MB" : "";
    const reduced = f.divisor > 1 ? " at 1/" + f.divisor : "";
    lines.push((f.view_width || f.width) + "×" + (f.view_height || f.height) + reduced + mem);
    for (const line of refinementLines(f.refinement)) lines.push(line);
  }
  if (lastRebuilt) {
    lines.push("rebuilt: " + lastRebuilt.map((r) => r.structure + (r.cause ? " (" + r.cause + ")" : "")).join(", "));
  }
  const stats = $("stats");
  stats.textContent = lines.join("\n") + (lines.length ? "\n" : "");
  stats.append(el("span", { class: connection === "connected" ? "" : "bad" }, connection));
}

/**
 * A full frame of a pyramid opened coarse under the memory budget draws the part in view from a finer
 * level (docs/engine.md "Refined views"): which level and box, what it holds, and what this frame read,
 * or why the box could not be read.
 */
export function refinementLines(refinement) {
  if (!Array.isArray(refinement)) return [];
  const mb = (bytes) => (bytes / 1048576).toFixed(bytes < 10485760 ? 1 : 0) + " MB";
  const lines = [];
  for (const r of refinement) {
    const volume = refinement.length > 1 ? "volume " + r.volume + " " : "";
    if (r.error) {  // the finer box could not be read: this frame shows the opened level there
      lines.push(volume + "level " + r.opened_level + " shown: " + r.error);
    } else if (r.held_bytes > 0) {
      lines.push(volume + "level " + r.level + " box " + r.dims.join("×") + " of level " + r.opened_level);
      lines.push("  held " + mb(r.held_bytes) + (r.loaded_bytes > 0 ? ", read " + mb(r.read_bytes) + " in " + Math.round(r.load_ms) + " ms" : "") +
                 (r.kept_bytes > 0 ? ", " + mb(r.kept_bytes) + " kept" : ""));
    } else if (r.kept_bytes > 0) {
      lines.push(volume + "level " + r.opened_level + " (" + mb(r.kept_bytes) + " of finer boxes kept)");
    } else if (r.evicted_bytes > 0) {
      lines.push(volume + "level " + r.opened_level + ": finer box given up (" + mb(r.evicted_bytes) + ")");
    }
  }
  return lines;
}

/** The progress of the accumulation: shown while a full frame has fewer samples than the server takes. */
export function renderProgress(meta) {
  const max = meta.max_samples || 1, samples = meta.samples || 0;
  const refining = meta.quality === "full" && samples < max;
  $("progress").hidden = !refining;
  if (!refining) return;
  $("progress-text").textContent = "refining " + samples + "/" + max;
  $("progress-bar").style.width = (100 * samples) / max + "%";
}

/** The banner while the connection is down (connection.js opens it again every 2 s). */
export function renderConnectionBanner(status, attempts) {
  const banner = $("connection-banner");
  banner.hidden = status === "connected" || attempts === 0;
  if (!banner.hidden) banner.textContent = "Connection to the server lost · reconnecting (attempt " + attempts + ")…";
}

export function showError(message) {
  $("error-text").textContent = message;
  $("error").hidden = false;
  clearTimeout(errorTimer);
  errorTimer = setTimeout(hideError, 6000);
}

export function hideError() {
  clearTimeout(errorTimer);
  $("error").hidden = true;
}
