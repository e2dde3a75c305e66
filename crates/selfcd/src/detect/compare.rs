//! Runs several methods over the same sequence of frames and counts, per
//! frame, what each one missed against the exact reference. This is how the
//! benchmark, the report and the sensor audit measure non-conservative methods.

use super::{new_detector, DetectorOptions, Method};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::stats::FrameStats;
use glam::DVec3;
use std::sync::Arc;

/// One frame of one method.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameRecord {
    /// What the detection cost and found.
    pub stats: FrameStats,
    /// Reference contacts this method did not report.
    pub missed: u64,
    /// Contacts this method reported that the reference did not (always 0 for a correct method).
    pub spurious: u64,
}

/// All frames of one method.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodRun {
    /// The method.
    pub method: Method,
    /// One record per frame, in order.
    pub frames: Vec<FrameRecord>,
}

/// Exact contacts of every frame (the reference), computed with the conservative
/// BVH, which the tests check equal to brute force.
pub fn reference_pairs(mesh: &Arc<Mesh>, frames: &[Vec<DVec3>]) -> Result<Vec<Vec<[u32; 2]>>> {
    reference_pairs_until(mesh, frames, || Ok(()))
}

/// [`reference_pairs`], calling `check` after each frame; its first error is
/// returned at once (so a long reference pass can be interrupted).
fn reference_pairs_until(
    mesh: &Arc<Mesh>,
    frames: &[Vec<DVec3>],
    mut check: impl FnMut() -> Result<()>,
) -> Result<Vec<Vec<[u32; 2]>>> {
    let mut det = new_detector(
        mesh.clone(),
        Method::BvhConesContour,
        &DetectorOptions::default(),
    )?;
    frames
        .iter()
        .map(|f| {
            let pairs = det.detect(f)?.pairs;
            check()?;
            Ok(pairs)
        })
        .collect()
}

/// Runs each method over `frames` in order (stateful methods see the frames as
/// an animation) and compares its contacts with the reference per frame.
/// `progress` is called after each (method, frame) with the number done so far.
pub fn compare_methods(
    mesh: &Arc<Mesh>,
    frames: &[Vec<DVec3>],
    methods: &[Method],
    opts: &DetectorOptions,
    mut progress: impl FnMut(usize),
) -> Result<Vec<MethodRun>> {
    compare_methods_until(mesh, frames, methods, opts, |done| {
        progress(done);
        Ok(())
    })
}

/// [`compare_methods`] whose `progress` can stop the run: its first error
/// (e.g. [`crate::Error::Interrupted`]) is returned at once. It is also
/// called with 0 after each frame of the reference pass, which runs first.
pub fn compare_methods_until(
    mesh: &Arc<Mesh>,
    frames: &[Vec<DVec3>],
    methods: &[Method],
    opts: &DetectorOptions,
    mut progress: impl FnMut(usize) -> Result<()>,
) -> Result<Vec<MethodRun>> {
    let reference = reference_pairs_until(mesh, frames, || progress(0))?;
    let mut done = 0;
    let mut runs = Vec::with_capacity(methods.len());
    for &method in methods {
        let mut det = new_detector(mesh.clone(), method, opts)?;
        let mut records = Vec::with_capacity(frames.len());
        for (f, want) in frames.iter().zip(&reference) {
            let got = det.detect(f)?;
            let (missed, spurious) = diff_sorted(want, &got.pairs);
            records.push(FrameRecord {
                stats: got.stats,
                missed,
                spurious,
            });
            done += 1;
            progress(done)?;
        }
        runs.push(MethodRun {
            method,
            frames: records,
        });
    }
    Ok(runs)
}

/// (|want \ got|, |got \ want|) of two sorted pair lists.
pub fn diff_sorted(want: &[[u32; 2]], got: &[[u32; 2]]) -> (u64, u64) {
    let (mut i, mut j, mut missed, mut spurious) = (0, 0, 0, 0);
    while i < want.len() || j < got.len() {
        if j == got.len() || (i < want.len() && want[i] < got[j]) {
            missed += 1;
            i += 1;
        } else if i == want.len() || got[j] < want[i] {
            spurious += 1;
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
    (missed, spurious)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_counts_both_sides() {
        assert_eq!(
            diff_sorted(&[[0, 1], [0, 2], [3, 4]], &[[0, 2], [5, 6]]),
            (2, 1)
        );
        assert_eq!(diff_sorted(&[], &[]), (0, 0));
    }
}
