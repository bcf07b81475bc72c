// Number, time and DOM helpers shared by the views.

/** A number for people: 5 significant digits, exponent form when large or small. */
export function num(x, digits = 5) {
  if (x === null || x === undefined || Number.isNaN(x)) return "—";
  if (!Number.isFinite(x)) return x > 0 ? "∞" : "−∞";
  const a = Math.abs(x);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return x.toExponential(digits - 1);
  return Number(x.toPrecision(digits)).toString();
}

/** A count with its noun: "1 warning", "3 warnings". */
export function count(n, singular, plural = `${singular}s`) {
  return `${n} ${n === 1 ? singular : plural}`;
}

/** Seconds as "1 h 2 min", "3 min 4 s" or "5.6 s". */
export function duration(s) {
  if (s === null || s === undefined) return "—";
  if (s < 60) return `${s.toFixed(1)} s`;
  const m = Math.floor(s / 60);
  if (m < 60) return `${m} min ${Math.round(s - 60 * m)} s`;
  return `${Math.floor(m / 60)} h ${m % 60} min`;
}

/** Unix seconds as local date and time. */
export function when(t) {
  if (!t) return "—";
  const d = new Date(t * 1000);
  const time = d.toLocaleTimeString(undefined, { hour: "2-digit", minute: "2-digit", second: "2-digit" });
  if (d.toDateString() === new Date().toDateString()) return time;
  return `${d.toLocaleDateString(undefined, { month: "short", day: "numeric" })} ${time}`;
}

/** Create an element: el("td", {class: "num"}, "text", child...). */
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (k === "class") e.className = v;
    else if (k === "text") e.textContent = v;
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children) if (c !== null && c !== undefined) e.append(c);
  return e;
}

/** Fill a <dl> from [label, value] pairs. */
export function facts(dl, pairs) {
  dl.replaceChildren(
    ...pairs.map(([k, v, attrs]) => el("div", {}, el("dt", {}, k), el("dd", attrs || {}, v))),
  );
}

export const $ = (id) => document.getElementById(id);

/** The display names the server gives (`GET /v1/labels`): criteria, phases, verdicts, job states,
 * warning kinds and error codes, each keyed by its JSON name; loaded once by `loadLabels`. */
export const labels = { criteria: {}, phases: {}, verdicts: {}, states: {}, warning_kinds: {}, error_codes: {} };

/** Fetch the labels once (without them, names show as they are). */
export async function loadLabels(fetchLabels) {
  try {
    Object.assign(labels, await fetchLabels());
  } catch {
    // The names themselves are readable; the dashboard works on.
  }
}

/** The label of `name` in the table `table` of `labels` (the name itself when it has none). */
export function label(table, name) {
  return (labels[table] && labels[table][name]) || name;
}

/** A criterion's symbol: `phi3` → Φ3, `phi3@crest` (bound to one region) → Φ3@crest. */
export function criterionLabel(name) {
  const [kind, region] = String(name).split("@");
  const c = labels.criteria[kind];
  const symbol = c ? c.symbol : kind;
  return region === undefined ? symbol : `${symbol}@${region}`;
}

/** What a criterion measures and its unit, [what, unit] (bound to one region: over that one). */
export function criterionInfo(name) {
  const [kind, region] = String(name).split("@");
  const c = labels.criteria[kind];
  // A name that is no Φ is a criterion defined in the scene (`criteria.defined`), in Pa.
  if (!c) return [`${kind}: a criterion defined in the scene`, "Pa"];
  return [`${c.quantity} over ${region === undefined ? c.over : `'${region}'`}`, c.unit];
}
