// cnc402 toolpath page. Data: the <script id="data"> JSON written by inspect/src/page.rs.
// A click picks the nearest drawn edge on screen, takes the 3D point under the cursor on it,
// then measures the exact pieces that edge spans (the drawing may be merged; the pieces are
// not) and names the nearest piece's block.
'use strict';
const D = JSON.parse(document.getElementById('data').textContent);

// µm integers, each the difference from the value three places before → mm.
function undelta(a) {
  const out = new Float64Array(a.length);
  const prev = [0, 0, 0];
  for (let i = 0; i < a.length; i++) { prev[i % 3] += a[i]; out[i] = prev[i % 3] / 1000; }
  return out;
}
const P = undelta(D.draw.points);
const NV = P.length / 3;
const vPiece = D.draw.piece;
const isStart = new Uint8Array(NV);
for (const s of D.draw.starts) isStart[s] = 1;
const ENDS = undelta(D.pieces.ends);
const KINDS = D.pieces.kind;
const PBLOCK = D.pieces.block;
const firstPiece = new Map();
PBLOCK.forEach((b, i) => { if (!firstPiece.has(b)) firstPiece.set(b, i); });
const TRACE = D.trace ? { cmd: undelta(D.trace.cmd), act: undelta(D.trace.act) } : null;
const ERR_AT = D.error && D.error.at ? undelta(D.error.at) : null;

// ---- geometry of one piece (mirrors inspect/src/geom.rs) ----
function pieceStart(i) { return [ENDS[6 * i], ENDS[6 * i + 1], ENDS[6 * i + 2]]; }
function pieceEnd(i) { return [ENDS[6 * i + 3], ENDS[6 * i + 4], ENDS[6 * i + 5]]; }
function piecePoint(i, t) {
  const s = pieceStart(i), e = pieceEnd(i), a = D.pieces.arcs[i];
  if (!a) return [0, 1, 2].map(k => s[k] + t * (e[k] - s[k]));
  const [c, p, q, a0, r0, r1, sweep] = a;
  const n = 3 - p - q, th = a0 + t * sweep, r = r0 + t * (r1 - r0), out = [0, 0, 0];
  out[p] = c[p] / 1000 + r * Math.cos(th);
  out[q] = c[q] / 1000 + r * Math.sin(th);
  out[n] = s[n] + t * (e[n] - s[n]);
  return out;
}
function dist3(a, b) { return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }
// Distance from x to piece i: closed form on a line; on an arc, 64 samples a turn then a
// golden-section search between the best sample's neighbours.
function pieceDistance(i, x) {
  const a = D.pieces.arcs[i];
  if (!a) {
    const s = pieceStart(i), e = pieceEnd(i), d = [e[0] - s[0], e[1] - s[1], e[2] - s[2]];
    const l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const t = l2 > 0 ? Math.min(1, Math.max(0, ((x[0] - s[0]) * d[0] + (x[1] - s[1]) * d[1] + (x[2] - s[2]) * d[2]) / l2)) : 0;
    return dist3(piecePoint(i, t), x);
  }
  const n = Math.min(65536, Math.max(16, Math.ceil(Math.abs(a[6]) / (2 * Math.PI) * 64)));
  const at = t => dist3(piecePoint(i, t), x);
  let best = 0, bd = Infinity;
  for (let k = 0; k <= n; k++) { const d = at(k / n); if (d < bd) { bd = d; best = k / n; } }
  let lo = Math.max(0, best - 1 / n), hi = Math.min(1, best + 1 / n);
  const g = (Math.sqrt(5) - 1) / 2;
  for (let k = 0; k < 60; k++) {
    const m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
    if (at(m1) <= at(m2)) hi = m2; else lo = m1;
  }
  return at((lo + hi) / 2);
}

