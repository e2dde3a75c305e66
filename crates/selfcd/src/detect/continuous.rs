//! Continuous query: between two positions of the mesh (each vertex moving
//! linearly over the step), every vertex-triangle and edge-edge pair that may
//! come within a thickness `thickness`, with a conservative time of impact.
//!
//! Broad phase: the BVH refitted to swept triangle boxes, boxes within
//! `thickness`. With thickness 0 (contact itself, what a CCD step-size query
//! asks) the cones are fitted to the normals over the whole step and the
//! swept certificate ([`SweptContourCull`]) skips patches that provably stay
//! free of contact: a sheet that bends little costs about a swept refit.
//! With a thickness, elements of one patch may legitimately come that close,
//! so every overlapping box pair is descended. Narrow phase: a triangle pair
//! that a separating axis keeps apart over the step, with a margin
//! ([`crate::geom::ccd::triangles_stay_apart`]: a sheet sliding along
//! itself), is skipped, which changes no answer; so is a pair with one
//! common vertex that a plane through it keeps apart
//! ([`crate::geom::ccd::fans_stay_apart`]: the triangles around a vertex
//! in a patch whose certificate failed); else additive CCD
//! ([`crate::geom::ccd`]) on each element pair, once per pair (owners).
//! No false negatives: every pair that comes within `thickness` during the step is
//! reported, at a time no later than when it does. (A certified patch can hold
//! no contact but may hold pairs the additive CCD would report within its
//! resolution, so at thickness 0 the certificate can only remove such false
//! positives.)

use super::hierarchy::BvhDetector;
use super::narrow::{for_each_owned_pair, ElementPair};
use super::Detector;
use crate::bvh::certify::{BoxesOnly, SweptContourCull};
use crate::bvh::topdown::{self, Shape};
use crate::bvh::traverse::{traverse, LeafVisitor};
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geom::ccd::{fans_stay_apart, time_of_impact, triangles_stay_apart};
use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;

/// An element pair that may come within the thickness during the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The elements: (vertex, triangle) or (edge, edge) with the smaller edge first.
    pub pair: ElementPair,
    /// Conservative time of impact in [0, 1] (fraction of the step).
    pub toi: f64,
}

/// Everything a continuous query found, sorted by element pair.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Impacts {
    /// Vertex-triangle impacts, sorted by (vertex, triangle).
    pub vertex_triangle: Vec<Impact>,
    /// Edge-edge impacts, sorted by edge ids.
    pub edge_edge: Vec<Impact>,
}

impl Impacts {
    /// The vertex-triangle impacts' triangles mapped through `map` (a
    /// renumbering), sorted again; edge-edge impacts are unchanged.
    pub fn map_triangles(&mut self, map: &[u32]) {
        for i in &mut self.vertex_triangle {
            if let ElementPair::VertexTriangle(_, t) = &mut i.pair {
                *t = map[*t as usize];
            }
        }
        self.vertex_triangle.sort_unstable_by_key(key);
    }

    /// The earliest time of impact, if any pair may meet during the step.
    pub fn earliest(&self) -> Option<f64> {
        self.vertex_triangle
            .iter()
            .chain(&self.edge_edge)
            .map(|i| i.toi)
            .min_by(f64::total_cmp)
    }
}

/// Time of impact of one element pair moving from `x0` to `x1`, or `None` for
/// incident pairs and pairs that stay apart.
pub fn element_toi(
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    pair: ElementPair,
    thickness: f64,
) -> Option<f64> {
    let (kind, ids) = pair.stencil(mesh)?;
    let at = |x: &[DVec3]| ids.map(|i| x[i as usize]);
    time_of_impact(kind, at(x0), at(x1), thickness)
}

/// The narrow phase of the continuous query on one triangle pair.
struct Continuous<'a> {
    mesh: &'a Mesh,
    x0: &'a [DVec3],
    x1: &'a [DVec3],
    thickness: f64,
}

