// The job view: live status (server-sent events, polling as fallback), convergence plots,
// worst/best data, sensitivities, solver statistics, the scenario mesh and downloads.
import { api, ApiError, download, hasToken } from "./api.js";
import { ConvergencePlots, sensitivityChart } from "./charts.js";
import { $, el, facts, num, count, duration, when, label, criterionLabel, criterionInfo } from "./format.js";
import { FIELDS, MeshView, drawColorbar } from "./mesh.js";
import { ProfilePlot } from "./profiles.js";

const POLL_MS = 1000;

let current = null; // {id, gen, es, timer, plots, status, result, scene}
let generation = 0;
let mesh = null;
let profilePlot = null;

const finished = (s) => ["succeeded", "failed", "cancelled"].includes(s.state);

/** Stop everything the job view follows (its EventSource first: browsers allow few connections). */
export function hideJob() {
  if (!current) return;
  if (current.es) current.es.close();
  clearTimeout(current.timer);
  current.plots.destroy();
  current = null;
  if (mesh) mesh.clear();
  if (profilePlot) profilePlot.clear();
}

/** Show job `id` and follow it until it finishes. */
export async function showJob(id) {
  hideJob();
  const gen = ++generation;
  current = { id, gen, es: null, timer: null, plots: new ConvergencePlots($("conv-plots")), status: null, result: null, scene: null, profiles: new Map() };
  const here = () => current && current.gen === gen;
  resetView(id);
  let status;
  try {
    status = await api.job(id);
  } catch (e) {
    if (!here()) return;
    $("job-title").textContent = "Job not found";
    showJobError(e.message);
    return;
  }
  if (!here()) return;
  api.scene(id).then((scene) => { if (here()) current.scene = scene; }).catch(() => {});
  onStatus(status);
  if (!finished(status)) follow(id, gen);
}

/** Show the result sections (mesh, data, sensitivities, statistics), or the note that they come. */
function showResultSections(on, note) {
  $("result-sections").hidden = !on;
  $("pending-note").hidden = on;
  if (note) $("pending-note").textContent = note;
}

function resetView(id) {
  showResultSections(false, "The mesh of the worst scenario, the worst and best data, the sensitivities and the solver statistics appear when the job has finished.");
  $("job-title").textContent = "Job";
  $("job-id").textContent = id;
  $("job-state").textContent = "";
  $("job-state").className = "badge";
  $("job-error").hidden = true;
  warningBanner([]);
  $("job-facts").replaceChildren();
  $("data-tables").replaceChildren(el("p", { class: "hint" }, "The worst and best data appear when the job has finished."));
  $("sens-chart").replaceChildren();
  $("sens-criterion").replaceChildren();
  $("stats").replaceChildren();
  $("mesh-facts").replaceChildren();
  $("mesh-criterion").replaceChildren();
  $("profile-zone").replaceChildren();
  $("profile-msg").textContent = "";
  delete $("profile-plot").dataset.ready;
  profilePlot.clear();
  mesh.clear();
  mesh.message("");
  delete $("mesh-canvas").dataset.ready;
  for (const c of ["cb-min", "cb-max", "cb-unit"]) $(c).textContent = "";
  for (const a of ["dl-result", "dl-csv", "dl-vtu"]) setLink(a, null);
  setLink("dl-csv", api.csvUrl(id), `wsm-${id}-evaluations.csv`);
}

function setLink(id, href, filename) {
  const a = $(id);
  if (filename) a.setAttribute("download", filename);
  // With a token, the file is fetched with it (a plain link cannot send it).
  a.onclick = (event) => {
    if (!hasToken() || !a.href) return;
    event.preventDefault();
    download(a.href, a.getAttribute("download") || "wsm-download").catch((e) => showJobError(e.message));
  };
  if (href) {
    a.href = href;
    a.removeAttribute("aria-disabled");
    a.removeAttribute("tabindex");
  } else {
    a.removeAttribute("href");
    a.setAttribute("aria-disabled", "true");
    a.setAttribute("tabindex", "-1");
  }
}

