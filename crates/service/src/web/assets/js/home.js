// The home view: the submit form and the live job list.
import { api, ApiError } from "./api.js";
import { $, el, num, count, when, labels, label, criterionLabel, criterionInfo } from "./format.js";
import { setUploadedScene } from "./solve.js";

const LIST_POLL_MS = 2000;
let listTimer = null;
let examplesLoaded = false;

/** Show the home view's data and start following the job list. */
export function showHome() {
  if (!examplesLoaded) {
    examplesLoaded = true;
    loadExamples();
  }
  $("submit-msg").textContent = "";
  refreshList();
  clearInterval(listTimer);
  listTimer = setInterval(() => {
    if (!document.hidden) refreshList();
  }, LIST_POLL_MS);
  $("jobs-live").classList.add("on");
}

/** Stop following the job list (another view is shown). */
export function hideHome() {
  clearInterval(listTimer);
  listTimer = null;
  $("jobs-live").classList.remove("on");
}

// ---- job list ----

function bestLines(job) {
  const byCriterion = new Map();
  for (const b of job.best) {
    const entry = byCriterion.get(b.criterion) || {};
    entry[b.sense] = b.value;
    byCriterion.set(b.criterion, entry);
  }
  return [...byCriterion].map(([c, v]) =>
    el("span", { class: "best-line" }, `${criterionLabel(c)}: ${num(v.max, 3)} / ${num(v.min, 3)}`),
  );
}

function jobRow(job) {
  const href = `#/jobs/${job.id}`;
  const tr = el(
    "tr",
    { "data-id": job.id, "data-state": job.state, "data-warnings": String(job.warnings) },
    el("td", { class: "scene", "data-label": "Scene" }, el("a", { href }, job.scene || job.id.slice(0, 8))),
    el("td", { "data-label": "State" }, el("span", { class: `badge ${job.state}` }, label("states", job.state)),
      job.warnings ? el("span", { class: "warn-flag", title: "The result has warnings: read them on the job's page" }, `⚠ ${count(job.warnings, "warning")}`) : null),
    el("td", { "data-label": "Phase" }, label("phases", job.phase)),
    el(
      "td",
      { class: "num", "data-label": "Progress" },
      el("progress", {
        max: job.budget, value: Math.min(job.evaluations, job.budget),
        "aria-label": `${job.evaluations} of ${job.budget} evaluations`,
      }),
      ` ${job.evaluations}/${job.budget}`,
    ),
    el("td", { "data-label": "Created" }, when(job.created_at)),
    el("td", { "data-label": "Criteria" }, job.criteria.map((c) => criterionLabel(c)).join(" ")),
    el("td", { class: "best", "data-label": "Best so far (max / min)" }, ...bestLines(job)),
  );
  tr.addEventListener("click", (e) => {
    if (e.target.tagName !== "A") location.hash = href;
  });
  return tr;
}

async function refreshList() {
  try {
    const jobs = await api.jobs();
    $("jobs-table").tBodies[0].replaceChildren(...jobs.map(jobRow));
    $("jobs-empty").hidden = jobs.length > 0;
  } catch (e) {
    $("jobs-empty").hidden = false;
    const hint = e instanceof ApiError && e.status === 401 ? " Enter it under “Access token”." : "";
    $("jobs-empty").textContent = `Could not load the jobs: ${e.message}${hint}`;
  }
}

// ---- submit form ----

const FIELD_ERRORS = ["scene", "criteria", "budget", "seed", "target-error", "general"];

function clearErrors() {
  for (const f of FIELD_ERRORS) {
    const e = $(`error-${f}`);
    e.hidden = true;
    e.replaceChildren();
  }
  for (const c of document.querySelectorAll("#submit-form [aria-invalid]")) {
    c.removeAttribute("aria-invalid");
  }
}

