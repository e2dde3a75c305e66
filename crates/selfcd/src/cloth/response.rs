//! Collision response (self and obstacle contacts alike), in three stages per
//! step. The response only turns what the step's queries found into velocity
//! and position changes; it runs no query itself. Contacts are four-point
//! stencils ([`Contact`]) over the cloth's vertices, then the obstacles'
//! (see [`crate::detect::obstacle`]); obstacle vertices have inverse mass 0.
//!
//! 1. **In the solve (the paper, 4.2).** A vertex closer than the thickness `d`
//!    to a triangle, and not moving away from it fast enough, is constrained
//!    along the contact normal n: the solve keeps only the tangential part of
//!    its acceleration, `a = (F - (F.n) n) / m`, and adds the triangle's
//!    acceleration along n (estimated from the triangle's velocity change in
//!    the previous step: both sides are unknowns of the same solve), plus a
//!    velocity change that stops the approach and pushes back out to `d`.
//! 2. **Impulses.** Every proximity contact (vertex-triangle and edge-edge)
//!    found within `d + margin` gets mass-weighted impulses, Gauss-Seidel in
//!    sorted order, so that its relative normal velocity `vn` satisfies
//!    `vn >= -(dist - d) / h` (do not get closer than `d` this step) or, inside
//!    `d`, `vn >= push (d - dist) / h` (move a fraction `push` back out).
//!
//! 2b. **Continuous collisions.** The step from the start positions to
//!    `x0 + h v` is checked with the engine's continuous query; every element
//!    pair that would meet gets an inelastic impulse at its time of impact
//!    (see [`impact_impulses`]), so fast folds do not pass through in one step.
//! 3. **Correction.** The end-of-step positions are checked for intersecting
//!    triangle pairs with a conservative detector; the vertices of intersecting
//!    triangles are gathered into rigid impact zones that move rigidly from
//!    their (intersection-free) start-of-step positions; cloth triangles that
//!    meet an obstacle move with the obstacle; the check repeats until no pair
//!    intersects (see [`Zones`]).
//!
//! Impulses carry Coulomb friction, one coefficient per contact kind
//! (cloth-cloth, cloth-obstacle).

use super::solver::Filter;
use super::springs::outer;
use crate::detect::coherent::same_bits;
use crate::detect::continuous::Impacts;
use crate::detect::narrow::ElementPair;
use crate::detect::obstacle::{self as cross, Meshes};
use crate::detect::ProximityContacts;
use crate::error::{Error, Result};
use crate::geom::ccd::StencilKind;
use crate::geom::distance::{point_triangle_distance2, segment_segment_distance2};
use crate::mesh::Mesh;
use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;

/// Contact thickness and how contacts are handled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Thickness d (m): the cloth keeps this distance from itself.
    pub thickness: f64,
    /// Extra detection distance (m) beyond `d`, so that contacts are seen a
    /// step before they close; the detector runs with thickness `d + margin`.
    pub margin: f64,
    /// Fraction of a penetration of the thickness pushed back out per step, in [0, 1].
    pub push: f64,
    /// Most Gauss-Seidel sweeps of the impulse stage.
    pub sweeps: u32,
    /// Coulomb friction coefficient of cloth-cloth contacts (>= 0).
    pub friction: f64,
    /// Coulomb friction coefficient of cloth-obstacle contacts (>= 0).
    pub obstacle_friction: f64,
}

impl ContactParams {
    /// Defaults scaled to a mesh: `d` = 10% and the margin 25% of the mean rest
    /// edge length; friction 0.3 on cloth and 0.5 on obstacles.
    pub fn for_mesh(mesh: &Mesh) -> ContactParams {
        let e = mesh.mean_edge_length();
        ContactParams {
            thickness: 0.1 * e,
            margin: 0.25 * e,
            push: 0.1,
            sweeps: 20,
            friction: 0.3,
            obstacle_friction: 0.5,
        }
    }

    /// The distance the detector reports contacts within: `d + margin`.
    pub fn detection_distance(&self) -> f64 {
        self.thickness + self.margin
    }

    /// Checks ranges: d > 0, margin >= 0, push in [0, 1], friction >= 0, all finite.
    pub fn validate(&self) -> Result<()> {
        let ok = self.thickness > 0.0
            && self.thickness.is_finite()
            && self.margin >= 0.0
            && self.margin.is_finite()
            && (0.0..=1.0).contains(&self.push)
            && [self.friction, self.obstacle_friction]
                .iter()
                .all(|f| *f >= 0.0 && f.is_finite());
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidParameter(format!(
                "contact parameters out of range (thickness > 0, margin >= 0, push in [0, 1], friction >= 0): {self:?}"
            )))
        }
    }
}

