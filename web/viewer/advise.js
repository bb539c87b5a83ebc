// The advise panel: the rig advisor's score around the pose now over two rotation axes (the
// same code as `sonarproj advise`), an arrow to its best small move, and "apply" to take it.
// The page's scene and sliders are app.js's; it hands this module the functions that reach them.

const $ = (id) => document.getElementById(id);

window.sonarprojAdvice = null;
window.sonarprojAdviceDrawn = null;

// Viridis, five stops, interpolated.
const STOPS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function colour(t) {
  const x = Math.min(1, Math.max(0, t)) * (STOPS.length - 1);
  const i = Math.min(STOPS.length - 2, Math.floor(x));
  const f = x - i;
  const c = STOPS[i].map((v, k) => Math.round(v + f * (STOPS[i + 1][k] - v)));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function draw(a) {
  const canvas = $("advise-canvas");
  const ctx = canvas.getContext("2d");
  const [xs, ys] = a.values;
  const pad = { l: 44, r: 8, t: 8, b: 34 };
  const w = canvas.width - pad.l - pad.r, h = canvas.height - pad.t - pad.b;
  const cw = w / xs.length, ch = h / ys.length;
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const known = a.scores.filter((s) => s !== null);
  const lo = Math.min(...known), hi = Math.max(...known);
  // Cell (i, j): first axis i left to right, second axis j bottom to top; grey: infeasible.
  const px = (v) => pad.l + ((v - xs[0]) / (xs[xs.length - 1] - xs[0])) * (w - cw) + cw / 2;
  const py = (v) => pad.t + h - ((v - ys[0]) / (ys[ys.length - 1] - ys[0])) * (h - ch) - ch / 2;
  for (let i = 0; i < xs.length; i++) {
    for (let j = 0; j < ys.length; j++) {
      const s = a.scores[i * ys.length + j];
      ctx.fillStyle = s === null ? "#c8c8c8" : colour(hi > lo ? (s - lo) / (hi - lo) : 0);
      ctx.fillRect(pad.l + i * cw, pad.t + h - (j + 1) * ch, Math.ceil(cw), Math.ceil(ch));
    }
  }
  ctx.fillStyle = "#222";
  ctx.font = "11px sans-serif";
  ctx.textAlign = "center";
  ctx.fillText(`${a.axes[0]} (°)`, pad.l + w / 2, canvas.height - 4);
  ctx.fillText(`${xs[0].toFixed(1)}`, pad.l + cw / 2, pad.t + h + 13);
  ctx.fillText(`${xs[xs.length - 1].toFixed(1)}`, pad.l + w - cw / 2, pad.t + h + 13);
  ctx.save();
  ctx.translate(11, pad.t + h / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.fillText(`${a.axes[1]} (°)`, 0, 0);
  ctx.restore();
  ctx.textAlign = "right";
  ctx.fillText(`${ys[0].toFixed(1)}`, pad.l - 3, pad.t + h - ch / 2 + 4);
  ctx.fillText(`${ys[ys.length - 1].toFixed(1)}`, pad.l - 3, pad.t + ch / 2 + 4);
  // The pose now (the centre) and the arrow to the move.
  const names = ["roll", "pitch", "yaw"];
  const [ka, kb] = a.axes.map((n) => names.indexOf(n));
  const now = a.move.now.rotation;
  const from = [px(now[ka]), py(now[kb])];
  ctx.strokeStyle = "#fff";
  ctx.lineWidth = 2;
  ctx.beginPath();
  ctx.arc(from[0], from[1], 5, 0, 2 * Math.PI);
  ctx.stroke();
  window.sonarprojAdviceDrawn = { from, to: null };
  if (a.move.best && !a.move.stay) {
    const to = [px(a.move.best.rotation[ka]), py(a.move.best.rotation[kb])];
    const ang = Math.atan2(to[1] - from[1], to[0] - from[0]);
    ctx.strokeStyle = "#d62728";
    ctx.fillStyle = "#d62728";
    ctx.lineWidth = 3;
    ctx.beginPath();
    ctx.moveTo(from[0], from[1]);
    ctx.lineTo(to[0], to[1]);
    ctx.stroke();
    ctx.beginPath();
    ctx.moveTo(to[0], to[1]);
    ctx.lineTo(to[0] - 10 * Math.cos(ang - 0.4), to[1] - 10 * Math.sin(ang - 0.4));
    ctx.lineTo(to[0] - 10 * Math.cos(ang + 0.4), to[1] - 10 * Math.sin(ang + 0.4));
    ctx.closePath();
    ctx.fill();
    window.sonarprojAdviceDrawn.to = to;
  }
}

function describe(a) {
  const fmt = (v) => (v === null || v === undefined ? "—" : Number(v).toPrecision(4));
  const unit = a.score_unit === "1" ? "" : ` ${a.score_unit}`;
  const withSe = (v, se) => (v === null || v === undefined ? "infeasible" : `${fmt(v)}${se != null ? ` ± ${fmt(se)}` : ""}${unit}`);
  const what = {
    correspondence: "mean search cost per point drawn",
    ambiguity: `mean ${a.metric} of the shared features`,
    recovery: "median elevation σ",
  }[a.objective];
  const m = a.move;
  let text = `Colour: ${what} (${a.score_unit === "1" ? "no unit" : a.score_unit}), dark lower (better) to yellow higher; grey: nothing shared; ○ the pose now. `;
  text += `Now: ${withSe(m.now.score, m.now.score_se)} (${Math.round(100 * m.now.shared)} ± ${Math.round(100 * m.now.shared_se)} % shared).`;
  text += ` ${a.tied} pose${a.tied === 1 ? "" : "s"} tied with the best (within 2 standard errors).`;
  if (m.best && !m.stay) {
    const gain = m.gain !== null ? ` (gain ${withSe(m.gain, m.gain_se)})` : " (the pose now is infeasible)";
    text += ` Best move: ${m.words} → ${withSe(m.best.score, m.best.score_se)}${gain}.`;
  } else if (m.best) {
    text += ` Stay: the best move gains ${withSe(m.gain, m.gain_se)}, within twice its standard error.`;
  } else {
    text += " Stay: no move within one cell scores better.";
  }
  for (const w of a.warnings) text += ` Note: ${w}.`;
  return text;
}

export function setupAdvise({ readScene, setValue, changed, showError }) {
  $("advise-run").addEventListener("click", async () => {
    let scene;
    try {
      scene = readScene();
    } catch (e) {
      showError(e.message);
      return;
    }
    const request = {
      scene,
      objective: $("advise-objective").value,
      axes: $("advise-axes").value.split(","),
      span: Number($("advise-span").value),
    };
    $("advise-text").textContent = "scoring…";
    $("advise-apply").disabled = true;
    try {
      const res = await fetch("/api/advise", {
        method: "POST",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify(request),
      });
      const body = await res.json();
      if (!res.ok) {
        $("advise-text").textContent = body.error || `the server answered ${res.status}`;
        return;
      }
      window.sonarprojAdvice = body;
      draw(body);
      $("advise-text").textContent = describe(body);
      $("advise-apply").disabled = !body.move.best || body.move.stay;
    } catch (e) {
      $("advise-text").textContent = `no answer from the viewer's server (${e.message})`;
    }
  });
  $("advise-apply").addEventListener("click", () => {
    const a = window.sonarprojAdvice;
    if (!a || !a.move.best || a.move.stay) return;
    const [roll, pitch, yaw] = a.move.best.rotation;
    setValue("rotation.roll", roll);
    setValue("rotation.pitch", pitch);
    setValue("rotation.yaw", yaw);
    $("advise-apply").disabled = true;
    $("advise-text").textContent += " Applied.";
    changed();
  });
}
