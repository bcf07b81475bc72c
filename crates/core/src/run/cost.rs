//! What a direct solve of a scene will cost, before meshing it (design §3.1, "Cost before
//! solving"): triangles, unknowns and contact pairs from the size field ([`crate::mesh::count`]),
//! peak memory and time from a model of the direct contact solver calibrated on measured peak RSS
//! and wall time (docs/benchmarks.md, "Solve cost"), and the refusal of a solve beyond a memory
//! limit, naming the size field that dominates and the value of it that fits.
//!
//! Memory model of the dense contact path: the dual Hessian C = B K⁺ Bᵀ is m × m with
//! m = 2 × pairs, and the solve holds about [`DENSE_COPIES`] matrices of that size at its peak
//! (C, its floating-body projection and correction terms, the QP's scaled copy and Cholesky
//! factor of the free set, the W = L₂₂⁻¹ B_cᵀ blocks); the rest grows with the unknowns (sparse
//! factor, mesh, fields). Time: the QP's dense factorisations, ∝ m³. The sparse contact path
//! (taken from [`crate::contact::sparse::AUTO_PAIRS`] pairs, or by `solver.contact`) holds no
//! matrix of the pairs' size: its memory and time grow with the unknowns only
//! ([`SPARSE_BYTES_PER_UNKNOWN`], [`SPARSE_SECONDS_PER_UNKNOWN`]: one merged pattern, its factor
//! and about 15 active-set steps).

use serde::Serialize;

use crate::error::WsmError;
use crate::scene::{ContactMethod, Scene, SceneError};

/// m × m matrices of 8 bytes held at the peak of a dense contact solve, m from the *estimated*
/// pairs (fitted: peak RSS of block-on-base at refine 0.004 … 0.0007 and tunnel-fault,
/// docs/benchmarks.md). On the real pairs it is 10.5; the pair estimate runs about 18 % low on
/// finely refined contact lines and this factor absorbs it.
const DENSE_COPIES: f64 = 14.5;
/// Bytes of a solve without contact: the process, the mesh and the tables.
const BASE_BYTES: f64 = 60.0e6;
/// Bytes per unknown: sparse factor, operator, mesh, fields (fitted with the above and hertz at refine 0.004, 70,514 unknowns).
const BYTES_PER_UNKNOWN: f64 = 1500.0;
/// Seconds per m³ of the dense QP (fitted on the same runs; machine dependent).
const SECONDS_PER_M3: f64 = 9.0e-10;
/// Seconds per unknown of meshing, assembly and factorisation.
const SECONDS_PER_UNKNOWN: f64 = 2.0e-5;
/// Extra bytes per unknown of the sparse contact path: the merged pattern, its assembly plan,
/// the step's factor and right-hand sides (fitted: hertz with 3,848 and 10,020 pairs, 144,166
/// and 370,902 unknowns, peak RSS 366 MB and 931 MB, docs/benchmarks.md).
const SPARSE_BYTES_PER_UNKNOWN: f64 = 1000.0;
/// Seconds per unknown of the sparse path's active-set steps (same runs: 13 and 16 steps).
const SPARSE_SECONDS_PER_UNKNOWN: f64 = 3.5e-5;
/// Share of the limit the suggested size aims at (estimates are within ~20 %).
const FIT_MARGIN: f64 = 0.8;

/// The estimated cost of one direct solve of a scene.
#[derive(Debug, Clone, Serialize)]
pub struct SolveCost {
    /// Triangles of the mesh.
    pub triangles: f64,
    /// Displacement unknowns (2 per node, before boundary conditions).
    pub unknowns: f64,
    /// Contact node pairs.
    pub contact_pairs: f64,
    /// Whether the contact problem is solved on the sparse path (no dense C; `solver.contact`,
    /// or `auto` with at least 1,500 estimated pairs).
    pub sparse_contact: bool,
    /// Peak memory \[bytes\].
    pub bytes: f64,
    /// Wall time of one solve \[s\] (order of magnitude; machine dependent).
    pub seconds: f64,
    /// JSON path of the size that accounts for most triangles (`mesh.max_size` or
    /// `mesh.refine[i].max_size`; `mesh.gmsh_file` or `mesh.inline` for an imported mesh).
    pub size_field: String,
    #[serde(skip)]
    scene: Scene,
}