/// A proximity contact as a weighted set of four vertices: the relative
/// position of the two sides is `sum_k weights[k] x[verts[k]]` (first side
/// minus second), and `normal` points from the second side to the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The vertices involved.
    pub verts: [u32; 4],
    /// Their weights: positive on the first side, negative on the second.
    pub weights: [f64; 4],
    /// Unit normal, from the second side to the first.
    pub normal: DVec3,
    /// Distance between the two sides when detected (m).
    pub distance: f64,
    /// What touches what.
    pub kind: StencilKind,
}

impl Contact {
    /// Relative velocity along the normal, `sum_k w_k v_k . n` (positive: separating).
    #[inline]
    pub fn normal_velocity(&self, v: &[DVec3]) -> f64 {
        self.combine(v).dot(self.normal)
    }

    /// `sum_k w_k y_k` for a per-vertex field `y`.
    #[inline]
    fn combine(&self, y: &[DVec3]) -> DVec3 {
        (0..4)
            .map(|k| y[self.verts[k] as usize] * self.weights[k])
            .sum()
    }
}

/// `v / |v|`, or `fallback` when `v` is too short to have a direction.
fn unit_or(v: DVec3, scale: f64, fallback: DVec3) -> DVec3 {
    let l = v.length();
    if l > 1e-12 * scale {
        v / l
    } else {
        fallback
    }
}

/// Turns the detector's proximity contacts at positions `x` into [`Contact`]s,
/// vertex-triangle contacts first, each list in the detector's sorted order.
/// In parallel (each contact is made alone, so the result does not depend
/// on the threads): a settled pile of 20k triangles has about 119k.
pub fn gather(mesh: &Mesh, x: &[DVec3], found: &ProximityContacts) -> Vec<Contact> {
    let at = |k: u32| x[k as usize];
    let mut out: Vec<Contact> = found
        .vertex_triangle
        .par_iter()
        .with_min_len(GATHER_MIN)
        .map(|c| vertex_triangle_contact(mesh, at, c.vertex, c.triangle, c.bary, c.distance))
        .collect();
    out.par_extend(
        found
            .edge_edge
            .par_iter()
            .with_min_len(GATHER_MIN)
            .map(|c| edge_edge_contact(mesh, at, c.edges, c.params, c.distance)),
    );
    out
}

/// Contacts per parallel task of [`gather`].
const GATHER_MIN: usize = 4096;

/// Vertex `v` against triangle `t` at positions `at`, closest point at barycentrics `w`.
fn vertex_triangle_contact(
    mesh: &Mesh,
    at: impl Fn(u32) -> DVec3,
    v: u32,
    t: u32,
    w: [f64; 3],
    distance: f64,
) -> Contact {
    let [a, b, c] = mesh.triangles()[t as usize];
    point_triangle_stencil(at, [v, a, b, c], w, distance, mesh.mean_edge_length())
}

/// Point `ids[0]` against triangle `ids[1..4]`, closest point at barycentrics
/// `w`; `scale` is a typical edge length (for the degenerate-normal fallback).
pub fn point_triangle_stencil(
    at: impl Fn(u32) -> DVec3,
    ids: [u32; 4],
    w: [f64; 3],
    distance: f64,
    scale: f64,
) -> Contact {
    let [p, a, b, c] = ids.map(&at);
    let q = a * w[0] + b * w[1] + c * w[2];
    let face = unit_or((b - a).cross(c - a), scale * scale, DVec3::Z);
    Contact {
        verts: ids,
        weights: [1.0, -w[0], -w[1], -w[2]],
        normal: unit_or(p - q, scale, face),
        distance,
        kind: StencilKind::VertexTriangle,
    }
}

/// Edges `e` at positions `at`, closest points at parameters `st` along each.
fn edge_edge_contact(
    mesh: &Mesh,
    at: impl Fn(u32) -> DVec3,
    e: [u32; 2],
    st: [f64; 2],
    distance: f64,
) -> Contact {
    let edges = &mesh.topology().edges;
    let ([a, b], [p, q]) = (edges[e[0] as usize], edges[e[1] as usize]);
    edge_edge_stencil(at, [a, b, p, q], st, distance, mesh.mean_edge_length())
}

