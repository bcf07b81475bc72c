// The mesh view: a job scenario's deformed mesh on a canvas, coloured by a field, with the
// criteria regions and contact zones outlined, zoom and pan, and the value under the cursor.
import { num } from "./format.js";

/** Colour-by choices: label, unit, and where the values live. */
// `robust`: colours span the 1st–99th percentile (stresses and contact values are singular at
// corners and at the ends of contact zones, and one peak would wash out the rest).
export const FIELDS = {
  u: { label: "|u|", unit: "m", on: "nodes", robust: false },
  i2: { label: "I2²", unit: "Pa²", on: "triangles", robust: true },
  von_mises: { label: "von Mises", unit: "Pa", on: "triangles", robust: true },
  sigma1: { label: "σ1", unit: "Pa", on: "triangles", robust: true },
  sigma2: { label: "σ2", unit: "Pa", on: "triangles", robust: true },
  sigma3: { label: "σ3 = τ33", unit: "Pa", on: "triangles", robust: true },
  tau_xy: { label: "τ_xy", unit: "Pa", on: "triangles", robust: true },
  // The angle θ of σ1's direction from the x axis, in (−90°, 90°].
  theta1: { label: "direction of σ1, θ", unit: "deg", on: "triangles", robust: false },
  temperature: { label: "T", unit: "K", on: "nodes", robust: false },
  pressure: { label: "contact pressure", unit: "Pa", on: "contact", robust: true },
  slip: { label: "slip", unit: "m", on: "contact", robust: true },
  // |τ_t| over the friction bound (g, or F × pressure under Coulomb): 1 where the pair slips;
  // none where the pair is frictionless.
  utilisation: { label: "friction utilisation |τ_t| / bound", unit: "-", on: "contact", robust: false },
};

// Viridis, 9 stops.
const STOPS = [
  [68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
  [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37],
];
const LEVELS = 256;
const PALETTE = Array.from({ length: LEVELS }, (_, i) => {
  const t = (i / (LEVELS - 1)) * (STOPS.length - 1);
  const k = Math.min(Math.floor(t), STOPS.length - 2);
  const f = t - k;
  const c = STOPS[k].map((a, j) => Math.round(a + f * (STOPS[k + 1][j] - a)));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
});
const ZONE_GREYS = ["#d9dde3", "#c9ced6", "#e4e1da", "#d3dbd3", "#dcd3dc"];

/** Draw the colour bar of a field into a small canvas. */
export function drawColorbar(canvas) {
  const ctx = canvas.getContext("2d");
  for (let i = 0; i < canvas.width; i++) {
    ctx.fillStyle = PALETTE[Math.round((i / (canvas.width - 1)) * (LEVELS - 1))];
    ctx.fillRect(i, 0, 1, canvas.height);
  }
}

/** A uniform grid over triangles, to find the one under a point. */
class TriangleGrid {
  constructor(xy, tris) {
    this.xy = xy;
    this.tris = tris;
    let [x0, y0, x1, y1] = [Infinity, Infinity, -Infinity, -Infinity];
    for (const [x, y] of xy) {
      x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
    }
    const n = Math.max(1, Math.ceil(Math.sqrt(tris.length / 2)));
    this.box = [x0, y0, x1, y1];
    this.nx = n; this.ny = n;
    this.dx = (x1 - x0) / n || 1; this.dy = (y1 - y0) / n || 1;
    this.cells = Array.from({ length: n * n }, () => []);
    tris.forEach((t, i) => {
      const xs = t.map((v) => xy[v][0]);
      const ys = t.map((v) => xy[v][1]);
      const [i0, i1] = [this.cx(Math.min(...xs)), this.cx(Math.max(...xs))];
      const [j0, j1] = [this.cy(Math.min(...ys)), this.cy(Math.max(...ys))];
      for (let a = i0; a <= i1; a++) for (let b = j0; b <= j1; b++) this.cells[b * n + a].push(i);
    });
  }
  cx(x) { return Math.min(this.nx - 1, Math.max(0, Math.floor((x - this.box[0]) / this.dx))); }
  cy(y) { return Math.min(this.ny - 1, Math.max(0, Math.floor((y - this.box[1]) / this.dy))); }

  /** The triangle containing (x, y) and its barycentric weights, or null. */
  locate(x, y) {
    const [x0, y0, x1, y1] = this.box;
    const tol = 1e-9 * Math.max(x1 - x0, y1 - y0);
    if (x < x0 - tol || x > x1 + tol || y < y0 - tol || y > y1 + tol) return null;
    for (const i of this.cells[this.cy(y) * this.nx + this.cx(x)]) {
      const [a, b, c] = this.tris[i].map((v) => this.xy[v]);
      const det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1]);
      if (det === 0) continue;
      const l1 = ((b[1] - c[1]) * (x - c[0]) + (c[0] - b[0]) * (y - c[1])) / det;
      const l2 = ((c[1] - a[1]) * (x - c[0]) + (a[0] - c[0]) * (y - c[1])) / det;
      const l3 = 1 - l1 - l2;
      const e = -1e-9;
      if (l1 >= e && l2 >= e && l3 >= e) return { tri: i, w: [l1, l2, l3] };
    }
    return null;
  }
}

