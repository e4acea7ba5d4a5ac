// rendr view: the page. Every picture is a pure function of the `go` words, the
// transfer function's control points and the lights; the page keeps those, asks the
// server for pictures, and prints the command that makes the same picture.
"use strict";

const TOKEN = new URLSearchParams(location.search).get("t") || "";
const CLIENT = Math.random().toString(36).slice(2) + Date.now().toString(36);
const $ = (id) => document.getElementById(id);

// Arity of each `go` option the page handles (0: a flag).
const ARITY = { k: 1, p: 1, b: 1, s: 1, s1s: 0, sz: 2, nt: 1, fr: 3, at: 3, up: 3, nc: 1,
  fc: 1, fov: 1, ortho: 0, ph: 4, dcn: 3, dcf: 3, us: 1, a1: 1, ov: 1, ref: 1, ess: 1,
  fast: 1, gmc: 1, q: 2 };
const ORDER = ["k", "p", "b", "s", "s1s", "sz", "nt", "fr", "at", "up", "nc", "fc", "fov",
  "ortho", "us", "a1", "ov", "gmc", "ph", "dcn", "dcf", "ref", "ess", "fast", "q"];
const KERNELS = ["box", "tent", "bspln2", "bspln3", "ctmr", "c4hexic"];
const PROBES = ["v", "gm", "rgba", "rgbalit", "in", "k1", "k2", "meancurv", "gausscurv"];
const BLENDS = ["max", "min", "sum", "mean", "over", "l2", "variance", "sd", "median"];

let info = null;
let opts = {};          // option -> array of value strings (flags: [])
let home = null;        // the first camera, for reset
let txf = { space: "rgb", rgb: [], alpha: [], mm: [0, 1], len: 256 };
let selected = null;    // index of the selected colour point
let txfEdited = false;  // with -lut on the command line: that LUT until the points move
let seq = 0, shownSeq = 0, pending = null, idleTimer = null, fullBlobUrl = null;

function num(v) { return Number(v); }
function vec(o) { return (opts[o] || []).map(num); }
function setVec(o, v) { opts[o] = v.map((x) => String(Number(x.toPrecision(12)))); }
function usesLut() { const p = opts.p[0]; return p === "rgba" || p === "rgbalit"; }
function usesLights() { return opts.p[0] === "rgbalit"; }
function fileLut() { return usesLut() && info.lut_file && !txfEdited; }