function showJobError(text) {
  $("job-error").textContent = text;
  $("job-error").hidden = !text;
}

/** Live status: an EventSource; polling when it is unavailable or keeps failing. */
function follow(id, gen) {
  const here = () => current && current.gen === gen;
  // An EventSource cannot send the token: with one, poll (the server may require it on reads).
  if (!window.EventSource || hasToken()) return poll(id, gen);
  const es = new EventSource(api.eventsUrl(id));
  current.es = es;
  let failures = 0;
  es.addEventListener("status", (e) => {
    if (!here()) return es.close();
    failures = 0;
    const status = JSON.parse(e.data);
    if (finished(status)) es.close();
    onStatus(status);
  });
  es.onerror = () => {
    if (!here()) return es.close();
    failures += 1;
    if (es.readyState === EventSource.CLOSED || failures >= 3) {
      es.close();
      current.es = null;
      poll(id, gen);
    }
  };
}

function poll(id, gen) {
  const here = () => current && current.gen === gen;
  const tick = async () => {
    if (!here()) return;
    try {
      const status = await api.job(id);
      if (!here()) return;
      onStatus(status);
      if (finished(status)) return;
    } catch {
      /* try again */
    }
    current.timer = setTimeout(tick, POLL_MS);
  };
  current.timer = setTimeout(tick, POLL_MS);
}

function onStatus(s) {
  const first = !current.status;
  const wasFinished = current.status && finished(current.status);
  current.status = s;
  $("job-title").textContent = s.scene || "Job";
  document.title = `${s.scene} — ${s.state} — wsm`;
  $("job-state").textContent = label("states", s.state);
  $("job-state").className = `badge ${s.state}`;
  const progress = $("job-progress");
  progress.max = s.budget;
  progress.value = Math.min(s.evaluations, s.budget);
  const failed = s.failures ? ` · ${s.failures} failed` : "";
  $("job-progress-text").textContent = `${s.evaluations} / ${s.budget} evaluations${failed} · ${label("phases", s.phase)}`;
  $("job-progress-text").dataset.evaluations = s.evaluations;
  $("job-progress-text").dataset.failures = s.failures || 0;
  facts($("job-facts"), [
    ["Phase", label("phases", s.phase)],
    ["Criteria", s.criteria.map((c) => criterionLabel(c)).join(", ")],
    ["Created", when(s.created_at)],
    ["Started", when(s.started_at)],
    ["Finished", when(s.finished_at)],
    ["Elapsed", duration(s.elapsed_seconds)],
    ["Time left (estimate)", s.eta_seconds === null ? "—" : duration(s.eta_seconds)],
    ["Outcome", s.outcome_status || "—"],
    ["Warnings", String(s.warnings), { id: "job-warnings-count", "data-value": String(s.warnings) }],
    ["Failed evaluations (search)", String(s.failures)],
    ["Failed refined solves (accuracy statement)", String(s.accuracy_failures),
      { id: "job-accuracy-failures", "data-value": String(s.accuracy_failures) }],
    ["Attempts", String(s.attempts)],
  ]);
  const cancel = $("cancel-btn");
  cancel.disabled = finished(s) || s.cancel_requested;
  cancel.textContent = s.cancel_requested && !finished(s) ? "Cancelling…" : "Cancel job";
  showJobError(s.error ? `${s.error_kind ? `${label("error_codes", s.error_kind)}: ` : ""}${s.error}` : "");
  if (!finished(s)) {
    for (const b of s.best) current.plots.add(b.criterion, b.sense, s.evaluations, b.value);
    current.plots.extendTo(s.evaluations);
  } else if (first || !wasFinished) {
    // Only a job that ran has an outcome (outcome_status says so): ask for nothing else.
    if (s.outcome_status) loadFinished(current.id, current.gen);
    else showResultSections(false, `This job ${s.state === "failed" ? "failed" : "was cancelled"} before it had a result.`);
  }
}

