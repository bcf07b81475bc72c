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