export class MeshView {
  constructor(canvas, tip, msg, onStats) {
    this.canvas = canvas;
    this.tip = tip;
    this.msg = msg;
    this.onStats = onStats || (() => {});
    this.data = null;
    this.field = "u";
    this.slider = 50;
    this.edges = false;
    this.view = null; // {wx, wy, zoom}
    this.hover = null;
    this.frame = 0;
    this.bind();
  }

  /** A message instead of a mesh (loading, or why there is none). */
  message(text) {
    this.msg.textContent = text || "";
  }

  clear() {
    this.data = null;
    this.view = null;
    this.tip.hidden = true;
    this.redraw();
  }

  /** New fields (the API's /fields JSON) and the job's scene (for regions and contacts). */
  setData(fields, scene) {
    const f = fields.fields;
    const nodes = f.nodes;
    const tris = f.triangles;
    const disp = f.displacement || nodes.map(() => [0, 0]);
    const umag = disp.map(([a, b]) => Math.hypot(a, b));
    const maxU = Math.max(0, ...umag);
    const grid = new TriangleGrid(nodes, tris);
    const [x0, y0, x1, y1] = grid.box;
    const size = Math.hypot(x1 - x0, y1 - y0);
    // Body of each node, from the zones of its triangles (zones numbered body by body).
    const zoneBody = [];
    (scene.bodies || []).forEach((b, bi) => b.zones.forEach(() => zoneBody.push(bi)));
    const nodeBody = new Int32Array(nodes.length).fill(-1);
    tris.forEach((t, i) => t.forEach((v) => { nodeBody[v] = zoneBody[f.triangle_zone[i]] ?? 0; }));
    // Boundary edges: those of one triangle only.
    const seen = new Map();
    for (const t of tris) {
      for (let k = 0; k < 3; k++) {
        const a = t[k];
        const b = t[(k + 1) % 3];
        const key = a < b ? `${a},${b}` : `${b},${a}`;
        seen.set(key, seen.has(key) ? null : [a, b]);
      }
    }
    const boundary = [...seen.values()].filter(Boolean);
    this.data = { nodes, tris, disp, umag, maxU, grid, size, nodeBody, boundary, zone: f.triangle_zone,
      i2: f.i2_squared, stress: f.stress || [], vonMises: f.von_mises || [],
      principal: f.principal_stress || [], direction: f.principal_direction || [],
      temperature: f.temperature, contact: f.contact || [], scene,
      bbox: [x0, y0, x1, y1] };
    this.data.contactDisp = this.data.contact.map((c) => this.nodeDispAt(c.position, null));
    this.data.outlines = this.outlines(scene);
    if (!this.view) this.fit();
    this.updateDeformed();
  }

  /** The mean displacement of the nodes at a point (of one body, when given). */
  nodeDispAt(p, body) {
    const d = this.data;
    let best = Infinity;
    let acc = [0, 0];
    let count = 0;
    for (let i = 0; i < d.nodes.length; i++) {
      if (body !== null && d.nodeBody[i] !== body) continue;
      const r = Math.hypot(d.nodes[i][0] - p[0], d.nodes[i][1] - p[1]);
      if (r < best - 1e-12 * d.size) {
        best = r; acc = [...d.disp[i]]; count = 1;
      } else if (Math.abs(r - best) <= 1e-12 * d.size) {
        acc[0] += d.disp[i][0]; acc[1] += d.disp[i][1]; count++;
      }
    }
    return count ? [acc[0] / count, acc[1] / count] : [0, 0];
  }

