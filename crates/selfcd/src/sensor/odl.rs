//! Original distance (ODL, paper 2.2): the length of the shortest path between
//! two particles along the rest surface, and the direction of that path at the
//! first particle.
//!
//! The rest shape is the cloth "before it deforms"; cloth neither stretches
//! much nor changes its topology, so the surface distance is measured in rest
//! space, with three cases:
//!
//! - Different components ([`crate::Mesh::triangle_components`]): no surface path, ro is
//!   infinite (no repulsion; attraction only, with t against the rest chord:
//!   see [`super::forces`]).
//! - Flat rest shape (every vertex within [`FLAT_TOLERANCE`] of one plane):
//!   the straight rest segment, ro = |R_j - R_i|, direction R_j - R_i; exact
//!   whenever the segment stays on the sheet (a lower bound across holes or notches).
//! - Curved rest shape: a geodesic distance field per particle
//!   ([`super::geodesic`]), from the particle's rest position, renewed only
//!   once the particle has walked more than [`REFRESH`] mean edges from that
//!   source (so a quiet frame computes none). ro(i, j) is field_j interpolated
//!   at particle i (never below the chord |R_j - R_i|, a lower bound of any
//!   surface path); the direction at i is minus the gradient of field_j on i's
//!   rest triangle. Within [`NEAR`] mean edges, or in one triangle, where the
//!   field's linear interpolation is coarse, the chord is used instead. Where
//!   the chord alone puts every corner of i's triangle beyond the field's
//!   reach, the field is not read (see [`OriginalDistance::path_between`]), so
//!   a renewed field is marched only once some particle comes that close
//!   ([`OriginalDistance::prepare`]): particles spread far apart on a large
//!   mesh march none.
//!
//! The fields and chords are computed on a copy of the rest shape in
//! mean-edge units, snapped to a grid of 2^-32 units: the same bits whatever
//! the mesh's scale, so the marching order (and the trajectories) do not
//! change with it. Directions are rest-space vectors; [`super::tangent::TriMap`] carries them
//! to the current shape (projecting onto the triangle's plane on the way).

use super::geodesic::Marcher;
use super::particle::SurfacePoint;
use super::tangent;
use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// Largest distance from the plane, relative to the rest bounding-box diagonal, that still counts as flat.
pub const FLAT_TOLERANCE: f64 = 1e-6;
/// A particle's geodesic field is recomputed once it is this far (mean edges, rest space) from the field's source.
pub const REFRESH: f64 = 0.5;
/// Below this ODL (mean edges) the chord replaces the geodesic field.
pub const NEAR: f64 = 2.0;
/// Least reach of a geodesic field (mean edges). The trigger only needs the
/// fields of pairs closer than the trigger distance (3 mean edges by default),
/// to tell whether their original distance exceeds the straight-line distance
/// by 1 / (1 - [`super::relax::FOLD_T`]); beyond the reach ro is the lower bound
/// max(chord, reach - the particle triangle's longest edge), and the repulsion there is b / ro^2 <= b / 144 along the
/// rest chord. A field's cost grows with the square of its reach (32 before:
/// 7 times the vertices, and most of the sensor's time on curved meshes).
pub const CUT: f64 = 12.0;
/// Grid of the normalised rest copy (mean-edge units).
const SNAP: f64 = 1.0 / 4_294_967_296.0;

/// The rest shape's mean plane: through the vertex centroid, normal to the
/// area-weighted sum of triangle normals (each flipped to agree with the
/// largest triangle's). Returns (point, unit normal).
pub fn rest_plane(mesh: &Mesh) -> (DVec3, DVec3) {
    let rest = mesh.rest();
    let crosses: Vec<DVec3> = (0..mesh.n_triangles())
        .map(|t| {
            let (e1, e2) = tangent::edges(mesh, rest, t);
            e1.cross(e2)
        })
        .collect();
    let largest = crosses.iter().copied().fold(DVec3::ZERO, |a, c| {
        if c.length_squared() > a.length_squared() {
            c
        } else {
            a
        }
    });
    let sum: DVec3 = crosses
        .iter()
        .map(|&c| if c.dot(largest) < 0.0 { -c } else { c })
        .sum();
    let centroid = rest.iter().copied().sum::<DVec3>() / rest.len() as f64;
    (centroid, sum.normalize_or(DVec3::Z))
}

