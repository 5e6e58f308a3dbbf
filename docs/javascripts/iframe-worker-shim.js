/* Search on a page opened from disk (file://).

   The theme's search runs lunr in a Web Worker (assets/javascripts/workers/search.*.min.js), and
   browsers refuse `new Worker("file://...")`. On file:// only, this replaces `Worker` with a stand-in
   that runs the worker's script in a hidden iframe of the page's own origin and passes messages the
   way a worker would. The search index comes as a script, search/search_index.js, written at build
   time by the theme's offline plugin (mkdocs.yml), which a page from disk may load.

   Written for this site, after the idea of squidfunk/iframe-worker, which the offline plugin would
   otherwise load from a CDN: the site needs no network. Loaded in the page's head (mkdocs.yml
   extra.polyfills), before the theme's bundle creates its worker. */
(function () {
  "use strict";
  if (location.protocol !== "file:") {
    return;  // served over http(s): the browser's own workers
  }

  function copy(data) {
    return typeof structuredClone === "function" ? structuredClone(data) : data;
  }

  function loadScript(win, src) {
    return new Promise(function (resolve, reject) {
      var script = win.document.createElement("script");
      script.src = src;
      script.onload = function () { resolve(); };
      script.onerror = function () { reject(new Error("could not load " + src)); };
      win.document.head.appendChild(script);
    });
  }

  function IFrameWorker(url) {
    var target = new EventTarget();
    var self = this;
    var queue = [];
    var ready = false;
    this.onmessage = null;
    this.onerror = null;

    var frame = document.createElement("iframe");
    frame.setAttribute("aria-hidden", "true");
    frame.setAttribute("tabindex", "-1");
    frame.style.display = "none";
    (document.body || document.documentElement).appendChild(frame);
    var win = frame.contentWindow;  // about:blank: the page's origin, so the page may script it

    function emit(type, init) {
      var event = type === "message" ? new MessageEvent("message", init) : new ErrorEvent("error", init);
      var handler = self["on" + type];
      if (typeof handler === "function") {
        handler.call(self, event);
      }
      target.dispatchEvent(event);
    }

    function deliver(data) {
      win.dispatchEvent(new win.MessageEvent("message", { data: copy(data) }));
    }

    // what the worker's script finds in its global scope
    win.postMessage = function (data) {
      setTimeout(function () { emit("message", { data: copy(data) }); }, 0);
    };
    win.importScripts = function () {  // sequential; the theme's worker awaits the result
      var srcs = Array.prototype.slice.call(arguments);
      return srcs.reduce(function (done, src) {
        return done.then(function () { return loadScript(win, new URL(src, url).href); });
      }, Promise.resolve());
    };

    url = new URL(url, location.href).href;
    loadScript(win, url).then(function () {
      ready = true;
      queue.splice(0).forEach(deliver);
    }, function (error) {
      emit("error", { message: error.message, error: error });
    });

    this.postMessage = function (data) {
      if (ready) {
        setTimeout(function () { deliver(data); }, 0);
      } else {
        queue.push(data);
      }
    };
    this.terminate = function () {
      frame.remove();
    };
    this.addEventListener = target.addEventListener.bind(target);
    this.removeEventListener = target.removeEventListener.bind(target);
    this.dispatchEvent = target.dispatchEvent.bind(target);
  }

  window.IFrameWorker = IFrameWorker;  // the theme's worker looks for this to find its lunr languages
  window.Worker = IFrameWorker;
})();