impl LeafVisitor for Continuous<'_> {
    type Item = Impact;
    const SKIP_ADJACENT: bool = false;

    fn visit(&self, a: u32, b: u32, adjacent: bool, out: &mut Vec<Impact>) {
        self.visit_counted(a, b, adjacent, out, &mut Counters::default());
    }

    /// Counts the triangle pairs [`stay_apart`] decides in `filter_decisions`.
    fn visit_counted(
        &self,
        a: u32,
        b: u32,
        _adjacent: bool,
        out: &mut Vec<Impact>,
        c: &mut Counters,
    ) {
        if stay_apart(self.mesh, self.x0, self.x1, [a, b], self.thickness) {
            c.filter_decisions += 1;
            return;
        }
        for_each_owned_pair(self.mesh, a, b, |pair| {
            let pair = pair.canonical();
            if let Some(toi) = element_toi(self.mesh, self.x0, self.x1, pair, self.thickness) {
                out.push(Impact { pair, toi });
            }
        });
    }
}

/// True when triangles `a` and `b` of `mesh` stay apart over the motion
/// `x0 -> x1` by the margin of [`triangles_stay_apart`] (sharing one vertex:
/// of [`fans_stay_apart`]; sharing an edge: never), so that no element pair
/// of theirs that shares no vertex has a time of impact: the continuous
/// queries skip their element tests, and their answers are the same with or
/// without this test.
#[inline]
pub(crate) fn stay_apart(
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    [a, b]: [u32; 2],
    thickness: f64,
) -> bool {
    let tris = mesh.triangles();
    let (p, q) = (tris[a as usize], tris[b as usize]);
    // A triangle's corners at both ends, from its corner `first` on.
    let at = |v: [u32; 3], first: usize| {
        let (i, j, k) = (v[first], v[(first + 1) % 3], v[(first + 2) % 3]);
        let c = |x: &[DVec3]| [x[i as usize], x[j as usize], x[k as usize]];
        [c(x0), c(x1)]
    };
    // How many vertices they share, and the places of one in `p` and `q`.
    let (mut common, mut place) = (0, (0, 0));
    for (i, v) in p.iter().enumerate() {
        for (j, w) in q.iter().enumerate() {
            if v == w {
                (common, place) = (common + 1, (i, j));
            }
        }
    }
    match common {
        0 => triangles_stay_apart(at(p, 0), at(q, 0), thickness),
        1 => fans_stay_apart(at(p, place.0), at(q, place.1), thickness),
        _ => false,
    }
}

fn key(i: &Impact) -> (u32, u32) {
    match i.pair {
        ElementPair::VertexTriangle(a, b) | ElementPair::EdgeEdge(a, b) => (a, b),
    }
}

impl Impacts {
    /// Splits raw impacts by kind and sorts each list by element pair.
    pub(crate) fn from_items(items: Vec<Impact>) -> Impacts {
        let mut out = Impacts::default();
        for i in items {
            match i.pair {
                ElementPair::VertexTriangle(..) => out.vertex_triangle.push(i),
                ElementPair::EdgeEdge(..) => out.edge_edge.push(i),
            }
        }
        out.vertex_triangle.sort_unstable_by_key(key);
        out.edge_edge.sort_unstable_by_key(key);
        out
    }
}

/// Checks the arguments of a continuous query.
pub(crate) fn check_args(mesh: &Mesh, x0: &[DVec3], x1: &[DVec3], thickness: f64) -> Result<()> {
    mesh.check_positions(x0)?;
    mesh.check_positions(x1)?;
    if !(thickness >= 0.0 && thickness.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "thickness must be finite and >= 0, got {thickness}"
        )));
    }
    Ok(())
}

/// The continuous query on a hierarchy already fitted to the swept boxes
/// ([`Bvh::refit_swept`]) of the motion `x0 -> x1`. With thickness 0 and the
/// cones fitted too ([`Bvh::refit_swept_cones`]), patches and adjacent pairs
/// that the swept certificate ([`SweptContourCull`]) proves free of contact
/// over the step are not descended (with full cones nothing is certified).
pub(crate) fn swept_query(
    bvh: &Bvh,
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    thickness: f64,
) -> (Impacts, Counters) {
    let visitor = Continuous {
        mesh,
        x0,
        x1,
        thickness,
    };
    let (items, counters) = if thickness == 0.0 {
        let cull = SweptContourCull::new(bvh, mesh, x0, x1);
        traverse(bvh, mesh, thickness, &cull, &visitor)
    } else {
        traverse(bvh, mesh, thickness, &BoxesOnly, &visitor)
    };
    (Impacts::from_items(items), counters)
}