async function cancelJob() {
  if (!current) return;
  const gen = current.gen;
  $("cancel-btn").disabled = true;
  try {
    const status = await api.cancel(current.id);
    if (current && current.gen === gen) onStatus(status);
  } catch (e) {
    if (current && current.gen === gen) {
      showJobError(`Could not cancel: ${e.message}`);
      $("cancel-btn").disabled = false;
    }
  }
}

// ---- a finished job ----

async function loadFinished(id, gen) {
  const here = () => current && current.gen === gen;
  let result;
  try {
    result = await api.result(id);
  } catch (e) {
    if (!here()) return;
    const why = e instanceof ApiError && e.status === 409 ? "This job has no result." : `Could not load the result: ${e.message}`;
    showResultSections(false, why);
    return;
  }
  if (!here()) return;
  current.result = result;
  warningBanner(result.warnings || []);
  showResultSections(true);
  setLink("dl-result", api.resultUrl(id), `wsm-${id}-result.json`);
  try {
    const history = await api.history(id);
    if (!here()) return;
    current.plots.destroy();
    current.plots = new ConvergencePlots($("conv-plots"));
    current.plots.setHistory(history);
    current.plots.extendTo(result.evaluations);
  } catch {
    /* keep the live curves */
  }
  if (!current.scene) {
    try {
      current.scene = await api.scene(id);
    } catch {
      current.scene = {};
    }
    if (!here()) return;
  }
  dataTables(result);
  failureTable(result);
  statistics(result);
  const names = result.criteria.map((c) => c.criterion);
  for (const sel of [$("mesh-criterion"), $("sens-criterion")]) {
    sel.replaceChildren(...names.map((c) => el("option", { value: c }, `${criterionLabel(c)} (${c})`)));
  }
  sensitivities();
  loadFields();
}

function boundText(b) {
  return { lower: "lower bound", upper: "upper bound", interior: "interior", fixed: "fixed" }[b] || b;
}

function yesNo(v) {
  return el("span", { class: v ? "yes" : "no" }, v ? "yes" : "no");
}

/** The accuracy statement's estimate of one extremum, as a table cell. */
function errorCell(name, sense, a, unit) {
  const attrs = { class: "num", id: `error-${name}-${sense}` };
  if (!a || a.estimate === null) return el("td", attrs, a && a.failure ? `refined solve failed: ${a.failure}` : "—");
  attrs["data-relative"] = String(a.relative);
  const order = a.observed_order === null ? "" : `, order ${num(a.observed_order, 2)}`;
  return el("td", attrs, `± ${num(a.estimate, 2)} ${unit} (${num(100 * a.relative, 2)} %${order})`);
}