/// A solve refused before meshing: the size field to coarsen and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CostRefusal {
    /// JSON path of the field, e.g. `mesh.refine[0].max_size`.
    pub path: String,
    /// The estimate, the limit and the value of the field that fits.
    pub message: String,
}

impl From<CostRefusal> for WsmError {
    fn from(r: CostRefusal) -> WsmError {
        SceneError::new(r.path, r.message).into()
    }
}

/// The cost of a direct solve of `scene`, from its polygons and size field (no meshing).
pub fn estimate_solve_cost(scene: &Scene) -> Result<SolveCost, WsmError> {
    let count = crate::mesh::count(scene)?;
    let sparse_contact = takes_sparse_path(scene, count.contact_pairs);
    let (bytes, seconds) = model(count.nodes, count.contact_pairs, sparse_contact);
    let size_field = count
        .shares
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or_else(|| "mesh.max_size".to_string(), |s| s.0.clone());
    Ok(SolveCost {
        triangles: count.triangles,
        unknowns: 2.0 * count.nodes,
        contact_pairs: count.contact_pairs,
        sparse_contact,
        bytes,
        seconds,
        size_field,
        scene: scene.clone(),
    })
}

/// Whether the direct solver takes the sparse contact path with about `pairs` pairs.
fn takes_sparse_path(scene: &Scene, pairs: f64) -> bool {
    match scene.solver.contact {
        ContactMethod::Dense => false,
        ContactMethod::Sparse => true,
        ContactMethod::Auto => pairs >= crate::contact::sparse::AUTO_PAIRS as f64,
    }
}

/// (peak bytes, seconds) of a direct solve with these nodes and contact pairs, on the sparse
/// contact path or the dense one.
fn model(nodes: f64, pairs: f64, sparse: bool) -> (f64, f64) {
    let (unknowns, m) = (2.0 * nodes, 2.0 * pairs);
    let base = BASE_BYTES + BYTES_PER_UNKNOWN * unknowns;
    if sparse {
        return (
            base + SPARSE_BYTES_PER_UNKNOWN * unknowns,
            (SECONDS_PER_UNKNOWN + SPARSE_SECONDS_PER_UNKNOWN) * unknowns,
        );
    }
    let bytes = base + DENSE_COPIES * 8.0 * m * m;
    let seconds = SECONDS_PER_UNKNOWN * unknowns + SECONDS_PER_M3 * m.powi(3);
    (bytes, seconds)
}

impl SolveCost {
    /// Ok when the solve fits in `max_bytes`; else the refusal naming the dominant size field,
    /// the estimate and the smallest value of that field that fits (when one does).
    pub fn check(&self, max_bytes: f64) -> Result<(), CostRefusal> {
        if self.bytes <= max_bytes {
            return Ok(());
        }
        let mut message = format!(
            "about {} triangles and {} contact pairs need about {} of memory (and about {}); \
             this limit is {}",
            count_text(self.triangles),
            count_text(self.contact_pairs),
            bytes_text(self.bytes),
            seconds_text(self.seconds),
            bytes_text(max_bytes),
        );
        match self.fitting_size(FIT_MARGIN * max_bytes) {
            Some(size) => message += &format!("; a max_size of at least {size} fits"),
            None if self.scene.mesh.subdivide > 0 => {
                message += "; subdivide the imported mesh less (mesh.subdivide)"
            }
            None if self.scene.mesh.gmsh_file.is_some() => {
                message += "; make a coarser mesh in Gmsh"
            }
            None if self.scene.mesh.inline.is_some() => message += "; give a coarser mesh",
            None => message += "; no value of this field alone fits: coarsen the others too",
        }
        Err(CostRefusal {
            path: self.size_field.clone(),
            message,
        })
    }

