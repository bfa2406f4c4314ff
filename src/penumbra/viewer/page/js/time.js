// Time: the slider and Play / Pause of a scene with frames (trajectories, volume series).

import { $, round6 } from "./util.js";
import { viewer, queueEdit, sendFullFrameEdit } from "./connection.js";
import { isPanelBusy } from "./panels.js";

/**
 * Playing keeps the wall clock: step k of the play is due k / fps seconds after Play, and the page asks
 * for the step due now once the full frame of the step it asked for before is shown. One step waits
 * at a time, never a queue of them: when rendering falls behind, the steps in between are skipped
 * (counted in `skipped`), so a slow scene plays at its true pace with fewer frames. `shown` counts the
 * steps whose full frame arrived; both are exposed as window.penumbraViewer.playback for tests and
 * benchmarks.
 */
const playback = { playing: false, requested: null, fps: 10, timer: 0, started: 0, first: 0, step: 0, shown: 0, skipped: 0 };
viewer.playback = playback;

function timeInfo() {
  return (viewer.state && viewer.state.time) || { frame: 0, frames: 0 };
}

function showTime(frame) {
  const t = timeInfo();
  $("time").value = frame;
  $("time-readout").textContent = "frame " + frame + " / " + Math.max(0, t.frames - 1) +
    (typeof t.time_ps === "number" && frame === t.frame ? " · " + round6(t.time_ps) + " ps" : "");
}

export function syncTime(state) {
  const t = state.time || { frame: 0, frames: 0 };
  $("time-section").hidden = !(t.frames > 1);
  $("time").max = Math.max(0, t.frames - 1);
  if (!isPanelBusy()) showTime(t.frame);
  if (t.frames <= 1 && playback.playing) setPlaying(false);
}

function setTime(frame) {
  playback.requested = frame;
  showTime(frame);
  if (playback.playing) sendFullFrameEdit({ time: frame });
  else queueEdit({ time: frame });
}

function setPlaying(on) {
  playback.playing = on;
  $("play").textContent = on ? "Pause" : "Play";
  clearInterval(playback.timer);
  playback.timer = on ? setInterval(stepPlayback, 1000 / playback.fps / 4) : 0;
  playback.requested = null;
  if (on) Object.assign(playback, { started: performance.now(), first: Number($("time").value), step: 0, shown: 0, skipped: 0 });
}

function stepPlayback() {
  const t = timeInfo();
  if (!playback.playing || playback.requested !== null || t.frames <= 1) return;
  const due = Math.floor(((performance.now() - playback.started) * playback.fps) / 1000);
  if (due <= playback.step) return;  // the next step is not due yet
  playback.skipped += due - playback.step - 1;
  playback.step = due;
  setTime((playback.first + due) % t.frames);
}

export function installTimeControls() {
  $("time").addEventListener("input", () => { setPlaying(false); setTime(Number($("time").value)); });
  $("play").addEventListener("click", () => setPlaying(!playback.playing));
}

/** A frame arrived: the step Play asked for is shown once its full frame is. */
export function frameShown(meta) {
  if (meta.quality === "full" && meta.time === playback.requested) {
    playback.requested = null;
    if (playback.playing) playback.shown += 1;
  }
}
