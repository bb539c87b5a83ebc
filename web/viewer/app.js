// sonarproj view: the page. Every change posts the scene to /api/scene; the engine (in the
// sonarproj process) computes it and this script draws the answer: a 3-D view of both fields of
// view and the sampled arc or surface (three.js), sonar 2's data (fan seen from above, raw
// layout, or a sidescan's range strip), the metrics and the "copy as" texts.
//
// Picture convention (as every picture of sonarproj): near range at the bottom, port on the
// left; in the raw layout beam 0 (starboard-most) is the rightmost column.

import { setupAdvise } from "/advise.js";

const COLOURS = {
  s1: 0x1f77b4, s2: 0xff7f0e, seen: 0xd62728, unseen: 0xa0a4ab, truth: 0x111111, rec: 0x2ca02c,
};
const METRICS = ["visible", "total", "visible_fraction", "range_min", "range_max", "span", "azimuth_min",
  "azimuth_max", "occupied", "occupied_measure", "projection_area", "range_per_elevation",
  "sigma_elevation"];

const $ = (id) => document.getElementById(id);
const state = { sonars: new Map(), last: null, copy: "command", fitted: false, cameraMoved: false };
// Where the last 2-D picture put sonar 2's data (canvas pixels), for tests.
window.sonarprojDrawn = null;
// What a test harness or benchmark reads: one entry per answered update.
window.sonarprojStats = { updates: [], errors: 0 };

// ---------------------------------------------------------------- fields (slider + number)

const fields = new Map();

function buildFields() {
  for (const div of document.querySelectorAll(".field")) {
    const key = div.dataset.key;
    const label = document.createElement("label");
    label.textContent = div.dataset.label;
    const slider = document.createElement("input");
    slider.type = "range";
    const number = document.createElement("input");
    number.type = "number";
    number.step = "any";
    const id = "f-" + key.replace(".", "-");
    number.id = id;
    slider.id = id + "-slider";
    label.htmlFor = id;
    const unit = document.createElement("span");
    unit.textContent = div.dataset.unit;
    div.append(label, slider, number, unit);
    const f = { slider, number, div, last: "" };
    slider.addEventListener("input", () => { number.value = slider.value; f.last = slider.value; changed(); });
    number.addEventListener("input", () => {
      if (number.value !== "" && Number.isFinite(Number(number.value)) && !number.validity.badInput) {
        slider.value = number.value;
        f.last = number.value;
        changed();
      } else {
        // Not a number (a browser empties a number field that holds letters): say what is
        // allowed and keep the last value, which comes back when the field is left.
        showError(`${div.dataset.label} (${key.split(".")[0]}): not a number; type a number ` +
          `from ${+Number(slider.min).toPrecision(6)} to ${+Number(slider.max).toPrecision(6)} ` +
          `${div.dataset.unit} (the last value, ${f.last}, is kept)`);
      }
    });
    number.addEventListener("change", () => {
      if (number.value === "" || number.validity.badInput || !Number.isFinite(Number(number.value))) {
        number.value = f.last;
        changed();
      }
    });
    fields.set(key, f);
  }
}

function setRange(key, min, max, step) {
  const f = fields.get(key);
  f.slider.min = min;
  f.slider.max = max;
  f.slider.step = step;
}

function setValue(key, v) {
  const f = fields.get(key);
  const r = Number(Number(v).toPrecision(12));
  f.number.value = String(r);
  f.slider.value = String(r);
  f.last = String(r);
}

function value(key) {
  const f = fields.get(key);
  const text = f.number.value.trim();
  const v = Number(text);
  if (text !== "" && Number.isFinite(v) && !f.number.validity.badInput) return v;
  // A field being typed into holds no number yet: the scene keeps its last value.
  const last = Number(f.last);
  if (f.last !== "" && Number.isFinite(last)) return last;
  throw new Error(`${key.replace(".", " ")}: "${text}" is not a number`);
}

function clamp(v, lo, hi) { return Math.min(hi, Math.max(lo, v)); }

// ---------------------------------------------------------------- sonar pair

function sonar(which) { return state.sonars.get($(which).value); }

// Returns v where it lies in [lo, hi]; else the round value nearest v a tenth of the span inside
// the interval (15 m in a 0.1–10 m sonar gives 9 m).
function keepInside(v, lo, hi) {
  if (v >= lo && v <= hi) return v;
  const span = hi - lo, step = niceStep(span, 20);
  const r = Math.round(clamp(v, lo + 0.1 * span, hi - 0.1 * span) / step) * step;
  return Number(clamp(r, lo, hi).toPrecision(12));
}

// Returns a starting value: `preferred` where it lies in [lo, hi], else the middle, rounded.
function startInside(preferred, lo, hi) {
  if (preferred >= lo && preferred <= hi) return preferred;
  const step = niceStep(hi - lo, 20);
  return Number(clamp(Math.round((lo + hi) / 2 / step) * step, lo, hi).toPrecision(12));
}