// ---- view: orthographic, Z up; yaw about Z, then pitch about the screen's x axis ----
const canvas = document.getElementById('canvas');
const ctx = canvas.getContext('2d');
const view = { yaw: -Math.PI / 6, pitch: Math.PI / 3, scale: 1, panX: 0, panY: 0 };
const box = (() => {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  const add = (arr) => { for (let i = 0; i < arr.length; i += 3) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], arr[i + k]); hi[k] = Math.max(hi[k], arr[i + k]); } };
  add(P); if (TRACE) add(TRACE.act);
  if (!isFinite(lo[0])) return { c: [0, 0, 0], size: 10 };
  return { c: [0, 1, 2].map(k => (lo[k] + hi[k]) / 2), size: Math.max(1e-3, hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) };
})();
// [screen x, screen y (down), depth toward the viewer] in CSS pixels.
function project(x, y, z) {
  const cy = Math.cos(view.yaw), sy = Math.sin(view.yaw), cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
  const X = x - box.c[0], Y = y - box.c[1], Z = z - box.c[2];
  const x1 = X * cy - Y * sy, y1 = X * sy + Y * cy;
  const up = y1 * cp + Z * sp, depth = -y1 * sp + Z * cp;
  return [canvas.clientWidth / 2 + view.panX + view.scale * x1, canvas.clientHeight / 2 + view.panY - view.scale * up, depth];
}
function fit() { view.scale = 0.8 * Math.min(canvas.clientWidth, canvas.clientHeight) / box.size; view.panX = view.panY = 0; }
const VIEWS = { iso: [-Math.PI / 6, Math.PI / 3], top: [0, 0], front: [0, Math.PI / 2], side: [-Math.PI / 2, Math.PI / 2] };

let S = new Float64Array(NV * 3);   // projected drawn vertices
let picked = null;                    // { piece, block, point }
function projectAll() {
  for (let v = 0; v < NV; v++) { const s = project(P[3 * v], P[3 * v + 1], P[3 * v + 2]); S[3 * v] = s[0]; S[3 * v + 1] = s[1]; S[3 * v + 2] = s[2]; }
}
function strokeSeries(arr, color, dash, width) {
  ctx.beginPath();
  for (let i = 0; i < arr.length; i += 3) { const s = project(arr[i], arr[i + 1], arr[i + 2]); if (i === 0) ctx.moveTo(s[0], s[1]); else ctx.lineTo(s[0], s[1]); }
  ctx.setLineDash(dash); ctx.strokeStyle = color; ctx.lineWidth = width; ctx.stroke(); ctx.setLineDash([]);
}
const STYLE = { R: ['#d2691e', [6, 4], 1], F: ['#1f5fbf', [], 1.3], T: ['#1a8c3a', [], 2] };
function marker(p, color, label, cross) {
  const s = project(p[0], p[1], p[2]);
  ctx.strokeStyle = color; ctx.fillStyle = color; ctx.lineWidth = 2; ctx.beginPath();
  if (cross) { ctx.moveTo(s[0] - 7, s[1] - 7); ctx.lineTo(s[0] + 7, s[1] + 7); ctx.moveTo(s[0] + 7, s[1] - 7); ctx.lineTo(s[0] - 7, s[1] + 7); }
  else ctx.arc(s[0], s[1], 6, 0, 2 * Math.PI);
  ctx.stroke(); ctx.font = '12px sans-serif'; ctx.fillText(label, s[0] + 9, s[1] - 8);
}
function draw() {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) { canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr); }
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  projectAll();
  for (const kind of 'RFT') {
    const [color, dash, width] = STYLE[kind];
    ctx.beginPath();
    for (let v = 1; v < NV; v++) {
      if (isStart[v] || KINDS[vPiece[v]] !== kind) continue;
      ctx.moveTo(S[3 * v - 3], S[3 * v - 2]); ctx.lineTo(S[3 * v], S[3 * v + 1]);
    }
    ctx.setLineDash(dash); ctx.strokeStyle = color; ctx.lineWidth = width; ctx.stroke(); ctx.setLineDash([]);
  }
  if (TRACE) {
    if (document.getElementById('showcmd').checked) strokeSeries(TRACE.cmd, '#777', [2, 3], 1);
    if (document.getElementById('showact').checked) strokeSeries(TRACE.act, 'rgba(224,160,0,0.55)', [], 1);
  }
  for (const b of D.breaks) for (const blk of b.blocks) {
    const i = firstPiece.get(blk);
    if (i !== undefined) marker(pieceStart(i), '#b0009b', 'break ' + b.spec, false);
  }
  if (ERR_AT) marker(ERR_AT, '#d00', 'error: ' + D.error.file.split('/').pop() + ':' + D.error.line, true);
  if (picked) {
    PBLOCK.forEach((b, i) => {
      if (b !== picked.block) return;
      const n = D.pieces.arcs[i] ? 64 : 1, pts = [];
      for (let k = 0; k <= n; k++) pts.push(...piecePoint(i, k / n));
      strokeSeries(pts, '#ff00aa', [], 4);
    });
    marker(picked.point, '#ff00aa', '', false);
  }
}