/// Time of impact of a candidate `pair` (canonical) with visiting triangles
/// `[a, b]` ([`ElementPair::visiting_triangles`]) exactly as the swept query
/// computes it, box test included: `None` where the swept query would not
/// report it. So a query over any candidate superset equals the swept query.
/// `leaves`: the swept leaf boxes of a hierarchy fitted to this motion
/// ([`Bvh::refit_swept`], the same boxes), if there is one.
pub(crate) fn candidate_toi(
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    pair: ElementPair,
    [a, b]: [u32; 2],
    leaves: Option<&[Aabb]>,
    thickness: f64,
) -> Option<Impact> {
    let swept = |t: u32| match leaves {
        Some(boxes) => boxes[t as usize],
        None => mesh.swept_box(x0, x1, t as usize),
    };
    if a == b || !swept(a).within(&swept(b), thickness) {
        return None;
    }
    element_toi(mesh, x0, x1, pair, thickness).map(|toi| Impact { pair, toi })
}

/// Every element pair that may come within `thickness` (>= 0) while the
/// mesh moves linearly from `x0` to `x1`, with conservative times of
/// impact, and what the query did: the one-shot query, on a hierarchy built
/// top-down only where it is needed ([`crate::bvh::topdown`]). At thickness
/// 0 it skips the patches, and unions of two, whose swept certificate holds
/// over the step (as [`SweptContourCull`] does on a kept hierarchy), so a
/// sheet that bends little costs its normals and one certificate; with a
/// thickness, boxes alone cull. For a hierarchy kept over many queries, see
/// [`BvhDetector::continuous`] and [`super::coherent::SelfQueries`].
pub fn continuous_impacts(
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    thickness: f64,
) -> Result<(Impacts, Counters)> {
    check_args(mesh, x0, x1, thickness)?;
    let visitor = Continuous {
        mesh,
        x0,
        x1,
        thickness,
    };
    let (items, counters) = topdown::query(mesh, Shape::Swept(x0, x1), thickness, &visitor);
    Ok((Impacts::from_items(items), counters))
}

impl BvhDetector {
    /// Every element pair that may come within `thickness` (>= 0) while the
    /// mesh moves linearly from `x0` to `x1`, with conservative times of
    /// impact. Leaves the hierarchy fitted to the swept boxes (the next
    /// `detect` refits it).
    pub fn continuous(&mut self, x0: &[DVec3], x1: &[DVec3], thickness: f64) -> Result<Impacts> {
        check_args(self.mesh(), x0, x1, thickness)?;
        if thickness == 0.0 {
            self.refit_swept_cones(x0, x1);
        } else {
            self.refit_swept(x0, x1);
        }
        let mut found = swept_query(self.bvh(), self.hierarchy_mesh(), x0, x1, thickness).0;
        if let Some(map) = self.triangle_order() {
            found.map_triangles(map);
        }
        Ok(found)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{grid, Deformation};

    /// A sheet bent a little over the step is certified at its root: no pair
    /// is tested; the same step with a thickness descends every box overlap.
    #[test]
    fn a_bending_sheet_is_certified_whole() {
        let (v, f) = grid(40, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let x0 = mesh.rest().to_vec();
        let x1 = Deformation::Crumple {
            amplitude: 0.02,
            wavelength: 0.5,
            seed: 2,
        }
        .apply(&x0);
        let mut bvh = crate::bvh::build::build(&mesh);
        bvh.refit_swept_cones(&mesh, &x0, &x1);
        let (found, c) = swept_query(&bvh, &mesh, &x0, &x1, 0.0);
        assert!(found.earliest().is_none());
        assert_eq!((c.self_culls, c.primitive_tests), (1, 0), "{c:?}");
        bvh.refit_swept(&mesh, &x0, &x1);
        let (_, c) = swept_query(&bvh, &mesh, &x0, &x1, 1e-3);
        assert!(c.self_culls == 0 && c.primitive_tests > 1000, "{c:?}");
        // The one-shot query: one certificate, no triangle pair; with a
        // thickness, the same pairs as the kept hierarchy's query.
        let (found, c) = continuous_impacts(&mesh, &x0, &x1, 0.0).unwrap();
        assert!(found.earliest().is_none());
        assert_eq!(
            (c.contour_tests, c.node_pairs, c.primitive_tests),
            (1, 0, 0),
            "{c:?}"
        );
        let kept = swept_query(&bvh, &mesh, &x0, &x1, 1e-3).0;
        assert_eq!(continuous_impacts(&mesh, &x0, &x1, 1e-3).unwrap().0, kept);
    }
}