// Sets the fields' ranges for the chosen pair. At the start every field takes its starting
// value; on a change of sonar the values that still apply stay (the pose always; a range or
// an angle while the new sonar's limits hold it, else the nearest round value inside them, or 0°).
function configurePair(first) {
  const s1 = sonar("from"), s2 = sonar("to");
  const r1 = s1.range_max - s1.range_min, r2 = s2.range_max - s2.range_min;
  const a1 = s1.azimuth_aperture / 2, e1 = s1.elevation_aperture / 2;
  const a2 = s2.azimuth_aperture / 2, e2 = s2.elevation_aperture / 2;
  const reach = Math.max(s1.range_max, s2.range_max);
  // [min, max, slider step]: a round step, so that a dragged slider gives round values
  const ranges = {
    "feature.range": [s1.range_min, s1.range_max, niceStep(r1, 1000)],
    "feature.azimuth": [-a1, a1, niceStep(2 * a1, 1000)],
    "feature.elevation": [-e1, e1, niceStep(2 * e1, 1000)],
    "place.range": [s2.range_min, s2.range_max, niceStep(r2, 1000)],
    "place.azimuth": [-a2, a2, niceStep(2 * a2, 1000)],
    "place.elevation": [-e2, e2, niceStep(2 * e2, 1000)],
    "second.range": [s2.range_min, s2.range_max, niceStep(r2, 1000)],
    "second.azimuth": [-a2, a2, niceStep(2 * a2, 1000)],
  };
  for (const k of ["x", "y", "z"]) ranges["translation." + k] = [-reach, reach, niceStep(2 * reach, 2000)];
  for (const k of ["roll", "pitch", "yaw"]) ranges["rotation." + k] = [-180, 180, 0.5];
  for (const [key, [lo, hi, step]] of Object.entries(ranges)) setRange(key, lo, hi, step);
  fields.get("second.azimuth").div.hidden = s2.kind !== "fls";
  fields.get("feature.azimuth").div.querySelector("label").textContent =
    s1.kind === "fls" ? "azimuth" : "azimuth*";
  $("feature-note").textContent = s1.kind === "fls"
    ? "An FLS measures range and azimuth; the elevation is lost (the arc)."
    : "A sidescan measures only the range; azimuth* and elevation place the true point on the surface.";
  $("pair-note").textContent = `${s1.kind.toUpperCase()} → ${s2.kind.toUpperCase()}`;
  if (first) {
    setValue("feature.range", startInside(5, s1.range_min, s1.range_max));
    setValue("feature.azimuth", 0);
    setValue("feature.elevation", 0);
    for (const k of ["roll", "pitch", "yaw"]) setValue("rotation." + k, 0);
    setValue("place.range", startInside(15, s2.range_min, s2.range_max));
    setValue("place.azimuth", 0);
    setValue("place.elevation", 0);
    for (const k of ["x", "y", "z"]) setValue("translation." + k, 0);
    setValue("translation.x", -1);
    setValue("second.range", fields.get("place.range").number.value);
    setValue("second.azimuth", 0);
  } else {
    for (const [key, [lo, hi]] of Object.entries(ranges)) {
      if (key.startsWith("rotation.")) continue;
      const v = Number(fields.get(key).last);
      if (!Number.isFinite(v)) continue;  // a field being typed into keeps its text
      const angle = /azimuth|elevation/.test(key);
      const kept = angle ? (v >= lo && v <= hi ? v : 0) : keepInside(v, lo, hi);
      if (kept !== v) setValue(key, kept);
    }
  }
  state.fitted = false;
}

// ---------------------------------------------------------------- the scene sent

function mode() { return document.querySelector("input[name=mode]:checked").value; }

function readScene() {
  const scene = {
    from: $("from").value,
    to: $("to").value,
    feature: { range: value("feature.range"), azimuth: value("feature.azimuth"), elevation: value("feature.elevation") },
    rotation: { roll: value("rotation.roll"), pitch: value("rotation.pitch"), yaw: value("rotation.yaw") },
  };
  if (mode() === "place") {
    scene.place = { range: value("place.range"), azimuth: value("place.azimuth"), elevation: value("place.elevation") };
  } else {
    scene.translation = [value("translation.x"), value("translation.y"), value("translation.z")];
  }
  if ($("exact").checked) scene.exact = true;
  else if (!$("auto-step").checked) scene.step = numberOf("step", "step");
  if ($("noise-on").checked) {
    scene.sigma = {};
    for (const k of ["roll", "pitch", "yaw", "tx", "ty", "tz", "range", "azimuth"]) {
      scene.sigma[k] = numberOf("sigma-" + k, "sigma " + k);
    }
    scene.coverage = numberOf("coverage", "coverage");
  }
  if ($("second-on").checked) {
    scene.second = { range: value("second.range") };
    if (sonar("to").kind === "fls") scene.second.azimuth = value("second.azimuth");
  }
  return scene;
}

function numberOf(id, name) {
  const text = $(id).value.trim();
  const v = Number(text);
  if (text === "" || !Number.isFinite(v)) throw new Error(`${name}: "${text}" is not a number`);
  return v;
}

// One request at a time; a change during a request is sent when it returns (the latest wins).
let inflight = false, pending = false, changedAt = 0;

function changed() {
  changedAt = performance.now();
  if (inflight) { pending = true; return; }
  send();
}

async function send() {
  const started = changedAt;
  let scene;
  try {
    scene = readScene();
  } catch (e) {
    showError(e.message);
    return;
  }
  inflight = true;
  try {
    const res = await fetch("/api/scene", {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(scene),
    });
    const body = await res.json();
    if (!res.ok) {
      showError(body.error || `the server answered ${res.status}`);
    } else {
      showError(null);
      render(body, performance.now() - started);
      window.sonarprojStats.updates.push({ ms: performance.now() - started, compute_ms: body.compute_ms });
    }
  } catch (e) {
    showError(`no answer from the viewer's server (${e.message}); is \`sonarproj view\` still running?`);
  } finally {
    inflight = false;
    document.body.dataset.updates = String(window.sonarprojStats.updates.length);
    if (pending) { pending = false; send(); }
  }
}

function showError(message) {
  const box = $("error");
  // What is on screen is the last good scene's until an answer comes: greyed while an error
  // stands, and said so.
  document.body.classList.toggle("stale", Boolean(message) && Boolean(state.last));
  if (message) {
    box.textContent = state.last
      ? `${message} — the views and metrics below are greyed: they show the last good scene.`
      : message;
    box.hidden = false;
    window.sonarprojStats.errors += 1;
    document.body.dataset.errors = String(window.sonarprojStats.errors);
  } else {
    box.hidden = true;
    box.textContent = "";
  }
}

// ---------------------------------------------------------------- rendering an answer

function fmt(v, digits) {
  if (v === null || v === undefined) return "—";
  if (Number.isInteger(v) && digits === undefined) return String(v);
  return Number(v).toPrecision(digits || 7);
}

