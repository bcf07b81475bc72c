//! Injected solve failures, for the tests of how a run reports them (design §6, "No failure
//! hidden"): a [`SolveFault`] is asked before each solve of a run — a search evaluation, a
//! refined solve of the accuracy statement, a solve of the target-error mesh choice — and where it
//! answers `Some(reason)` that solve fails with the reason instead of solving. The run then
//! handles the failure exactly as a solver's refusal. Nothing outside tests and the hidden
//! `wsm serve --inject-failures` flag sets one.

/// The solve a [`SolveFault`] is asked about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultSite<'a> {
    /// An evaluation of the search at the uncertain data `point`.
    Evaluation {
        /// The uncertain parameter values, in the order of the scene's `uncertain` list.
        point: &'a [f64],
    },
    /// A solve of the accuracy statement at `point` on the run's mesh refined `level` times
    /// (`crate::estimate::statement`).
    Refined {
        /// Mesh sizes halved this many times (1 or 2).
        level: u32,
        /// The uncertain parameter values (the worst or best data of some criteria).
        point: &'a [f64],
    },
    /// A solve of the target-error mesh choice at the nominal data, on the scene's mesh with
    /// every size × `size_factor` (`crate::estimate::mesh_choice`).
    MeshChoice {
        /// Mesh sizes relative to the scene's (4, 2, 1, 1/2, …).
        size_factor: f64,
    },
}

/// A fault injector: `Some(reason)` fails the solve at that site with the reason.
pub type SolveFault = dyn Fn(&FaultSite<'_>) -> Option<String> + Send + Sync;

/// What `fault` answers at `site` (nothing without a fault).
pub fn injected(fault: Option<&SolveFault>, site: FaultSite<'_>) -> Option<String> {
    fault.and_then(|f| f(&site))
}