// ---- words and the command -------------------------------------------------------
function parseWords(words) {
  const o = {};
  for (let i = 0; i < words.length; i++) {
    const name = words[i].replace(/^-+/, "");
    const n = ARITY[name];
    if (n === undefined) continue;
    o[name] = words.slice(i + 1, i + 1 + n);
    i += n;
  }
  return o;
}
function words(full) {
  const w = [];
  for (const o of ORDER) {
    if (!(o in opts)) continue;
    if (ARITY[o] === 0) { if (opts[o]) w.push("-" + o); continue; }
    let v = opts[o];
    if (o === "sz" && !full) v = previewSize();
    w.push("-" + o, ...v);
  }
  return w;
}
function previewSize() {
  const [w, h] = vec("sz");
  const f = Math.max(1, Math.ceil(Math.max(w, h) / 128));
  return [String(Math.max(1, Math.round(w / f))), String(Math.max(1, Math.round(h / f)))];
}
function fmt(x) { return String(Number(Number(x).toPrecision(12))); }
function txfText() {
  const rgb = "#space:=" + txf.space + "\n" + txf.rgb.map((p) => p.map(fmt).join(" ")).join("\n") + "\n";
  const alpha = "#space:=alpha\n" + txf.alpha.map((p) => p.map(fmt).join(" ")).join("\n") + "\n";
  return { rgb, alpha };
}
function quote(s) { return /^[\w@%+=:,./-]+$/.test(s) ? s : "'" + s.replace(/'/g, "'\\''") + "'"; }
function command() {
  const lines = [];
  const go = ["rendr", "go", "-i", quote(info.volume)];
  if (fileLut()) {
    go.push("-lut", quote(info.lut_file));
  } else if (usesLut()) {
    lines.push(["rendr", "lgen", "-i", "rgb.txt", "alpha.txt", "-mm", fmt(txf.mm[0]), fmt(txf.mm[1]),
      "-l", String(txf.len), "-o", "lut.nrrd"].join(" "));
    go.push("-lut", "lut.nrrd");
  }
  if (usesLights()) go.push("-lit", "lights.txt");
  if (info.lev_file) go.push("-lev", quote(info.lev_file));
  go.push(...words(true).map(quote), "-o", "rendr.png");
  lines.push(go.join(" "));
  return lines.join(" &&\n");
}
function request(full, format) {
  const r = { client: CLIENT, seq: ++seq, args: words(full), txf: null, lights: null };
  if (usesLut() && !fileLut()) { const t = txfText(); r.txf = { rgb: t.rgb, alpha: t.alpha, mm: txf.mm, len: txf.len }; }
  if (usesLights()) r.lights = $("lights").value;
  if (format) r.format = format;
  return r;
}

// ---- rendering ---------------------------------------------------------------------
async function post(req, signal) {
  const resp = await fetch("render?t=" + TOKEN, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(req),
    signal,
  });
  if (!resp.ok) throw new Error(resp.status + ": " + (await resp.text()).trim());
  return resp.blob();
}
async function draw(full) {
  if (pending) pending.abort();
  const ctl = new AbortController();
  pending = ctl;
  const req = request(full);
  const mine = req.seq;
  const t0 = performance.now();
  status(full ? "rendering…" : "preview…");
  try {
    const blob = await post(req, ctl.signal);
    if (mine < shownSeq) return;
    shownSeq = mine;
    const bmp = await createImageBitmap(blob);
    const c = $("image"), [w, h] = vec("sz");
    c.width = w; c.height = h;
    const g = c.getContext("2d");
    g.imageSmoothingEnabled = !full;
    g.drawImage(bmp, 0, 0, w, h);
    c.dataset.full = full ? "1" : "0";
    c.dataset.seq = String(mine);
    if (full) {
      if (fullBlobUrl) URL.revokeObjectURL(fullBlobUrl);
      fullBlobUrl = URL.createObjectURL(blob);
      $("dl-png").href = fullBlobUrl;
      c.dataset.command = command();
    }
    status((full ? "full " : "preview ") + bmp.width + "×" + bmp.height + " in " +
      Math.round(performance.now() - t0) + " ms");
  } catch (e) {
    if (e.name === "AbortError" || /^409/.test(e.message)) return;
    status(e.message, true);
  }
}
function status(msg, bad) { const s = $("status"); s.textContent = msg; s.className = bad ? "error" : ""; }
// A coarse picture now, the full one when the input rests.
function changed(interactive) {
  updateCommand();
  $("lutnote").textContent = fileLut() ? "using -lut " + info.lut_file + " until a point moves" : "";
  clearTimeout(idleTimer);
  if (interactive) {
    draw(false);
    idleTimer = setTimeout(() => draw(true), 250);
  } else {
    draw(true);
  }
}
function updateCommand() {
  $("command").value = command();
  const t = txfText();
  blobLink("dl-rgb", t.rgb);
  blobLink("dl-alpha", t.alpha);
  blobLink("dl-lights", $("lights").value);
}
function blobLink(id, text) {
  const a = $(id);
  if (a.href && a.href.startsWith("blob:")) URL.revokeObjectURL(a.href);
  a.href = URL.createObjectURL(new Blob([text], { type: "text/plain" }));
}

// ---- camera --------------------------------------------------------------------------
const sub = (a, b) => a.map((x, i) => x - b[i]);
const add = (a, b) => a.map((x, i) => x + b[i]);
const mul = (a, s) => a.map((x) => x * s);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => mul(a, 1 / Math.hypot(...a));
function rotate(v, axis, ang) {   // Rodrigues
  const k = norm(axis), c = Math.cos(ang), s = Math.sin(ang);
  return add(add(mul(v, c), mul(cross(k, v), s)), mul(k, dot(k, v) * (1 - c)));
}
function frame() {
  const fr = vec("fr"), at = vec("at"), up = vec("up");
  const n = norm(sub(fr, at));
  const u = norm(cross(up, n));
  const v = cross(n, u);
  return { fr, at, up, n, u, v, d: Math.hypot(...sub(fr, at)) };
}
function orbit(dx, dy) {
  const f = frame();
  let off = sub(f.fr, f.at), up = f.v;
  off = rotate(off, f.v, -dx * 0.01);
  const right = norm(cross(up, norm(off)));
  off = rotate(off, right, -dy * 0.01);
  up = rotate(up, right, -dy * 0.01);
  setVec("fr", add(f.at, off));
  setVec("up", up);
}
function pan(dx, dy) {
  const f = frame();
  const px = 2 * f.d * Math.tan((num(opts.fov[0]) * Math.PI) / 360) / vec("sz")[1];
  const move = add(mul(f.u, -dx * px), mul(f.v, dy * px));
  setVec("fr", add(f.fr, move));
  setVec("at", add(f.at, move));
}
function zoom(k) {
  const f = frame();
  setVec("fr", add(f.at, mul(sub(f.fr, f.at), k)));
}
function snap(axis, sign) {
  const f = frame();
  const dir = [0, 0, 0];
  dir[axis] = sign;
  setVec("fr", add(f.at, mul(dir, f.d)));
  setVec("up", axis === 2 ? [0, 1, 0] : [0, 0, 1]);
}

// ---- transfer function editor --------------------------------------------------------
function txfX(v) { return ((v - txf.mm[0]) / (txf.mm[1] - txf.mm[0])) * 512; }
function txfV(x) { return txf.mm[0] + (x / 512) * (txf.mm[1] - txf.mm[0]); }
function colourAt(p) {
  const c = p.slice(1);
  return txf.space === "rgb" ? c : hsvToRgb(c);
}
function hsvToRgb([h, s, v]) {
  const i = Math.floor(h * 6) % 6, f = h * 6 - Math.floor(h * 6);
  const p = v * (1 - s), q = v * (1 - f * s), t = v * (1 - (1 - f) * s);
  return [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]][(i + 6) % 6];
}
function rgbToHsv([r, g, b]) {
  const mx = Math.max(r, g, b), mn = Math.min(r, g, b), d = mx - mn;
  let h = 0;
  if (d > 0) h = mx === r ? ((g - b) / d) % 6 : mx === g ? (b - r) / d + 2 : (r - g) / d + 4;
  h = (h / 6 + 1) % 1;
  return [h, mx > 0 ? d / mx : 0, mx];
}
const hex = (c) => "#" + c.map((x) => Math.round(Math.min(1, Math.max(0, x)) * 255).toString(16).padStart(2, "0")).join("");
function drawTxf() {
  // Every drawing after the first follows an edit of the points or the domain.
  if (drawTxf.done) txfEdited = true;
  drawTxf.done = true;
  const c = $("txf"), g = c.getContext("2d"), H = c.height;
  g.clearRect(0, 0, 512, H);
  const hist = info.hist, mx = Math.log1p(Math.max(...hist));
  g.fillStyle = "#445";
  const [lo, hi] = info.range;
  for (let i = 0; i < hist.length; i++) {
    const x0 = txfX(lo + ((hi - lo) * i) / hist.length), x1 = txfX(lo + ((hi - lo) * (i + 1)) / hist.length);
    const y = (Math.log1p(hist[i]) / mx) * H;
    g.fillRect(x0, H - y, Math.max(1, x1 - x0), y);
  }
  g.strokeStyle = "#eee";
  g.beginPath();
  txf.alpha.forEach((p, i) => { const x = txfX(p[0]), y = H - p[1] * H; i ? g.lineTo(x, y) : g.moveTo(x, y); });
  g.stroke();
  g.fillStyle = "#fff";
  for (const p of txf.alpha) g.fillRect(txfX(p[0]) - 3, H - p[1] * H - 3, 6, 6);
  const b = $("cbar").getContext("2d");
  for (let x = 0; x < 512; x++) {
    b.fillStyle = hex(colourAt(evalTxf(txf.rgb, txfV(x + 0.5))));
    b.fillRect(x, 0, 1, 24);
  }
  txf.rgb.forEach((p, i) => {
    b.strokeStyle = i === selected ? "#ff0" : "#000";
    b.strokeRect(txfX(p[0]) - 3, 2, 6, 20);
  });
}
function evalTxf(pts, v) {   // for the colour bar only (the LUT is made by the server)
  if (!pts.length) return [0, 1, 1, 1];
  if (v <= pts[0][0]) return pts[0];
  for (let i = 1; i < pts.length; i++) {
    if (v <= pts[i][0]) {
      const a = pts[i - 1], b = pts[i], t = (v - a[0]) / (b[0] - a[0] || 1);
      return a.map((x, j) => x + (b[j] - x) * t);
    }
  }
  return pts[pts.length - 1];
}
function pointer(el, onDown, onMove) {
  el.addEventListener("pointerdown", (e) => {
    if (!onDown(e)) return;
    el.setPointerCapture(e.pointerId);
    const move = (m) => onMove(m);
    const up = () => { el.removeEventListener("pointermove", move); el.removeEventListener("pointerup", up); changed(false); };
    el.addEventListener("pointermove", move);
    el.addEventListener("pointerup", up);
  });
}
function setupTxf() {
  const c = $("txf"), H = c.height;
  let drag = -1;
  const pos = (e) => { const r = c.getBoundingClientRect(); return [((e.clientX - r.left) / r.width) * 512, ((e.clientY - r.top) / r.height) * H]; };
  pointer(c, (e) => {
    const [x, y] = pos(e);
    drag = txf.alpha.findIndex((p) => Math.abs(txfX(p[0]) - x) < 6 && Math.abs(H - p[1] * H - y) < 6);
    if (drag < 0) {
      txf.alpha.push([txfV(x), Math.min(1, Math.max(0, 1 - y / H))]);
      txf.alpha.sort((a, b) => a[0] - b[0]);
      drag = txf.alpha.findIndex((p) => p[0] === txfV(x));
    }
    drawTxf(); changed(true);
    return true;
  }, (e) => {
    const [x, y] = pos(e);
    const lo = drag > 0 ? txf.alpha[drag - 1][0] : -Infinity, hi = drag < txf.alpha.length - 1 ? txf.alpha[drag + 1][0] : Infinity;
    txf.alpha[drag] = [Math.min(hi, Math.max(lo, txfV(x))), Math.min(1, Math.max(0, 1 - y / H))];
    drawTxf(); changed(true);
  });
  c.addEventListener("dblclick", (e) => {
    const [x, y] = pos(e);
    const i = txf.alpha.findIndex((p) => Math.abs(txfX(p[0]) - x) < 6 && Math.abs(H - p[1] * H - y) < 6);
    if (i >= 0 && txf.alpha.length > 2) { txf.alpha.splice(i, 1); drawTxf(); changed(false); }
  });
  const b = $("cbar");
  let cdrag = -1;
  const bx = (e) => { const r = b.getBoundingClientRect(); return ((e.clientX - r.left) / r.width) * 512; };
  pointer(b, (e) => {
    const x = bx(e);
    cdrag = txf.rgb.findIndex((p) => Math.abs(txfX(p[0]) - x) < 5);
    if (cdrag < 0) {
      const v = txfV(x);
      txf.rgb.push([v, ...evalTxf(txf.rgb, v).slice(1)]);
      txf.rgb.sort((p, q) => p[0] - q[0]);
      cdrag = txf.rgb.findIndex((p) => p[0] === v);
    }
    selected = cdrag;
    $("pcol").value = hex(colourAt(txf.rgb[cdrag]));
    drawTxf(); changed(true);
    return true;
  }, (e) => {
    const i = cdrag;
    const lo = i > 0 ? txf.rgb[i - 1][0] : -Infinity, hi = i < txf.rgb.length - 1 ? txf.rgb[i + 1][0] : Infinity;
    txf.rgb[i][0] = Math.min(hi, Math.max(lo, txfV(bx(e))));
    drawTxf(); changed(true);
  });
  b.addEventListener("dblclick", (e) => {
    const i = txf.rgb.findIndex((p) => Math.abs(txfX(p[0]) - bx(e)) < 5);
    if (i >= 0 && txf.rgb.length > 2) { txf.rgb.splice(i, 1); selected = null; drawTxf(); changed(false); }
  });
  $("pcol").addEventListener("input", () => {
    if (selected === null || !txf.rgb[selected]) return;
    const h = $("pcol").value, rgb = [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16) / 255);
    txf.rgb[selected] = [txf.rgb[selected][0], ...(txf.space === "rgb" ? rgb : rgbToHsv(rgb))];
    drawTxf(); changed(true);
  });
  $("space").addEventListener("change", () => {
    const to = $("space").value;
    if (to === txf.space) return;
    txf.rgb = txf.rgb.map((p) => [p[0], ...(to === "rgb" ? hsvToRgb(p.slice(1)) : rgbToHsv(p.slice(1)))]);
    txf.space = to;
    drawTxf(); changed(false);
  });
  for (const [id, i] of [["mm0", 0], ["mm1", 1]]) {
    $(id).addEventListener("change", () => { const v = num($(id).value); if (isFinite(v)) { txf.mm[i] = v; drawTxf(); changed(false); } });
  }
  $("len").addEventListener("change", () => { txf.len = Math.max(1, Math.round(num($("len").value))); txfEdited = true; changed(false); });
}