/// Segment `ids[0..2]` against segment `ids[2..4]`, closest points at
/// parameters `st` along each; `scale` as for [`point_triangle_stencil`].
pub fn edge_edge_stencil(
    at: impl Fn(u32) -> DVec3,
    ids: [u32; 4],
    st: [f64; 2],
    distance: f64,
    scale: f64,
) -> Contact {
    let [s, t] = st;
    let [xa, xb, xp, xq] = ids.map(&at);
    let across = unit_or((xb - xa).cross(xq - xp), scale * scale, DVec3::Z);
    let gap = (xa + (xb - xa) * s) - (xp + (xq - xp) * t);
    Contact {
        verts: ids,
        weights: [1.0 - s, s, t - 1.0, -t],
        normal: unit_or(gap, scale, across),
        distance,
        kind: StencilKind::EdgeEdge,
    }
}

/// A stencil of `kind` over `ids` at positions `at`, with the closest points
/// found again there (for contacts found by a continuous query).
pub fn stencil_at(
    at: impl Fn(u32) -> DVec3,
    kind: StencilKind,
    ids: [u32; 4],
    scale: f64,
) -> Contact {
    let [p, a, b, c] = ids.map(&at);
    match kind {
        StencilKind::VertexTriangle => {
            let (d2, w) = point_triangle_distance2(p, a, b, c);
            point_triangle_stencil(at, ids, w, d2.sqrt(), scale)
        }
        StencilKind::EdgeEdge => {
            let (d2, s, t) = segment_segment_distance2(p, a, b, c);
            edge_edge_stencil(at, ids, [s, t], d2.sqrt(), scale)
        }
    }
}

/// The relative normal velocity a contact must reach this step (see the module doc).
#[inline]
fn goal(c: &Contact, p: &ContactParams, h: f64) -> f64 {
    let gap = c.distance - p.thickness;
    if gap < 0.0 {
        -p.push * gap / h
    } else {
        -gap / h
    }
}

/// Stage 1: constrains, in the solve's filter, every (cloth) vertex closer
/// than `d` to a triangle that is not separating at the goal speed; contacts
/// whose vertex is not in the filter (an obstacle's) are left to the impulses. `dv_prev` is the last
/// step's velocity change (the triangle's acceleration estimate). Returns the
/// number of constraints added.
pub fn constrain(
    contacts: &[Contact],
    v: &[DVec3],
    dv_prev: &[DVec3],
    p: &ContactParams,
    h: f64,
    filter: &mut Filter,
) -> usize {
    let (mut added, covered) = (0, filter.len());
    for c in contacts
        .iter()
        .filter(|c| c.kind == StencilKind::VertexTriangle && c.distance < p.thickness)
        .filter(|c| (c.verts[0] as usize) < covered)
    {
        let (vn, want) = (c.normal_velocity(v), goal(c, p, h));
        if vn >= want {
            continue;
        }
        // The triangle's part of sum w dv (weights 1..3 are minus its barycentrics).
        let obstacle_dv: DVec3 = (1..4)
            .map(|k| dv_prev[c.verts[k] as usize] * -c.weights[k])
            .sum();
        let target = want - vn + obstacle_dv.dot(c.normal);
        if filter.constrain(c.verts[0] as usize, c.normal, target) {
            added += 1;
        }
    }
    added
}

/// What the impulse stage did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImpulseStats {
    /// Gauss-Seidel sweeps run.
    pub sweeps: u32,
    /// Impulses applied, over all sweeps.
    pub impulses: u64,
    /// Contacts tested, over all sweeps (the others were skipped as still met).
    pub tested: u64,
}

/// Stage 2: mass-weighted impulses until every contact meets its goal normal
/// velocity (or `p.sweeps` sweeps). An impulse `j` along n changes `v_k` by
/// `w_k j n / m_k`, with `j = (goal - vn) / sum_k w_k^2 / m_k`, so momentum is
/// conserved and pinned vertices (inverse mass 0) do not move. Then Coulomb
/// friction `mu(c)` on the total normal impulse (see `resolve`).
pub fn impulses(
    contacts: &[Contact],
    inv_mass: &[f64],
    v: &mut [DVec3],
    p: &ContactParams,
    h: f64,
    mu: impl Fn(&Contact) -> f64,
) -> ImpulseStats {
    resolve(
        contacts,
        inv_mass,
        v,
        p.sweeps,
        1e-9 * p.thickness / h,
        |c| goal(c, p, h),
        mu,
    )
}

