// Convergence plots (uPlot) and the sensitivity bar chart (SVG).
import { el, num, criterionLabel, criterionInfo } from "./format.js";

const MAX_COLOR = "#c0392b";
const MIN_COLOR = "#1f5fbf";

/**
 * One convergence plot per criterion: best value so far against evaluations, max and min.
 * Points come either live (`add`) or all at once from /history (`setHistory`).
 */
export class ConvergencePlots {
  constructor(container) {
    this.container = container;
    this.plots = new Map(); // criterion -> {u, max: [[x, y]], min: [[x, y]]}
    this.resize = () => this.fit();
    window.addEventListener("resize", this.resize);
  }

  destroy() {
    window.removeEventListener("resize", this.resize);
    for (const p of this.plots.values()) p.u.destroy();
    this.plots.clear();
    this.container.replaceChildren();
  }

  width() {
    const box = this.container.firstElementChild || this.container;
    return Math.max(240, box.clientWidth - 12);
  }

  plot(criterion) {
    let p = this.plots.get(criterion);
    if (p) return p;
    const [what, unit] = criterionInfo(criterion);
    const box = el("figure", { class: "plot", "data-criterion": criterion },
      el("h3", {}, `${criterionLabel(criterion)} — ${what} [${unit}]`));
    this.container.append(box);
    const axisValues = (u, splits) => splits.map((v) => num(v, 3));
    const opts = {
      width: this.width(),
      height: 220,
      scales: { x: { time: false } },
      axes: [
        { label: "evaluations", values: (u, s) => s.map((v) => String(v)) },
        { values: axisValues, size: 80, label: unit, labelSize: 18 },
      ],
      series: [
        { label: "evaluation" },
        { label: "max (worst)", stroke: MAX_COLOR, width: 2, paths: window.uPlot.paths.stepped({ align: 1 }), points: { size: 5 }, value: (u, v) => num(v) },
        { label: "min (best)", stroke: MIN_COLOR, width: 2, paths: window.uPlot.paths.stepped({ align: 1 }), points: { size: 5 }, value: (u, v) => num(v) },
      ],
      legend: { live: true },
    };
    p = { u: new window.uPlot(opts, [[], [], []], box), max: [], min: [], box };
    box.querySelector("canvas").setAttribute("aria-label", `Convergence of ${criterion}`);
    box.querySelector("canvas").setAttribute("role", "img");
    this.plots.set(criterion, p);
    return p;
  }

  /** Append a live best value (ignored when it does not change the curve). */
  add(criterion, sense, evaluations, value) {
    if (value === null || value === undefined) return;
    const p = this.plot(criterion);
    const pts = p[sense];
    const last = pts[pts.length - 1];
    if (last && last[1] === value) return;
    if (last && last[0] === evaluations) last[1] = value;
    else pts.push([evaluations, value]);
    this.redraw(p);
  }

  /** Replace everything with the finished job's history. */
  setHistory(history) {
    for (const h of history) {
      const p = this.plot(h.criterion);
      p.max = h.worst.map(([x, y]) => [x, y]);
      p.min = h.best.map(([x, y]) => [x, y]);
      this.redraw(p);
    }
  }

  /** Extend each curve to the current evaluation count (the best stays what it was). */
  extendTo(evaluations) {
    for (const p of this.plots.values()) {
      for (const sense of ["max", "min"]) {
        const pts = p[sense];
        const last = pts[pts.length - 1];
        if (last && last[0] < evaluations) pts.push([evaluations, last[1]]);
      }
      this.redraw(p);
    }
  }

  redraw(p) {
    // Merge the two step curves on one x axis, carrying each best value forward.
    const xs = [...new Set([...p.max, ...p.min].map(([x]) => x))].sort((a, b) => a - b);
    const carry = (pts) => {
      let i = 0;
      let v = null;
      return xs.map((x) => {
        while (i < pts.length && pts[i][0] <= x) v = pts[i++][1];
        return v;
      });
    };
    p.u.setData([xs, carry(p.max), carry(p.min)]);
  }