// ---- the rest of the controls --------------------------------------------------------
function fillSelect(id, names) {
  const s = $(id);
  for (const n of names) { const o = document.createElement("option"); o.textContent = n; s.appendChild(o); }
  if (!names.includes(opts[id][0])) { const o = document.createElement("option"); o.textContent = opts[id][0]; s.appendChild(o); }
  s.value = opts[id][0];
  s.addEventListener("change", () => { opts[id] = [s.value]; showSets(); changed(false); });
}
function showSets() {
  $("txfset").style.display = usesLut() ? "" : "none";
  $("litset").style.display = usesLights() ? "" : "none";
}
function bindNumber(id, get, set) {
  const e = $(id);
  e.value = get();
  e.addEventListener("change", () => { const v = num(e.value); if (isFinite(v)) { set(v); changed(false); } });
}
function bindText(id, opt) {
  const e = $(id);
  e.value = opts[opt].join(" ");
  e.addEventListener("change", () => { opts[opt] = e.value.trim().split(/\s+/); changed(false); });
}
function setupImage() {
  const c = $("image");
  const down = new Map();   // pointers held: id -> [x, y]
  let panning = false, spread = 0;
  const gap = () => { const [a, b] = [...down.values()]; return Math.hypot(a[0] - b[0], a[1] - b[1]); };
  c.addEventListener("contextmenu", (e) => e.preventDefault());
  c.addEventListener("pointerdown", (e) => {
    down.set(e.pointerId, [e.clientX, e.clientY]);
    panning = e.shiftKey || e.button === 2;
    if (down.size === 2) spread = gap();
    c.setPointerCapture(e.pointerId);
  });
  c.addEventListener("pointermove", (e) => {
    const last = down.get(e.pointerId);
    if (!last) return;
    const r = c.getBoundingClientRect(), s = c.height / r.height;
    const dx = (e.clientX - last[0]) * s, dy = (e.clientY - last[1]) * s;
    down.set(e.pointerId, [e.clientX, e.clientY]);
    if (down.size === 2) {            // two fingers: pinch to zoom
      const g = gap();
      if (spread > 0 && g > 0) zoom(spread / g);
      spread = g;
    } else if (panning) pan(dx, dy); else orbit(dx, dy);
    changed(true);
  });
  const up = (e) => { down.delete(e.pointerId); spread = 0; };
  c.addEventListener("pointerup", up);
  c.addEventListener("pointercancel", up);
  c.addEventListener("wheel", (e) => { e.preventDefault(); zoom(Math.exp(e.deltaY * 0.001)); changed(true); }, { passive: false });
}