/// `sum_k w_k^2 / m_k`: the inverse of the contact's effective mass.
fn inverse_effective_mass(c: &Contact, inv_mass: &[f64]) -> f64 {
    (0..4)
        .map(|k| c.weights[k] * c.weights[k] * inv_mass[c.verts[k] as usize])
        .sum()
}

/// Adds the impulse `j` (a vector) to the contact's vertices: `v_k += w_k j / m_k`.
fn apply(c: &Contact, inv_mass: &[f64], v: &mut [DVec3], j: DVec3) {
    for k in 0..4 {
        let i = c.verts[k] as usize;
        v[i] += j * (c.weights[k] * inv_mass[i]);
    }
}

/// Gauss-Seidel over `contacts` until each has relative normal velocity at
/// least `goal(c)` (within `slack`), or `sweeps` sweeps. Then one friction
/// pass (Coulomb): each contact's relative tangential velocity `vt` is reduced
/// by a tangential impulse of at most `mu(c)` times its total normal impulse,
/// stopping the sliding when that is enough (static friction).
///
/// A sweep skips a contact that cannot need an impulse (see [`Watch`]), so it
/// gives exactly the velocities of testing every contact every sweep.
fn resolve(
    contacts: &[Contact],
    inv_mass: &[f64],
    v: &mut [DVec3],
    sweeps: u32,
    slack: f64,
    goal: impl Fn(&Contact) -> f64,
    mu: impl Fn(&Contact) -> f64,
) -> ImpulseStats {
    let mut stats = ImpulseStats::default();
    let mut total = vec![0.0; contacts.len()];
    let mut watch = Watch::new(contacts, v, &goal);
    while stats.sweeps < sweeps {
        stats.sweeps += 1;
        let mut applied = 0;
        let guard = watch.guard();
        for (k, (c, total)) in contacts.iter().zip(&mut total).enumerate() {
            if watch.still_met(k, guard) {
                continue;
            }
            stats.tested += 1;
            let deficit = goal(c) - c.normal_velocity(v);
            let w_m = inverse_effective_mass(c, inv_mass);
            if deficit <= slack || w_m <= 0.0 {
                watch.met(
                    k,
                    c,
                    if w_m > 0.0 {
                        slack - deficit
                    } else {
                        f64::INFINITY
                    },
                );
                continue;
            }
            let j = deficit / w_m;
            apply(c, inv_mass, v, c.normal * j);
            watch.moved(k, c, inv_mass, j);
            *total += j;
            applied += 1;
        }
        stats.impulses += applied;
        if applied == 0 {
            break;
        }
    }
    for (c, &jn) in contacts.iter().zip(&total) {
        let mu = mu(c);
        if !(jn > 0.0 && mu > 0.0) {
            continue;
        }
        let u = c.combine(v);
        let vt = u - c.normal * u.dot(c.normal);
        let (speed, w_m) = (vt.length(), inverse_effective_mass(c, inv_mass));
        if speed > 0.0 && w_m > 0.0 {
            let jt = (speed / w_m).min(mu * jn);
            apply(c, inv_mass, v, vt * (-jt / speed));
        }
    }
    stats
}

/// Which contacts a Gauss-Seidel sweep can skip. A contact's relative normal
/// velocity `vn = sum_k w_k v_k . n` changes by at most `sum_k |dv_k|` when its
/// vertices' velocities change by `dv_k` (`|n| = 1`; weights `|w_k| <= 1`,
/// else the room below is divided by the largest). Each vertex
/// keeps its *drift*, the sum of the lengths of the velocity changes it got
/// this stage; a contact met with room `slack - deficit` stays met while its
/// vertices' drifts have grown by less than that room since (less a rounding
/// guard far above the error of evaluating the deficit). On a settled pile of
/// cloth most contacts are met by a wide margin and most impulses are small,
/// so a sweep tests few of them, but it still reads every contact's entry:
/// one 24-byte record (its vertices and the drift sum it stays met below)
/// in one stream, so the reading is all a skip costs.
struct Watch {
    /// Per contact, what a skip reads.
    entries: Vec<WatchEntry>,
    drift: Vec<f64>,
    /// Bound on every speed at the start, and on any |goal|.
    speed: f64,
    goal: f64,
    most_drift: f64,
}

/// A contact's vertices and `limit`: the sum of their drifts when it was
/// last found met plus its room then (`-inf`: test it). Folding the two into
/// one number adds one rounding of it (a relative `1e-16`), of the size of
/// those the room and the drift sums carry already: the guard
/// ([`Watch::guard`], `1e-12` of the bounds on the goals and speeds, which
/// bound the room and the drifts) covers them all.
#[derive(Clone, Copy)]
struct WatchEntry {
    verts: [u32; 4],
    limit: f64,
}