function dataTables(result) {
  const statement = result.accuracy ? result.accuracy.criteria : [];
  const blocks = result.criteria.map((c) => {
    const name = c.criterion;
    const [what, unit] = criterionInfo(name);
    const accuracy = statement.find((a) => a.criterion === name);
    const value = (o, sense) => el("td", { class: `num ${sense}`, id: `value-${name}-${sense}`, "data-value": String(o.value),
      "data-region": o.region || "" },
      o.value === null ? "—" : `${num(o.value, 6)} ${unit}`, o.region ? el("span", { class: "bound" }, ` in '${o.region}'`) : null);
    const rows = result.parameters.map((p, i) => el("tr", {},
      el("th", { scope: "row" }, p.name, p.field !== p.name ? el("span", { class: "bound" }, ` ${p.field}`) : null),
      el("td", { class: "num" }, `[${num(p.interval[0])}, ${num(p.interval[1])}]`),
      ...[c.worst, c.best].flatMap((o) => [
        el("td", { class: "num" }, o.point ? num(o.point[i], 6) : "—"),
        el("td", { class: "bound" }, boundText(o.active_bounds[i]),
          o.gradient && o.gradient[p.field] ? el("span", { class: "gradient" }, ` ∂Φ/∂θ ${slopeText(o.gradient[p.field])}`) : null),
      ]),
    ));
    return el("div", { class: "crit-table table-wrap" },
      el("h3", {}, `${criterionLabel(name)} — ${what} [${unit}]`),
      el("table", { "data-criterion": name },
        el("thead", {}, el("tr", {},
          el("th", { scope: "col" }, "Parameter"), el("th", { scope: "col", class: "num" }, "Interval"),
          el("th", { scope: "col", class: "num max" }, "Worst θ (max)"), el("th", { scope: "col" }, "Active bound"),
          el("th", { scope: "col", class: "num min" }, "Best θ (min)"), el("th", { scope: "col" }, "Active bound"))),
        el("tbody", {},
          el("tr", {}, el("th", { scope: "row" }, `${criterionLabel(name)} value`), el("td"),
            value(c.worst, "max"), el("td"), value(c.best, "min"), el("td")),
          accuracy ? el("tr", {}, el("th", { scope: "row" }, "Discretisation error (estimate)"), el("td"),
            errorCell(name, "max", accuracy.worst, unit), el("td"), errorCell(name, "min", accuracy.best, unit), el("td")) : null,
          ...rows,
          el("tr", {}, el("th", { scope: "row" }, "At a vertex / vertex optimal"), el("td"),
            el("td", { class: "num" }, yesNo(c.worst.at_vertex), " / ", yesNo(c.worst.vertex_optimal)), el("td"),
            el("td", { class: "num" }, yesNo(c.best.at_vertex), " / ", yesNo(c.best.vertex_optimal)), el("td")),
          el("tr", {}, el("th", { scope: "row" }, "Several optima"), el("td"),
            el("td", { class: "num" }, yesNo(c.worst.several_optima)), el("td"),
            el("td", { class: "num" }, yesNo(c.best.several_optima)), el("td")),
          el("tr", {}, el("th", { scope: "row" }, "Search status"), el("td"),
            el("td", { class: "num" }, statusText(c.worst.status)), el("td"), el("td", { class: "num" }, statusText(c.best.status)), el("td")),
          el("tr", {}, el("th", { scope: "row" }, "Local proof (relative residual)"), el("td"),
            el("td", { class: "num" }, proofText(c.worst.certificate, result.parameters)), el("td"),
            el("td", { class: "num" }, proofText(c.best.certificate, result.parameters)), el("td")),
          el("tr", {}, el("th", { scope: "row" }, "Global evidence"), el("td"),
            globalCell(name, "max", c.worst.global, unit), el("td"), globalCell(name, "min", c.best.global, unit), el("td")),
        )));
  });
  $("data-tables").replaceChildren(...blocks);
}

/** A one-sided derivative pair: one number where both sides agree. */
function slopeText(s) {
  return s.right === s.left ? num(s.right, 4) : `${num(s.left, 4)} (left) / ${num(s.right, 4)} (right)`;
}

/** A search status in words: a certificate is only ever local. */
function statusText(s) {
  return (s || "—").replaceAll("_", " ");
}

/** What the search knows about other local optima of an extremum: the rule's verdict, the runner-up. */
function globalCell(name, sense, g, unit) {
  const attrs = { class: `num global ${g && g.rule_met ? "yes" : "no"}`, id: `global-${name}-${sense}` };
  if (!g || !g.summary) return el("td", attrs, "—");
  attrs["data-rule-met"] = String(g.rule_met);
  const r = g.runner_up;
  const runner = r ? el("div", {}, `Runner-up local ${sense === "max" ? "maximum" : "minimum"}: ${num(r.value, 6)} ${unit} (${num(100 * r.gap, 2)} % less extreme)`) : null;
  return el("td", attrs, g.summary, runner);
}

/** What the exact derivatives prove about an extremum (`parameters` name a kink's datum). */
function proofText(c, parameters) {
  if (!c) return "—";
  const verdict = label("verdicts", c.verdict);
  if (c.residual === null || c.residual === undefined) return verdict;
  const starts = c.starts > 1 ? ` · ${c.starts} local searches agree` : "";
  const p = c.kink ? parameters[c.kink.parameter] : null;
  const kink = p ? ` · at a kink along ${p.name || p.field}` : "";
  return `${verdict} (${num(c.residual, 2)})${starts}${kink}`;
}