async function start() {
  const r = await fetch("info?t=" + TOKEN);
  if (!r.ok) { status(await r.text(), true); return; }
  info = await r.json();
  opts = parseWords(info.words);
  if (!opts.nt) opts.nt = [String(Math.min(2, info.max_threads))];
  home = { fr: opts.fr, at: opts.at, up: opts.up };
  $("volume").textContent = info.volume + ": " + info.sizes.join(" × ") + " " + info.voxel +
    ", values " + info.range.map(fmt).join(" to ");
  const [lo, hi] = info.range;
  txf.mm = [lo, hi];
  txf.rgb = [[lo, 0.9, 0.75, 0.65], [hi, 1, 1, 1]];
  txf.alpha = [[lo, 0], [lo + 0.15 * (hi - lo), 0], [lo + 0.3 * (hi - lo), 0.8], [hi, 0.8]];
  $("lights").value = info.lights || "#space:=rgb\n# one white light from the upper left (view space)\n1 1 1  -1 1 1  1\n";
  fillSelect("k", KERNELS); fillSelect("p", PROBES); fillSelect("b", BLENDS);
  bindNumber("s", () => opts.s[0], (v) => { opts.s = [String(v)]; });
  bindNumber("szw", () => opts.sz[0], (v) => { opts.sz[0] = String(Math.min(info.max_side, Math.max(1, Math.round(v)))); });
  bindNumber("szh", () => opts.sz[1], (v) => { opts.sz[1] = String(Math.min(info.max_side, Math.max(1, Math.round(v)))); });
  bindNumber("nt", () => opts.nt[0], (v) => { opts.nt = [String(Math.max(1, Math.round(v)))]; });
  bindNumber("fov", () => opts.fov[0], (v) => { opts.fov = [String(v)]; });
  bindNumber("mm0", () => txf.mm[0], () => {});
  bindNumber("mm1", () => txf.mm[1], () => {});
  bindNumber("len", () => txf.len, () => {});
  $("ortho").checked = "ortho" in opts;
  $("ortho").addEventListener("change", () => { if ($("ortho").checked) opts.ortho = []; else delete opts.ortho; changed(false); });
  bindText("ph", "ph"); bindText("dcn", "dcn"); bindText("dcf", "dcf");
  $("lights").addEventListener("change", () => changed(false));
  $("reset").addEventListener("click", () => { Object.assign(opts, home); changed(false); });
  for (const btn of document.querySelectorAll("[data-axis]")) {
    const [a, s] = btn.dataset.axis.split(" ").map(num);
    btn.addEventListener("click", () => { snap(a, s); changed(false); });
  }
  $("copy").addEventListener("click", async () => {
    const text = command();
    try { await navigator.clipboard.writeText(text); status("command copied"); } catch (_) {
      $("command").select(); document.execCommand("copy"); status("command copied");
    }
  });
  $("dl-nrrd").addEventListener("click", async () => {
    try {
      const blob = await post(request(true, "nrrd"));
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob); a.download = "rendr.nrrd"; a.click();
    } catch (e) { status(e.message, true); }
  });
  setupImage();
  setupTxf();
  showSets();
  drawTxf();
  changed(false);
}
start();
