//! The global phase with exact derivatives (design §4.3, "The global question"): a locally
//! certified extremum is only a local statement, so after the vertex walk the budget goes to
//! looking for other local optima, and the search says what it found ([`GlobalEvidence`]).
//!
//! 1. **Vertices.** When the box has at most [`VERTEX_CAP`] vertices and the budget affords them
//!    beside a reserve for the starts, every vertex is evaluated (one batch). Each carries its own
//!    derivatives, so each is a proven local optimum of an objective or not (the sign test of
//!    [`certificate::certify`]) — for every objective at once.
//! 2. **Rounds of local searches** (projected quasi-Newton ascents, `ascent`), all objectives'
//!    ascents in lockstep so that the batches are wide. The starts of a round: a scrambled Latin
//!    hypercube (fresh points, shared by the objectives: the *random starts*); for each
//!    objective the vertices its gradient signs point to at the other objectives' optima; and,
//!    for every datum along which its derivative has been seen with both signs, its best point
//!    moved to the far end of that datum's interval (a criterion that is not monotone in a datum
//!    may peak at both ends). Each directed start is used once.
//! 3. **Stopping** ([`StopRule`]): `first_certificate` stops an objective when its best point is
//!    locally certified; `global_rule` when its *rule* is met: every vertex screened (or more
//!    than [`VERTEX_CAP`] of them) and the Boender–Rinnooy Kan estimate of the local optima not
//!    yet found, W(N − 1)/(N − W − 2) − W for N random starts whose ascents ended at W distinct
//!    optima, below ½ (Boender & Rinnooy Kan, Math. Programming 37, 1987: the posterior mean of
//!    the number of optima under a uniform prior on the basins' relative sizes); `budget` never
//!    stops early. Every mode stops at the budget, the time limit or a cancel.
//!
//! The local optima of an objective are the distinct ends of its local searches and its locally
//! certified vertices, clustered within [`SAME_OPTIMUM`] (unit box) or by equal value (within
//! 1e-9: a criterion independent of some data has a flat face of equal maxima, one optimum); the
//! best of them other than the reported extremum is the *runner-up*. An ascent that ends at the border of a region where
//! the solver fails (`unsettled`), or is cut short by the budget, found no optimum: it counts
//! neither as a start of the estimate nor as an optimum.

use std::collections::HashSet;

use serde::{Deserialize, Serialize};

use super::ascent::{self, Start};
use super::certificate::{self, scale, CERTIFY_TOL};
use super::optima::OPTIMUM_TOL;
use super::random::{stream, Rng};
use super::screening::latin_hypercube;
use super::session::{Probe, Session};
use super::space::{distance, is_vertex, Space};
use super::{Phase, Sense, Status, StopRule, Verdict};

/// Boxes with more vertices than this are never screened whole.
pub const VERTEX_CAP: u64 = 1024;
/// Ends of local searches this close (unit box, Euclidean) are the same local optimum.
pub const SAME_OPTIMUM: f64 = 0.05;
/// A point within this distance (unit box) of a local search's end is that end.
const SAME_POINT: f64 = 1e-6;
/// The rule is met when fewer than this many local optima are estimated unseen.
pub const UNSEEN_THRESHOLD: f64 = 0.5;
/// A runner-up local optimum within this fraction of |Φ| of the reported one is warned about.
pub const CLOSE_RUNNER_UP: f64 = 0.05;
/// Of the budget left after the vertex walk, this share (at most [`START_RESERVE_CAP`]
/// evaluations) is kept for the local searches when deciding whether the vertices fit.
const START_RESERVE_SHARE: f64 = 0.25;
const START_RESERVE_CAP: usize = 100;
/// Random stream ids of the rounds' Latin hypercubes (round r uses `ROUND_STREAM + r`).
const ROUND_STREAM: u64 = 1 << 20;

/// The default evaluation budget for `dim` free data: 300, plus the 2^dim vertices when there are
/// at most `VERTEX_CAP` (1024) of them, so that the global rule can be met by default.
pub fn default_budget(dim: usize) -> usize {
    match vertex_count(dim) {
        Some(v) if v <= VERTEX_CAP => 300 + v as usize,
        _ => 300,
    }
}

/// 2^dim, if it fits in a u64.
fn vertex_count(dim: usize) -> Option<u64> {
    u32::try_from(dim).ok().and_then(|d| 1u64.checked_shl(d))
}