/** A warning's readable text, `subject: message` (results stored before warnings were typed
 * hold plain strings). */
function warningText(w) {
  if (typeof w === "string") return w;
  return w.subject ? `${w.subject}: ${w.message}` : w.message;
}

/** A warning's kind (`legacy` for a plain string). */
function warningKind(w) {
  return typeof w === "string" ? "legacy" : w.kind;
}

/** The result's warnings at the top of the page: what to read before trusting its numbers. */
function warningBanner(warnings) {
  const banner = $("job-warnings");
  banner.hidden = warnings.length === 0;
  banner.dataset.count = warnings.length;
  $("job-warnings-title").textContent = `${count(warnings.length, "warning")}: read before trusting the numbers below.`;
  $("job-warnings-list").replaceChildren(
    ...warnings.map((w) => el("li", { "data-kind": warningKind(w) }, warningText(w))),
  );
}

/** The failed solves of a result: the search's evaluations and the accuracy statement's refined
 * solves, each counted and listed apart. */
function failureTable(result) {
  const f = result.failures || { count: 0, listed: [] };
  const refined = (result.accuracy && result.accuracy.failures) || [];
  $("failures-section").hidden = f.count === 0 && refined.length === 0;
  $("search-failures").hidden = f.count === 0;
  $("refined-failures").hidden = refined.length === 0;
  if (f.count > 0) searchFailureTable(result, f);
  if (refined.length > 0) refinedFailureTable(result.accuracy);
}

/** Where in the box the search's solver gave no answer, and why. */
function searchFailureTable(result, f) {
  const shown = f.listed.length < f.count ? ` (the first ${f.listed.length} listed)` : "";
  $("failures-summary").textContent = `${f.count} of ${result.evaluations} evaluations failed${shown}. ` +
    "The worst or best may lie where the solver gave no answer; objectives with a failure next to their best point have the status “unsettled”.";
  $("failures-table").replaceChildren(
    el("thead", {}, el("tr", {}, el("th", { scope: "col" }, "#"),
      ...result.parameters.map((p) => el("th", { scope: "col", class: "num" }, p.name)),
      el("th", { scope: "col" }, "Error"))),
    el("tbody", {}, ...f.listed.map((e, i) => el("tr", {}, el("td", { class: "num" }, String(i + 1)),
      ...e.point.map((x) => el("td", { class: "num" }, num(x, 6))),
      el("td", { class: "error-text" }, e.error)))));
}

/** The accuracy statement's refined solves that failed: at whose data, on which mesh, why. */
function refinedFailureTable(statement) {
  const failures = statement.failures;
  $("refined-failures-summary").textContent = `${count(failures.length, "refined solve")} of the accuracy statement failed. ` +
    "The discretisation error of the values at those data rests on fewer meshes than asked, or is unknown (see the warnings at the top).";
  const names = (criteria) => criteria.map((c) => criterionLabel(c)).join(", ");
  const extrema = (f) => [f.worst_of.length ? `worst ${names(f.worst_of)}` : null,
    f.best_of.length ? `best ${names(f.best_of)}` : null].filter(Boolean).join("; ");
  const mesh = (level) => {
    const m = statement.meshes[level];
    return `refinement ${level}: sizes × ${num(m.size_factor)}, ${m.unknowns ? `${m.unknowns} unknowns` : "not built"}`;
  };
  $("refined-failures-table").replaceChildren(
    el("thead", {}, el("tr", {}, el("th", { scope: "col" }, "#"), el("th", { scope: "col" }, "At the data of"),
      el("th", { scope: "col" }, "Refined mesh"), el("th", { scope: "col" }, "Error"))),
    el("tbody", {}, ...failures.map((f, i) => el("tr", {}, el("td", { class: "num" }, String(i + 1)),
      el("td", {}, extrema(f)), el("td", {}, mesh(f.level)),
      el("td", { class: "error-text" }, f.error)))));
}