function render(r, roundTrip) {
  state.last = r;
  window.sonarprojLast = r;
  for (const name of METRICS) {
    const el = $("m-" + name);
    const v = r.metrics[name];
    el.textContent = fmt(v);
    el.dataset.value = v === null ? "" : String(v);
  }
  $("m-mask").textContent = r.mask
    ? `${r.mask.count} ${r.to.kind === "fls" ? "pixels" : "bins"} (ball radius ${fmt(r.mask.radius, 3)} m)`
    : "— (turn on noise)";
  $("m-recovery").textContent = recoveryText(r.recovery);
  // (the device is named in the header; one short line keeps the panels' sizes still)
  $("m-time").textContent = `${r.compute_ms.toFixed(1)} ms engine, ${roundTrip.toFixed(1)} ms round trip`;
  $("m-time").title = `computed on ${r.device}`;
  $("copy-text").textContent = r.copy[state.copy];
  drawData();
  update3d(r);
}

function recoveryText(rec) {
  if (!rec) return "— (give a second measurement)";
  const c = rec.candidates;
  const flags = rec.flags.length ? `; flags: ${rec.flags.join(", ")}` : "";
  if (rec.curve) return `a curve of ${fmt(rec.curve.length, 4)} m seen by both (${c.length} points)${flags}`;
  if (!c.length) return `no point fits both measurements${flags}`;
  const b = c[0];
  return `${c.length} candidate(s); best: elevation ${fmt(b.first[2], 5)}° in sonar 1, ` +
    `${fmt(b.second[2], 5)}° in sonar 2${b.in_view ? "" : " (outside a field of view)"}${flags}`;
}

// ---------------------------------------------------------------- sonar 2's data, 2-D

function occupancyGrid(o) {
  const grid = new Uint8Array(o.range_bins * o.beams);
  for (const [start, len] of o.runs) grid.fill(1, start, start + len);
  return grid;
}

// Calls fn(row, j0, j1) for every run of set pixels, split at row ends.
function eachRun(runs, beams, fn) {
  for (const [start, len] of runs) {
    let k = start;
    const end = start + len;
    while (k < end) {
      const row = Math.floor(k / beams), j0 = k % beams;
      const j1 = Math.min(beams - 1, j0 + (end - k) - 1);
      fn(row, j0, j1);
      k += j1 - j0 + 1;
    }
  }
}

function niceStep(span, target) {
  const raw = span / target;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 2.5, 5, 10]) if (m * p >= raw) return m * p;
  return 10 * p;
}

function drawData() {
  const r = state.last;
  const canvas = $("data-canvas");
  const ctx = canvas.getContext("2d");
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!r) return;
  ctx.font = "13px system-ui, sans-serif";
  // A sidescan's data is its range strip: one view, so the choice is switched off.
  const view = $("layout-view");
  view.disabled = r.to.kind === "sss";
  view.title = view.disabled ? "a sidescan's data is one range strip (per side): there is one view" : "";
  if (r.to.kind === "sss") drawStrip(ctx, canvas, r);
  else if ($("layout-view").value === "raw") drawRaw(ctx, canvas, r);
  else drawFan(ctx, canvas, r);
}

// Returns the fan's geometry on the canvas: sonar 2 at (cx, cy), forward up, port (+y) left.
function fanGeometry(canvas, s) {
  const half = s.azimuth_aperture / 2 * Math.PI / 180;
  const pts = [[0, 0]];
  for (let i = 0; i <= 64; i++) {
    const a = -half + 2 * half * i / 64;
    pts.push([s.range_max * Math.cos(a), s.range_max * Math.sin(a)]);
  }
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  const [xmin, xmax, ymin, ymax] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  const pad = { l: 70, r: 70, t: 34, b: 40 };
  const scale = Math.min((canvas.width - pad.l - pad.r) / (ymax - ymin), (canvas.height - pad.t - pad.b) / (xmax - xmin));
  const cx = pad.l + (ymax / (ymax - ymin)) * (ymax - ymin) * scale +
    ((canvas.width - pad.l - pad.r) - (ymax - ymin) * scale) / 2;
  const cy = pad.t + xmax * scale + ((canvas.height - pad.t - pad.b) - (xmax - xmin) * scale) / 2;
  // canvas angle of azimuth a (rad): forward is up, +azimuth (port) to the left.
  const ang = (a) => -Math.PI / 2 - a;
  return { cx, cy, scale, half, ang };
}

function sector(ctx, g, r0, r1, a0, a1) {
  ctx.beginPath();
  // azimuth a0 < a1 → canvas angles ang(a0) > ang(a1); draw counter-clockwise from ang(a0).
  ctx.arc(g.cx, g.cy, r1 * g.scale, g.ang(a0), g.ang(a1), true);
  ctx.arc(g.cx, g.cy, Math.max(r0, 0) * g.scale, g.ang(a1), g.ang(a0), false);
  ctx.closePath();
}

// Fills the canvas pixels the rectangle touches (whole pixels, at least one): small regions are
// drawn in their exact colour instead of an anti-aliased blend.
function snapRect(ctx, x, y, w, h) {
  const x0 = Math.floor(x), y0 = Math.floor(y);
  const x1 = Math.max(x0 + 1, Math.ceil(x + w)), y1 = Math.max(y0 + 1, Math.ceil(y + h));
  ctx.fillRect(x0, y0, x1 - x0, y1 - y0);
}