/// What the search knows about the other local optima of an objective: how much of the box it
/// looked at, how many distinct local optima it found, the best of the others, and whether its
/// stopping rule was met.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct GlobalEvidence {
    /// The rule the search ran under (`search.stop`).
    pub stop: StopRule,
    /// Whether the global rule held when the search ended: all vertices screened (or more than
    /// 1024 of them) and fewer than ½ local optima estimated unseen. Evidence, not proof: a
    /// narrow peak no start fell into can still be missed.
    pub rule_met: bool,
    /// Vertices of the box evaluated.
    pub vertices_screened: u64,
    /// Vertices of the box, 2^k for k free data (`None` beyond 2^63).
    pub vertices_total: Option<u64>,
    /// Local searches run (the vertex walk and every ascent, also those cut short by the budget
    /// or ended at the border of a failure region).
    pub starts: usize,
    /// Ascents from points of the space-filling design (uniform starts) that ended at a local
    /// optimum: N of the estimate.
    pub random_starts: usize,
    /// Distinct local optima found: ends of local searches and locally certified vertices,
    /// clustered within 0.05 of the unit box.
    pub local_optima: usize,
    /// Of them, reached from random starts (W of the estimate).
    pub random_optima: usize,
    /// The Boender–Rinnooy Kan estimate of the local optima not yet found,
    /// W(N − 1)/(N − W − 2) − W (absent while N ≤ W + 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unseen_estimate: Option<f64>,
    /// The best local optimum other than the reported extremum and those tying with it within
    /// 1e-9 relative (those are `several_optima`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runner_up: Option<RunnerUp>,
    /// The evidence in plain words.
    pub summary: String,
}

/// The best local optimum other than the reported extremum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct RunnerUp {
    /// Its criterion value.
    pub value: f64,
    /// Its data, in the order of the parameters.
    pub point: Vec<f64>,
    /// (extremum − runner-up) / |extremum| for a maximum, the opposite for a minimum: how much
    /// less extreme it is (≥ 0).
    pub gap: f64,
    /// Whether the derivatives prove it a local optimum (else a local search stalled there).
    pub locally_certified: bool,
}

/// One distinct local optimum of an objective.
#[derive(Clone, Debug)]
struct Optimum {
    unit: Vec<f64>,
    score: f64,
    certified: bool,
    /// Random starts whose ascent ended here.
    random_hits: usize,
}

/// What one objective's global phase has seen.
#[derive(Default)]
struct Landscape {
    optima: Vec<Optimum>,
    starts: usize,
    random_starts: usize,
    /// Directed starts already used (bits of the unit point).
    used: HashSet<Vec<u64>>,
}

impl Landscape {
    /// Add a local optimum (or a new member of a known one: within [`SAME_OPTIMUM`], or of the
    /// same value within 1e-9 relative — a flat ridge or face of equal values is one optimum);
    /// its cluster index.
    fn note(&mut self, unit: &[f64], score: f64, certified: bool) -> usize {
        let same_value = |s: f64| (s - score).abs() <= OPTIMUM_TOL * s.abs().max(score.abs());
        if let Some(i) = self
            .optima
            .iter()
            .position(|o| distance(&o.unit, unit) <= SAME_OPTIMUM || same_value(o.score))
        {
            let o = &mut self.optima[i];
            if score > o.score {
                (o.unit, o.score) = (unit.to_vec(), score);
            }
            o.certified |= certified;
            return i;
        }
        self.optima.push(Optimum {
            unit: unit.to_vec(),
            score,
            certified,
            random_hits: 0,
        });
        self.optima.len() - 1
    }

    fn random_optima(&self) -> usize {
        self.optima.iter().filter(|o| o.random_hits > 0).count()
    }

    /// W(N − 1)/(N − W − 2) − W, defined for N > W + 2 and W ≥ 1.
    fn unseen_estimate(&self) -> Option<f64> {
        let (n, w) = (self.random_starts as f64, self.random_optima() as f64);
        (w >= 1.0 && n > w + 2.0).then(|| w * (n - 1.0) / (n - w - 2.0) - w)
    }
}

/// The global phase's state over all objectives.
pub(super) struct Global<'s, 'a> {
    session: &'s Session<'a>,
    stop: StopRule,
    landscapes: Vec<Landscape>,
    /// All vertices were screened, or there are too many to.
    vertices_done: bool,
}