  /**
   * Show another displacement on the same mesh: a dynamic run's frame at one output time.
   * `maxU` (the largest |u| over every frame) fixes the magnification and the |u| colours, so
   * that frames compare.
   */
  setDisplacement(disp, maxU) {
    const d = this.data;
    if (!d) return;
    d.disp = disp;
    d.umag = disp.map(([a, b]) => Math.hypot(a, b));
    d.maxU = maxU;
    d.uLimit = maxU;
    d.contactDisp = d.contact.map((c) => this.nodeDispAt(c.position, null));
    d.outlines = this.outlines(d.scene);
    this.updateDeformed();
  }

  /** The displacement at a reference point, interpolated (nearest node off the mesh). */
  dispAt(p, body) {
    const d = this.data;
    const hit = body === null ? d.grid.locate(p[0], p[1]) : null;
    if (!hit) return this.nodeDispAt(p, body);
    const t = d.tris[hit.tri];
    return [0, 1].map((k) => t.reduce((s, v, j) => s + hit.w[j] * d.disp[v][k], 0));
  }

  /** Criteria regions and contact zones of the scene, as polylines with their displacements. */
  outlines(scene) {
    const out = [];
    const bodies = (scene.bodies || []).map((b) => b.name);
    const dense = (pts, closed) => {
      const ring = closed ? [...pts, pts[0]] : pts;
      const res = [];
      for (let i = 0; i + 1 < ring.length; i++) {
        for (let k = 0; k < 16; k++) {
          const f = k / 16;
          res.push([ring[i][0] + f * (ring[i + 1][0] - ring[i][0]), ring[i][1] + f * (ring[i + 1][1] - ring[i][1])]);
        }
      }
      res.push(ring[ring.length - 1]);
      return res;
    };
    for (const r of (scene.criteria && scene.criteria.regions) || []) {
      if (!r.polygon || r.polygon.length < 3) continue;
      const pts = dense(r.polygon, true);
      out.push({ kind: "region", name: r.name, pts, disp: pts.map((p) => this.dispAt(p, null)) });
    }
    const segments = scene.segments || {};
    for (const c of scene.contacts || []) {
      for (const name of c.between || []) {
        const s = segments[name];
        if (!s) continue;
        let pts = s.path || (s.from && s.to ? [s.from, s.to] : []);
        if (pts.length < 2) continue;
        pts = dense(pts, !!s.closed);
        const body = bodies.indexOf(s.body);
        out.push({ kind: "contact", name: c.name, pts, disp: pts.map((p) => this.nodeDispAt(p, body < 0 ? null : body)) });
      }
    }
    return out;
  }

  /** The displacement scale for the slider position (50: the largest |u| is 5% of the model). */
  magnification() {
    const d = this.data;
    if (!d || d.maxU === 0 || this.slider === 0) return 0;
    return ((0.05 * d.size) / d.maxU) * Math.pow(10, (this.slider - 50) / 25);
  }

  setSlider(v) {
    this.slider = v;
    if (this.data) this.updateDeformed();
  }

  setField(f) {
    this.field = f;
    this.redraw();
  }

  setEdges(on) {
    this.edges = on;
    this.redraw();
  }

  /** The value range and per-item values of the current field. */
  values() {
    const d = this.data;
    switch (this.field) {
      case "u": return { node: d.umag };
      case "temperature": return d.temperature ? { node: d.temperature } : null;
      case "i2": return d.i2 ? { tri: d.i2 } : null;
      case "von_mises": return d.vonMises.length ? { tri: d.vonMises } : null;
      case "sigma1": return d.principal.length ? { tri: d.principal.map((p) => p[0]) } : null;
      case "sigma2": return d.principal.length ? { tri: d.principal.map((p) => p[1]) } : null;
      case "sigma3": return d.principal.length ? { tri: d.principal.map((p) => p[2]) } : null;
      case "tau_xy": return d.stress.length ? { tri: d.stress.map((s) => s[2]) } : null;
      case "theta1": return d.direction.length
        ? { tri: d.direction.map(([c, s]) => (Math.atan2(s, c) * 180) / Math.PI) } : null;
      case "pressure": return { contact: d.contact.map((c) => c.pressure) };
      case "slip": return { contact: d.contact.map((c) => c.slip) };
      case "utilisation": return { contact: d.contact.map((c) => (c.bound > 0 ? Math.abs(c.shear) / c.bound : null)) };
      default: return null;
    }
  }