function drawFan(ctx, canvas, r) {
  const s = r.to, g = fanGeometry(canvas, s);
  const edges = s.beam_edges.map((e) => e * Math.PI / 180);
  const dr = (s.range_max - s.range_min) / s.range_bins;
  ctx.fillStyle = "#e8eef7";
  ctx.strokeStyle = "#9aa8bd";
  sector(ctx, g, s.range_min, s.range_max, -g.half, g.half);
  ctx.fill();
  ctx.stroke();
  const paint = (runs, fill) => {
    ctx.fillStyle = fill;
    ctx.strokeStyle = fill;
    ctx.lineWidth = 0.8;
    eachRun(runs, s.beams, (row, j0, j1) => {
      const r0 = s.range_min + row * dr, a0 = edges[j0], a1 = edges[j1 + 1];
      sector(ctx, g, r0, r0 + dr, a0, a1);
      ctx.fill();
      ctx.stroke();
      // a region smaller than 2 canvas pixels is drawn as a 3-pixel square, so it stays visible
      if (dr * g.scale < 2 || (a1 - a0) * (r0 + dr) * g.scale < 2) {
        const rm = r0 + dr / 2, am = (a0 + a1) / 2;
        snapRect(ctx, g.cx + Math.cos(g.ang(am)) * rm * g.scale - 1.5, g.cy + Math.sin(g.ang(am)) * rm * g.scale - 1.5, 3, 3);
      }
    });
  };
  if (r.mask) paint(r.mask.runs, "#fdd0a2");
  paint(r.occupancy.runs, "#d62728");
  // range rings and bearings
  ctx.strokeStyle = "rgba(60,70,90,0.35)";
  ctx.fillStyle = "#374151";
  ctx.lineWidth = 1;
  const step = niceStep(s.range_max, 5);
  ctx.textAlign = "left";
  for (let q = step; q <= s.range_max + 1e-9; q += step) {
    ctx.beginPath();
    ctx.arc(g.cx, g.cy, q * g.scale, g.ang(-g.half), g.ang(g.half), true);
    ctx.stroke();
    const a = g.ang(-g.half);
    ctx.fillText(`${+q.toPrecision(6)} m`, g.cx + Math.cos(a) * q * g.scale + 4, g.cy + Math.sin(a) * q * g.scale + 4);
  }
  const bstep = niceStep(2 * g.half * 180 / Math.PI, 6);
  ctx.textAlign = "center";
  for (let b = -Math.floor(g.half * 180 / Math.PI / bstep) * bstep; b <= g.half * 180 / Math.PI + 1e-9; b += bstep) {
    const a = g.ang(b * Math.PI / 180);
    ctx.beginPath();
    ctx.moveTo(g.cx, g.cy);
    ctx.lineTo(g.cx + Math.cos(a) * s.range_max * g.scale, g.cy + Math.sin(a) * s.range_max * g.scale);
    ctx.stroke();
    const t = s.range_max * g.scale + 14;
    ctx.fillText(`${b > 0 ? "+" : ""}${+b.toPrecision(4)}°`, g.cx + Math.cos(a) * t, g.cy + Math.sin(a) * t + 4);
  }
  window.sonarprojDrawn = { view: "fan", cx: g.cx, cy: g.cy, scale: g.scale };
  ctx.font = "bold 14px system-ui, sans-serif";
  ctx.textAlign = "left";
  ctx.fillText("◀ port", 8, canvas.height - 12);
  ctx.textAlign = "right";
  ctx.fillText("starboard ▶", canvas.width - 8, canvas.height - 12);
  ctx.textAlign = "center";
  ctx.font = "12px system-ui, sans-serif";
  ctx.fillText("sonar 2, seen from above (forward up)", canvas.width / 2, canvas.height - 12);
}

function axisLayout(canvas) {
  return { l: 64, r: 24, t: 30, b: 56, w: canvas.width - 88, h: canvas.height - 86 };
}

function drawRaw(ctx, canvas, r) {
  const s = r.to, p = axisLayout(canvas);
  const cw = p.w / s.beams, rh = p.h / s.range_bins;
  // column of beam j: beam 0 (starboard-most) at the right.
  const x = (j) => p.l + (s.beams - 1 - j) * cw;
  const y = (row) => p.t + p.h - (row + 1) * rh;
  ctx.fillStyle = "#e8eef7";
  ctx.fillRect(p.l, p.t, p.w, p.h);
  const paint = (runs, fill) => {
    ctx.fillStyle = fill;
    eachRun(runs, s.beams, (row, j0, j1) => {
      snapRect(ctx, x(j1), y(row), (j1 - j0 + 1) * cw, rh);
    });
  };
  if (r.mask) paint(r.mask.runs, "#fdd0a2");
  paint(r.occupancy.runs, "#d62728");
  ctx.strokeStyle = "#9aa8bd";
  ctx.strokeRect(p.l, p.t, p.w, p.h);
  window.sonarprojDrawn = { view: "raw", left: p.l, top: p.t, width: p.w, height: p.h };
  ctx.fillStyle = "#374151";
  ctx.textAlign = "center";
  for (const j of [s.beams - 1, Math.floor((s.beams - 1) / 2), 0]) {
    ctx.fillText(String(j), x(j) + cw / 2, p.t + p.h + 16);
  }
  ctx.fillText("beam (0 = starboard-most, on the right)", p.l + p.w / 2, p.t + p.h + 34);
  ctx.font = "bold 14px system-ui, sans-serif";
  ctx.textAlign = "left";
  ctx.fillText("◀ port", 8, canvas.height - 8);
  ctx.textAlign = "right";
  ctx.fillText("starboard ▶", canvas.width - 8, canvas.height - 8);
  ctx.font = "13px system-ui, sans-serif";
  rangeAxis(ctx, s, p, "range bin (near range at the bottom)");
}

