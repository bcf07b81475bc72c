// Contact profiles (design §5.8): along one contact zone, against the arc length, a displacement
// jump or a traction of the nominal, worst and best scenarios of a criterion, as a uPlot line plot.
import { el, num } from "./format.js";

/** The plotted quantities: label, unit, and the profile's array. */
export const PROFILE_QUANTITIES = {
  pressure: { label: "contact pressure", unit: "Pa" },
  shear: { label: "tangential traction", unit: "Pa" },
  normal_jump: { label: "normal displacement jump n·(u^k − u^l)", unit: "m" },
  tangential_jump: { label: "tangential displacement jump t·(u^k − u^l)", unit: "m" },
};

const SCENARIOS = [
  { key: "nominal", label: "nominal", stroke: "#555" },
  { key: "worst", label: "worst (max)", stroke: "#c0392b" },
  { key: "best", label: "best (min)", stroke: "#1f5fbf" },
];

export class ProfilePlot {
  constructor(container) {
    this.container = container;
    this.u = null;
    this.resize = () => this.u && this.u.setSize({ width: this.width(), height: 260 });
    window.addEventListener("resize", this.resize);
  }

  width() {
    return Math.max(240, this.container.clientWidth - 12);
  }

  clear() {
    if (this.u) this.u.destroy();
    this.u = null;
    this.container.replaceChildren();
  }

  /**
   * Plot `quantity` along zone `zone` for each scenario's profiles (`byScenario`: scenario key →
   * the fields' `contact_profiles`, or null when that scenario has none). Returns the number of
   * curves drawn.
   */
  show(byScenario, zone, quantity) {
    this.clear();
    const q = PROFILE_QUANTITIES[quantity];
    const curves = SCENARIOS.map((s) => {
      const profiles = byScenario[s.key];
      const p = profiles && profiles.find((x) => x.zone === zone);
      return p ? { s, p } : null;
    }).filter(Boolean);
    if (curves.length === 0) return 0;
    // The scenarios share the run's mesh, hence the zone's pairs and arc lengths.
    const xs = curves[0].p.arc_length;
    const shown = curves.filter((c) => c.p.arc_length.length === xs.length);
    this.container.append(el("h3", {}, `${zone}: ${q.label} [${q.unit}] against the arc length [m]`));
    const opts = {
      width: this.width(),
      height: 260,
      scales: { x: { time: false } },
      axes: [
        { label: "arc length [m]", values: (u, s) => s.map((v) => num(v, 3)) },
        { label: q.unit, size: 80, labelSize: 18, values: (u, s) => s.map((v) => num(v, 3)) },
      ],
      series: [
        { label: "s [m]", value: (u, v) => (v === null ? "" : num(v, 4)) },
        ...shown.map((c) => ({ label: c.s.label, stroke: c.s.stroke, width: 2, points: { size: 4 },
          value: (u, v) => (v === null ? "" : num(v)) })),
      ],
      legend: { live: true },
    };
    this.u = new window.uPlot(opts, [xs, ...shown.map((c) => c.p[quantity])], this.container);
    const canvas = this.container.querySelector("canvas");
    canvas.setAttribute("role", "img");
    canvas.setAttribute("aria-label", `${q.label} along contact zone ${zone}`);
    this.container.dataset.curves = String(shown.length);
    return shown.length;
  }
}
