//! The scaling benchmark (sizes x states x methods), shared by the example
//! binary and the command line so both measure the same thing.

use crate::bvh::build::build;
use crate::detect::{new_detector, DetectorOptions, Method};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::scene::{grid_side_for, try_grid, BenchState};
use crate::stats::FrameStats;
use std::sync::Arc;
use std::time::Instant;

/// One row of the scaling benchmark: one size, state and method.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalingRow {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// The state the cloth is in.
    pub state: BenchState,
    /// The detection method.
    pub method: Method,
    /// Median BVH build time over the repetitions, its depth-first
    /// renumbering included (what a kept detector pays), in s; 0 for brute.
    pub build_time: f64,
    /// Median refit time per frame (s).
    pub refit_time: f64,
    /// Median traversal (+ narrow phase) time per frame (s).
    pub traverse_time: f64,
    /// Counters of the last repetition (identical across repetitions).
    pub stats: FrameStats,
    /// BVH bytes per triangle, renumbered depth-first (0 for brute; not
    /// counting the detector's copy of the mesh in that order).
    pub bvh_bytes_per_triangle: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Smallest size measured: the sensor needs at least as many triangles as its 4 particles.
pub const MIN_SIZE: usize = 8;

/// Measures every (size, state, method): `reps` detections of the same frame
/// after one warm-up, medians reported. Calls `progress` after each row.
/// Errors: a size below [`MIN_SIZE`], too large for 32-bit indices, or too
/// large to allocate ([`crate::Error::OutOfMemory`]).
pub fn scaling(
    sizes: &[usize],
    states: &[BenchState],
    methods: &[Method],
    reps: usize,
    mut progress: impl FnMut(&ScalingRow),
) -> Result<Vec<ScalingRow>> {
    scaling_until(sizes, states, methods, reps, |r| {
        progress(r);
        Ok(())
    })
}

/// [`scaling`] whose `progress` can stop the run: its first error (e.g.
/// [`crate::Error::Interrupted`]) is returned at once.
pub fn scaling_until(
    sizes: &[usize],
    states: &[BenchState],
    methods: &[Method],
    reps: usize,
    mut progress: impl FnMut(&ScalingRow) -> Result<()>,
) -> Result<Vec<ScalingRow>> {
    if let Some(&bad) = sizes.iter().find(|&&s| s < MIN_SIZE) {
        return Err(Error::InvalidParameter(format!(
            "benchmark sizes must be at least {MIN_SIZE} triangles, got {bad}"
        )));
    }
    let mut rows = Vec::new();
    for &size in sizes {
        let side = grid_side_for(size);
        let (v, f) = try_grid(side, 1.0)?;
        let mesh = Arc::new(Mesh::new(v, f)?);
        let mut bytes = 0.0;
        let builds: Vec<f64> = (0..reps.clamp(1, 3))
            .map(|_| {
                // What a kept detector builds: the hierarchy, renumbered depth-first.
                let t0 = Instant::now();
                let (bvh, ..) = build(&mesh).depth_first(&mesh);
                let t = t0.elapsed().as_secs_f64();
                bytes = bvh.memory_bytes() as f64 / mesh.n_triangles() as f64;
                t
            })
            .collect();
        let build_time = median(builds);
        for &state in states {
            let p = state.deformation(side).apply(mesh.rest());
            for &method in methods {
                let mut det = new_detector(mesh.clone(), method, &DetectorOptions::default())?;
                let mut last = det.detect(&p)?.stats;
                let (mut refit, mut trav) = (Vec::new(), Vec::new());
                for _ in 0..reps.max(1) {
                    last = det.detect(&p)?.stats;
                    refit.push(last.refit_time);
                    trav.push(last.traverse_time + last.sensor_time);
                }
                let is_bvh = method != Method::Brute;
                let row = ScalingRow {
                    triangles: mesh.n_triangles(),
                    state,
                    method,
                    build_time: if is_bvh { build_time } else { 0.0 },
                    refit_time: median(refit),
                    traverse_time: median(trav),
                    stats: last,
                    bvh_bytes_per_triangle: if is_bvh { bytes } else { 0.0 },
                };
                progress(&row)?;
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[ScalingRow]) -> String {
    let mut s = String::from(
        "| triangles | state | method | build ms | refit ms | traverse ms | refit+traverse ms | node pairs | cone culls | contour tests | primitive tests | contacts | BVH B/tri |\n|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let st = &r.stats;
        s += &format!(
            "| {} | {} | {} | {:.1} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {} | {:.0} |\n",
            r.triangles,
            r.state.name(),
            r.method,
            r.build_time * 1e3,
            r.refit_time * 1e3,
            r.traverse_time * 1e3,
            (r.refit_time + r.traverse_time) * 1e3,
            st.node_pairs,
            st.self_culls + st.pair_culls,
            st.contour_tests,
            st.primitive_tests,
            st.contacts,
            r.bvh_bytes_per_triangle
        );
    }
    s
}