impl Watch {
    fn new(contacts: &[Contact], v: &[DVec3], goal: &impl Fn(&Contact) -> f64) -> Watch {
        Watch {
            entries: (contacts.iter())
                .map(|c| WatchEntry {
                    verts: c.verts,
                    limit: f64::NEG_INFINITY,
                })
                .collect(),
            drift: vec![0.0; v.len()],
            speed: v.iter().map(|x| x.length()).fold(0.0, f64::max),
            goal: contacts.iter().map(|c| goal(c).abs()).fold(0.0, f64::max),
            most_drift: 0.0,
        }
    }

    /// The rounding guard for this sweep: evaluating a deficit errs by a few
    /// units in the last place of `|goal| + sum_k |v_k|`, and no speed exceeds
    /// the start's largest plus the largest drift.
    fn guard(&self) -> f64 {
        1e-12 * (self.goal + 4.0 * (self.speed + self.most_drift))
    }

    #[inline]
    fn drift_of(&self, verts: &[u32; 4]) -> f64 {
        verts.iter().map(|&i| self.drift[i as usize]).sum()
    }

    /// True when contact `k` was met and cannot have a deficit above the slack now.
    #[inline]
    fn still_met(&self, k: usize, guard: f64) -> bool {
        let e = &self.entries[k];
        self.drift_of(&e.verts) < e.limit - guard
    }

    /// Contact `k` (`c`) is met with `room` (at least 0) to spare.
    fn met(&mut self, k: usize, c: &Contact, room: f64) {
        // (Weights are at most 1 in size; dividing keeps the bound if one is not.)
        let w = c.weights.iter().fold(1.0, |m: f64, w| m.max(w.abs()));
        let drift = self.drift_of(&self.entries[k].verts);
        self.entries[k].limit = drift + room / w;
    }

    /// Contact `k` (`c`) got impulse `j`: its vertices drift by `|w_k j / m_k|`.
    fn moved(&mut self, k: usize, c: &Contact, inv_mass: &[f64], j: f64) {
        for (&i, w) in c.verts.iter().zip(c.weights) {
            let d = &mut self.drift[i as usize];
            *d += (j * w * inv_mass[i as usize]).abs();
            self.most_drift = self.most_drift.max(*d);
        }
        self.entries[k].limit = f64::NEG_INFINITY;
    }
}

/// Stage 2b, continuous collisions (Bridson et al. 2002): given the element
/// pairs that come within the thickness while every vertex moves from `x0`
/// to `x0 + h v` (the engine's continuous query, run by the caller), each
/// gets an inelastic impulse that stops its approach along the normal at its
/// time of impact, then friction `mu(c)`. The caller repeats the query with
/// the new velocities until nothing meets; what is left is for the correction stage.
pub fn impact_impulses(
    hits: &[Contact],
    inv_mass: &[f64],
    v: &mut [DVec3],
    mu: impl Fn(&Contact) -> f64,
) -> ImpulseStats {
    resolve(hits, inv_mass, v, 20, 0.0, |_| 0.0, mu)
}

/// The contacts of self impacts, at their times of impact on the way from `x0` to `x1`.
pub fn impact_contacts(mesh: &Mesh, x0: &[DVec3], x1: &[DVec3], found: &Impacts) -> Vec<Contact> {
    let edges = &mesh.topology().edges;
    let scale = mesh.mean_edge_length();
    found
        .vertex_triangle
        .iter()
        .chain(&found.edge_edge)
        .map(|i| {
            let at = |k: u32| x0[k as usize].lerp(x1[k as usize], i.toi);
            let (kind, ids) = match i.pair {
                ElementPair::VertexTriangle(v, t) => {
                    let [a, b, c] = mesh.triangles()[t as usize];
                    (StencilKind::VertexTriangle, [v, a, b, c])
                }
                ElementPair::EdgeEdge(e0, e1) => {
                    let ([a, b], [p, q]) = (edges[e0 as usize], edges[e1 as usize]);
                    (StencilKind::EdgeEdge, [a, b, p, q])
                }
            };
            stencil_at(at, kind, ids, scale)
        })
        .collect()
}