function showError(field, message, path) {
  const box = $(`error-${field}`);
  box.replaceChildren(message);
  if (path) box.append(" (at ", el("code", {}, path), ")");
  box.hidden = false;
  const control = {
    scene: sourceIsUpload() ? $("scene-file") : $("example"),
    criteria: $("criteria"),
    budget: $("budget"),
    seed: $("seed"),
    "target-error": $("target-error"),
  }[field];
  if (control) {
    control.setAttribute("aria-invalid", "true");
    control.focus();
  }
}

/** Put an API validation error next to the control its path names. */
function placeError(err) {
  const path = err.path || "";
  if (path.startsWith("settings.budget") || path === "scene.search.budget") {
    showError("budget", err.message, path);
  } else if (path.startsWith("settings.seed")) {
    showError("seed", err.message, path);
  } else if (path.startsWith("settings.target_error")) {
    showError("target-error", err.message, path);
  } else if (path.startsWith("settings.criteria")) {
    showError("criteria", err.message, path);
  } else if (path === "scene" || path.startsWith("scene.") || path.startsWith("scene[") || path === "example") {
    showError("scene", err.message, path);
  } else {
    showError("general", `${err.code || "error"}: ${err.message}`, path || null);
  }
}

function sourceIsUpload() {
  return document.querySelector("input[name=source]:checked").value === "upload";
}

/** The checked criteria, then those bound to one region (`phi3@crest`). */
function selectedCriteria() {
  const checked = [...document.querySelectorAll("#criteria input:checked")].map((c) => c.value);
  const bound = $("bound-criteria").value.split(",").map((c) => c.trim()).filter((c) => c !== "");
  return [...checked, ...bound];
}

/** Show a scene's criteria: the plain ones as checks, those bound to a region as text. */
function setCriteria(list) {
  const names = list.map((c) => (typeof c === "string" ? c : c.region ? `${c.criterion}@${c.region}` : c.criterion));
  for (const c of document.querySelectorAll("#criteria input")) c.checked = names.includes(c.value);
  $("bound-criteria").value = names.filter((c) => c.includes("@")).join(", ");
}

/** A contact zone's friction in words, as the scene gives it. */
function contactFriction(c) {
  if (c.kind === "bilateral") return "bilateral";
  if (typeof c.friction_coefficient === "number") return `Coulomb F = ${num(c.friction_coefficient, 3)}`;
  if (c.slip_limit && typeof c.slip_limit === "object") return "Tresca, slip-limit profile";
  if (typeof c.slip_limit === "number" && c.slip_limit > 0) return `Tresca g = ${num(c.slip_limit, 3)} Pa`;
  return "frictionless";
}

function fillFromScene(scene) {
  const contacts = (scene && Array.isArray(scene.contacts)) ? scene.contacts : [];
  $("contacts-hint").textContent = contacts.length
    ? `Contacts: ${contacts.map((c) => `${c.name} (${contactFriction(c)})`).join("; ")}`
    : "";
  const search = (scene && scene.search) || {};
  if (search.criteria) setCriteria(search.criteria);
  if (search.budget !== undefined) $("budget").value = search.budget;
  if (search.seed !== undefined) $("seed").value = search.seed;
}

async function loadExamples() {
  const checks = $("criteria");
  for (const c of Object.keys(labels.criteria)) {
    const [what, unit] = criterionInfo(c);
    checks.append(
      el("label", { title: `${what} [${unit}]` },
        el("input", { type: "checkbox", value: c, name: "criteria" }), ` ${criterionLabel(c)} `,
        el("span", { class: "hint" }, `(${c})`)),
    );
  }
  try {
    const examples = await api.examples();
    $("example").replaceChildren(
      ...examples.map((x) => el("option", { value: x.name }, `${x.name} — ${x.title}`)),
    );
    $("example").dataset.info = JSON.stringify(examples);
    await exampleChanged();
  } catch (e) {
    showError("general", `Could not load the examples: ${e.message}`);
  }
}