impl<'s, 'a> Global<'s, 'a> {
    /// After the vertex walk, whose certified ends are the first local optima.
    pub(super) fn new(session: &'s Session<'a>, stop: StopRule) -> Self {
        let m = session.objectives().len();
        Global {
            session,
            stop,
            landscapes: (0..m)
                .map(|k| Landscape {
                    starts: session.ends(k),
                    ..Landscape::default()
                })
                .collect(),
            vertices_done: vertex_count(session.space.dim()).is_none_or(|v| v > VERTEX_CAP),
        }
    }

    /// Run the phase — vertices, then rounds of starts until every objective may stop — and
    /// give each objective's status: `budget_exhausted` for one still looking when the budget
    /// ran out, a halt's status, else `stagnated` (the caller turns a locally certified best
    /// point into `locally_certified`).
    pub(super) fn run(&mut self, seed: u64) -> Vec<Status> {
        self.harvest_vertices();
        let mut exhausted = false;
        if !self.active().is_empty() {
            self.screen_vertices();
            self.harvest_vertices();
            let mut round = 0;
            loop {
                let active = self.active();
                if active.is_empty() || self.session.check_halt().is_some() {
                    break;
                }
                let before = self.session.evaluations();
                self.session.set_phase(Phase::Multistart { round });
                let mut rng = stream(seed, ROUND_STREAM + round as u64);
                exhausted = self.round(&active, &mut rng);
                if exhausted || self.session.evaluations() == before {
                    break;
                }
                round += 1;
            }
        }
        let active = self.active();
        (0..self.landscapes.len())
            .map(|k| {
                self.session
                    .halt()
                    .unwrap_or(if exhausted && active.contains(&k) {
                        Status::BudgetExhausted
                    } else {
                        Status::Stagnated
                    })
            })
            .collect()
    }

    /// The objectives that may not stop yet.
    fn active(&self) -> Vec<usize> {
        (0..self.landscapes.len())
            .filter(|&k| match self.stop {
                StopRule::Budget => true,
                StopRule::GlobalRule => !self.rule_met(k),
                StopRule::FirstCertificate => !self.best_certified(k),
            })
            .collect()
    }

    fn best_certified(&self, k: usize) -> bool {
        self.session.best_probe(k).is_some_and(|p| {
            let sense = self.session.objectives()[k].sense;
            certificate::certify(
                self.session.space,
                sense,
                &p.unit,
                p.value,
                p.slopes.as_deref(),
            )
            .verdict
                == Verdict::LocallyCertified
        })
    }

    fn rule_met(&self, k: usize) -> bool {
        self.vertices_done
            && self.landscapes[k]
                .unseen_estimate()
                .is_some_and(|u| u < UNSEEN_THRESHOLD)
    }

    /// Evaluate every vertex when there are at most [`VERTEX_CAP`] and they fit the budget beside
    /// the reserve for the starts.
    fn screen_vertices(&mut self) {
        let dim = self.session.space.dim();
        let Some(count) = vertex_count(dim).filter(|&v| v <= VERTEX_CAP) else {
            return;
        };
        let left = self
            .session
            .budget()
            .saturating_sub(self.session.evaluations());
        let reserve = ((left as f64 * START_RESERVE_SHARE) as usize).min(START_RESERVE_CAP);
        if count as usize > left.saturating_sub(reserve) {
            return;
        }
        self.session.set_phase(Phase::Screening);
        let vertices: Vec<Vec<f64>> = (0..count)
            .map(|mask| (0..dim).map(|j| ((mask >> j) & 1) as f64).collect())
            .collect();
        if self.session.evaluate(&vertices).is_ok() {
            self.vertices_done = true;
        }
    }

    /// Every evaluated vertex that the derivatives prove locally optimal for an objective is one
    /// of its local optima.
    fn harvest_vertices(&mut self) {
        for (k, landscape) in self.landscapes.iter_mut().enumerate() {
            let sense = self.session.objectives()[k].sense;
            for p in self.session.feasible(k) {
                if is_vertex(&p.unit) && certified(self.session.space, sense, &p) {
                    landscape.note(&p.unit, sense.score(p.value), true);
                }
            }
        }
    }