  fit() {
    const w = this.width();
    for (const p of this.plots.values()) p.u.setSize({ width: w, height: 220 });
  }
}

/** Horizontal bars of the sensitivities of one criterion's max and min, per parameter. */
export function sensitivityChart(container, parameters, criterion) {
  const rows = parameters.map((par, i) => ({
    name: par.name,
    max: criterion.worst.sensitivities[i],
    min: criterion.best.sensitivities[i],
  }));
  const extent = Math.max(1e-12, ...rows.flatMap((r) => [Math.abs(r.max || 0), Math.abs(r.min || 0)]));
  const W = 560;
  const label = 190;
  const rowH = 40;
  const H = rows.length * rowH + 34;
  const mid = label + (W - label - 10) / 2;
  const half = (W - label - 10) / 2 - 50;
  const ns = "http://www.w3.org/2000/svg";
  const s = (tag, attrs, text) => {
    const e = document.createElementNS(ns, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  };
  const svg = s("svg", { viewBox: `0 0 ${W} ${H}`, role: "img", "aria-label": `Sensitivities of ${criterion.criterion}` });
  svg.append(s("line", { x1: mid, x2: mid, y1: 4, y2: H - 26, stroke: "#555" }));
  rows.forEach((r, i) => {
    const y = 8 + i * rowH;
    svg.append(s("text", { x: 4, y: y + 20 }, r.name.length > 28 ? `…${r.name.slice(-27)}` : r.name));
    [["max", r.max, MAX_COLOR, 0], ["min", r.min, MIN_COLOR, 16]].forEach(([sense, v, color, dy]) => {
      if (v === null || v === undefined) {
        svg.append(s("text", { x: mid + 4, y: y + dy + 12, fill: "#888" }, `${sense}: —`));
        return;
      }
      const w = (Math.abs(v) / extent) * half;
      const x = v >= 0 ? mid : mid - w;
      const bar = s("rect", { x, y: y + dy, width: Math.max(w, 1), height: 13, fill: color });
      bar.append(s("title", {}, `${sense}: ${num(v)}`));
      svg.append(bar);
      const tx = v >= 0 ? mid + w + 4 : mid - w - 4;
      svg.append(s("text", { x: tx, y: y + dy + 11, "text-anchor": v >= 0 ? "start" : "end" }, num(v, 3)));
    });
  });
  const ly = H - 10;
  svg.append(s("rect", { x: label, y: ly - 9, width: 12, height: 10, fill: MAX_COLOR }));
  svg.append(s("text", { x: label + 16, y: ly }, "max (worst)"));
  svg.append(s("rect", { x: label + 110, y: ly - 9, width: 12, height: 10, fill: MIN_COLOR }));
  svg.append(s("text", { x: label + 126, y: ly }, "min (best)"));
  container.replaceChildren(svg);
}

const CURVE_COLORS = ["#1f5fbf", "#c0392b", "#1b7f3b", "#a15c00", "#7b3fa0", "#00838f", "#5b6475", "#d81b60", "#6d4c41"];
const MARKER_COLOR = "#f0a202";

/**
 * The curves of a dynamic run's history (GET/POST /v1/solve `summary.history`), one plot per
 * quantity: [id, title, unit, [[label, values]]]; plots without curves are left out.
 */
function historyCurves(h) {
  const xy = (name, key, values) => [[`${name} ${key}x`, values.map((p) => p[0])], [`${name} ${key}y`, values.map((p) => p[1])]];
  const receivers = Object.entries(h.receivers || {});
  const zones = Object.entries(h.contact_zones || {});
  const bodies = Object.entries(h.bodies || {});
  const e = h.energy || {};
  const energy = [["kinetic", e.kinetic], ["strain", e.strain], ["viscous", e.viscous], ["absorbing", e.absorbing],
    ["contact", e.contact], ["friction", e.friction], ["work of loads", e.work], ["residual (numerical)", e.numerical]];
  return [
    ["receiver-displacement", "Receiver displacement", "m", receivers.flatMap(([n, r]) => xy(n, "u", r.displacement))],
    ["receiver-velocity", "Receiver velocity", "m/s", receivers.flatMap(([n, r]) => xy(n, "v", r.velocity))],
    ["zone-forces", "Contact-zone forces (normal: compression > 0)", "N/m",
      zones.flatMap(([n, z]) => [[`${n} normal`, z.normal_force], [`${n} tangential`, z.tangential_force]])],
    ["zone-slip", "Contact-zone largest slip", "m", zones.map(([n, z]) => [`${n} max slip`, z.max_slip])],
    ["body-velocity", "Bodies' mean velocity", "m/s", bodies.flatMap(([n, b]) => xy(n, "v", b.mean_velocity))],
    ["energy", "Energy budget (work = Δ(kinetic + strain) + dissipated + residual)", "J/m",
      energy.filter(([, v]) => Array.isArray(v))],
  ].filter(([, , , curves]) => curves.length > 0);
}

/**
 * Line plots of a dynamic run's history against time, with a marker at the time shown on the
 * mesh view (`setTime`).
 */
export class HistoryPlots {
  constructor(container) {
    this.container = container;
    this.plots = [];
    this.time = null;
    this.resize = () => this.fit();
    window.addEventListener("resize", this.resize);
  }

  destroy() {
    window.removeEventListener("resize", this.resize);
    for (const p of this.plots) p.u.destroy();
    this.plots = [];
    this.container.replaceChildren();
  }

  width() {
    const box = this.container.firstElementChild || this.container;
    return Math.max(240, box.clientWidth - 12);
  }

  /** Plot `history` (replacing what was shown). */
  show(history) {
    for (const p of this.plots) p.u.destroy();
    this.plots = [];
    this.container.replaceChildren();
    const marker = (u) => {
      if (this.time === null) return;
      const x = u.valToPos(this.time, "x", true);
      const ctx = u.ctx;
      ctx.save();
      ctx.strokeStyle = MARKER_COLOR;
      ctx.lineWidth = 2 * (window.devicePixelRatio || 1);
      ctx.beginPath();
      ctx.moveTo(x, u.bbox.top);
      ctx.lineTo(x, u.bbox.top + u.bbox.height);
      ctx.stroke();
      ctx.restore();
    };
    for (const [id, title, unit, curves] of historyCurves(history)) {
      // The axes' labels are drawn on the canvas: the figure names them for tools and tests.
      const box = el("figure", { class: "plot", "data-plot": id, "data-curves": String(curves.length),
        "data-x-label": "time [s]", "data-y-label": unit }, el("h3", {}, `${title} [${unit}]`));
      this.container.append(box);
      const opts = {
        width: this.width(),
        height: 220,
        scales: { x: { time: false } },
        axes: [
          { label: box.dataset.xLabel, values: (u, s) => s.map((v) => num(v, 3)) },
          { label: unit, labelSize: 18, size: 80, values: (u, s) => s.map((v) => num(v, 3)) },
        ],
        series: [
          { label: "t [s]", value: (u, v) => num(v) },
          ...curves.map(([label], i) => ({
            label, stroke: CURVE_COLORS[i % CURVE_COLORS.length], width: 1.5, value: (u, v) => num(v),
          })),
        ],
        hooks: { draw: [marker] },
        legend: { live: true },
      };
      const u = new window.uPlot(opts, [history.times, ...curves.map(([, v]) => v)], box);
      const canvas = box.querySelector("canvas");
      canvas.setAttribute("role", "img");
      canvas.setAttribute("aria-label", `${title} [${unit}] against time [s]`);
      this.plots.push({ u, box });
    }
  }

  /** Move the marker to time `t` [s]. */
  setTime(t) {
    this.time = t;
    for (const p of this.plots) {
      p.box.dataset.time = String(t);
      p.u.redraw(false, false);
    }
  }

  fit() {
    const w = this.width();
    for (const p of this.plots) p.u.setSize({ width: w, height: 220 });
  }
}
