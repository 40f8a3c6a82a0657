"""A self-contained HTML player for any run: one file, no CDN, works offline.

Play / pause / scrub, speed, trails, group colours, each agent's facing (a tick from the
body's centre, :attr:`Trajectories.facing`), its gait (a ring round the body coloured by
its locomotion state, and a dot beside it for each foot on the ground, left and right of
the facing: :mod:`crowdmotion.locomotion`), obstacles (moving ones move), a 2D top view
and a 3D orbit view (drag to turn, wheel to zoom), frame counter. The data are
embedded as base64 float32 arrays; the page draws on a canvas with plain JavaScript.
Opening the file with ``#selftest`` makes the page play a few frames by itself, compare
canvas pixels and write the result (and any errors it caught) into ``<pre id=selftest>``,
which the tests read from headless Chromium.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from matplotlib.colors import to_hex

from crowdmotion.io.atomic import atomic_path
from crowdmotion.locomotion import STATES
from crowdmotion.render.colours import group_colours
from crowdmotion.trajectories import Trajectories

STATE_COLOURS = {"idle": "#9e9e9e", "walk": "#2e7d32", "run": "#e65100", "turn": "#6a1b9a", "move": "#1565c0"}


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def player_data(traj: Trajectories, max_frames: int = 3000) -> dict:
    """What the page needs, at most ``max_frames`` frames (evenly picked)."""
    frames = np.unique(np.linspace(0, traj.n_frames - 1, min(traj.n_frames, max_frames)).round().astype(int))
    pos = traj.positions[frames].astype(np.float32)
    yaw, pitch = traj.facing[frames], traj.facing_pitch[frames]
    facing = np.stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)], axis=-1)
    names = list(dict.fromkeys(traj.group.tolist()))
    colours = group_colours(names)
    loco = traj.locomotion()  # on the run's own frames (shared with the run's files), then picked as the positions are
    # one byte per agent and frame: the state (bits 0-2), left foot down (bit 3), right (bit 4)
    gait = (loco.gait_state[frames].astype(np.uint8) | (loco.contact_left[frames].astype(np.uint8) << 3)
            | (loco.contact_right[frames].astype(np.uint8) << 4))  # as in the pictures: a group called "red" is red
    return {
        "frames": int(len(frames)), "agents": int(traj.n_agents), "dim": int(traj.dim),
        "times": (frames * traj.dt).round(6).tolist(),
        "positions": _b64(pos), "active": _b64(traj.active_mask[frames].astype(np.uint8)),
        "facing": _b64(facing.astype(np.float32)),
        "gait": _b64(gait), "states": [{"name": n, "colour": STATE_COLOURS[n]} for n in STATES],
        "radius": np.asarray(traj.radius, float).round(4).tolist(),
        "group": [names.index(g) for g in traj.group.tolist()],
        "groups": [{"name": str(n), "colour": to_hex(colours[n])} for n in names],
        "scene": traj.metadata.get("scene"),
        "title": str(traj.metadata.get("scenario") or traj.metadata.get("method") or "crowdmotion run"),
    }


def write_player(traj: Trajectories, path, max_frames: int = 3000) -> Path:
    """Write the player for ``traj`` to ``path`` (one HTML file), atomically."""
    data = json.dumps(player_data(traj, max_frames), separators=(",", ":"))
    html = PAGE.replace("__DATA__", data.replace("</", "<\\/")).replace("__TITLE__",
                                                                        json.loads(data)["title"].replace("<", ""))
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(html, encoding="utf-8")
    return path


PAGE = r"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>__TITLE__ - crowdmotion player</title>
<style>
body{margin:0;font:13px system-ui,sans-serif;background:#fafafa;color:#222}
#bar{display:flex;gap:10px;align-items:center;padding:6px 10px;background:#eee;border-bottom:1px solid #ccc;flex-wrap:wrap}
#bar input[type=range]{flex:1;min-width:200px}
canvas{display:block;background:#fff}
#legend span{display:inline-block;margin-right:10px}
#legend i{display:inline-block;width:10px;height:10px;border-radius:5px;margin-right:4px;vertical-align:middle}
pre#selftest{display:none}
</style></head><body>
<div id="bar">
<button id="play">Play</button>
<input id="scrub" type="range" min="0" value="0">
<span id="counter"></span>
<label>speed <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option>
<option>2</option><option>4</option><option>8</option></select></label>
<label><input id="trails" type="checkbox" checked> trails</label>
<label><input id="facing" type="checkbox" checked> facing</label>
<label><input id="gait" type="checkbox"> gait</label>
<label>view <select id="view"><option value="top">2D top</option><option value="orbit">3D orbit</option></select></label>
<span id="legend"></span>
</div>
<canvas id="c"></canvas>
<pre id="selftest"></pre>
<script>
"use strict";
const errors = [];
window.addEventListener("error", e => errors.push(String(e.message)));
const origError = console.error;
console.error = function(...a){ errors.push(a.join(" ")); origError.apply(console, a); };
const D = __DATA__;
function decode(b64, Type){ const s = atob(b64); const u = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i); return new Type(u.buffer); }
const P = decode(D.positions, Float32Array), A = decode(D.active, Uint8Array), F = decode(D.facing, Float32Array);
const G = decode(D.gait, Uint8Array);
const N = D.agents, T = D.frames, DIM = D.dim;
const cv = document.getElementById("c"), ctx = cv.getContext("2d");
const scrub = document.getElementById("scrub"), counter = document.getElementById("counter");
const playBtn = document.getElementById("play");
scrub.max = T - 1;
document.getElementById("legend").innerHTML = D.groups.map(g =>
  `<span><i style="background:${g.colour}"></i>${g.name.replace(/</g, "&lt;")}</span>`).join("")
  + `<span id="gaitlegend" style="display:none">` + D.states.map(s =>
  `<span><i style="background:none;border:2px solid ${s.colour};box-sizing:border-box"></i>${s.name}</span>`).join("") + `</span>`;
let frame = 0, playing = false, last = null, clock = 0, yaw = -0.6, pitch = 0.9, zoom = 1.0;
// scene extent
let lo = [Infinity, Infinity, 0], hi = [-Infinity, -Infinity, 0];
if (D.scene) { lo = D.scene.bounds[0].slice(); hi = D.scene.bounds[1].slice(); if (lo.length < 3) { lo.push(0); hi.push(0); } }
else { for (let i = 0; i < P.length; i += DIM) { for (let k = 0; k < 2; k++) { lo[k] = Math.min(lo[k], P[i + k]); hi[k] = Math.max(hi[k], P[i + k]); } } }
function pos(f, a){ const o = (f * N + a) * DIM; return [P[o], P[o + 1], DIM === 3 ? P[o + 2] : 0]; }
function offset(ob, t){ if (!ob.path) return [0, 0, 0]; const ts = ob.path.times, ps = ob.path.positions;
  let k = 0; while (k < ts.length - 1 && t > ts[k + 1]) k++;
  const c = ob.center || ob.lower || ob.vertices[0];
  let p; if (t <= ts[0]) p = ps[0]; else if (t >= ts[ts.length - 1]) p = ps[ps.length - 1];
  else { const u = (t - ts[k]) / (ts[k + 1] - ts[k]); p = ps[k].map((v, i) => v + u * (ps[k + 1][i] - v)); }
  const centre = ob.center ? ob.center : (ob.lower ? ob.lower.map((v, i) => (v + ob.upper[i]) / 2)
    : ob.vertices.reduce((s, v) => [s[0] + v[0] / ob.vertices.length, s[1] + v[1] / ob.vertices.length], [0, 0]));
  return [p[0] - centre[0], p[1] - centre[1], (p[2] || 0) - (centre[2] || 0)]; }
// an obstacle added or removed while running stands in [present[0], present[1]) (null: open)
function standing(ob, t){ const w = ob.present; return !w || ((w[0] === null || t >= w[0]) && (w[1] === null || t < w[1])); }
function resize(){ cv.width = window.innerWidth; cv.height = Math.max(200, window.innerHeight - document.getElementById("bar").offsetHeight); }
window.addEventListener("resize", () => { resize(); draw(); });
// projections
function topProj(){ const w = hi[0] - lo[0], h = hi[1] - lo[1]; const s = Math.min(cv.width / w, cv.height / h) * 0.95;
  const ox = (cv.width - s * w) / 2, oy = (cv.height - s * h) / 2;
  return { s, f: p => [ox + (p[0] - lo[0]) * s, cv.height - oy - (p[1] - lo[1]) * s, 1] }; }
function orbitProj(){ const c = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
  const R = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2 || 1; const dist = 3 * R / zoom;
  const fpx = Math.min(cv.width, cv.height) * 1.2;
  return { s: fpx / dist, f: p => { let x = p[0] - c[0], y = p[1] - c[1], z = p[2] - c[2];
    const cy = Math.cos(yaw), sy = Math.sin(yaw); [x, y] = [cy * x - sy * y, sy * x + cy * y];
    const cp = Math.cos(pitch), sp = Math.sin(pitch); const yy = cp * y - sp * z, zz = sp * y + cp * z;
    const depth = dist + yy; const k = fpx / Math.max(depth, 1e-3);
    return [cv.width / 2 + x * k, cv.height / 2 - zz * k, k / (fpx / dist)]; } }; }
function drawObstacles(pr, t){ if (!D.scene) return; ctx.fillStyle = "rgba(90,90,90,0.6)"; ctx.strokeStyle = "#333";
  for (const ob of D.scene.obstacles) { if (!standing(ob, t)) continue; const o = offset(ob, t); ctx.beginPath();
    if (ob.center) { const c = [ob.center[0] + o[0], ob.center[1] + o[1], (ob.center[2] || 0) + o[2]];
      const q = pr.f(c); ctx.arc(q[0], q[1], Math.max(1, ob.radius * pr.s * q[2]), 0, 2 * Math.PI); }
    else if (ob.lower) { const l = ob.lower, u = ob.upper, z0 = l[2] || 0;
      const pts = [[l[0], l[1]], [u[0], l[1]], [u[0], u[1]], [l[0], u[1]]].map(p => pr.f([p[0] + o[0], p[1] + o[1], z0 + o[2]]));
      pts.forEach((q, i) => i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])); ctx.closePath(); }
    else { ob.vertices.map(v => pr.f([v[0] + o[0], v[1] + o[1], o[2]])).forEach((q, i) => i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])); ctx.closePath(); }
    ctx.fill(); ctx.stroke(); } }
function draw(){ const view = document.getElementById("view").value; const pr = view === "top" ? topProj() : orbitProj();
  const t = D.times[frame]; ctx.clearRect(0, 0, cv.width, cv.height);
  if (view === "orbit") { ctx.strokeStyle = "#bbb"; ctx.beginPath();
    [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]], [lo[0], lo[1]]].map(p => pr.f([p[0], p[1], lo[2]]))
      .forEach((q, i) => i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])); ctx.stroke(); }
  else { const a = pr.f([lo[0], hi[1], 0]), b = pr.f([hi[0], lo[1], 0]); ctx.strokeStyle = "#bbb"; ctx.strokeRect(a[0], a[1], b[0] - a[0], b[1] - a[1]); }
  drawObstacles(pr, t);
  if (document.getElementById("trails").checked) { const back = Math.max(0, frame - 40); ctx.lineWidth = 1;
    for (let a = 0; a < N; a++) { ctx.strokeStyle = D.groups[D.group[a]].colour; ctx.globalAlpha = 0.35; ctx.beginPath(); let on = false;
      for (let f = back; f <= frame; f++) { if (!A[f * N + a]) { on = false; continue; } const q = pr.f(pos(f, a));
        if (on) ctx.lineTo(q[0], q[1]); else ctx.moveTo(q[0], q[1]); on = true; }
      ctx.stroke(); } ctx.globalAlpha = 1; }
  const order = [...Array(N).keys()].filter(a => A[frame * N + a]).map(a => [a, pr.f(pos(frame, a))]);
  order.sort((x, y) => x[1][2] - y[1][2]);
  for (const [a, q] of order) { ctx.fillStyle = D.groups[D.group[a]].colour; ctx.beginPath();
    ctx.arc(q[0], q[1], Math.max(1.5, D.radius[a] * pr.s * q[2]), 0, 2 * Math.PI); ctx.fill(); }
  if (document.getElementById("facing").checked) { ctx.strokeStyle = "#222"; ctx.lineWidth = 1.5; ctx.beginPath();
    for (const [a, q] of order) { const r = D.radius[a]; if (r * pr.s * q[2] < 2) continue;  // too small to show a tick
      const p = pos(frame, a), o = (frame * N + a) * 3, e = pr.f([p[0] + 1.6 * r * F[o], p[1] + 1.6 * r * F[o + 1], p[2] + 1.6 * r * F[o + 2]]);
      ctx.moveTo(q[0], q[1]); ctx.lineTo(e[0], e[1]); }
    ctx.stroke(); ctx.lineWidth = 1; }
  const gaitOn = document.getElementById("gait").checked;
  document.getElementById("gaitlegend").style.display = gaitOn ? "inline" : "none";
  if (gaitOn) { ctx.lineWidth = 2;
    for (const [a, q] of order) { const r = D.radius[a], px = r * pr.s * q[2]; if (px < 2) continue;
      const g = G[frame * N + a]; ctx.strokeStyle = D.states[g & 7].colour; ctx.beginPath();
      ctx.arc(q[0], q[1], px + 1.5, 0, 2 * Math.PI); ctx.stroke();
      const p = pos(frame, a), o = (frame * N + a) * 3, fx = F[o], fy = F[o + 1];
      for (const [bit, side] of [[8, 1], [16, -1]]) { if (!(g & bit)) continue;  // left of the facing is +90°
        const e = pr.f([p[0] - side * 0.6 * r * fy, p[1] + side * 0.6 * r * fx, p[2]]);
        ctx.fillStyle = "#111"; ctx.beginPath(); ctx.arc(e[0], e[1], Math.max(1, 0.15 * px), 0, 2 * Math.PI); ctx.fill(); } }
    ctx.lineWidth = 1; }
  counter.textContent = `frame ${frame + 1} / ${T}   t = ${t.toFixed(2)} s`; scrub.value = frame; }
function tick(now){ if (!playing) return; if (last !== null) { clock += (now - last) / 1000 * parseFloat(document.getElementById("speed").value); }
  last = now; const end = D.times[T - 1]; if (clock > end) clock = 0;
  let f = frame; while (f < T - 1 && D.times[f + 1] <= clock) f++; if (D.times[f] > clock) f = 0; while (f < T - 1 && D.times[f + 1] <= clock) f++;
  frame = f; draw(); requestAnimationFrame(tick); }
function setPlaying(on){ playing = on; playBtn.textContent = on ? "Pause" : "Play"; last = null; clock = D.times[frame]; if (on) requestAnimationFrame(tick); }
playBtn.onclick = () => setPlaying(!playing);
scrub.oninput = () => { frame = parseInt(scrub.value); clock = D.times[frame]; draw(); };
for (const id of ["trails", "facing", "gait", "view", "speed"]) document.getElementById(id).onchange = draw;
let drag = null; cv.onmousedown = e => drag = [e.clientX, e.clientY]; window.onmouseup = () => drag = null;
cv.onmousemove = e => { if (!drag || document.getElementById("view").value !== "orbit") return;
  yaw += (e.clientX - drag[0]) * 0.01; pitch = Math.min(1.5, Math.max(0.05, pitch + (e.clientY - drag[1]) * 0.01)); drag = [e.clientX, e.clientY]; draw(); };
cv.onwheel = e => { zoom *= e.deltaY < 0 ? 1.1 : 1 / 1.1; e.preventDefault(); draw(); };
document.addEventListener("keydown", e => { if (e.key === " ") { setPlaying(!playing); e.preventDefault(); } });
resize(); if (DIM === 3) document.getElementById("view").value = "orbit"; draw();
if (location.hash === "#selftest") {
  const snap = () => ctx.getImageData(0, 0, cv.width, cv.height).data;
  const first = snap(); setPlaying(true); playing = false;
  const steps = Math.min(T - 1, Math.max(1, Math.floor(T / 3)));
  for (let k = 0; k < steps; k++) { frame = Math.min(T - 1, frame + 1); draw(); }
  const second = snap(); let diff = 0; for (let i = 0; i < first.length; i++) if (first[i] !== second[i]) diff++;
  document.getElementById("view").value = "orbit"; draw(); document.getElementById("view").value = "top"; draw();
  const plain = snap(); document.getElementById("gait").checked = true; draw(); const withGait = snap();
  let gaitDiff = 0; for (let i = 0; i < plain.length; i++) if (plain[i] !== withGait[i]) gaitDiff++;
  document.getElementById("gait").checked = false; draw();
  const standingAt = D.scene ? D.scene.obstacles.map(ob => [standing(ob, D.times[0]), standing(ob, D.times[T - 1])]) : [];
  document.getElementById("selftest").textContent = JSON.stringify({ changed_pixels: diff, gait_pixels: gaitDiff,
    frame: frame, frames: T, errors: errors, standing: standingAt });
}
</script></body></html>
"""