/// Largest distance of a rest vertex from [`rest_plane`], relative to the rest bounding-box diagonal.
pub fn flatness_deviation(mesh: &Mesh) -> f64 {
    let rest = mesh.rest();
    let (c, n) = rest_plane(mesh);
    let lo = rest.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let hi = rest.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    let diag = (hi - lo).length().max(f64::MIN_POSITIVE);
    rest.iter()
        .map(|&p| (p - c).dot(n).abs())
        .fold(0.0, f64::max)
        / diag
}

/// The original distance between two particles and the path's direction at the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Path {
    /// ro in mean-edge units; infinite between components.
    pub length: f64,
    /// The rest chord |R_j - R_i| in mean-edge units (= ro on a flat rest
    /// shape; finite between components too).
    pub chord: f64,
    /// A lower bound of ro: `length` less the field's interpolation error (the
    /// longest rest edge of the first particle's triangle: a linearly
    /// interpolated distance overestimates by at most that) and less the
    /// field's staleness (its source is up to [`REFRESH`] from the second
    /// particle), never below the chord.
    pub lower: f64,
    /// Rest-space direction at the first particle towards the second (in its
    /// triangle's plane up to the chord case); zero between components or when undefined.
    pub direction: DVec3,
}

/// A particle's point in the normalised rest copy and its component ([`OriginalDistance::locate`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// Position in the normalised rest copy.
    pub rest: DVec3,
    /// Component of its triangle.
    pub component: u32,
    /// Longest rest edge of its triangle (normalised units): no corner is
    /// farther from the point, and a linearly interpolated distance
    /// overestimates by at most this.
    pub longest: f64,
}

/// A geodesic field and the surface point it is computed from. The source is
/// set when the particle walked [`REFRESH`] away from the last one; the
/// distances are marched from it only when a path reads them
/// ([`OriginalDistance::prepare`]), and are then exactly what an immediate
/// march would have given.
#[derive(Debug, Clone)]
struct Field {
    /// The source's position in the normalised rest copy.
    source: DVec3,
    /// The source point.
    from: SurfacePoint,
    dist: Vec<f64>,
    /// True when `dist` was marched from `from`.
    marched: bool,
}

impl Field {
    /// True when no corner of the triangle of the particle at `ai` can be
    /// within `reach` of this field's source, by the rest chord alone: the
    /// corners are within `ai.longest` of `ai`, and the source is
    /// `|source - aj|` from the field's particle at `aj`. Neither a surface
    /// path nor the march (test `the_march_is_never_shorter_than_the_straight_line`)
    /// is shorter than the straight line, so the field is infinite at those
    /// corners, and the path needs no march. (A relative margin of 1e-9,
    /// far above the rounding of these distances and of the march's bound,
    /// keeps the answer off that boundary.)
    #[inline]
    fn beyond(&self, ai: &Located, aj: &Located, reach: f64) -> bool {
        let far = reach + ai.longest + self.source.distance(aj.rest);
        ai.rest.distance(aj.rest) > far * (1.0 + 1e-9)
    }
}

/// The original distance of one mesh, with the per-particle geodesic fields of a curved rest shape.
#[derive(Debug, Clone)]
pub struct OriginalDistance {
    mesh: Arc<Mesh>,
    component: Arc<Vec<u32>>,
    flat: bool,
    /// Rest positions relative to the bounds' low corner, in mean-edge units, snapped to [`SNAP`].
    rest: Vec<DVec3>,
    fields: Vec<Option<Field>>,
    /// Reach of the fields (mean edges, at least [`CUT`]).
    reach: f64,
    marcher: Marcher,
    /// Geodesic fields computed so far (a cost counter).
    pub fields_computed: u64,
    /// Vertices those fields reached, in all (a cost counter).
    pub vertices_marched: u64,
}

impl OriginalDistance {
    /// The original distance on `mesh` (components and flatness computed here).
    pub fn new(mesh: Arc<Mesh>) -> OriginalDistance {
        let component = Arc::new(mesh.triangle_components());
        let flat = flatness_deviation(&mesh) <= FLAT_TOLERANCE;
        let unit = mesh.mean_edge_length();
        let lo = mesh.rest().iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
        let rest = mesh
            .rest()
            .iter()
            .map(|&p| ((p - lo) / (unit * SNAP)).round() * SNAP)
            .collect();
        OriginalDistance {
            mesh,
            component,
            flat,
            rest,
            fields: Vec::new(),
            reach: CUT,
            marcher: Marcher::default(),
            fields_computed: 0,
            vertices_marched: 0,
        }
    }