  /**
   * The colour range of the current field: its [min, max], or for a `robust` field the 1st to
   * 99th percentile; `full` is the true [min, max] and `clipped` says whether the colours
   * saturate at either end.
   */
  range() {
    const v = this.values();
    if (!v) return null;
    const limit = this.data.uLimit;
    if (this.field === "u" && limit > 0) return { lo: 0, hi: limit, full: [0, limit], clipped: [false, false] };
    const arr = (v.node || v.tri || v.contact || []).filter((x) => x !== null && Number.isFinite(x));
    if (arr.length === 0) return null;
    const sorted = Float64Array.from(arr).sort();
    const at = (q) => sorted[Math.min(sorted.length - 1, Math.max(0, Math.round(q * (sorted.length - 1))))];
    const full = [sorted[0], sorted[sorted.length - 1]];
    let [lo, hi] = FIELDS[this.field].robust ? [at(0.01), at(0.99)] : full;
    if (!(hi > lo)) [lo, hi] = full;
    return { lo, hi, full, clipped: [lo > full[0], hi < full[1]] };
  }

  updateDeformed() {
    const d = this.data;
    const m = this.magnification();
    d.mag = m;
    d.def = d.nodes.map(([x, y], i) => [x + m * d.disp[i][0], y + m * d.disp[i][1]]);
    d.defGrid = new TriangleGrid(d.def, d.tris);
    this.redraw();
  }

  fit() {
    const d = this.data;
    if (!d) return;
    const [x0, y0, x1, y1] = d.bbox;
    const W = this.canvas.clientWidth;
    const H = this.canvas.clientHeight;
    const zoom = 0.88 * Math.min(W / (x1 - x0 || 1), H / (y1 - y0 || 1));
    this.view = { wx: (x0 + x1) / 2, wy: (y0 + y1) / 2, zoom };
    this.redraw();
  }

  toScreen([x, y]) {
    const v = this.view;
    return [this.canvas.clientWidth / 2 + (x - v.wx) * v.zoom, this.canvas.clientHeight / 2 - (y - v.wy) * v.zoom];
  }

  toWorld(sx, sy) {
    const v = this.view;
    return [v.wx + (sx - this.canvas.clientWidth / 2) / v.zoom, v.wy - (sy - this.canvas.clientHeight / 2) / v.zoom];
  }