/// The contacts of cloth-obstacle proximity pairs at combined positions `x`.
pub fn cross_contacts(m: Meshes, x: &[DVec3], found: &[cross::Near]) -> Vec<Contact> {
    let scale = m.cloth.mean_edge_length();
    let at = |k: u32| x[k as usize];
    found
        .iter()
        .map(|n| match m.stencil(n.pair) {
            (StencilKind::VertexTriangle, ids) => {
                point_triangle_stencil(at, ids, n.params, n.distance, scale)
            }
            (StencilKind::EdgeEdge, ids) => {
                edge_edge_stencil(at, ids, [n.params[0], n.params[1]], n.distance, scale)
            }
        })
        .collect()
}

/// The contacts of cloth-obstacle impacts, at their times of impact (combined positions).
pub fn cross_impact_contacts(
    m: Meshes,
    x0: &[DVec3],
    x1: &[DVec3],
    found: &[cross::Impact],
) -> Vec<Contact> {
    let scale = m.cloth.mean_edge_length();
    found
        .iter()
        .map(|i| {
            let (kind, ids) = m.stencil(i.pair);
            stencil_at(
                |k: u32| x0[k as usize].lerp(x1[k as usize], i.toi),
                kind,
                ids,
                scale,
            )
        })
        .collect()
}

/// Start-of-step state and masses the correction stage moves zones with.
pub struct StepStart<'a> {
    /// Positions at the start of the step (intersection-free).
    pub x0: &'a [DVec3],
    /// Vertex masses.
    pub mass: &'a [f64],
    /// Pinned vertices: a zone holding one is frozen.
    pub pinned: &'a [bool],
    /// Time step (s).
    pub h: f64,
}

/// Stage 3, rigid impact zones (Provot 1997; Bridson et al. 2002). The step
/// runs the loop, with a conservative intersection check at every round:
///
/// while a check finds intersecting pairs at `x`: [`Zones::absorb`] merges the
/// vertices of each self-intersecting pair's two triangles into one zone
/// (union-find), and [`Zones::bind`] ties the vertices of each cloth triangle
/// that meets an obstacle to the obstacle (they move with it from their start
/// positions); [`Zones::move_rigidly`] then moves every zone rigidly from its
/// start-of-step positions with its own momentum and angular momentum,
/// `x_i = c0 + h v_c + R(h w) (x0_i - c0)`, `w = I^-1 L` (pinned and bound
/// vertices count with their own velocity and keep their position). A rigid
/// motion keeps the zone's own triangles as intersection-free as they were at
/// `x0`, so each round must merge or grow zones, unless a pin stayed behind;
/// if a round cannot, the zones still intersecting are frozen at `x0` with
/// zero velocity, and if that cannot help either, the loop stops and reports
/// the pairs left.
pub struct Zones {
    parent: Vec<u32>,
    member: Vec<bool>,
    frozen: Vec<bool>,
    /// Pinned vertices, then bound ones: they keep their position.
    fixed: Vec<bool>,
    /// Displacement over the step of a vertex bound to an obstacle.
    bound: Vec<Option<DVec3>>,
}

impl Zones {
    /// No zone yet; `pinned` vertices never move.
    pub fn new(pinned: &[bool]) -> Zones {
        let n = pinned.len();
        Zones {
            parent: (0..n as u32).collect(),
            member: vec![false; n],
            frozen: vec![false; n],
            fixed: pinned.to_vec(),
            bound: vec![None; n],
        }
    }

    /// Grows zones from intersecting triangle pairs of `mesh`; if none grew,
    /// freezes the zones of the pairs. True when anything changed.
    pub fn absorb(&mut self, mesh: &Mesh, pairs: &[[u32; 2]]) -> bool {
        let tris = mesh.triangles();
        let mut changed = false;
        for &[a, b] in pairs {
            let (ta, tb) = (tris[a as usize], tris[b as usize]);
            for &i in ta.iter().chain(&tb) {
                changed |= self.join(ta[0] as usize, i as usize);
            }
        }
        if !changed {
            for &[a, b] in pairs {
                changed |= self.freeze(tris[a as usize][0] as usize);
                changed |= self.freeze(tris[b as usize][0] as usize);
            }
        }
        changed
    }