const INNER_LABELS = {
  solves: "State solves (search)", failures: "Failed solves (search)", factorisations: "Factorisations",
  reused_factorisations: "Reused factorisations", elastic_solves: "Elastic solves", heat_solves: "Heat solves",
  mean_qp_iterations: "Mean QP iterations", solver_seconds: "Solver time [s]", max_kkt_residual: "Max KKT residual",
};

function statistics(r) {
  const inner = r.inner || {};
  const pairs = [
    ["Status", r.status],
    ["Evaluations (new)", `${r.evaluations} (${r.new_evaluations})`, { id: "stat-evaluations", "data-value": String(r.evaluations) }],
    ["Failed evaluations (search)", String((r.failures || {}).count || 0), { id: "stat-failures", "data-value": String((r.failures || {}).count || 0) }],
    ["Budget", String(r.budget)],
    ["Wall time", duration(r.wall_seconds)],
    ["Setup time", duration(r.setup_seconds)],
    ["Evaluations per second", num(r.evaluations_per_second, 4)],
    ["Inner-solver time share", `${num(100 * r.inner_time_share, 3)} %`],
  ];
  const choice = r.mesh_choice;
  if (choice) {
    pairs.push(["Target error", `${num(100 * choice.target_error, 3)} % — ${choice.met ? "met" : "not met"} at the nominal data with mesh sizes × ${num(choice.size_factor)} (chosen in ${duration(choice.seconds)})`,
      { id: "stat-target" }]);
  }
  const statement = r.accuracy;
  if (statement) {
    const failed = (statement.failures || []).length;
    const incomplete = failed ? ` (incomplete: ${count(failed, "refined solve")} failed)` : " (incomplete: cut short)";
    pairs.push(["Accuracy statement", `${statement.meshes.map((m) => m.unknowns).join(" → ")} unknowns, ${duration(statement.seconds)}${statement.complete ? "" : incomplete}`,
      { id: "stat-accuracy" }]);
    pairs.push(["Failed refined solves (accuracy statement)", String(failed), { id: "stat-refined-failures", "data-value": String(failed) }]);
  }
  const warnings = (r.warnings || []).length;
  pairs.push(["Warnings", warnings ? `${warnings} (listed at the top of the page)` : "none", { id: "stat-warnings", "data-value": String(warnings) }]);
  for (const [k, v] of Object.entries(inner)) {
    const label = INNER_LABELS[k] || k.replaceAll("_", " ");
    const attrs = k === "max_kkt_residual" ? { id: "stat-kkt", "data-value": String(v) } : undefined;
    pairs.push([label, typeof v === "number" ? num(v) : String(v), attrs]);
  }
  facts($("stats"), pairs);
}

function sensitivities() {
  const r = current && current.result;
  if (!r) return;
  const c = r.criteria.find((x) => x.criterion === $("sens-criterion").value) || r.criteria[0];
  if (c) sensitivityChart($("sens-chart"), r.parameters, c);
}

// ---- the scenario mesh ----

let fieldsRequest = 0; // the latest /fields request wins

