// The camera's standard views: the one the scene opened with (reset), the six looking along an axis
// (+X: from the +X side towards the centre) and an isometric one, each framing the data's bounding
// sphere as the scene file's framed camera does (docs/scene-file.md "camera"). Up is the scene's up
// snapped to an axis; a view along that axis takes the next axis as its up.

import { V, clone } from "./util.js";

export const VIEW_NAMES = ["reset", "+x", "-x", "+y", "-y", "+z", "-z", "iso"];
const FRAMING_MARGIN = 1.05;   // as the scene file's framed camera

let openingCamera = null;      // the first state's camera

/** Remembers the camera of the first state the page receives. */
export function noteOpeningCamera(state) {
  if (!openingCamera && state.camera) openingCamera = clone(state.camera);
}

function snappedAxis(v) {
  const a = [0, 1, 2].reduce((best, i) => (Math.abs(v[i]) > Math.abs(v[best]) ? i : best), 0);
  const axis = [0, 0, 0];
  axis[a] = 1;
  return { axis, index: a };
}

/** The camera ({eye, target, up}) of the view `name` for the state's data, or null. */
export function standardCamera(name, state) {
  if (name === "reset") return openingCamera && { eye: openingCamera.eye, target: openingCamera.target, up: openingCamera.up };
  if (!state || !state.camera) return null;
  const b = state.bounds;
  const target = b ? V.scale(V.add(b.lo, b.hi), 0.5) : state.camera.target;
  const radius = state.radius || V.len(V.sub(state.camera.eye, state.camera.target)) / 3;
  const fov = ((state.camera.fov_deg || 35) * Math.PI) / 180;
  const distance = (radius / Math.sin(fov / 2)) * FRAMING_MARGIN;
  let direction;
  if (name === "iso") direction = V.norm([1, 1, 1]);
  else {
    direction = [0, 0, 0];
    direction["xyz".indexOf(name[1])] = name[0] === "-" ? -1 : 1;
  }
  const sceneUp = snappedAxis((openingCamera || state.camera).up || [0, 1, 0]);
  let up = sceneUp.axis;
  const along = V.dot(direction, up);
  if (Math.abs(along) > 0.99) {
    up = [0, 0, 0];
    up[(sceneUp.index + 1) % 3] = along > 0 ? -1 : 1;
  }
  return { eye: V.add(target, V.scale(direction, distance)), target, up };
}