    /// Binds the (free) vertices of `triangles` to an obstacle: vertex `i`
    /// moves by `displacement(i)` from its start position. True when any was new.
    pub fn bind(
        &mut self,
        mesh: &Mesh,
        triangles: impl IntoIterator<Item = u32>,
        displacement: impl Fn(usize) -> DVec3,
    ) -> bool {
        let mut changed = false;
        for t in triangles {
            for &i in &mesh.triangles()[t as usize] {
                let i = i as usize;
                if !self.fixed[i] {
                    (self.fixed[i], self.bound[i], self.member[i]) =
                        (true, Some(displacement(i)), true);
                    changed = true;
                }
            }
        }
        changed
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let p = self.parent[i] as usize;
            self.parent[i] = self.parent[p];
            i = p;
        }
        i
    }

    /// Puts `i` in `a`'s zone; true when that changed anything.
    fn join(&mut self, a: usize, i: usize) -> bool {
        let new_member = !(self.member[a] && self.member[i]);
        self.member[a] = true;
        self.member[i] = true;
        let (ra, ri) = (self.root(a), self.root(i));
        if ra == ri {
            return new_member;
        }
        // The smaller index becomes the root: the result does not depend on order.
        let (keep, drop) = (ra.min(ri), ra.max(ri));
        self.parent[drop] = keep as u32;
        self.frozen[keep] |= self.frozen[drop];
        true
    }

    /// Freezes `i`'s zone; true when it was not frozen.
    fn freeze(&mut self, i: usize) -> bool {
        let r = self.root(i);
        !std::mem::replace(&mut self.frozen[r], true)
    }

    /// Vertices in a zone or bound to an obstacle.
    pub fn members(&self) -> usize {
        self.member.iter().filter(|&&m| m).count()
    }

    /// Number of zones (a bound vertex alone counts as one).
    pub fn count(&mut self) -> usize {
        (0..self.parent.len())
            .filter(|&i| self.member[i] && self.root(i) == i)
            .count()
    }

    /// Moves every zone rigidly from `s.x0` with the momentum of the velocities
    /// `u` (those the step had before the correction), and bound vertices with
    /// their obstacle. Returns the vertices whose position changed (bits), once
    /// each: what a later intersection check tests again.
    pub fn move_rigidly(
        &mut self,
        s: &StepStart,
        u: &[DVec3],
        x: &mut [DVec3],
        v: &mut [DVec3],
    ) -> Vec<u32> {
        let n = x.len();
        let mut moved = Vec::new();
        let mut place = |i: usize, p: DVec3, x: &mut [DVec3]| {
            if !same_bits(x[i], p) {
                moved.push(i as u32);
            }
            x[i] = p;
        };
        let mut by_root: Vec<Vec<u32>> = vec![Vec::new(); n];
        for i in 0..n {
            if self.member[i] {
                let r = self.root(i);
                by_root[r].push(i as u32);
            }
        }
        for (i, d) in self.bound.iter().enumerate() {
            if let Some(d) = d {
                place(i, s.x0[i] + *d, x);
                v[i] = *d / s.h;
            }
        }
        for (r, verts) in by_root.iter().enumerate().filter(|(_, z)| !z.is_empty()) {
            let motion = if self.frozen[r] {
                RigidMotion::default()
            } else {
                RigidMotion::of(verts, s, u)
            };
            for &i in verts.iter().filter(|&&i| !self.fixed[i as usize]) {
                let i = i as usize;
                place(i, motion.apply(s.x0[i]), x);
                v[i] = (x[i] - s.x0[i]) / s.h;
            }
        }
        moved
    }
}

/// A rigid displacement over one step: `p -> c0 + t + R (p - c0)`.
#[derive(Debug, Clone, Copy)]
struct RigidMotion {
    c0: DVec3,
    t: DVec3,
    r: DQuat,
}

impl Default for RigidMotion {
    fn default() -> Self {
        RigidMotion {
            c0: DVec3::ZERO,
            t: DVec3::ZERO,
            r: DQuat::IDENTITY,
        }
    }
}

impl RigidMotion {
    /// The motion of `verts` with their total momentum and angular momentum (about
    /// the centre of mass at `x0`) under velocities `u`, over one step.
    fn of(verts: &[u32], s: &StepStart, u: &[DVec3]) -> RigidMotion {
        let m = |i: u32| s.mass[i as usize];
        let total: f64 = verts.iter().map(|&i| m(i)).sum();
        let c0 = verts
            .iter()
            .map(|&i| s.x0[i as usize] * m(i))
            .sum::<DVec3>()
            / total;
        let vc = verts.iter().map(|&i| u[i as usize] * m(i)).sum::<DVec3>() / total;
        let (mut l, mut inertia) = (DVec3::ZERO, DMat3::ZERO);
        for &i in verts {
            let r = s.x0[i as usize] - c0;
            l += r.cross(u[i as usize] - vc) * m(i);
            inertia += (DMat3::from_diagonal(DVec3::splat(r.length_squared())) - outer(r)) * m(i);
        }
        // A small regularisation keeps a (nearly) collinear zone's inertia invertible.
        let eps =
            1e-9 * (inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z) + f64::MIN_POSITIVE;
        let inertia = inertia + DMat3::from_diagonal(DVec3::splat(eps));
        let w = if inertia.determinant() > 0.0 {
            inertia.inverse() * l
        } else {
            DVec3::ZERO
        };
        let angle = w.length() * s.h;
        let r = if angle > 0.0 && angle.is_finite() {
            DQuat::from_axis_angle(w / w.length(), angle)
        } else {
            DQuat::IDENTITY
        };
        RigidMotion { c0, t: vc * s.h, r }
    }

