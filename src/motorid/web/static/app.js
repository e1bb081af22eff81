// motorid servo lab: the few behaviours htmx does not give by attributes (drop zone with
// folders, error box, elapsed time, closing the tab's temporary folder).
(function () {
  "use strict";
  // a 422 carries the one-line error the command line prints: swap it (the server retargets
  // it to #errors); other errors are shown in the same box
  htmx.config.responseHandling = [
    { code: "204", swap: false },
    { code: "[23]..", swap: true },
    { code: "422", swap: true, error: false },
    { code: "[45]..", swap: false, error: true },
  ];

  const tab = document.body.dataset.tab;
  const errors = () => document.getElementById("errors");

  document.body.addEventListener("htmx:beforeRequest", (ev) => {
    if (ev.detail.elt.id !== "design-form") errors().innerHTML = "";
    const busy = ev.detail.elt.querySelector && ev.detail.elt.querySelector(".elapsed");
    if (busy) {
      const t0 = performance.now();
      busy.textContent = "";
      ev.detail.elt._timer = setInterval(() => {
        busy.textContent = ((performance.now() - t0) / 1000).toFixed(1) + " s";
      }, 100);
    }
  });
  document.body.addEventListener("htmx:afterRequest", (ev) => {
    if (ev.detail.elt._timer) clearInterval(ev.detail.elt._timer);
    if (ev.detail.elt.id === "design-form" && ev.detail.successful) {
      errors().innerHTML = "";
    }
  });
  document.body.addEventListener("htmx:responseError", (ev) => {
    const p = document.createElement("p");
    p.className = "error";
    p.textContent = "motorid: internal error (HTTP " + ev.detail.xhr.status + "): see the server's terminal";
    errors().replaceChildren(p);
  });
  document.body.addEventListener("htmx:sendError", () => {
    const p = document.createElement("p");
    p.className = "error";
    p.textContent = "motorid: the server does not answer: is motorid serve still running?";
    errors().replaceChildren(p);
  });

  // drop zone: files and whole folders (ALLnnnn/), sent with their folder in the name
  function readEntry(entry, prefix, out) {
    return new Promise((resolve) => {
      if (entry.isFile) {
        entry.file((f) => { out.push(new File([f], prefix + f.name, { type: f.type })); resolve(); }, () => resolve());
      } else if (entry.isDirectory) {
        const reader = entry.createReader();
        const all = [];
        const next = () => reader.readEntries((batch) => {
          if (!batch.length) {
            Promise.all(all.map((e) => readEntry(e, prefix + entry.name + "/", out))).then(resolve);
          } else { all.push(...batch); next(); }
        }, () => resolve());
        next();
      } else { resolve(); }
    });
  }
  function setup() {
    const zone = document.getElementById("dropzone");
    const input = document.getElementById("files");
    if (!zone || !input) return;
    ["dragenter", "dragover"].forEach((n) => zone.addEventListener(n, (ev) => {
      ev.preventDefault(); zone.classList.add("over");
    }));
    zone.addEventListener("dragleave", () => zone.classList.remove("over"));
    zone.addEventListener("drop", async (ev) => {
      ev.preventDefault();
      zone.classList.remove("over");
      const items = Array.from(ev.dataTransfer.items || []);
      const out = [];
      const entries = items.map((it) => it.webkitGetAsEntry && it.webkitGetAsEntry()).filter(Boolean);
      if (entries.length) {
        await Promise.all(entries.map((e) => readEntry(e, "", out)));
      } else {
        out.push(...Array.from(ev.dataTransfer.files));
      }
      const dt = new DataTransfer();
      out.forEach((f) => dt.items.add(f));
      input.files = dt.files;
      input.dispatchEvent(new Event("change", { bubbles: true }));
    });
  }
  document.addEventListener("DOMContentLoaded", setup);

  // a download that takes a while (the report: seconds) shows a busy line with its elapsed time
  // until the file arrives; without JavaScript the link downloads as a plain link
  document.body.addEventListener("click", async (ev) => {
    const link = ev.target.closest && ev.target.closest("a[data-busy]");
    if (!link || ev.defaultPrevented || ev.button !== 0 || ev.ctrlKey || ev.metaKey || ev.shiftKey) return;
    ev.preventDefault();
    if (link.dataset.pending) return;
    link.dataset.pending = "1";
    const busy = document.createElement("span");
    busy.className = "busy";
    busy.setAttribute("role", "status");
    const t0 = performance.now();
    const tick = () => { busy.textContent = link.dataset.busy + " " + ((performance.now() - t0) / 1000).toFixed(1) + " s"; };
    tick();
    const timer = setInterval(tick, 100);
    link.after(busy);
    try {
      const resp = await fetch(link.href);
      if (!resp.ok) {
        errors().innerHTML = await resp.text();
        return;
      }
      const blob = await resp.blob();
      const named = /filename="?([^";]+)"?/.exec(resp.headers.get("Content-Disposition") || "");
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = named ? named[1] : (link.getAttribute("download") || "");
      document.body.appendChild(a);
      a.click();
      a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 60000);
    } catch (e) {
      const p = document.createElement("p");
      p.className = "error";
      p.textContent = "motorid: the server does not answer: is motorid serve still running?";
      errors().replaceChildren(p);
    } finally {
      clearInterval(timer);
      busy.remove();
      delete link.dataset.pending;
    }
  });

  // the tab's uploads are deleted when the page goes away
  window.addEventListener("pagehide", () => {
    if (tab) navigator.sendBeacon("/tab/" + tab + "/close");
  });
})();