async function loadFields() {
  if (!current || !current.result) return;
  const { id, gen } = current;
  const ticket = ++fieldsRequest;
  delete $("mesh-canvas").dataset.ready;
  const criterion = $("mesh-criterion").value;
  const scenario = $("mesh-scenario").value;
  setLink("dl-vtu", api.vtuUrl(id, scenario, criterion), `wsm-${id}-${scenario}-${criterion}.vtu`);
  $("dl-vtu").textContent = `VTU (${scenario} ${criterion})`;
  const c = current.result.criteria.find((x) => x.criterion === criterion);
  const extremum = c && (scenario === "worst" ? c.worst : c.best);
  if (!extremum || !extremum.point) {
    mesh.clear();
    setLink("dl-vtu", null);
    mesh.message(`No feasible point was found for the ${scenario} scenario of ${criterionLabel(criterion)}: there is no mesh to show.`);
    return;
  }
  mesh.message(`Solving the ${scenario} scenario of ${criterionLabel(criterion)}…`);
  let fields;
  try {
    fields = await api.fields(id, scenario, criterion);
  } catch (e) {
    if (current && current.gen === gen && ticket === fieldsRequest) mesh.message(`No mesh: ${e.message}`);
    return;
  }
  if (!current || current.gen !== gen || ticket !== fieldsRequest) return;
  mesh.message("");
  const f = fields.fields;
  const options = $("mesh-field").options;
  for (const o of options) {
    o.disabled = (o.value === "temperature" && !f.temperature)
      || (FIELDS[o.value].on === "triangles" && !(f.stress && f.stress.length))
      || (FIELDS[o.value].on === "contact" && !(f.contact && f.contact.length));
  }
  if (options[$("mesh-field").selectedIndex].disabled) $("mesh-field").value = "u";
  mesh.field = $("mesh-field").value;
  mesh.setData(fields, current.scene || {});
  $("mesh-canvas").dataset.ready = `${scenario}-${criterion}`;
  updateColorbar();
  updateMag();
  meshFacts(fields.summary);
  current.profiles.set(`${scenario}-${criterion}`, f.contact_profiles || []);
  loadProfiles();
}

// ---- contact profiles ----

let profilesRequest = 0; // the latest request wins

/**
 * The contact profiles of the nominal, worst and best scenarios of the mesh view's criterion,
 * each fetched once per job (the scenario in the mesh view is already there).
 */
async function loadProfiles() {
  if (!current || !current.result) return;
  const { id, gen } = current;
  const ticket = ++profilesRequest;
  const criterion = $("mesh-criterion").value;
  const zones = ((current.scene && current.scene.contacts) || []).map((c) => c.name);
  $("profile-section").hidden = zones.length === 0;
  if (zones.length === 0) return;
  const select = $("profile-zone");
  if ([...select.options].map((o) => o.value).join("\n") !== zones.join("\n")) {
    select.replaceChildren(...zones.map((z) => el("option", { value: z }, z)));
  }
  delete $("profile-plot").dataset.ready;
  const c = current.result.criteria.find((x) => x.criterion === criterion);
  const byScenario = {};
  const missing = [];
  $("profile-msg").textContent = "Solving the scenarios for their contact profiles…";
  for (const scenario of ["nominal", "worst", "best"]) {
    const key = `${scenario}-${criterion}`;
    const extremum = c && (scenario === "worst" ? c.worst : c.best);
    if (scenario !== "nominal" && (!extremum || !extremum.point)) {
      missing.push(scenario);
      continue;
    }
    if (!current.profiles.has(key)) {
      try {
        const fields = await api.fields(id, scenario, criterion);
        if (!current || current.gen !== gen) return;
        current.profiles.set(key, fields.fields.contact_profiles || []);
      } catch (e) {
        missing.push(`${scenario} (${e.message})`);
        continue;
      }
    }
    byScenario[scenario] = current.profiles.get(key);
  }
  if (!current || current.gen !== gen || ticket !== profilesRequest) return;
  $("profile-msg").textContent = missing.length ? `No profile for: ${missing.join(", ")}.` : "";
  const curves = profilePlot.show(byScenario, select.value, $("profile-quantity").value);
  $("profile-plot").dataset.ready = `${criterion}-${curves}`;
}

/** Replot the fetched profiles for another zone or quantity. */
function redrawProfiles() {
  if (!current) return;
  const criterion = $("mesh-criterion").value;
  const byScenario = {};
  for (const scenario of ["nominal", "worst", "best"]) {
    byScenario[scenario] = current.profiles.get(`${scenario}-${criterion}`) || null;
  }
  profilePlot.show(byScenario, $("profile-zone").value, $("profile-quantity").value);
}

