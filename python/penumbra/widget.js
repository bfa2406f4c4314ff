// penumbra's notebook widget, the browser half (python/penumbra/widget.py is the kernel's): the viewer's
// own page in an iframe, its messages carried over the widget's comm instead of a WebSocket.
//
// The kernel sends the page's files on request ({"type": "page"}): index.html with its placeholders
// filled, and the modules of js/, which become blob: URLs here, each module's imports of its siblings
// rewritten to their blob URLs (the modules import only "./name.js", and no two import each other in
// a cycle). The iframe's element carries the channel (penumbraChannel) that connection.js takes in
// place of a WebSocket. Every message of docs/viewer.md travels as {message: TEXT}, a frame's JPEG (and
// a download's bytes) as the message's one buffer. Loaded by ipywidgets 6 (jupyter-js-widgets) as the
// module "penumbra-widget", defined by the Javascript output the widget shows before its view.
require.undef("penumbra-widget");

define("penumbra-widget", ["jupyter-js-widgets"], function (widgets) {
  "use strict";

  function asArrayBuffer(buffer) {
    if (buffer instanceof ArrayBuffer) return buffer;
    return buffer.buffer.slice(buffer.byteOffset, buffer.byteOffset + buffer.byteLength);
  }

  // The blob URL of the module at `path` ("/js/main.js"), made after those of the modules it imports.
  function moduleUrls(modules) {
    const urls = {};
    const urlOf = (path) => {
      if (!(path in modules)) throw new Error("penumbra widget: no page module " + path);
      if (!urls[path]) {
        const text = modules[path].replace(/(\bfrom\s*)"\.\/([\w-]+\.js)"/g,
          (match, head, name) => head + JSON.stringify(urlOf("/js/" + name)));
        urls[path] = URL.createObjectURL(new Blob([text], { type: "text/javascript" }));
      }
      return urls[path];
    };
    return { urlOf, all: () => Object.values(urls) };
  }

  const PenumbraView = widgets.DOMWidgetView.extend({
    render: function () {
      this.listener = null;
      this.urls = [];
      this.frame = document.createElement("iframe");
      this.frame.className = "penumbra-widget";
      this.frame.style.cssText = "width: 100%; border: 0; display: block; background: #121215";
      this.frame.style.height = this.model.get("height") + "px";
      this.frame.penumbraChannel = {
        send: (text) => this.send({ message: text }),
        listen: (listener) => {
          this.listener = listener;
          this.send({ message: JSON.stringify({ type: "hello" }) });  // the kernel answers with the state and a frame
        },
      };
      this.el.appendChild(this.frame);
      this.listenTo(this.model, "msg:custom", this.onMessage);
      this.listenTo(this.model, "change:height", () => { this.frame.style.height = this.model.get("height") + "px"; });
      this.send({ message: JSON.stringify({ type: "page" }) });
    },

    onMessage: function (content, buffers) {
      if (content.page) {
        if (!this.frame.srcdoc) this.showPage(content.page);
        return;
      }
      if (!this.listener || typeof content.message !== "string") return;
      this.listener(content.message);
      if (buffers && buffers.length) this.listener(asArrayBuffer(buffers[0]));
    },

    showPage: function (page) {
      const modules = moduleUrls(page.modules);
      const main = modules.urlOf("/js/main.js");
      this.urls = modules.all();
      this.frame.srcdoc = page.html.replace("{{main_module}}", main);
    },

    remove: function () {
      for (const url of this.urls) URL.revokeObjectURL(url);
      this.listener = null;
      return widgets.DOMWidgetView.prototype.remove.apply(this, arguments);
    },
  });

  return { PenumbraView: PenumbraView };
});
