"""A self-contained HTML animation of a navigation run: one file, no network.

The map is embedded as a PNG (base64), the frames as JSON, and a few lines of JavaScript draw
them on a canvas with their own play/pause button and slider — nothing is fetched from a CDN,
so the page plays offline and in any browser. Each frame shows the robot's footprint and
heading at its true pose, the lidar's returns, the current ``/plan``, AMCL's particles (each
with its heading), the people, the goals and the path driven so far. The page states how
fast it plays against simulated time, and the speed can be changed; ``#frame=N`` at the end
of its address opens it at frame ``N``.
"""

from __future__ import annotations

import base64
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from kit import msgs

__all__ = ["write_html_animation"]


def _map_png(grid: msgs.OccupancyGrid, extent: tuple[float, float, float, float]
             ) -> tuple[str, list[float]]:
    """The grid's cells inside ``extent`` as a base64 PNG (white free, black occupied, grey
    unknown, top row first) and the extent of those whole cells [m]."""
    from PIL import Image

    info = grid.info
    res, x0, y0 = info.resolution, info.origin.position.x, info.origin.position.y
    cells = grid.data.reshape(info.height, info.width).astype(np.int16)
    c0, c1 = (min(info.width, max(0, round((e - x0) / res))) for e in extent[:2])
    r0, r1 = (min(info.height, max(0, round((e - y0) / res))) for e in extent[2:])
    part = cells[r0:r1, c0:c1]
    image = np.where(part < 0, 160, 255 - np.clip(part, 0, 100) * 255 // 100).astype(np.uint8)
    out = io.BytesIO()
    Image.fromarray(np.flipud(image)).save(out, format="PNG")
    return (base64.b64encode(out.getvalue()).decode("ascii"),
            [x0 + c0 * res, x0 + c1 * res, y0 + r0 * res, y0 + r1 * res])


def _round(a: ArrayLike, digits: int = 3) -> Any:
    return np.round(np.asarray(a, dtype=float), digits).tolist()


def write_html_animation(path: str | Path, grid: msgs.OccupancyGrid,
                         frames: Sequence[dict[str, Any]], footprint: ArrayLike,
                         goals: ArrayLike, extent: tuple[float, float, float, float],
                         frame_period: float, speed: float = 5.0, title: str = "") -> Path:
    """Write the animation.

    Parameters
    ----------
    path
        The ``.html`` file to write.
    grid
        The map drawn under everything.
    frames
        One dict per frame: ``time`` [s], ``truth`` (x, y, yaw), ``particles`` (N, 3) or
        None, ``plan`` (M, 2), ``scan`` (K, 2) returns in the map frame, ``people`` (P, 2).
    footprint
        (F, 2) [m] outline in the robot's base frame.
    goals
        (G, 3) goal poses.
    extent
        ``(x_min, x_max, y_min, y_max)`` [m] of the view.
    frame_period
        Simulated seconds between frames.
    speed
        Default playback speed: simulated seconds per second of animation.
    """
    image, cells = _map_png(grid, extent)
    data = {
        "title": title, "extent": cells, "period": float(frame_period),
        "speed": float(speed), "footprint": _round(footprint), "goals": _round(goals),
        "map": image,
        "frames": [{
            "t": round(float(f["time"]), 2), "pose": _round(f["truth"]),
            "particles": None if f.get("particles") is None else _round(f["particles"], 2),
            "plan": _round(f.get("plan", np.zeros((0, 2))), 2),
            "scan": _round(f.get("scan", np.zeros((0, 2))), 2),
            "people": _round(f.get("people", np.zeros((0, 2))), 2)} for f in frames]}
    html = _PAGE.replace("__DATA__", json.dumps(data, separators=(",", ":")))
    path = Path(path)
    path.write_text(html, encoding="utf-8")
    return path


_PAGE = r"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>kit: navigation run</title>
<style>
body{font-family:sans-serif;margin:12px;color:#222}
#bar{display:flex;gap:10px;align-items:center;margin:6px 0}
#slider{flex:1}
canvas{border:1px solid #999;max-width:100%}
.key span{display:inline-block;margin-right:14px;font-size:13px}
.sw{display:inline-block;width:14px;height:10px;margin-right:4px;vertical-align:middle}
</style></head><body>
<h3 id="title"></h3>
<div id="bar"><button id="play">Play</button>
<input id="slider" type="range" min="0" value="0">
<span id="clock"></span>
<label>speed <select id="speed"></select></label></div>
<canvas id="view"></canvas>
<div class="key">
<span><i class="sw" style="background:#1f77b4"></i>robot footprint and heading (true pose)</span>
<span><i class="sw" style="background:#9ecae1"></i>path driven</span>
<span><i class="sw" style="background:#2ca02c"></i>/plan</span>
<span><i class="sw" style="background:#9467bd"></i>AMCL particles (with heading)</span>
<span><i class="sw" style="background:#d62728"></i>lidar returns</span>
<span><i class="sw" style="background:#ff7f0e"></i>people</span>
<span><i class="sw" style="background:#e6ab02"></i>goals</span>
</div>
<p id="note" style="font-size:13px"></p>
<script>
const D = __DATA__;
const [X0, X1, Y0, Y1] = D.extent;
const canvas = document.getElementById("view"), ctx = canvas.getContext("2d");
const scale = Math.min(1100 / (X1 - X0), 700 / (Y1 - Y0));
canvas.width = Math.round((X1 - X0) * scale); canvas.height = Math.round((Y1 - Y0) * scale);
const px = x => (x - X0) * scale, py = y => (Y1 - y) * scale;
const img = new Image(); img.src = "data:image/png;base64," + D.map;
const slider = document.getElementById("slider"), play = document.getElementById("play");
const speedBox = document.getElementById("speed");
slider.max = D.frames.length - 1;
document.getElementById("title").textContent = D.title;
for (const s of [1, 2, 5, 10, 20]) {
  const o = document.createElement("option"); o.value = s; o.textContent = s + "x";
  if (s === D.speed) o.selected = true; speedBox.appendChild(o);
}
function note() {
  document.getElementById("note").textContent = "Plays at " + speedBox.value +
    "x simulated time: 1 s of animation = " + speedBox.value + " s of the run (a frame every " +
    D.period + " s simulated). Drawn offline from the run's own data; no network needed.";
}
function poly(points, close) {
  ctx.beginPath();
  points.forEach((p, i) => i ? ctx.lineTo(px(p[0]), py(p[1])) : ctx.moveTo(px(p[0]), py(p[1])));
  if (close) ctx.closePath();
}
function star(x, y, r) {
  ctx.beginPath();
  for (let i = 0; i < 10; i++) {
    const a = Math.PI / 2 + i * Math.PI / 5, rr = i % 2 ? r / 2.5 : r;
    ctx.lineTo(px(x) + rr * Math.cos(a), py(y) - rr * Math.sin(a));
  }
  ctx.closePath();
}
function draw(k) {
  const f = D.frames[k];
  ctx.drawImage(img, 0, 0, canvas.width, canvas.height);
  ctx.lineWidth = 2; ctx.strokeStyle = "#9ecae1";
  poly(D.frames.slice(0, k + 1).map(g => g.pose), false); ctx.stroke();
  if (f.plan.length) {
    ctx.strokeStyle = "#2ca02c"; ctx.lineWidth = 2.5; poly(f.plan, false); ctx.stroke();
  }
  if (f.particles) {
    ctx.strokeStyle = "#9467bd"; ctx.lineWidth = 1;
    for (const p of f.particles) {
      ctx.beginPath(); ctx.moveTo(px(p[0]), py(p[1]));
      ctx.lineTo(px(p[0] + 0.15 * Math.cos(p[2])), py(p[1] + 0.15 * Math.sin(p[2]))); ctx.stroke();
    }
  }
  ctx.fillStyle = "#d62728";
  for (const s of f.scan) ctx.fillRect(px(s[0]) - 1.5, py(s[1]) - 1.5, 3, 3);
  ctx.fillStyle = "#ff7f0e";
  for (const p of f.people) {
    ctx.beginPath(); ctx.arc(px(p[0]), py(p[1]), 0.25 * scale, 0, 7); ctx.fill();
  }
  ctx.fillStyle = "#e6ab02"; ctx.strokeStyle = "#7a5a00"; ctx.lineWidth = 1;
  for (const g of D.goals) { star(g[0], g[1], 9); ctx.fill(); ctx.stroke(); }
  const [x, y, th] = f.pose, c = Math.cos(th), s = Math.sin(th);
  const outline = D.footprint.map(q => [x + c * q[0] - s * q[1], y + s * q[0] + c * q[1]]);
  ctx.fillStyle = "rgba(31,119,180,0.35)"; ctx.strokeStyle = "#1f77b4"; ctx.lineWidth = 2;
  poly(outline, true); ctx.fill(); ctx.stroke();
  ctx.beginPath(); ctx.moveTo(px(x), py(y));
  ctx.lineTo(px(x + 0.5 * c), py(y + 0.5 * s)); ctx.stroke();
  document.getElementById("clock").textContent = "t = " + f.t.toFixed(1) + " s";
  slider.value = k;
}
let timer = null;
function stop() { clearInterval(timer); timer = null; play.textContent = "Play"; }
function start() {
  if (+slider.value >= D.frames.length - 1) slider.value = 0;
  play.textContent = "Pause";
  timer = setInterval(() => {
    const k = +slider.value + 1;
    if (k >= D.frames.length) { stop(); return; }
    draw(k);
  }, 1000 * D.period / +speedBox.value);
}
play.onclick = () => timer ? stop() : start();
slider.oninput = () => draw(+slider.value);
speedBox.onchange = () => { note(); if (timer) { stop(); start(); } };
const asked = /frame=(\d+)/.exec(location.hash);
img.onload = () => draw(Math.min(asked ? +asked[1] : 0, D.frames.length - 1));
note();
</script></body></html>
"""
