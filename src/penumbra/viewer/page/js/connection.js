// The connection to the server: the WebSocket (opened again 2 s after it closes), the protocol's
// messages in (handed to the handlers main.js passes to start) and out, and the edits, coalesced to
// one message per animation frame. The protocol is docs/viewer.md.
//
// Inside a Jupyter notebook (python/penumbra/widget.py) the page lives in an iframe whose element
// carries a channel to the kernel, frameElement.penumbraChannel = { send(text), listen(onData) }: the
// same messages travel over the widget's comm instead of a WebSocket, and the kernel renders them.

export const TOKEN = new URLSearchParams(location.search).get("token") || "";
export const TOKEN_QUERY = "?token=" + encodeURIComponent(TOKEN);
const channel = window.frameElement ? window.frameElement.penumbraChannel : null;
/** Whether the page is the notebook widget's (its messages go over the kernel's comm). */
export const inNotebook = () => channel != null;

let ws = null;
let connection = "connecting";
let handlers = null;          // { onStatus, onOpen, onState, onFrameMeta, onFrameBytes, onError, onProbe, onDownload }
let pendingDownload = null;   // a "download" message whose bytes come next (the notebook's downloads)

let attempts = 0;             // connections tried since the last one opened (0 while connected)
let editObserver = null;      // sees each edit queued from the user's input (history.js)

/**
 * What the page shows, for automated tests: window.penumbraViewer = { state, frames, lastFrame, send,
 * dropConnection } (the last closes the socket as a dropped network would).
 */
export const viewer = window.penumbraViewer = {
  state: null,
  frames: 0,
  lastFrame: null,
  send: (obj) => ws.send(JSON.stringify(obj)),
  dropConnection: () => ws && ws.close(),
};

/** Opens the connection; `on` receives its status, its opening and each message by type. */
export function start(on) {
  handlers = on;
  connect();
}

function connect() {
  setConnection("connecting");
  if (channel) {
    // the notebook's comm: open while the kernel lives (a restarted kernel needs the cell run again)
    ws = { readyState: WebSocket.OPEN, send: (text) => channel.send(text), close: () => {} };
    channel.listen((data) => onMessage({ data }));
    setConnection("connected");
    handlers.onOpen();
    return;
  }
  const scheme = location.protocol === "https:" ? "wss://" : "ws://";
  try {
    ws = new WebSocket(scheme + location.host + "/ws" + TOKEN_QUERY);
  } catch (e) {
    ws = null;
    attempts += 1;
    setConnection("disconnected");
    setTimeout(connect, 2000);
    return;
  }
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { attempts = 0; setConnection("connected"); handlers.onOpen(); };
  ws.onmessage = onMessage;
  ws.onclose = () => { attempts += 1; setConnection("disconnected"); setTimeout(connect, 2000); };
}

export const connectionStatus = () => connection;
export const reconnectAttempts = () => attempts;
export const isOpen = () => ws !== null && ws.readyState === WebSocket.OPEN;

function setConnection(status) {
  connection = status;
  handlers.onStatus(status);
}

export function sendMessage(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
}

function onMessage(event) {
  if (typeof event.data !== "string") {
    if (pendingDownload) handlers.onDownload(pendingDownload, event.data);
    else handlers.onFrameBytes(event.data);
    pendingDownload = null;
    return;
  }
  let msg;
  try { msg = JSON.parse(event.data); } catch (e) { return; }
  if (msg.type === "download") pendingDownload = msg;
  else if (msg.type === "state") handlers.onState(msg);
  else if (msg.type === "frame") handlers.onFrameMeta(msg);
  else if (msg.type === "error") handlers.onError(msg.message);
  else if (msg.type === "probe") handlers.onProbe(msg);
}

// ---------------------------------------------------------------------------------------------
// Edits: coalesced to one message per animation frame
// ---------------------------------------------------------------------------------------------

let pendingSet = null;
let editFrame = 0;
let editTimer = 0;

/** `observer(set)` sees every edit queued with `observed` (the user's, not undo's and redo's). */
export function observeEdits(observer) {
  editObserver = observer;
}

/**
 * Merges `set` into the pending edit, sent at the next animation frame. A timer backs the frame up
 * where none come (a hidden tab, a headless browser); whichever fires first sends.
 */
export function queueEdit(set, observed = true) {
  if (observed && editObserver) editObserver(set);
  pendingSet = Object.assign(pendingSet || {}, set);
  if (editFrame) return;
  editFrame = requestAnimationFrame(flushEdits);
  editTimer = setTimeout(flushEdits, 100);
}

/**
 * Sends `set` now, after any pending edit, as an edit whose frames start with the full frame (no
 * preview): a playback step, which waits for its full frame anyway.
 */
export function sendFullFrameEdit(set) {
  flushEdits();
  sendMessage({ type: "edit", set, preview: false });
}

function flushEdits() {
  cancelAnimationFrame(editFrame);
  clearTimeout(editTimer);
  editFrame = editTimer = 0;
  if (!pendingSet) return;
  const set = pendingSet;
  pendingSet = null;
  sendMessage({ type: "edit", set });
}