    #[inline]
    fn apply(&self, p: DVec3) -> DVec3 {
        self.c0 + self.t + self.r * (p - self.c0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random vertex-triangle and edge-edge stencils over `n` vertices (some
    /// without mass), crowded so that contacts share vertices.
    fn crowd(n: usize, count: usize, seed: u64) -> (Vec<Contact>, Vec<f64>, Vec<DVec3>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let inv_mass = (0..n)
            .map(|i| {
                if i % 17 == 0 {
                    0.0
                } else {
                    rng.gen_range(0.5..4.0)
                }
            })
            .collect();
        let v = (0..n)
            .map(|_| {
                DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                )
            })
            .collect();
        let contacts = (0..count)
            .map(|_| {
                let mut verts = [0u32; 4];
                for k in 0..4 {
                    verts[k] = loop {
                        let i = rng.gen_range(0..n as u32);
                        if !verts[..k].contains(&i) {
                            break i;
                        }
                    };
                }
                let (s, t) = (rng.gen_range(0.0..1.0), rng.gen_range(0.0..1.0));
                let vt = rng.gen_bool(0.5);
                let weights = if vt {
                    let u = rng.gen_range(0.0..1.0 - s);
                    [1.0, -s, -u, -(1.0 - s - u)]
                } else {
                    [1.0 - s, s, -(1.0 - t), -t]
                };
                let normal =
                    DVec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), 1.0).normalize();
                Contact {
                    verts,
                    weights,
                    normal,
                    distance: rng.gen_range(0.0..0.3),
                    kind: if vt {
                        StencilKind::VertexTriangle
                    } else {
                        StencilKind::EdgeEdge
                    },
                }
            })
            .collect();
        (contacts, inv_mass, v)
    }

    /// Gauss-Seidel testing every contact in every sweep (the definition).
    fn plain(
        contacts: &[Contact],
        inv_mass: &[f64],
        v: &mut [DVec3],
        p: &ContactParams,
        h: f64,
    ) -> u64 {
        let (slack, mut impulses) = (1e-9 * p.thickness / h, 0);
        for _ in 0..p.sweeps {
            let mut applied = 0;
            for c in contacts {
                let deficit = goal(c, p, h) - c.normal_velocity(v);
                let w_m = inverse_effective_mass(c, inv_mass);
                if deficit > slack && w_m > 0.0 {
                    apply(c, inv_mass, v, c.normal * (deficit / w_m));
                    applied += 1;
                }
            }
            impulses += applied;
            if applied == 0 {
                break;
            }
        }
        impulses
    }

    #[test]
    fn skipping_met_contacts_gives_the_plain_sweeps_to_the_bit() {
        let p = ContactParams {
            thickness: 0.1,
            margin: 0.2,
            push: 0.1,
            sweeps: 20,
            friction: 0.0,
            obstacle_friction: 0.0,
        };
        for (n, count, seed) in [(40, 300, 1), (200, 900, 2), (1000, 2000, 3)] {
            let (contacts, inv_mass, v0) = crowd(n, count, seed);
            let (mut a, mut b) = (v0.clone(), v0.clone());
            let impulses = plain(&contacts, &inv_mass, &mut a, &p, 0.01);
            let stats = super::impulses(&contacts, &inv_mass, &mut b, &p, 0.01, |_| 0.0);
            assert_eq!(stats.impulses, impulses);
            // Some sweep skipped contacts (else the test would show nothing).
            let sweeps = u64::from(stats.sweeps);
            assert!(
                sweeps > 2 && stats.tested < sweeps * count as u64,
                "{stats:?}"
            );
            assert!(
                impulses > count as u64,
                "the sweeps must do work: {impulses}"
            );
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(
                    x.to_array().map(f64::to_bits),
                    y.to_array().map(f64::to_bits)
                );
            }
        }
    }
}
