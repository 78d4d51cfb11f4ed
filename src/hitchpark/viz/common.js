// What every hitchpark page shares. viz/page.py puts this before the page's own script, in the same element.
"use strict";
const hitchpark = Object.freeze({
  // An element with attributes and, if given, inner HTML (escape text with esc first).
  el(tag, attrs, html) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (html !== undefined) e.innerHTML = html;
    return e;
  },
  // Text safe to put in HTML.
  esc(s) {
    return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
  },
});
