//! Obstacles: meshes whose motion is given (static, or keyframed and played
//! back with linear interpolation), which the cloth collides with but cannot move.
//!
//! All obstacles of a simulation are merged into one mesh with one hierarchy
//! ([`Obstacles`]); the cloth-obstacle queries are those of
//! [`crate::detect::obstacle`], in the combined index space (cloth vertices,
//! then the obstacles' vertices).

use crate::bvh::{build::build, Bvh};
use crate::detect::obstacle::{self as cross, CrossPair, Impact, Meshes, Near};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// One obstacle: triangles and keyframed vertex positions.
#[derive(Debug, Clone)]
pub struct Obstacle {
    triangles: Vec<[u32; 3]>,
    frames: Vec<Vec<DVec3>>,
    frame_time: f64,
}

impl Obstacle {
    /// A static obstacle.
    pub fn fixed(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Result<Obstacle> {
        Obstacle::animated(vec![vertices], triangles, 1.0)
    }

    /// An obstacle at `frames[k]` at time `k * frame_time` (s), moving linearly
    /// in between and holding its last frame after the end. Errors when there
    /// is no frame, the frames differ in size, `frame_time` is not positive, or
    /// the first frame does not make a valid mesh ([`Mesh::new`]).
    pub fn animated(
        frames: Vec<Vec<[f64; 3]>>,
        triangles: Vec<[u32; 3]>,
        frame_time: f64,
    ) -> Result<Obstacle> {
        let first = frames
            .first()
            .ok_or(Error::EmptyMesh("an obstacle animation has no frames"))?;
        let mesh = Mesh::new(first.clone(), triangles.clone())?;
        if !(frame_time > 0.0 && frame_time.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "obstacle frame time must be positive, got {frame_time}"
            )));
        }
        let frames = frames
            .into_iter()
            .map(|f| {
                let f: Vec<DVec3> = f.into_iter().map(DVec3::from).collect();
                mesh.check_positions(&f).map(|_| f)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Obstacle {
            triangles,
            frames,
            frame_time,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.frames[0].len()
    }

    /// Number of keyframes.
    pub fn n_frames(&self) -> usize {
        self.frames.len()
    }

    /// Positions at time `t` (s), appended to `out`.
    fn positions_at(&self, t: f64, out: &mut Vec<DVec3>) {
        let last = self.frames.len() - 1;
        let s = (t / self.frame_time).clamp(0.0, last as f64);
        let k = (s.floor() as usize).min(last);
        let (a, b) = (&self.frames[k], &self.frames[(k + 1).min(last)]);
        let w = s - k as f64;
        out.extend(a.iter().zip(b).map(|(p, q)| p.lerp(*q, w)));
    }
}

/// Every obstacle of a simulation, merged into one mesh with its hierarchy.
#[derive(Debug, Clone)]
pub struct Obstacles {
    parts: Vec<Obstacle>,
    mesh: Arc<Mesh>,
    bvh: Bvh,
}

impl Obstacles {
    /// Merges `parts` (at least one).
    pub fn new(parts: Vec<Obstacle>) -> Result<Obstacles> {
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        for p in &parts {
            let o = vertices.len() as u32;
            triangles.extend(p.triangles.iter().map(|t| t.map(|i| i + o)));
            vertices.extend(p.frames[0].iter().map(|v| v.to_array()));
        }
        let mesh = Arc::new(Mesh::new(vertices, triangles)?);
        let bvh = build(&mesh);
        Ok(Obstacles { parts, mesh, bvh })
    }

    /// The merged mesh (its rest positions are the first frames).
    pub fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Positions of the merged mesh at time `t` (s).
    pub fn positions_at(&self, t: f64) -> Vec<DVec3> {
        let mut out = Vec::with_capacity(self.mesh.n_vertices());
        for p in &self.parts {
            p.positions_at(t, &mut out);
        }
        out
    }
}

/// The cloth-obstacle queries of one step, over combined positions.
pub struct Collider<'a> {
    /// The two meshes.
    pub meshes: Meshes<'a>,
    /// The cloth's hierarchy (refitted by these queries).
    pub cloth_bvh: &'a mut Bvh,
    /// The obstacles' hierarchy (refitted by these queries).
    pub obstacle_bvh: &'a mut Bvh,
}

impl<'a> Collider<'a> {
    /// The collider of `cloth` against `obstacles`, using `cloth_bvh`.
    pub fn new(
        cloth: &'a Mesh,
        cloth_bvh: &'a mut Bvh,
        obstacles: &'a mut Obstacles,
    ) -> Collider<'a> {
        Collider {
            meshes: Meshes {
                cloth,
                obstacle: &obstacles.mesh,
            },
            cloth_bvh,
            obstacle_bvh: &mut obstacles.bvh,
        }
    }

    fn split<'x>(&self, x: &'x [DVec3]) -> (&'x [DVec3], &'x [DVec3]) {
        x.split_at(self.meshes.cloth.n_vertices())
    }

    /// Element pairs closer than `d` at combined positions `x`.
    pub fn proximity(&mut self, x: &[DVec3], d: f64) -> Vec<Near> {
        let (c, o) = self.split(x);
        self.cloth_bvh.refit(self.meshes.cloth, c);
        self.obstacle_bvh.refit(self.meshes.obstacle, o);
        let pairs = self.candidates(d);
        cross::proximity(self.meshes, x, &pairs, d)
    }

    /// Element pairs that come within `thickness` while moving from `x0` to `x1` (combined).
    pub fn continuous(&mut self, x0: &[DVec3], x1: &[DVec3], thickness: f64) -> Vec<Impact> {
        let ((c0, o0), (c1, o1)) = (self.split(x0), self.split(x1));
        self.cloth_bvh.refit_swept(self.meshes.cloth, c0, c1);
        self.obstacle_bvh.refit_swept(self.meshes.obstacle, o0, o1);
        let pairs = self.candidates(thickness);
        cross::continuous(self.meshes, x0, x1, &pairs, thickness)
    }

    /// (cloth triangle, obstacle triangle) pairs that intersect at combined positions `x`.
    pub fn intersections(&mut self, x: &[DVec3]) -> Vec<[u32; 2]> {
        let (c, o) = self.split(x);
        self.cloth_bvh.refit(self.meshes.cloth, c);
        self.obstacle_bvh.refit(self.meshes.obstacle, o);
        cross::intersections(
            self.meshes,
            x,
            &cross::leaf_pairs(self.cloth_bvh, self.obstacle_bvh, 0.0),
        )
    }

    fn candidates(&self, gap: f64) -> Vec<CrossPair> {
        cross::element_pairs(
            self.meshes,
            &cross::leaf_pairs(self.cloth_bvh, self.obstacle_bvh, gap),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn animation_interpolates_and_holds() {
        let tri = vec![[0, 1, 2]];
        let f0 = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let f1: Vec<[f64; 3]> = f0.iter().map(|p| [p[0], p[1], p[2] + 2.0]).collect();
        let o = Obstacles::new(vec![
            Obstacle::animated(vec![f0, f1], tri.clone(), 0.5).unwrap()
        ])
        .unwrap();
        assert_eq!(o.positions_at(0.25)[1], DVec3::new(1.0, 0.0, 1.0));
        assert_eq!(o.positions_at(7.0)[2], DVec3::new(0.0, 1.0, 2.0));
        assert!(Obstacle::animated(vec![], tri.clone(), 1.0).is_err());
        assert!(Obstacle::animated(vec![vec![[f64::NAN; 3]; 3]], tri, 1.0).is_err());
    }
}