/** A contact zone's friction law in words, with its data in this scenario. */
function frictionLaw(z) {
  switch (z.friction_law) {
    case "coulomb": return `Coulomb, F = ${num(z.friction_coefficient, 4)}`;
    case "tresca": {
      const [lo, hi] = z.slip_limit;
      return lo === hi ? `Tresca, g = ${num(lo)} Pa` : `Tresca, g = ${num(lo)} … ${num(hi)} Pa`;
    }
    case "bilateral": return "bilateral (tied normal, frictionless)";
    default: return "frictionless";
  }
}

function meshFacts(summary) {
  const kkt = (summary.report && summary.report.kkt) || {};
  const pairs = [
    ["Mesh", `${summary.mesh.nodes} nodes, ${summary.mesh.triangles} triangles`],
    ["Contact pairs", String(summary.mesh.contact_pairs)],
  ];
  const attained = summary.attained_in || {};
  for (const [c, v] of Object.entries(summary.criteria || {})) {
    if (v === null) continue;
    if (c === "phi5_equivalent_stress") {
      pairs.push(["√Φ5 here", `${num(v, 6)} Pa`]);
      continue;
    }
    const where = attained[c] ? ` in '${attained[c]}'` : "";
    pairs.push([`${criterionLabel(c)} here`, `${num(v, 6)} ${criterionInfo(c)[1]}${where}`]);
  }
  for (const z of summary.contact_zones || []) {
    pairs.push([`Contact ${z.name}: friction`, frictionLaw(z)]);
    pairs.push([`Contact ${z.name}: max pressure`, `${num(z.max_pressure)} Pa`]);
    pairs.push([`Contact ${z.name}: stick / slip / open`, `${z.stick} / ${z.slip} / ${z.open}`]);
  }
  for (const [k, v] of Object.entries(kkt)) pairs.push([`KKT ${k.replaceAll("_", " ")}`, num(v, 3)]);
  if (summary.report) {
    pairs.push(["Solver", `${summary.report.solver}, ${summary.report.qp_iterations} QP iterations`]);
    for (const w of summary.report.warnings || []) pairs.push(["Warning", warningText(w)]);
  }
  facts($("mesh-facts"), pairs);
}

function updateColorbar() {
  const f = FIELDS[mesh.field];
  const r = mesh.data ? mesh.range() : null;
  $("cb-min").textContent = r ? `${r.clipped[0] ? "≤ " : ""}${num(r.lo, 4)}` : "";
  $("cb-max").textContent = r ? `${r.clipped[1] ? "≥ " : ""}${num(r.hi, 4)}` : "";
  let unit = r ? `${f.label} [${f.unit}]` : `${f.label}: none in this scenario`;
  if (r && (r.clipped[0] || r.clipped[1])) {
    unit += ` · colours span the 1st–99th percentile; all values ${num(r.full[0], 4)} … ${num(r.full[1], 4)}`;
  }
  $("cb-unit").textContent = unit;
}

function updateMag() {
  const m = mesh.magnification();
  $("mesh-mag-out").textContent = mesh.data ? (m === 0 ? "(undeformed)" : `×${num(m, 3)}`) : "";
}

/** Wire the job view's controls (once). */
export function initJob() {
  mesh = new MeshView($("mesh-canvas"), $("mesh-tip"), $("mesh-msg"));
  profilePlot = new ProfilePlot($("profile-plot"));
  $("profile-zone").addEventListener("change", redrawProfiles);
  $("profile-quantity").addEventListener("change", redrawProfiles);
  drawColorbar($("cb-canvas"));
  $("cancel-btn").addEventListener("click", cancelJob);
  $("mesh-criterion").addEventListener("change", loadFields);
  $("mesh-scenario").addEventListener("change", loadFields);
  $("mesh-field").addEventListener("change", () => {
    mesh.setField($("mesh-field").value);
    updateColorbar();
  });
  $("mesh-mag").addEventListener("input", () => {
    mesh.setSlider(Number($("mesh-mag").value));
    updateMag();
  });
  $("mesh-reset").addEventListener("click", () => mesh.fit());
  $("mesh-edges").addEventListener("change", () => mesh.setEdges($("mesh-edges").checked));
  $("sens-criterion").addEventListener("change", sensitivities);
}