    /// True when the rest shape is flat (exact chord distances, no fields).
    pub fn is_flat(&self) -> bool {
        self.flat
    }

    /// Component id of every triangle.
    pub fn components(&self) -> &Arc<Vec<u32>> {
        &self.component
    }

    /// Sets the reach of the fields to `reach` mean edges (at least [`CUT`]);
    /// fields of another reach are dropped (recomputed on the next refresh).
    pub fn set_reach(&mut self, reach: f64) {
        let reach = if reach.is_finite() {
            reach.max(CUT)
        } else {
            CUT
        };
        if reach != self.reach {
            self.reach = reach;
            self.fields.clear();
        }
    }

    /// Reach of the fields (mean edges).
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Makes the field of every particle current for paths between `points`
    /// (curved rest shapes only): [`Self::renew`], then [`Self::prepare`].
    pub fn refresh(&mut self, points: &[SurfacePoint]) {
        let mut at = Vec::with_capacity(points.len());
        self.locate(points, &mut at);
        self.renew(points);
        self.prepare(points, &at);
    }

    /// Moves the source of every field whose particle walked more than
    /// [`REFRESH`] from it (or that has none) to the particle; marches nothing.
    pub fn renew(&mut self, points: &[SurfacePoint]) {
        if self.flat {
            return;
        }
        self.fields.resize(points.len(), None);
        for (p, slot) in points.iter().zip(self.fields.iter_mut()) {
            let r = p.position(&self.mesh, &self.rest);
            match slot {
                Some(f) if f.source.distance(r) <= REFRESH => {}
                Some(f) => (f.source, f.from, f.marched) = (r, *p, false),
                None => {
                    *slot = Some(Field {
                        source: r,
                        from: *p,
                        dist: Vec::new(),
                        marched: false,
                    })
                }
            }
        }
    }

    /// Marches every renewed field that a path between `points` (located at
    /// `at`) reads: one whose particle has another particle of its component,
    /// on another triangle, not `Field::beyond` its reach.
    pub fn prepare(&mut self, points: &[SurfacePoint], at: &[Located]) {
        for j in 0..self.fields.len().min(points.len()) {
            let Some(f) = &self.fields[j] else { continue };
            let read = |i: usize| {
                i != j
                    && at[i].component == at[j].component
                    && points[i].tri != points[j].tri
                    && !f.beyond(&at[i], &at[j], self.reach)
            };
            if f.marched || !(0..points.len()).any(read) {
                continue;
            }
            let f = self.fields[j].as_mut().expect("a field");
            self.vertices_marched += self.marcher.distance_field(
                &self.mesh,
                &self.rest,
                &f.from,
                self.reach,
                &mut f.dist,
            ) as u64;
            self.fields_computed += 1;
            f.marched = true;
        }
    }

    /// Keeps the fields of the particles with `keep[i]` true (particles were removed).
    pub fn retain(&mut self, keep: &[bool]) {
        let mut k = keep.iter();
        self.fields.retain(|_| *k.next().unwrap_or(&true));
    }

    /// Where each of `points` is in the normalised rest copy, and its
    /// component: what every path from or to it reads. Computed once per
    /// update, not once per pair.
    pub fn locate(&self, points: &[SurfacePoint], out: &mut Vec<Located>) {
        out.clear();
        out.extend(points.iter().map(|p| {
            let [a, b, c] = self.mesh.corners(&self.rest, p.tri as usize);
            Located {
                rest: a * p.bary[0] + b * p.bary[1] + c * p.bary[2],
                component: self.component[p.tri as usize],
                longest: a.distance(b).max(b.distance(c)).max(c.distance(a)),
            }
        }));
    }

    /// The path from particle `i` to particle `j` of `points` (after
    /// [`Self::refresh`] of these points for curved shapes).
    pub fn path(&self, points: &[SurfacePoint], i: usize, j: usize) -> Path {
        let mut at = Vec::with_capacity(2);
        self.locate(&[points[i], points[j]], &mut at);
        self.path_between((&points[i], &at[0]), (&points[j], &at[1]), j)
    }