// ---- picking: the same code for a user's click and the #pick= test hook ----
const PICK_RADIUS = 10; // CSS pixels
function pickAt(mx, my) {
  let best = -1, bestD = Infinity, bestU = 0, bestDepth = -Infinity;
  for (let v = 1; v < NV; v++) {
    if (isStart[v]) continue;
    const ax = S[3 * v - 3], ay = S[3 * v - 2], bx = S[3 * v], by = S[3 * v + 1];
    const dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    const u = l2 > 0 ? Math.min(1, Math.max(0, ((mx - ax) * dx + (my - ay) * dy) / l2)) : 0;
    const d = Math.hypot(ax + u * dx - mx, ay + u * dy - my);
    const depth = S[3 * v - 1] + u * (S[3 * v + 2] - S[3 * v - 1]);
    // Nearest on screen; among edges equally near (within half a pixel), the one in front.
    if (d < bestD - 0.5 || (d <= bestD + 0.5 && depth > bestDepth)) { best = v; bestD = Math.min(d, bestD); bestU = u; bestDepth = depth; }
  }
  if (best < 0 || bestD > PICK_RADIUS) return null;
  const q = [0, 1, 2].map(k => P[3 * best - 3 + k] + bestU * (P[3 * best + k] - P[3 * best - 3 + k]));
  let piece = -1, pd = Infinity;
  for (let i = vPiece[best - 1]; i <= vPiece[best]; i++) { const d = pieceDistance(i, q); if (d < pd) { pd = d; piece = i; } }
  return { piece, block: PBLOCK[piece], point: q };
}
function fmt(x) { return (Math.round(x * 1000) / 1000).toFixed(3); }
function showPick(p) {
  const el = document.getElementById('picked');
  picked = p;
  if (!p) { el.textContent = 'Nothing within ' + PICK_RADIUS + ' px of the click.'; el.dataset.file = el.dataset.line = el.dataset.n = ''; draw(); return; }
  const [file, line, n, text] = D.blocks[p.block];
  const name = D.files[file];
  el.dataset.file = name; el.dataset.line = line; el.dataset.n = n === null ? '' : n; el.dataset.kind = KINDS[p.piece];
  const where = `X${fmt(p.point[0])} Y${fmt(p.point[1])} Z${fmt(p.point[2])}`;
  el.textContent = `${name}:${line}${n === null ? '' : ' N' + n}  (${({ R: 'rapid', F: 'feed', T: 'tap' })[KINDS[p.piece]]})\n${text}\n\nat ${where} (${D.frame} coordinates)\n` +
    `exact list: cnc402 which ${D.program} ${fmt(p.point[0])} ${fmt(p.point[1])} ${fmt(p.point[2])}` + (D.frame === 'machine' ? ' --machine' : '');
  draw();
}