    /// One round for the `active` objectives: new random starts and the directed starts, all
    /// ascents in lockstep; whether the budget ran out.
    fn round(&mut self, active: &[usize], rng: &mut Rng) -> bool {
        let dim = self.session.space.dim();
        let random = latin_hypercube(dim, (dim + 1).max(4), rng);
        // Directed starts first: when the budget cannot take a whole round, the ascents listed
        // last end first, and finishing the best point's local search matters most.
        let mut starts: Vec<Start> = Vec::new();
        for &k in active {
            for unit in self.directed_starts(k) {
                starts.push(Start {
                    objective: k,
                    unit,
                    random: false,
                });
            }
        }
        for &k in active {
            for u in &random {
                starts.push(Start {
                    objective: k,
                    unit: u.clone(),
                    random: true,
                });
            }
        }
        let mut exhausted = false;
        let ends = ascent::run(self.session, &starts, self.session.budget());
        for (start, (status, end)) in starts.iter().zip(ends) {
            exhausted |= status == Status::BudgetExhausted;
            let k = start.objective;
            self.landscapes[k].starts += 1;
            let Some((unit, score)) = end else { continue };
            if !matches!(status, Status::LocallyCertified | Status::Stagnated) {
                continue;
            }
            self.session.note_end(k, unit.clone());
            let certified = status == Status::LocallyCertified;
            let landscape = &mut self.landscapes[k];
            let i = landscape.note(&unit, score, certified);
            if start.random {
                landscape.random_starts += 1;
                landscape.optima[i].random_hits += 1;
            }
        }
        exhausted
    }

    /// Objective `k`'s starts not used before: the vertices its gradient signs point to at the
    /// other objectives' optima, and its best point moved to the far end of every datum along
    /// which its derivative changes sign.
    fn directed_starts(&mut self, k: usize) -> Vec<Vec<f64>> {
        let session = self.session;
        let sense = session.objectives()[k].sense;
        let mut starts: Vec<Vec<f64>> = Vec::new();
        for (other, landscape) in self.landscapes.iter().enumerate() {
            if other == k {
                continue;
            }
            for o in &landscape.optima {
                if let Some(p) = session.probe_at(k, &o.unit) {
                    if let Some(slopes) = &p.slopes {
                        starts.push(sign_vertex(session.space, sense, slopes));
                    }
                }
            }
        }
        if let Some(best) = session.best_probe(k) {
            // The best point, when no local search has ended there and it is not proven: the
            // local search it deserves (e.g. an ascent the budget cut short earlier).
            if !certified(session.space, sense, &best)
                && session.ends_near(k, &best.unit, SAME_POINT) == 0
            {
                starts.push(best.unit.clone());
            }
            for j in sign_changes(session.space, sense, &session.feasible(k)) {
                let mut u = best.unit.clone();
                u[j] = if u[j] >= 0.5 { 0.0 } else { 1.0 };
                starts.push(u);
            }
        }
        let used = &mut self.landscapes[k].used;
        starts.retain(|u| used.insert(u.iter().map(|x| x.to_bits()).collect()));
        starts
    }

    /// The evidence of objective `k`, for the extremum reported at `best` (unit point, value).
    pub(super) fn evidence(&self, k: usize, best: Option<(&[f64], f64)>) -> GlobalEvidence {
        let landscape = &self.landscapes[k];
        let sense = self.session.objectives()[k].sense;
        let dim = self.session.space.dim();
        let runner_up = best.and_then(|(unit, value)| {
            // Optima that tie with the extremum (within 1e-9) are several maximisers of the same
            // value (`several_optima`), not a runner-up.
            let tie = sense.score(value) - OPTIMUM_TOL * scale(value);
            landscape
                .optima
                .iter()
                .filter(|o| distance(&o.unit, unit) > SAME_OPTIMUM && o.score < tie)
                .max_by(|a, b| a.score.total_cmp(&b.score))
                .map(|o| RunnerUp {
                    value: sense.score(o.score),
                    point: self.session.space.to_physical(&o.unit),
                    gap: (sense.score(value) - o.score) / scale(value),
                    locally_certified: o.certified,
                })
        });
        let mut evidence = GlobalEvidence {
            stop: self.stop,
            rule_met: self.rule_met(k),
            vertices_screened: self.session.vertices_evaluated() as u64,
            vertices_total: vertex_count(dim),
            starts: landscape.starts,
            random_starts: landscape.random_starts,
            local_optima: landscape.optima.len(),
            random_optima: landscape.random_optima(),
            unseen_estimate: landscape.unseen_estimate(),
            runner_up,
            summary: String::new(),
        };
        evidence.summary = summary(&evidence);
        evidence
    }
}

/// Whether the derivatives at `p` prove it a local optimum of an objective of `sense`.
fn certified(space: &Space, sense: Sense, p: &Probe) -> bool {
    certificate::certify(space, sense, &p.unit, p.value, p.slopes.as_deref()).verdict
        == Verdict::LocallyCertified
}

