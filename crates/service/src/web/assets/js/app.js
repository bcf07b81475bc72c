// The dashboard's entry: hash routes `#/` (jobs and submit), `#/submit`, `#/jobs/{id}`.
import { initHome, showHome, hideHome } from "./home.js";
import { initJob, showJob, hideJob } from "./job.js";
import { $, loadLabels } from "./format.js";
import { api } from "./api.js";

function route() {
  const hash = location.hash || "#/";
  const job = hash.match(/^#\/jobs\/([0-9a-fA-F-]+)$/);
  $("view-home").hidden = !!job;
  $("view-job").hidden = !job;
  if (job) {
    hideHome();
    showJob(job[1]);
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
  window.addEventListener("hashchange", route);
  route();
}

// uPlot is a classic deferred script: it has run before this module (modules are deferred too).
start();