function rangeAxis(ctx, s, p, title) {
  ctx.textAlign = "right";
  ctx.fillStyle = "#374151";
  const step = niceStep(s.range_max - s.range_min, 6);
  for (let q = Math.ceil(s.range_min / step) * step; q <= s.range_max + 1e-9; q += step) {
    const yy = p.t + p.h - (q - s.range_min) / (s.range_max - s.range_min) * p.h;
    ctx.fillText(`${+q.toPrecision(6)} m`, p.l - 6, yy + 4);
  }
  ctx.save();
  ctx.translate(Math.max(14, p.l - 50), p.t + p.h / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = "center";
  ctx.fillText(title, 0, 0);
  ctx.restore();
}

function drawStrip(ctx, canvas, r) {
  const s = r.to;
  // A two-sided sidescan's data is one row: port far to near (index n - 1 - bin), then
  // starboard near to far (n + bin); it is drawn as a port strip left of a starboard strip.
  // A one-sided channel is one strip. Strips are at most 240 pixels wide, centred.
  const twoSided = s.beams === 2;
  const gap = twoSided ? 24 : 0;
  const room = canvas.width - 2 * 110;
  const sw = Math.max(40, Math.min(240, twoSided ? (room - gap) / 2 : room));
  const p = { t: 30, b: 56, w: twoSided ? 2 * sw + gap : sw };
  p.l = Math.round((canvas.width - p.w) / 2);
  p.h = canvas.height - p.t - p.b;
  const n = s.range_bins;
  const rh = p.h / n;
  const strips = twoSided ? [p.l, p.l + sw + gap] : [p.l];
  ctx.fillStyle = "#e8eef7";
  for (const x of strips) ctx.fillRect(x, p.t, sw, p.h);
  // Paints range bins [b0, b1) of strip x, at least 3 pixels high (centred), so that one bin
  // of thousands stays visible.
  const bins = (x, b0, b1) => {
    const h = (b1 - b0) * rh, y = p.t + p.h - b1 * rh;
    if (h >= 3) snapRect(ctx, x, y, sw, h);
    else snapRect(ctx, x, y + h / 2 - 1.5, sw, 3);
  };
  const paint = (runs, fill) => {
    ctx.fillStyle = fill;
    for (const [start, len] of runs) {
      const end = start + len;
      if (!twoSided) { bins(p.l, start, end); continue; }
      if (start < n) bins(strips[0], n - Math.min(end, n), n - start);
      if (end > n) bins(strips[1], Math.max(start, n) - n, end - n);
    }
  };
  if (r.mask) paint(r.mask.runs, "#fdd0a2");
  paint(r.occupancy.runs, "#d62728");
  ctx.strokeStyle = "#9aa8bd";
  for (const x of strips) ctx.strokeRect(x, p.t, sw, p.h);
  window.sonarprojDrawn = { view: "strip", left: p.l, top: p.t, width: p.w, height: p.h, sides: strips.length };
  rangeAxis(ctx, s, p, "range (near range at the bottom)");
  ctx.fillStyle = "#374151";
  ctx.textAlign = "center";
  const mid = canvas.width / 2;
  if (twoSided) {
    ctx.fillText("port", strips[0] + sw / 2, p.t + p.h + 18);
    ctx.fillText("starboard", strips[1] + sw / 2, p.t + p.h + 18);
    ctx.fillText("a two-sided sidescan: each side's range bins", mid, p.t + p.h + 34);
    // Which side is which, where both are drawn.
    ctx.font = "bold 14px system-ui, sans-serif";
    ctx.textAlign = "left";
    ctx.fillText("◀ port", 8, canvas.height - 8);
    ctx.textAlign = "right";
    ctx.fillText("starboard ▶", canvas.width - 8, canvas.height - 8);
  } else {
    ctx.fillText("one sidescan channel: range bins only", mid, p.t + p.h + 18);
    ctx.fillText("(port and starboard are separate channels)", mid, p.t + p.h + 34);
  }
}

// ---------------------------------------------------------------- 3-D

const three = { ok: false };

async function init3d() {
  let THREE, OrbitControls;
  try {
    THREE = await import("/vendor/three/three.module.min.js");
    ({ OrbitControls } = await import("/vendor/three/OrbitControls.js"));
    const canvas = $("three-canvas");
    if (!canvas.getContext("webgl2") && !canvas.getContext("webgl")) throw new Error("no WebGL");
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(canvas.clientWidth || canvas.width, canvas.clientHeight || canvas.height, false);
    renderer.setClearColor(0xffffff);
    const scene = new THREE.Scene();
    const camera = new THREE.PerspectiveCamera(45, (canvas.clientWidth || canvas.width) / (canvas.clientHeight || canvas.height), 0.01, 5000);
    camera.up.set(0, 0, 1);  // the sonars' z is up
    camera.position.set(-8, -8, 6);
    const controls = new OrbitControls(camera, canvas);
    controls.addEventListener("change", draw3d);
    // The person moved the camera: a resize keeps it where they put it.
    controls.addEventListener("start", () => { state.cameraMoved = true; });
    scene.add(new THREE.AxesHelper(1));
    Object.assign(three, { ok: true, THREE, renderer, scene, camera, controls, dynamic: [], ring: ringTexture(THREE) });
  } catch (e) {
    $("three-canvas").hidden = true;
    $("three-overlay").hidden = true;
    $("no-webgl").hidden = false;
    $("fit").disabled = $("fit-all").disabled = true;
  }
}

// Returns a texture of a ring: the true point is drawn as one, so that the samples under it show.
function ringTexture(THREE) {
  const c = document.createElement("canvas");
  c.width = c.height = 64;
  const ctx = c.getContext("2d");
  ctx.strokeStyle = "#111";
  ctx.lineWidth = 6;
  ctx.beginPath();
  ctx.arc(32, 32, 28, 0, 2 * Math.PI);
  ctx.stroke();
  return new THREE.CanvasTexture(c);
}

function fovLines(THREE, s, colour) {
  const half = s.azimuth_aperture / 2 * Math.PI / 180, eh = s.elevation_aperture / 2 * Math.PI / 180;
  const sph = (r, a, e) => new THREE.Vector3(r * Math.cos(e) * Math.cos(a), r * Math.cos(e) * Math.sin(a), r * Math.sin(e));
  const pts = [];
  const seg = (p, q) => pts.push(p, q);
  const n = 48;
  for (const r of [s.range_min, s.range_max]) {
    if (r <= 0) continue;
    for (const e of [-eh, eh]) for (let i = 0; i < n; i++) seg(sph(r, -half + 2 * half * i / n, e), sph(r, -half + 2 * half * (i + 1) / n, e));
    for (const a of [-half, half]) for (let i = 0; i < 12; i++) seg(sph(r, a, -eh + 2 * eh * i / 12), sph(r, a, -eh + 2 * eh * (i + 1) / 12));
  }
  for (const a of [-half, half]) for (const e of [-eh, eh]) seg(sph(s.range_min, a, e), sph(s.range_max, a, e));
  const geom = new THREE.BufferGeometry().setFromPoints(pts);
  return new THREE.LineSegments(geom, new THREE.LineBasicMaterial({ color: colour, transparent: true, opacity: 0.7 }));
}

// Returns a sidescan's thin fan as a faint sheet (its middle elevation), so that where it cuts
// the arc shows; null for an imaging sonar, whose field of view is a volume.
function fanSheet(THREE, s, colour) {
  if (s.kind !== "sss") return null;
  const half = s.azimuth_aperture / 2 * Math.PI / 180, n = 64;
  const pos = [];
  for (let i = 0; i < n; i++) {
    const a0 = -half + 2 * half * i / n, a1 = -half + 2 * half * (i + 1) / n;
    const p = (r, a) => [r * Math.cos(a), r * Math.sin(a), 0];
    const [q0, q1, q2, q3] = [p(s.range_min, a0), p(s.range_max, a0), p(s.range_max, a1), p(s.range_min, a1)];
    pos.push(...q0, ...q1, ...q2, ...q0, ...q2, ...q3);
  }
  const geom = new THREE.BufferGeometry();
  geom.setAttribute("position", new THREE.Float32BufferAttribute(pos, 3));
  const mesh = new THREE.Mesh(geom, new THREE.MeshBasicMaterial({
    color: colour, transparent: true, opacity: 0.1, side: THREE.DoubleSide, depthWrite: false,
  }));
  return mesh;
}

function points(THREE, positions, material, kind) {
  const geom = new THREE.BufferGeometry();
  geom.setAttribute("position", new THREE.Float32BufferAttribute(positions, 3));
  const o = new THREE.Points(geom, material);
  o.userData.kind = kind;
  return o;
}

function update3d(r) {
  if (!three.ok) return;
  const { THREE, scene } = three;
  for (const o of three.dynamic) {
    scene.remove(o);
    o.traverse((c) => { c.geometry && c.geometry.dispose(); c.material && c.material.dispose(); });
  }
  three.dynamic = [];
  const add = (o) => { if (o) { scene.add(o); three.dynamic.push(o); } return o; };
  add(fovLines(THREE, r.from, COLOURS.s1));
  add(fanSheet(THREE, r.from, COLOURS.s1));
  // sonar 2's frame in sonar 1's: p1 = Rᵀ (p2 − t); rotation[i] is row i of R.
  const R = r.pose.rotation, t = r.pose.translation;
  const m = new THREE.Matrix4();
  const rt = [0, 1, 2].map((i) => -(R[0][i] * t[0] + R[1][i] * t[1] + R[2][i] * t[2]));
  m.set(R[0][0], R[1][0], R[2][0], rt[0], R[0][1], R[1][1], R[2][1], rt[1], R[0][2], R[1][2], R[2][2], rt[2], 0, 0, 0, 1);
  const g2 = new THREE.Group();
  g2.add(fovLines(THREE, r.to, COLOURS.s2));
  const sheet2 = fanSheet(THREE, r.to, COLOURS.s2);
  if (sheet2) g2.add(sheet2);
  g2.add(new THREE.AxesHelper(0.6));
  g2.matrixAutoUpdate = false;
  g2.matrix.copy(m);
  add(g2);
  three.origins = [new THREE.Vector3(0, 0, 0), new THREE.Vector3(...rt)];
  // The samples: those sonar 2 sees larger, and drawn over everything else.
  const pos = r.samples.first, vis = r.samples.visible;
  const seenPos = [], unseenPos = [];
  vis.forEach((v, k) => (v ? seenPos : unseenPos).push(pos[3 * k], pos[3 * k + 1], pos[3 * k + 2]));
  add(points(THREE, unseenPos, new THREE.PointsMaterial({ size: 3, sizeAttenuation: false, color: COLOURS.unseen }), "samples"));
  const seen = add(points(THREE, seenPos, new THREE.PointsMaterial({
    size: 5, sizeAttenuation: false, color: COLOURS.seen, depthTest: false,
  }), "samples"));
  seen.renderOrder = 2;
  const f = readSceneSafe();
  if (f) {
    const e = f.feature.elevation * Math.PI / 180, a = f.feature.azimuth * Math.PI / 180;
    const p = [f.feature.range * Math.cos(e) * Math.cos(a), f.feature.range * Math.cos(e) * Math.sin(a), f.feature.range * Math.sin(e)];
    const truth = add(points(THREE, p, new THREE.PointsMaterial({
      size: 21, sizeAttenuation: false, map: three.ring, transparent: true, alphaTest: 0.3, depthTest: false,
    }), "truth"));
    truth.renderOrder = 3;
  }
  if (r.recovery && r.recovery.candidates.length) {
    const rp = r.recovery.candidates.flatMap((c) => c.point_first);
    const rec = add(points(THREE, rp, new THREE.PointsMaterial({ size: 8, sizeAttenuation: false, color: COLOURS.rec, depthTest: false }), "recovered"));
    rec.renderOrder = 1;
  }
  if (!state.fitted) fit(false);
  draw3d();
}

function readSceneSafe() { try { return readScene(); } catch (e) { return null; } }

// Calls `each(v)` with every drawn vertex of the objects `which` accepts (default: all, both
// fields of view, the sampled set, the truth and the recovered points) in world coordinates;
// `v` is reused between calls.
function eachVertex(each, which) {
  const v = new three.THREE.Vector3();
  for (const o of three.dynamic) {
    if (which && !which(o)) continue;
    o.updateMatrixWorld(true);
    o.traverse((c) => {
      const pos = c.geometry && c.geometry.getAttribute("position");
      if (!pos) return;
      for (let k = 0; k < pos.count; k++) each(v.fromBufferAttribute(pos, k).applyMatrix4(c.matrixWorld));
    });
  }
}

// Returns the extent of the given points on the 3-D canvas in normalised device coordinates
// (−1 to 1 is on the canvas).
function extent(pts) {
  const { camera } = three;
  camera.updateMatrixWorld();
  const e = { left: Infinity, right: -Infinity, bottom: Infinity, top: -Infinity, points: 0 };
  const v = new three.THREE.Vector3();
  for (const p of pts) {
    v.copy(p).project(camera);
    e.left = Math.min(e.left, v.x); e.right = Math.max(e.right, v.x);
    e.bottom = Math.min(e.bottom, v.y); e.top = Math.max(e.top, v.y);
    e.points += 1;
  }
  return e;
}

// Returns the vertices of the drawn objects of a kind ("samples", "truth", "recovered"), or of
// all drawn objects.
function vertices(kind) {
  const out = [];
  eachVertex((v) => out.push(v.clone()), kind ? (o) => o.userData.kind === kind : null);
  return out;
}

// For tests: the extent on the canvas of everything drawn, or of one kind of points.
window.sonarprojFraming = (kind) => (three.ok ? extent(vertices(kind)) : null);

// Returns what "frame the feature" shows: the sampled arc or surface, the true point and the
// recovered points (`focus`), and the sonars whose origins are near them (`context`: within
// three times the focus's radius; a farther sonar's label points to it from the edge).
function featurePoints() {
  const focus = [...vertices("samples"), ...vertices("truth"), ...vertices("recovered")];
  if (!focus.length) return { focus: vertices(), context: [] };
  const sphere = new three.THREE.Sphere().setFromPoints(focus);
  const near = Math.max(3 * sphere.radius, 0.5);
  return { focus, context: three.origins.filter((o) => o.distanceTo(sphere.center) <= near) };
}

// Returns the direction from the orbit centre to the camera: from behind, starboard and above
// for the whole scene; for the feature, mostly square to the plane through sonar 1 and the arc
// (an imaging sonar's arc is seen from its side, a sidescan's from above), tilted that way.
function viewDirection(whole) {
  const THREE = three.THREE;
  const usual = new THREE.Vector3(-0.6, -0.9, 0.7).normalize();
  const samples = vertices("samples");
  if (whole || samples.length < 2) return usual;
  const centroid = new THREE.Vector3();
  for (const p of samples) centroid.add(p);
  centroid.divideScalar(samples.length);
  const farthest = (from) => samples.reduce((a, p) => (p.distanceToSquared(from) > a.distanceToSquared(from) ? p : a));
  const a = farthest(centroid), b = farthest(a);
  const o1 = three.origins[0];
  const n = new THREE.Vector3().crossVectors(a.clone().sub(o1), b.clone().sub(o1));
  const scale = a.distanceTo(o1) * b.distanceTo(o1);
  if (!(n.length() > 1e-3 * scale)) return usual;  // the arc points at sonar 1: no plane
  n.normalize();
  if (n.dot(usual) < 0) n.negate();
  return n.addScaledVector(usual, 0.5).normalize();
}

// Frames the feature (or, `whole`, everything drawn): the camera looks from `viewDirection` at
// the sphere around the framed points, from as far back as that sphere needs, then closes in
// (a few steps, never nearer than the sphere's radius, so that nothing framed falls behind the
// camera) until the framed points fill 90 % of the canvas, the feature at most 55 %: the arc is
// large, with room around it for the fields of view that cross it.
function fit(whole) {
  if (!three.ok || !three.dynamic.length) return;
  const { THREE, camera, controls } = three;
  const { focus, context } = whole ? { focus: [], context: vertices() } : featurePoints();
  const pts = [...focus, ...context];
  const sphere = new THREE.Sphere().setFromPoints(pts);
  const all = new THREE.Sphere().setFromPoints(vertices());
  const radius = Math.max(sphere.radius, 0.25);
  const tanV = Math.tan(camera.fov * Math.PI / 360), tanH = tanV * camera.aspect;
  const towards = viewDirection(whole);
  let distance = 1.05 * radius / Math.sin(Math.atan(Math.min(tanV, tanH)));
  controls.target.copy(sphere.center);
  camera.position.copy(sphere.center).addScaledVector(towards, distance);
  camera.lookAt(controls.target);
  const halfOf = (e) => Math.max(e.right - e.left, e.top - e.bottom) / 2;
  for (let step = 0; step < 5; step++) {
    const e = extent(pts);
    const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
    const up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
    const shift = right.multiplyScalar((e.left + e.right) / 2 * distance * tanH)
      .add(up.multiplyScalar((e.bottom + e.top) / 2 * distance * tanV));
    const ratio = Math.max(halfOf(e) / 0.9, focus.length ? halfOf(extent(focus)) / 0.55 : 0);
    distance = Math.max(1.01 * radius, distance * ratio);
    controls.target.add(shift);
    camera.position.copy(controls.target).addScaledVector(towards, distance);
    camera.lookAt(controls.target);
  }
  // Near and far planes that hold everything drawn, not only what is framed.
  camera.near = Math.max(radius, 0.05) / 1000;
  camera.far = (distance + camera.position.distanceTo(all.center) + all.radius) * 1.5;
  camera.updateProjectionMatrix();
  controls.update();
  state.fitted = true;
  state.cameraMoved = false;
}

// Draws the 3-D view and what lies over it: a scale bar (its length at the orbit centre) and the
// two sonars' labels, at their origins or, where one is off the canvas, at the edge towards it.
function draw3d() {
  if (!three.ok) return;
  three.renderer.render(three.scene, three.camera);
  const { camera, controls } = three;
  const canvas = $("three-canvas");
  const W = canvas.clientWidth, H = canvas.clientHeight;
  const distance = camera.position.distanceTo(controls.target);
  const perMetre = H / (2 * distance * Math.tan(camera.fov * Math.PI / 360));
  const metres = niceStep(60 / perMetre, 1);
  const bar = $("scale-bar");
  bar.querySelector(".bar").style.width = `${(metres * perMetre).toFixed(1)}px`;
  $("scale-label").textContent = metres >= 1 ? `${+metres.toPrecision(3)} m` : `${+(100 * metres).toPrecision(3)} cm`;
  bar.dataset.metres = String(metres);
  bar.dataset.pixels = String(metres * perMetre);
  if (!three.origins) return;
  const truth = vertices("truth")[0];
  three.origins.forEach((o, k) => placeLabel($(`origin-${k + 1}`), `sonar ${k + 1}`, o, truth, W, H));
  // Two labels on one spot: the second moves below the first.
  const [l1, l2] = [$("origin-1"), $("origin-2")];
  const b1 = l1.getBoundingClientRect(), b2 = l2.getBoundingClientRect();
  if (b1.left < b2.right && b2.left < b1.right && b1.top < b2.bottom && b2.top < b1.bottom) {
    l2.style.top = `${(parseFloat(l2.style.top) + (b1.bottom - b2.top) + 2).toFixed(1)}px`;
  }
}

const ARROWS = ["→", "↗", "↑", "↖", "←", "↙", "↓", "↘"];

function placeLabel(el, name, p, truth, W, H) {
  const { camera } = three;
  const c = p.clone().applyMatrix4(camera.matrixWorldInverse);  // camera space: −z ahead
  const ndc = p.clone().project(camera);
  const inFront = c.z < -camera.near;
  if (inFront && Math.abs(ndc.x) <= 1 && Math.abs(ndc.y) <= 1) {
    el.textContent = name;
    el.style.left = `${((ndc.x + 1) / 2 * W + 6).toFixed(1)}px`;
    el.style.top = `${((1 - ndc.y) / 2 * H - 8).toFixed(1)}px`;
    el.style.transform = "";
    el.dataset.where = "on";
    return;
  }
  // Off the canvas: at the edge, in the direction of the sonar from the centre.
  let dx = inFront ? ndc.x : c.x, dy = inFront ? ndc.y : c.y;
  if (!inFront && dx === 0 && dy === 0) dy = -1;
  const k = Math.max(Math.abs(dx), Math.abs(dy)) / 0.92;
  dx /= k; dy /= k;
  const angle = Math.atan2(dy * H, dx * W);
  const arrow = ARROWS[((Math.round(angle / (Math.PI / 4)) % 8) + 8) % 8];
  const away = truth ? `, ${+p.distanceTo(truth).toPrecision(3)} m away` : "";
  el.textContent = `${arrow} ${name}${away}`;
  el.style.left = `${((dx + 1) / 2 * W).toFixed(1)}px`;
  el.style.top = `${((1 - dy) / 2 * H).toFixed(1)}px`;
  // keep the label inside: anchored by its side towards the centre
  el.style.transform = `translate(${(-50 - 50 * dx).toFixed(0)}%, ${(-50 + 50 * dy).toFixed(0)}%)`;
  el.dataset.where = "edge";
}

// Sizes the canvases' drawing buffers to what the layout gives them and draws again (the 3-D
// view framed again while the person has not moved its camera).
function sizeCanvases() {
  const data = $("data-canvas");
  const w = Math.round(data.clientWidth), h = Math.round(data.clientHeight);
  if (w > 0 && h > 0 && (data.width !== w || data.height !== h)) {
    data.width = w;
    data.height = h;
    drawData();
  }
  if (!three.ok) return;
  const c3 = $("three-canvas");
  const w3 = Math.round(c3.clientWidth), h3 = Math.round(c3.clientHeight);
  if (w3 <= 0 || h3 <= 0 || (three.size && three.size[0] === w3 && three.size[1] === h3)) return;
  three.size = [w3, h3];
  three.renderer.setSize(w3, h3, false);
  three.camera.aspect = w3 / h3;
  three.camera.updateProjectionMatrix();
  if (state.last && !state.cameraMoved) fit(false);
  draw3d();
}

// ---------------------------------------------------------------- start

async function start() {
  buildFields();
  await init3d();
  sizeCanvases();
  const resized = new ResizeObserver(sizeCanvases);
  for (const stage of document.querySelectorAll(".stage")) resized.observe(stage);
  let init;
  try {
    init = await (await fetch("/api/init")).json();
  } catch (e) {
    showError(`cannot reach the viewer's server: ${e.message}`);
    return;
  }
  $("device").textContent = `computing on ${init.device} (${init.backend})`;
  for (const s of init.sonars) state.sonars.set(s.label, s);
  for (const id of ["from", "to"]) {
    const sel = $(id);
    for (const s of init.sonars) sel.add(new Option(`${s.label} (${s.kind})`, s.label));
    sel.value = init.initial[id];
    sel.addEventListener("change", () => { configurePair(false); changed(); });
  }
  configurePair(true);
  for (const el of document.querySelectorAll("input[name=mode]")) {
    el.addEventListener("change", () => {
      $("place-fields").hidden = mode() !== "place";
      $("translation-fields").hidden = mode() === "place";
      changed();
    });
  }
  $("auto-step").addEventListener("change", () => { $("step").disabled = $("auto-step").checked; changed(); });
  $("step").addEventListener("input", changed);
  $("exact").addEventListener("change", () => {
    $("auto-step").disabled = $("exact").checked;
    $("step").disabled = $("exact").checked || $("auto-step").checked;
    changed();
  });
  $("noise-on").addEventListener("change", () => { $("noise-fields").hidden = !$("noise-on").checked; changed(); });
  for (const el of document.querySelectorAll("#noise-fields input")) el.addEventListener("input", changed);
  $("second-on").addEventListener("change", () => { $("second-fields").hidden = !$("second-on").checked; changed(); });
  $("second-truth").addEventListener("click", () => {
    if (!state.last) return;
    const [range, azimuth] = state.last.truth_second;
    setValue("second.range", range);
    setValue("second.azimuth", azimuth);
    changed();
  });
  $("layout-view").addEventListener("change", drawData);
  $("fit").addEventListener("click", () => { fit(false); draw3d(); });
  $("fit-all").addEventListener("click", () => { fit(true); draw3d(); });
  for (const b of document.querySelectorAll(".tabs button[data-copy]")) {
    b.addEventListener("click", () => {
      state.copy = b.dataset.copy;
      for (const o of document.querySelectorAll(".tabs button[data-copy]")) o.classList.toggle("active", o === b);
      if (state.last) $("copy-text").textContent = state.last.copy[state.copy];
    });
  }
  $("copy-button").addEventListener("click", async () => {
    const text = $("copy-text").textContent;
    try {
      await navigator.clipboard.writeText(text);
      $("copy-button").textContent = "copied";
    } catch (e) {
      const range = document.createRange();
      range.selectNodeContents($("copy-text"));
      window.getSelection().removeAllRanges();
      window.getSelection().addRange(range);
      $("copy-button").textContent = "selected: press Ctrl-C";
    }
    setTimeout(() => { $("copy-button").textContent = "copy"; }, 1500);
  });
  setupAdvise({ readScene, setValue, changed, showError });
  changed();
}

start();