/// The vertex the signs of an objective's `slopes` point to (unit box; ties go down).
fn sign_vertex(space: &Space, sense: Sense, slopes: &[super::OneSided]) -> Vec<f64> {
    certificate::unit_slopes(space, sense, slopes)
        .iter()
        .map(|s| if s.mean() > 0.0 { 1.0 } else { 0.0 })
        .collect()
}

/// The free data along which the objective's derivative has been seen clearly positive at one
/// evaluated point and clearly negative at another.
fn sign_changes(space: &Space, sense: Sense, points: &[Probe]) -> Vec<usize> {
    let mut seen = vec![[false; 2]; space.dim()];
    for p in points {
        let Some(slopes) = &p.slopes else { continue };
        let tol = CERTIFY_TOL * scale(p.value);
        for (j, s) in certificate::unit_slopes(space, sense, slopes)
            .iter()
            .enumerate()
        {
            seen[j][0] |= s.mean() > tol;
            seen[j][1] |= s.mean() < -tol;
        }
    }
    (0..seen.len())
        .filter(|&j| seen[j][0] && seen[j][1])
        .collect()
}

/// The evidence in plain words.
fn summary(e: &GlobalEvidence) -> String {
    let vertices = match e.vertices_total {
        Some(total) if total <= VERTEX_CAP => {
            format!("{} of {total} vertices screened", e.vertices_screened)
        }
        Some(total) => format!("{total} vertices, too many to screen"),
        None => "too many vertices to screen".to_string(),
    };
    let unseen = e
        .unseen_estimate
        .map_or("not yet estimable".to_string(), |u| format!("{u:.2}"));
    let optima = format!(
        "{} local searches ({} from random starts ending at an optimum) found {} distinct \
         local {}; local optima estimated unseen: {unseen}",
        e.starts,
        e.random_starts,
        e.local_optima,
        if e.local_optima == 1 {
            "optimum"
        } else {
            "optima"
        }
    );
    let verdict = match (e.stop, e.rule_met) {
        (_, true) => "global rule met".to_string(),
        (StopRule::FirstCertificate, false) => {
            "global rule not met: the search stopped at its first local certificate \
             (search.stop = first_certificate)"
                .to_string()
        }
        (_, false) => "global rule not met".to_string(),
    };
    format!("{verdict}: {vertices}; {optima}")
}

/// The evidence of a search without derivatives: what it screened, and that no rule applies.
pub(super) fn without_derivatives(session: &Session, stop: StopRule) -> GlobalEvidence {
    let vertices_total = vertex_count(session.space.dim());
    let vertices_screened = session.vertices_evaluated() as u64;
    GlobalEvidence {
        stop,
        vertices_screened,
        vertices_total,
        summary: format!(
            "global rule not applicable: searched without derivatives, so no local optimum is \
             proven and none can be counted ({vertices_screened} of {} vertices evaluated)",
            vertices_total.map_or("2^k".to_string(), |v| v.to_string())
        ),
        ..GlobalEvidence::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boender_rinnooy_kan_estimate() {
        let mut l = Landscape::default();
        l.note(&[0.0], 1.0, true);
        l.optima[0].random_hits = 3;
        l.random_starts = 3;
        // N = W + 2: not estimable yet.
        assert_eq!(l.unseen_estimate(), None);
        l.random_starts = 7;
        // 1 · 6 / 4 − 1 = 0.5: not yet below ½.
        assert_eq!(l.unseen_estimate(), Some(0.5));
        l.random_starts = 8;
        assert!((l.unseen_estimate().unwrap() - 0.4).abs() < 1e-15);
        // A second optimum: 2 · 7 / 4 − 2 = 1.5 unseen.
        let i = l.note(&[1.0], 0.5, false);
        l.optima[i].random_hits = 1;
        assert!((l.unseen_estimate().unwrap() - 1.5).abs() < 1e-15);
        // Ends within 0.05 join a cluster, keeping the better point.
        assert_eq!(l.note(&[0.97], 0.7, true), 1);
        // A far end of the same value (a flat face of maxima) is the same optimum.
        assert_eq!(l.note(&[0.5], 1.0 + 1e-12, false), 0);
        assert_eq!(l.optima.len(), 2);
        assert_eq!(
            (l.optima[1].unit.clone(), l.optima[1].certified),
            (vec![0.97], true)
        );
        assert_eq!(default_budget(3), 308);
        assert_eq!(default_budget(10), 1324);
        assert_eq!(default_budget(11), 300);
    }
}