  redraw() {
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => {
      this.frame = 0;
      this.draw();
    });
  }

  draw() {
    const c = this.canvas;
    const dpr = window.devicePixelRatio || 1;
    const W = c.clientWidth;
    const H = c.clientHeight;
    if (c.width !== Math.round(W * dpr) || c.height !== Math.round(H * dpr)) {
      c.width = Math.round(W * dpr);
      c.height = Math.round(H * dpr);
    }
    const ctx = c.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, W, H);
    const d = this.data;
    if (!d || !this.view) return;
    const S = d.def.map((p) => this.toScreen(p));
    const values = this.values();
    const range = this.range();
    const [lo, hi] = range ? [range.lo, range.hi] : [0, 1];
    const level = (x) => Math.max(0, Math.min(LEVELS - 1, Math.round(((x - lo) / (hi - lo || 1)) * (LEVELS - 1))));
    // Triangles batched by colour, filled and stroked in it (no hairline seams).
    const groups = new Map();
    d.tris.forEach((t, i) => {
      let key;
      if (values && values.node) key = level((values.node[t[0]] + values.node[t[1]] + values.node[t[2]]) / 3);
      else if (values && values.tri) key = level(values.tri[i]);
      else key = `z${d.zone[i] % ZONE_GREYS.length}`;
      let p = groups.get(key);
      if (!p) groups.set(key, (p = new Path2D()));
      p.moveTo(...S[t[0]]);
      p.lineTo(...S[t[1]]);
      p.lineTo(...S[t[2]]);
      p.closePath();
    });
    ctx.lineWidth = 0.6;
    ctx.lineJoin = "round";
    for (const [key, p] of groups) {
      const color = typeof key === "string" ? ZONE_GREYS[Number(key.slice(1))] : PALETTE[key];
      ctx.fillStyle = color;
      ctx.strokeStyle = color;
      ctx.fill(p);
      ctx.stroke(p);
    }
    if (this.edges) {
      const e = new Path2D();
      for (const t of d.tris) {
        e.moveTo(...S[t[0]]); e.lineTo(...S[t[1]]); e.lineTo(...S[t[2]]); e.closePath();
      }
      ctx.strokeStyle = "rgba(0,0,0,.25)";
      ctx.lineWidth = 0.5;
      ctx.stroke(e);
    }
    // Undeformed boundary (thin grey) and deformed boundary (dark).
    if (d.mag > 0) {
      const u = new Path2D();
      for (const [a, b] of d.boundary) {
        u.moveTo(...this.toScreen(d.nodes[a])); u.lineTo(...this.toScreen(d.nodes[b]));
      }
      ctx.strokeStyle = "#999";
      ctx.lineWidth = 1;
      ctx.setLineDash([3, 3]);
      ctx.stroke(u);
      ctx.setLineDash([]);
    }
    const bd = new Path2D();
    for (const [a, b] of d.boundary) {
      bd.moveTo(...S[a]); bd.lineTo(...S[b]);
    }
    ctx.strokeStyle = "#333";
    ctx.lineWidth = 1;
    ctx.stroke(bd);
    // Contact zones and criteria regions, moved with the mesh.
    for (const o of d.outlines) {
      const p = new Path2D();
      o.pts.forEach((q, i) => {
        const s = this.toScreen([q[0] + d.mag * o.disp[i][0], q[1] + d.mag * o.disp[i][1]]);
        if (i === 0) p.moveTo(...s); else p.lineTo(...s);
      });
      if (o.kind === "region") {
        ctx.strokeStyle = "#111"; ctx.lineWidth = 2; ctx.setLineDash([6, 4]);
      } else {
        ctx.strokeStyle = "#ff00c8"; ctx.lineWidth = 3; ctx.setLineDash([]);
      }
      ctx.stroke(p);
      ctx.setLineDash([]);
    }
    for (const o of d.outlines.filter((o) => o.kind === "region")) {
      const q = o.pts[0];
      const s = this.toScreen([q[0] + d.mag * o.disp[0][0], q[1] + d.mag * o.disp[0][1]]);
      ctx.fillStyle = "#111";
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillText(o.name, s[0] + 3, s[1] - 4);
    }
    // Contact values as dots.
    if (values && values.contact) {
      d.contact.forEach((cp, i) => {
        const dd = d.contactDisp[i];
        const s = this.toScreen([cp.position[0] + d.mag * dd[0], cp.position[1] + d.mag * dd[1]]);
        ctx.beginPath();
        ctx.arc(s[0], s[1], 4.5, 0, 2 * Math.PI);
        const v = values.contact[i];
        ctx.fillStyle = v === null ? "#fff" : PALETTE[level(v)];
        ctx.fill();
        ctx.strokeStyle = "#222";
        ctx.lineWidth = 0.7;
        ctx.stroke();
      });
    }
    if (this.hover && this.hover.mark) {
      ctx.beginPath();
      ctx.arc(this.hover.mark[0], this.hover.mark[1], 6, 0, 2 * Math.PI);
      ctx.strokeStyle = "#f0a202";
      ctx.lineWidth = 2;
      ctx.stroke();
    }
  }

  /** The field value under a screen point: {text, mark} or null. */
  probe(sx, sy) {
    const d = this.data;
    if (!d) return null;
    const values = this.values();
    const f = FIELDS[this.field];
    if (values && values.contact) {
      let best = null;
      d.contact.forEach((cp, i) => {
        const dd = d.contactDisp[i];
        const s = this.toScreen([cp.position[0] + d.mag * dd[0], cp.position[1] + d.mag * dd[1]]);
        const r = Math.hypot(s[0] - sx, s[1] - sy);
        if (r < 12 && (!best || r < best.r)) best = { r, i, s };
      });
      if (!best) return null;
      const cp = d.contact[best.i];
      const v = values.contact[best.i];
      const value = v === null ? "none (frictionless)" : `${num(v)} ${f.unit}`;
      const bound = cp.bound > 0 ? `, bound ${num(cp.bound)} Pa` : "";
      return {
        text: `${f.label} = ${value} (${cp.state}${bound}) at (${num(cp.position[0], 4)}, ${num(cp.position[1], 4)}) m`,
        mark: best.s,
      };
    }
    const [x, y] = this.toWorld(sx, sy);
    const hit = d.defGrid.locate(x, y);
    if (!hit) return null;
    const t = d.tris[hit.tri];
    const ref = [0, 1].map((k) => t.reduce((s, v, j) => s + hit.w[j] * d.nodes[v][k], 0));
    let value;
    if (!values) value = null;
    else if (values.node) value = t.reduce((s, v, j) => s + hit.w[j] * values.node[v], 0);
    else value = values.tri[hit.tri];
    const at = `at (${num(ref[0], 4)}, ${num(ref[1], 4)}) m`;
    return { text: value === null ? `no ${f.label} in this scene ${at}` : `${f.label} = ${num(value)} ${f.unit} ${at}` };
  }

  bind() {
    const c = this.canvas;
    let drag = null;
    c.addEventListener("pointerdown", (e) => {
      if (!this.view) return;
      drag = { x: e.clientX, y: e.clientY, wx: this.view.wx, wy: this.view.wy };
      c.setPointerCapture(e.pointerId);
      c.classList.add("dragging");
    });
    c.addEventListener("pointerup", (e) => {
      drag = null;
      c.releasePointerCapture(e.pointerId);
      c.classList.remove("dragging");
    });
    c.addEventListener("pointermove", (e) => {
      const r = c.getBoundingClientRect();
      const sx = e.clientX - r.left;
      const sy = e.clientY - r.top;
      if (drag) {
        this.view.wx = drag.wx - (e.clientX - drag.x) / this.view.zoom;
        this.view.wy = drag.wy + (e.clientY - drag.y) / this.view.zoom;
        this.redraw();
        return;
      }
      this.showProbe(sx, sy);
    });
    c.addEventListener("pointerleave", () => {
      this.tip.hidden = true;
      this.hover = null;
      this.redraw();
    });
    c.addEventListener("wheel", (e) => {
      if (!this.view) return;
      e.preventDefault();
      const r = c.getBoundingClientRect();
      this.zoomAt(e.clientX - r.left, e.clientY - r.top, Math.exp(-e.deltaY * 0.0015));
    }, { passive: false });
    c.addEventListener("keydown", (e) => {
      if (!this.view) return;
      const step = 40 / this.view.zoom;
      const W = c.clientWidth / 2;
      const H = c.clientHeight / 2;
      const keys = {
        "+": () => this.zoomAt(W, H, 1.25), "=": () => this.zoomAt(W, H, 1.25),
        "-": () => this.zoomAt(W, H, 0.8), 0: () => this.fit(),
        ArrowLeft: () => { this.view.wx -= step; }, ArrowRight: () => { this.view.wx += step; },
        ArrowUp: () => { this.view.wy += step; }, ArrowDown: () => { this.view.wy -= step; },
      };
      const k = keys[e.key];
      if (!k) return;
      e.preventDefault();
      k();
      this.redraw();
    });
    window.addEventListener("resize", () => this.redraw());
  }

  zoomAt(sx, sy, factor) {
    const [x, y] = this.toWorld(sx, sy);
    this.view.zoom *= factor;
    const [x2, y2] = this.toWorld(sx, sy);
    this.view.wx += x - x2;
    this.view.wy += y - y2;
    this.redraw();
  }

  showProbe(sx, sy) {
    const p = this.probe(sx, sy);
    this.hover = p;
    if (!p) {
      this.tip.hidden = true;
    } else {
      this.tip.textContent = p.text;
      this.tip.hidden = false;
      const W = this.canvas.clientWidth;
      this.tip.style.left = `${Math.min(sx + 14, W - this.tip.offsetWidth - 4)}px`;
      this.tip.style.top = `${sy + 16}px`;
    }
    this.redraw();
  }
}