    /// [`Self::path`] from particle `pi` to particle `j`, `pj`, each with its
    /// [`Located`] point (after [`Self::prepare`] of the particles). Field j is
    /// read only when i is not `Field::beyond` its reach; otherwise the path
    /// is what the field would give there (every corner infinite, the
    /// particle farther than the reach: the chord).
    #[inline]
    pub fn path_between(
        &self,
        (pi, ai): (&SurfacePoint, &Located),
        (pj, aj): (&SurfacePoint, &Located),
        j: usize,
    ) -> Path {
        let chord = aj.rest - ai.rest;
        if ai.component != aj.component {
            return Path {
                length: f64::INFINITY,
                chord: chord.length(),
                lower: f64::INFINITY,
                direction: DVec3::ZERO,
            };
        }
        let straight = Path {
            length: chord.length(),
            chord: chord.length(),
            lower: chord.length(),
            direction: chord,
        };
        let field = match self.fields.get(j) {
            Some(Some(f)) if !self.flat && pi.tri != pj.tri && !f.beyond(ai, aj, self.reach) => f,
            _ => return straight,
        };
        debug_assert!(field.marched, "field {j} read before it was prepared");
        let corners = self.mesh.triangles()[pi.tri as usize].map(|v| field.dist[v as usize]);
        let along: f64 = corners.iter().zip(&pi.bary).map(|(d, b)| d * b).sum();
        let longest = ai.longest;
        if along.is_infinite() {
            // A corner lies beyond the reach, and the particle within `longest` of it.
            let beyond = straight.length.max(self.reach - longest);
            return Path {
                length: beyond,
                lower: beyond,
                ..straight
            };
        }
        if !(along >= NEAR && along > straight.length) {
            return straight;
        }
        let (e1, e2) = tangent::edges(&self.mesh, &self.rest, pi.tri as usize);
        let direction = tangent::dual(e1, e2)
            .map(|(d1, d2)| -(d1 * (corners[1] - corners[0]) + d2 * (corners[2] - corners[0])))
            .filter(|g| g.length_squared() > 0.0 && g.is_finite())
            .unwrap_or(chord);
        Path {
            length: along,
            // The field is from j's source, up to REFRESH from j: its value
            // at i is off by at most that offset (triangle inequality, with
            // the rest chord standing in for the short surface path).
            lower: (along - longest - field.source.distance(aj.rest)).max(straight.length),
            direction,
            ..straight
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SplitMix;
    use crate::sensor::testing::crumpled_rest;

    /// Fields marched only where a path reads them give every path exactly as
    /// fields marched for every particle do, and particles far apart march none.
    #[test]
    fn lazy_fields_give_the_paths_of_eager_ones() {
        let mesh = Arc::new(crumpled_rest(101));
        let mut rng = SplitMix::new(5);
        let points: Vec<SurfacePoint> = (0..12)
            .map(|_| SurfacePoint {
                tri: (rng.next_u64() % mesh.n_triangles() as u64) as u32,
                bary: [0.2, 0.3, 0.5],
            })
            .collect();
        let mut lazy = OriginalDistance::new(mesh.clone());
        assert!(!lazy.is_flat());
        lazy.refresh(&points);
        let mut eager = lazy.clone();
        for f in eager.fields.iter_mut().flatten().filter(|f| !f.marched) {
            eager.marcher.distance_field(
                &eager.mesh,
                &eager.rest,
                &f.from,
                eager.reach,
                &mut f.dist,
            );
            f.marched = true;
        }
        let marched = lazy.fields_computed as usize;
        assert!(0 < marched && marched < points.len(), "{marched} marched");
        let mut at = Vec::new();
        eager.locate(&points, &mut at);
        for i in 0..points.len() {
            for j in (0..points.len()).filter(|&j| j != i) {
                assert_eq!(
                    lazy.path(&points, i, j),
                    eager.path(&points, i, j),
                    "{i}->{j}"
                );
                // Where the chord skips the field, the field is infinite at
                // every corner: the path is the one the field would give.
                let f = eager.fields[j].as_ref().unwrap();
                if f.beyond(&at[i], &at[j], eager.reach) {
                    let tri = mesh.triangles()[points[i].tri as usize];
                    assert!(tri.iter().all(|&v| f.dist[v as usize].is_infinite()));
                }
            }
        }
    }
}