async function exampleChanged() {
  const name = $("example").value;
  const info = JSON.parse($("example").dataset.info || "[]").find((x) => x.name === name);
  $("example-hint").textContent = info
    ? `Uncertain: ${info.uncertain.join(", ")}`
    : "";
  try {
    fillFromScene(await api.example(name));
  } catch {
    /* the form keeps its values */
  }
}

let uploaded = null; // {name, scene} of the chosen file, parsed

async function fileChanged() {
  clearErrors();
  uploaded = null;
  const file = $("scene-file").files[0];
  if (!file) return;
  try {
    const scene = JSON.parse(await file.text());
    uploaded = { name: file.name, scene };
    fillFromScene(scene);
  } catch (e) {
    showError("scene", `${file.name} is not JSON: ${e.message}`);
  }
}

function sourceChanged() {
  const upload = sourceIsUpload();
  $("field-upload").hidden = !upload;
  $("field-example").hidden = upload;
  clearErrors();
  if (!upload) exampleChanged();
}

async function submit(event) {
  event.preventDefault();
  clearErrors();
  const settings = {};
  const criteria = selectedCriteria();
  if (criteria.length === 0) return showError("criteria", "Choose at least one criterion.");
  settings.criteria = criteria;
  for (const f of ["budget", "seed"]) {
    const raw = $(f).value.trim();
    if (raw === "") continue;
    const v = Number(raw);
    if (!Number.isInteger(v) || v < 0) {
      return showError(f, `Must be a whole number ≥ ${f === "budget" ? 1 : 0}.`);
    }
    settings[f] = v;
  }
  const target = $("target-error").value.trim();
  if (target !== "") {
    const percent = Number(target);
    if (!(percent > 0 && percent < 100)) {
      return showError("target-error", "A percentage between 0 and 100, e.g. 1.");
    }
    settings.target_error = percent / 100;
  }
  if (!$("derivatives").checked) settings.derivatives = false;
  const body = { settings };
  if (sourceIsUpload()) {
    if (!uploaded) return showError("scene", "Choose a scene file (JSON).");
    body.scene = uploaded.scene;
  } else {
    body.example = $("example").value;
  }
  sessionStorage.setItem("wsm-token", $("token").value.trim());
  const button = $("submit-btn");
  button.disabled = true;
  $("submit-msg").textContent = "Submitting…";
  try {
    const submitted = await api.submit(body);
    $("submit-msg").textContent = "Queued.";
    location.hash = `#/jobs/${submitted.id}`;
  } catch (e) {
    $("submit-msg").textContent = "";
    if (e instanceof ApiError) placeError(e);
    else showError("general", `Could not submit: ${e.message}`);
  } finally {
    button.disabled = false;
  }
}

/** "Solve once": the solve view of the chosen example, or of the uploaded scene. */
function solveOnce() {
  clearErrors();
  sessionStorage.setItem("wsm-token", $("token").value.trim());
  if (!sourceIsUpload()) {
    location.hash = `#/solve/${$("example").value}`;
    return;
  }
  if (!uploaded) return showError("scene", "Choose a scene file (JSON).");
  setUploadedScene(uploaded.scene);
  location.hash = "#/solve/upload";
}

/** Wire the form's controls (once). */
export function initHome() {
  $("token").value = sessionStorage.getItem("wsm-token") || "";
  // A token opens the reads too (the server may require it for the list).
  $("token").addEventListener("change", () => {
    const token = $("token").value.trim();
    if (token === (sessionStorage.getItem("wsm-token") || "")) return; // e.g. a blur after typing
    sessionStorage.setItem("wsm-token", token);
    refreshList();
  });
  $("submit-form").addEventListener("submit", submit);
  $("solve-btn").addEventListener("click", solveOnce);
  $("example").addEventListener("change", exampleChanged);
  $("scene-file").addEventListener("change", fileChanged);
  for (const r of document.querySelectorAll("input[name=source]")) {
    r.addEventListener("change", sourceChanged);
  }
}
