// The solve view (`#/solve/{example}`, or `#/solve/upload` for the scene chosen in the form): one
// synchronous solve of the nominal data (POST /v1/solve) on the mesh view; for a dynamic scene
// (design §3.5) its time histories as line plots and its displacement frames behind a time
// slider with play/pause, the current time marked on every plot.
import { api } from "./api.js";
import { HistoryPlots } from "./charts.js";
import { $, facts, num, duration } from "./format.js";
import { MeshView, drawColorbar } from "./mesh.js";

const PLAY_MS = 120; // one frame per tick while playing

let mesh = null;
let plots = null;
let uploaded = null; // the scene document chosen in the form, for #/solve/upload
let generation = 0;
let run = null; // {frames, times, index, timer, maxU}

/** Keep the uploaded scene for `#/solve/upload`. */
export function setUploadedScene(scene) {
  uploaded = scene;
}

/** Stop playing and forget the shown solve. */
export function hideSolve() {
  generation += 1;
  pause();
  run = null;
  if (plots) plots.destroy();
  if (mesh) mesh.clear();
}

/** Solve `source` (an example's name, or `upload`) and show it. */
export async function showSolve(source) {
  hideSolve();
  const gen = generation;
  const here = () => gen === generation;
  $("solve-title").textContent = source === "upload" ? "Solve of the uploaded scene" : `Solve of ${source}`;
  document.title = `${source} — solve — wsm`;
  $("solve-error").hidden = true;
  $("solve-facts").replaceChildren();
  $("history-section").hidden = true;
  $("time-controls").hidden = true;
  delete $("solve-canvas").dataset.ready;
  delete $("solve-canvas").dataset.frame;
  for (const c of ["solve-cb-min", "solve-cb-max", "solve-cb-unit"]) $(c).textContent = "";
  let scene;
  try {
    scene = source === "upload" ? uploaded : await api.example(source);
  } catch (e) {
    if (here()) showError(e);
    return;
  }
  if (!here()) return;
  if (!scene) {
    showError(new Error("No scene was chosen: upload one in the form first."));
    return;
  }
  const dynamic = Boolean(scene.dynamics);
  const body = source === "upload" ? { scene } : { example: source };
  body.settings = { fields: true, frames: dynamic };
  $("solve-msg").textContent = dynamic
    ? `Running the dynamic scene to t = ${num(scene.dynamics.t_end)} s…`
    : "Solving the nominal data…";
  let output;
  try {
    output = await api.solve(body);
  } catch (e) {
    if (here()) showError(e);
    return;
  }
  if (!here()) return;
  $("solve-msg").textContent = "";
  mesh.field = "u";
  mesh.setData(output, scene);
  summaryFacts(output.summary);
  const history = output.summary.history;
  if (history && output.frames && output.frames.length > 0) showRun(history, output.frames);
  $("solve-canvas").dataset.ready = source;
  updateColorbar();
}

function showError(e) {
  $("solve-msg").textContent = "";
  $("solve-error").textContent = e.path ? `${e.message} (at ${e.path})` : e.message;
  $("solve-error").hidden = false;
}

/** The histories as plots and the frames behind the time slider. */
function showRun(history, frames) {
  const maxU = Math.max(0, ...frames.map((f) => Math.max(0, ...f.displacement.map(([a, b]) => Math.hypot(a, b)))));
  run = { frames, index: 0, timer: null, maxU };
  $("history-section").hidden = false;
  plots.show(history);
  const slider = $("time-slider");
  slider.max = String(frames.length - 1);
  slider.value = "0";
  $("time-controls").hidden = false;
  showFrame(0);
}

/** Show output time `index` on the mesh view and the plots. */
function showFrame(index) {
  if (!run) return;
  run.index = index;
  const frame = run.frames[index];
  mesh.setDisplacement(frame.displacement, run.maxU);
  plots.setTime(frame.time);
  $("time-slider").value = String(index);
  $("time-out").textContent = `t = ${num(frame.time, 4)} s (${index + 1} of ${run.frames.length})`;
  $("solve-canvas").dataset.frame = String(index);
  $("solve-canvas").dataset.time = String(frame.time);
  updateMag();
}

function play() {
  if (!run) return;
  if (run.index >= run.frames.length - 1) showFrame(0);
  $("time-play").textContent = "Pause";
  $("time-play").setAttribute("aria-pressed", "true");
  run.timer = setInterval(() => {
    if (run.index >= run.frames.length - 1) return pause();
    showFrame(run.index + 1);
  }, PLAY_MS);
}

function pause() {
  if (run) {
    clearInterval(run.timer);
    run.timer = null;
  }
  $("time-play").textContent = "Play";
  $("time-play").setAttribute("aria-pressed", "false");
}

function summaryFacts(s) {
  const pairs = [
    ["Mesh", `${s.mesh.nodes} nodes, ${s.mesh.triangles} triangles`],
    ["Unknowns", String(s.mesh.unknowns)],
    ["Contact pairs", String(s.mesh.contact_pairs)],
  ];
  const h = s.history;
  if (h) {
    const r = h.report;
    pairs.push(["Time steps", `${r.steps} × Δt = ${num(r.dt)} s (${r.scheme}), ${h.times.length} output times`]);
    pairs.push(["Contact solver", `${r.contact_solver}, ${r.qp_iterations} iterations, ${r.pdas_fallbacks} fallbacks`]);
    pairs.push(["Run time", duration(r.seconds)]);
    const p = h.peaks;
    pairs.push(["Peak |u|", `${num(p.displacement.value)} m at t = ${num(p.displacement.time)} s`]);
    pairs.push(["Peak contact pressure", `${num(p.contact_pressure.value)} Pa at t = ${num(p.contact_pressure.time)} s`]);
    pairs.push(["Note", "the summary's criteria are the static solve with the loads at t = 0"]);
  }
  for (const w of s.report.warnings || []) pairs.push(["Warning", typeof w === "string" ? w : w.message]);
  facts($("solve-facts"), pairs);
}

function updateColorbar() {
  const r = mesh.data ? mesh.range() : null;
  $("solve-cb-min").textContent = r ? num(r.lo, 4) : "";
  $("solve-cb-max").textContent = r ? num(r.hi, 4) : "";
  $("solve-cb-unit").textContent = r ? `|u| [m]${run ? " · one scale for every time" : ""}` : "";
}

function updateMag() {
  const m = mesh.magnification();
  $("solve-mag-out").textContent = mesh.data ? (m === 0 ? "(undeformed)" : `×${num(m, 3)}`) : "";
}

/** Wire the solve view's controls (once). */
export function initSolve() {
  mesh = new MeshView($("solve-canvas"), $("solve-tip"), $("solve-mesh-msg"));
  plots = new HistoryPlots($("history-plots"));
  drawColorbar($("solve-cb-canvas"));
  $("time-slider").addEventListener("input", () => {
    pause();
    showFrame(Number($("time-slider").value));
  });
  $("time-play").addEventListener("click", () => (run && run.timer ? pause() : play()));
  $("solve-mag").addEventListener("input", () => {
    mesh.setSlider(Number($("solve-mag").value));
    updateMag();
  });
  $("solve-reset").addEventListener("click", () => mesh.fit());
}
