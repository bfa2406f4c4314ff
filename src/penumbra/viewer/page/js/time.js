// Time: the slider and Play / Pause of a scene with frames (trajectories, volume series).

import { $, round6 } from "./util.js";
import { viewer, queueEdit } from "./connection.js";
import { isPanelBusy } from "./panels.js";

/** Playing steps `time` once the full frame of the previous step is shown, at most `fps` a second. */
const playback = { playing: false, requested: null, last: 0, fps: 10, timer: 0 };

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
  playback.last = performance.now();
  showTime(frame);
  queueEdit({ time: frame });
}

function setPlaying(on) {
  playback.playing = on;
  $("play").textContent = on ? "Pause" : "Play";
  clearInterval(playback.timer);
  playback.timer = on ? setInterval(stepPlayback, 1000 / playback.fps / 2) : 0;
  playback.requested = null;
}

function stepPlayback() {
  const t = timeInfo();
  if (!playback.playing || playback.requested !== null || t.frames <= 1) return;
  if (performance.now() - playback.last < 1000 / playback.fps) return;
  setTime((Number($("time").value) + 1) % t.frames);
}

export function installTimeControls() {
  $("time").addEventListener("input", () => { setPlaying(false); setTime(Number($("time").value)); });
  $("play").addEventListener("click", () => setPlaying(!playback.playing));
}

/** A frame arrived: the step Play asked for is shown once its full frame is. */
export function frameShown(meta) {
  if (meta.quality === "full" && meta.time === playback.requested) playback.requested = null;
}
