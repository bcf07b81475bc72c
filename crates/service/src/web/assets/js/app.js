// The dashboard's entry: hash routes `#/` (jobs and submit), `#/submit`, `#/jobs/{id}`,
// `#/solve/{example}` and `#/solve/upload`.
import { initHome, showHome, hideHome } from "./home.js";
import { initJob, showJob, hideJob } from "./job.js";
import { initSolve, showSolve, hideSolve } from "./solve.js";
import { $, loadLabels } from "./format.js";
import { api } from "./api.js";

function route() {
  const hash = location.hash || "#/";
  const job = hash.match(/^#\/jobs\/([0-9a-fA-F-]+)$/);
  const solve = hash.match(/^#\/solve\/([A-Za-z0-9_.-]+)$/);
  $("view-home").hidden = !!(job || solve);
  $("view-job").hidden = !job;
  $("view-solve").hidden = !solve;
  if (!solve) hideSolve();
  if (job) {
    hideHome();
    showJob(job[1]);
  } else if (solve) {
    hideHome();
    hideJob();
    showSolve(solve[1]);
  } else {
    hideJob();
    document.title = "wsm — worst-scenario dashboard";
    showHome();
    if (hash === "#/submit") $("example").focus();
  }
}

async function start() {
  await loadLabels(api.labels);
  initHome();
  initJob();
  initSolve();
  window.addEventListener("hashchange", route);
  route();
}

// uPlot is a classic deferred script: it has run before this module (modules are deferred too).
start();