// ---- mouse: drag rotates (shift or right button pans), wheel zooms at the cursor ----
let drag = null, moved = false;
canvas.addEventListener('contextmenu', e => e.preventDefault());
canvas.addEventListener('mousedown', e => { drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 }; moved = false; });
window.addEventListener('mousemove', e => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 2) moved = true;
  if (drag.pan) { view.panX += dx; view.panY += dy; }
  else { view.yaw += dx * 0.01; view.pitch = Math.min(Math.PI, Math.max(0, view.pitch - dy * 0.01)); }
  drag.x = e.clientX; drag.y = e.clientY; draw();
});
window.addEventListener('mouseup', () => { drag = null; });
canvas.addEventListener('wheel', e => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect(), mx = e.clientX - r.left - canvas.clientWidth / 2 - view.panX, my = e.clientY - r.top - canvas.clientHeight / 2 - view.panY;
  const f = Math.exp(-e.deltaY * 0.0015);
  view.panX -= mx * (f - 1); view.panY -= my * (f - 1); view.scale *= f; draw();
}, { passive: false });
canvas.addEventListener('click', e => {
  if (moved) { moved = false; return; }
  const r = canvas.getBoundingClientRect();
  showPick(pickAt(e.clientX - r.left, e.clientY - r.top));
});
for (const b of document.querySelectorAll('#tools button')) b.addEventListener('click', () => {
  const v = b.dataset.view;
  if (v !== 'fit') [view.yaw, view.pitch] = VIEWS[v];
  fit(); draw();
});
for (const id of ['showact', 'showcmd']) document.getElementById(id).addEventListener('change', draw);
window.addEventListener('resize', draw);

// ---- side panel ----
function sidePanel() {
  if (D.error) {
    const el = document.getElementById('error');
    el.style.display = 'block';
    el.textContent = `The dry run stopped at ${D.error.file}:${D.error.line}:${D.error.col}: ${D.error.message}` +
      (D.error.expected ? ` (expected ${D.error.expected})` : '') + `\n${D.error.block}\nThe path drawn is what ran before it (× marks where the machine was).`;
  }
  const br = document.getElementById('breaks');
  if (D.breaks.length) {
    br.textContent = '';
    for (const b of D.breaks) {
      const d = document.createElement('div');
      d.className = b.warning ? 'warn' : '';
      d.textContent = b.spec + ': ' + (b.blocks.length ? b.blocks.map(k => { const [f, l, n] = D.blocks[k]; return `${D.files[f]}:${l}${n === null ? '' : ' N' + n}`; }).join(', ') : 'not marked') + (b.warning ? ' — ' + b.warning : '');
      br.appendChild(d);
    }
  }
  if (TRACE) document.getElementById('tracekeys').style.display = 'block';
  document.getElementById('about').textContent = `${PBLOCK.length} path pieces of ${D.blocks.length} blocks in ${D.frame} coordinates (mm); ` +
    `${NV} vertices drawn` + (D.draw.tolerance > 0 ? `, merged within ${D.draw.tolerance} mm (block lookup uses the exact pieces)` : '') +
    (D.truncated ? '. The program goes on past the segment limit; the rest is not drawn.' : '.');
}

// ---- start: #view=top|front|side|iso, #pick=X,Y,Z (a click at that point's screen position),
// #zoom=F (with pick: that point in the middle, F times closer; a pixel is 1/F as much path) ----
function start() {
  const params = new URLSearchParams(location.hash.slice(1));
  if (VIEWS[params.get('view')]) [view.yaw, view.pitch] = VIEWS[params.get('view')];
  sidePanel(); fit(); draw();
  const pick = params.get('pick');
  if (!pick) return;
  const [x, y, z] = pick.split(',').map(Number);
  const zoom = Number(params.get('zoom'));
  if (zoom > 0) {
    view.scale *= zoom;
    const s = project(x, y, z);
    view.panX -= s[0] - Math.round(canvas.clientWidth / 2);
    view.panY -= s[1] - Math.round(canvas.clientHeight / 2);
    draw();
  }
  const s = project(x, y, z), r = canvas.getBoundingClientRect();
  canvas.dispatchEvent(new MouseEvent('click', { clientX: r.left + s[0], clientY: r.top + s[1], bubbles: true }));
}
window.addEventListener('load', start);