    /// The smallest value (2 significant digits, rounded up) of the dominant size field with
    /// which the estimate is within `target` bytes, by bisection on a log scale.
    fn fitting_size(&self, target: f64) -> Option<f64> {
        let current = size_at(&self.scene, &self.size_field)?;
        let bytes = |v: f64| -> Option<f64> {
            let mut scene = self.scene.clone();
            set_size(&mut scene, &self.size_field, v);
            let count = crate::mesh::count(&scene).ok()?;
            let sparse = takes_sparse_path(&scene, count.contact_pairs);
            Some(model(count.nodes, count.contact_pairs, sparse).0)
        };
        let (mut lo, mut hi) = (current, current);
        for _ in 0..30 {
            hi *= 2.0;
            if bytes(hi)? <= target {
                break;
            }
            lo = hi;
        }
        if bytes(hi)? > target {
            return None;
        }
        for _ in 0..12 {
            let mid = (lo * hi).sqrt();
            if bytes(mid)? <= target {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(round_up_2(hi))
    }
}

/// The value of `mesh.max_size` or `mesh.refine[i].max_size` (`None` for an imported mesh's
/// `mesh.gmsh_file` or `mesh.inline`: no size of wsm's changes it).
fn size_at(scene: &Scene, path: &str) -> Option<f64> {
    match refine_index(path) {
        Some(i) => scene.mesh.refine.get(i).map(|r| r.max_size),
        None if scene.mesh.imported() == Some(path) => None,
        None => scene.mesh.max_size,
    }
}

fn set_size(scene: &mut Scene, path: &str, value: f64) {
    match refine_index(path) {
        Some(i) => scene.mesh.refine[i].max_size = value,
        None => scene.mesh.max_size = Some(value),
    }
}

fn refine_index(path: &str) -> Option<usize> {
    path.strip_prefix("mesh.refine[")?
        .split(']')
        .next()?
        .parse()
        .ok()
}

/// x rounded up to two significant digits.
fn round_up_2(x: f64) -> f64 {
    let scale = 10f64.powf(x.log10().floor() - 1.0);
    let r = (x / scale).ceil() * scale;
    // Print cleanly: through the decimal text.
    format!("{r:.12}").parse().unwrap_or(r)
}

/// 93,103 below a million, 2.1e6 above.
fn count_text(x: f64) -> String {
    if x >= 1e6 {
        return format!("{x:.1e}");
    }
    let digits = format!("{:.0}", x.max(0.0));
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Bytes in MB or GB with two significant digits.
fn bytes_text(b: f64) -> String {
    let (v, unit) = if b >= 1e9 {
        (b / 1e9, "GB")
    } else {
        (b / 1e6, "MB")
    };
    if v >= 10.0 {
        format!("{v:.0} {unit}")
    } else {
        format!("{v:.1} {unit}")
    }
}

/// Seconds, minutes or hours, two significant digits at most.
fn seconds_text(t: f64) -> String {
    if t < 120.0 {
        format!("{:.0} s", t.max(1.0))
    } else if t < 7200.0 {
        format!("{:.0} min", t / 60.0)
    } else {
        format!("{:.0} h", t / 3600.0)
    }
}

/// A safe share of the machine for one solve: half of the memory available to this process
/// (the smaller of MemTotal in /proc/meminfo and a cgroup v2 limit), 4 GiB when neither can be
/// read.
pub fn default_max_solve_memory() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find_map(|l| l.strip_prefix("MemTotal:"))
            .and_then(|v| v.trim().strip_suffix("kB"))
            .and_then(|v| v.trim().parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok());
    match (total, cgroup) {
        (Some(t), Some(c)) => t.min(c) / 2,
        (Some(t), None) => t / 2,
        (None, Some(c)) => c / 2,
        (None, None) => 4 << 30,
    }
}

/// Bytes from `12000000000`, `12G`, `512M`, `4GiB`, `1.5T` (K, M, G, T: powers of 1024).
pub fn parse_bytes(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("'{text}' is not a size in bytes (e.g. 12G, 512M, 4000000000)"))?;
    let shift = match unit
        .trim()
        .to_ascii_uppercase()
        .trim_end_matches("IB")
        .trim_end_matches('B')
    {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("'{text}': unknown unit (use K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if (1.0..1.8e19).contains(&bytes) {
        Ok(bytes as u64)
    } else {
        Err(format!("'{text}' is not a positive size in bytes"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block_on_base(refine: f64) -> Scene {
        let mut scene =
            crate::scene::parse(crate::bundled::example("block-on-base").unwrap()).expect("parses");
        scene.mesh.refine[0].max_size = refine;
        scene
    }

    fn dense(mut scene: Scene) -> Scene {
        scene.solver.contact = ContactMethod::Dense;
        scene
    }

    /// The independent probe's block-on-base case (refine 0.0002, 23 GB before the OOM killer;
    /// design §3.1, "Cost before solving") on the dense contact path is refused under a 12 GB
    /// limit, naming the refinement, and the suggested size does fit.
    #[test]
    fn refusal_names_the_field_and_a_size_that_fits() {
        let cost = estimate_solve_cost(&dense(block_on_base(0.0002))).unwrap();
        let limit = 12e9;
        let refusal = cost.check(limit).expect_err("too big");
        assert_eq!(refusal.path, "mesh.refine[0].max_size");
        assert!(
            refusal.message.contains("this limit is 12 GB"),
            "{}",
            refusal.message
        );
        let suggested: f64 = refusal
            .message
            .rsplit("at least ")
            .next()
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .expect("a suggested size");
        assert!(suggested > 0.0002, "{suggested}");
        let fits = estimate_solve_cost(&dense(block_on_base(suggested))).unwrap();
        assert!(fits.bytes <= limit, "{} > {limit}", fits.bytes);
        assert!(fits.check(limit).is_ok());
        // Just below the suggestion (2 significant digits) no longer meets the margin.
        let below = estimate_solve_cost(&dense(block_on_base(0.9 * suggested))).unwrap();
        assert!(below.bytes > FIT_MARGIN * limit * 0.999);
    }

    /// By default the probe's case takes the sparse contact path, whose estimate is the
    /// measured peak (657 MB for 249,110 unknowns and 9,519 pairs, docs/benchmarks.md) within
    /// 30 %; a ten times finer refinement (2.1e6 triangles, 5.5 GB) is refused on it under 4 GB.
    #[test]
    fn many_pairs_take_the_sparse_path_in_the_estimate() {
        let cost = estimate_solve_cost(&block_on_base(0.0002)).unwrap();
        assert!(cost.sparse_contact, "{} pairs", cost.contact_pairs);
        assert!(
            (cost.bytes / 657e6 - 1.0).abs() < 0.3,
            "{} bytes estimated",
            cost.bytes
        );
        let finer = estimate_solve_cost(&block_on_base(0.00002)).unwrap();
        assert!(finer.sparse_contact);
        let refusal = finer.check(4e9).expect_err("too big");
        assert_eq!(refusal.path, "mesh.refine[0].max_size");
    }

    /// The global size dominates when the refinement is no finer than it.
    #[test]
    fn global_size_named_when_it_dominates() {
        let mut scene = block_on_base(0.0042);
        scene.mesh.max_size = Some(0.0042);
        let cost = estimate_solve_cost(&scene).unwrap();
        assert_eq!(cost.size_field, "mesh.max_size");
        let refusal = cost.check(cost.bytes / 2.0).expect_err("over half");
        assert_eq!(refusal.path, "mesh.max_size");
    }

    #[test]
    fn byte_sizes_parse() {
        assert_eq!(parse_bytes("4G"), Ok(4 << 30));
        assert_eq!(parse_bytes("512MiB"), Ok(512 << 20));
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert_eq!(parse_bytes("1.5K"), Ok(1536));
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("4Q").is_err());
        assert!(parse_bytes("0").is_err());
        assert!(default_max_solve_memory() > 0);
    }

    #[test]
    fn texts() {
        assert_eq!(count_text(93103.4), "93,103");
        assert_eq!(count_text(2_140_000.0), "2.1e6");
        assert_eq!(bytes_text(23.4e9), "23 GB");
        assert_eq!(seconds_text(300.0), "5 min");
        assert_eq!(round_up_2(0.001_041), 0.0011);
    }
}
