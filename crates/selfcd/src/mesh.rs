//! `Mesh`: rest positions, triangles and the topology built once from them.
//!
//! Topology never changes while the mesh deforms, so everything derived from
//! connectivity (edges, vertex -> triangles, edge -> triangles) is computed here
//! once and shared by the BVH, the sensor and the cloth.

use crate::error::{Error, Result};
use crate::geom::predicates::{exponent, mul_pow2};
use glam::DVec3;
use std::collections::HashMap;

/// Compressed sparse rows: `items[offsets[i]..offsets[i+1]]` belong to `i`.
#[derive(Debug, Clone, Default)]
pub struct Csr {
    /// Start of each row; one more entry than rows.
    pub offsets: Vec<u32>,
    /// Row contents, concatenated.
    pub items: Vec<u32>,
}

impl Csr {
    /// Builds rows from `(row, item)` pairs; items keep their input order within a row.
    pub fn from_pairs(rows: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Csr {
        let mut offsets = vec![0u32; rows + 1];
        for (r, _) in pairs.clone() {
            offsets[r as usize + 1] += 1;
        }
        for i in 0..rows {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[rows] as usize];
        for (r, it) in pairs {
            items[fill[r as usize] as usize] = it;
            fill[r as usize] += 1;
        }
        Csr { offsets, items }
    }

    /// The items of row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// Connectivity of a triangle mesh, built once.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Unique undirected edges, each stored with its smaller vertex first.
    pub edges: Vec<[u32; 2]>,
    /// For each triangle, the ids of its edges (v0v1, v1v2, v2v0).
    pub tri_edges: Vec<[u32; 3]>,
    /// For each edge, the triangles that contain it.
    pub edge_tris: Csr,
    /// For each vertex, the triangles that contain it.
    pub vertex_tris: Csr,
}

impl Topology {
    /// Builds the topology of `tris` over `n_vertices` vertices (indices must be valid).
    pub fn new(n_vertices: usize, tris: &[[u32; 3]]) -> Topology {
        let mut edge_id: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 2);
        let mut edges = Vec::with_capacity(tris.len() * 3 / 2 + 1);
        let mut tri_edges = Vec::with_capacity(tris.len());
        for t in tris {
            let mut ids = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                ids[k] = *edge_id.entry(key).or_insert_with(|| {
                    edges.push([key.0, key.1]);
                    (edges.len() - 1) as u32
                });
            }
            tri_edges.push(ids);
        }
        let edge_tris = Csr::from_pairs(
            edges.len(),
            tri_edges
                .iter()
                .enumerate()
                .flat_map(|(t, e)| e.iter().map(move |&e| (e, t as u32))),
        );
        let vertex_tris = Csr::from_pairs(
            n_vertices,
            tris.iter()
                .enumerate()
                .flat_map(|(t, v)| v.iter().map(move |&v| (v, t as u32))),
        );
        Topology {
            edges,
            tri_edges,
            edge_tris,
            vertex_tris,
        }
    }

    /// True when edge `e` has exactly two triangles (an interior edge of a manifold).
    #[inline]
    pub fn is_manifold_interior(&self, e: u32) -> bool {
        self.edge_tris.row(e as usize).len() == 2
    }
}

/// A triangle mesh with validated rest positions and its topology.
#[derive(Debug, Clone)]
pub struct Mesh {
    rest: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    topo: Topology,
    mean_edge: f64,
}

impl Mesh {
    /// Validates `vertices` (rest shape) and `triangles` and builds the topology.
    ///
    /// Errors: empty mesh, non-finite coordinate, index out of range, a triangle
    /// repeating a vertex index, two triangles with the same vertex set.
    ///
    /// Accepted: zero-area triangles (collinear or coincident corners, in the
    /// rest shape or any frame). Every query treats one as the segment or point
    /// it is: it intersects what that segment or point touches; its normal cone
    /// is the full cone, so no node holding it is culled.
    ///
    /// Refused, by policy: a repeated vertex *index* (`[a, b, b]`) names an edge
    /// from a vertex to itself, which the edge topology cannot hold; a collapsed
    /// corner needs its own vertex at the same position (`weld` in the Python
    /// API keeps one so). Two triangles with the same three vertices are
    /// refused too: they are adjacent, so their contact is never a
    /// self-intersection, and one of them is a duplicate to remove.
    pub fn new(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Result<Mesh> {
        if vertices.is_empty() {
            return Err(Error::EmptyMesh("no vertices"));
        }
        if triangles.is_empty() {
            return Err(Error::EmptyMesh("no triangles"));
        }
        let rest: Vec<DVec3> = vertices.iter().map(|v| DVec3::from_array(*v)).collect();
        check_finite(&rest)?;
        let n = rest.len();
        let mut seen: HashMap<[u32; 3], usize> = HashMap::with_capacity(triangles.len());
        for (i, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
                return Err(Error::IndexOutOfRange {
                    triangle: i,
                    index: bad as u64,
                    vertex_count: n,
                });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(Error::RepeatedVertex {
                    triangle: i,
                    indices: *t,
                });
            }
            let mut key = *t;
            key.sort_unstable();
            if let Some(&first) = seen.get(&key) {
                return Err(Error::DuplicateTriangle { first, second: i });
            }
            seen.insert(key, i);
        }
        let topo = Topology::new(n, &triangles);
        let mean_edge = mean_length(topo.edges.iter().map(|e| edge_length(&rest, *e)));
        Ok(Mesh {
            rest,
            tris: triangles,
            topo,
            mean_edge,
        })
    }

    /// Rest positions.
    pub fn rest(&self) -> &[DVec3] {
        &self.rest
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.tris
    }

    /// Connectivity built at construction.
    pub fn topology(&self) -> &Topology {
        &self.topo
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest.len()
    }

    /// Number of triangles.
    pub fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Mean rest edge length: the length unit of the sensor.
    pub fn mean_edge_length(&self) -> f64 {
        self.mean_edge
    }

    /// Checks that `positions` fit this mesh: right length, all finite.
    pub fn check_positions(&self, positions: &[DVec3]) -> Result<()> {
        if positions.len() != self.rest.len() {
            return Err(Error::PositionsLength {
                expected: self.rest.len(),
                got: positions.len(),
            });
        }
        check_finite(positions)
    }

    /// The three corners of triangle `t` in `positions`.
    #[inline]
    pub fn corners(&self, positions: &[DVec3], t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.tris[t];
        [
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        ]
    }

    /// True when triangles `a` and `b` share at least one vertex.
    #[inline]
    pub fn share_vertex(&self, a: usize, b: usize) -> bool {
        let (ta, tb) = (&self.tris[a], &self.tris[b]);
        ta.iter().any(|v| tb.contains(v))
    }

    /// Flags, per triangle, whether it touches a non-manifold edge (more than two
    /// triangles) or a non-manifold vertex (its triangles form several fans).
    pub fn nonmanifold_triangles(&self) -> Vec<bool> {
        let mesh = self;
        let topo = mesh.topology();
        let tris = mesh.triangles();
        let mut bad = vec![false; tris.len()];
        for e in 0..topo.edges.len() {
            let row = topo.edge_tris.row(e);
            if row.len() > 2 {
                row.iter().for_each(|&t| bad[t as usize] = true);
            }
        }
        // A vertex is manifold when its triangles are connected through edges at it.
        let mut parent: Vec<u32> = Vec::new();
        for v in 0..mesh.n_vertices() {
            let fan = topo.vertex_tris.row(v);
            if fan.len() < 2 {
                continue;
            }
            parent.clear();
            parent.extend(0..fan.len() as u32);
            fn find(p: &mut [u32], mut x: u32) -> u32 {
                while p[x as usize] != x {
                    p[x as usize] = p[p[x as usize] as usize];
                    x = p[x as usize];
                }
                x
            }
            for i in 0..fan.len() {
                for j in i + 1..fan.len() {
                    let (ti, tj) = (fan[i] as usize, fan[j] as usize);
                    let shares_edge_at_v = topo.tri_edges[ti].iter().any(|e| {
                        topo.tri_edges[tj].contains(e)
                            && topo.edges[*e as usize].contains(&(v as u32))
                    });
                    if shares_edge_at_v {
                        let (ri, rj) = (find(&mut parent, i as u32), find(&mut parent, j as u32));
                        parent[ri as usize] = rj;
                    }
                }
            }
            let roots = (0..fan.len() as u32)
                .filter(|&i| find(&mut parent, i) == i)
                .count();
            if roots > 1 {
                fan.iter().for_each(|&t| bad[t as usize] = true);
            }
        }
        bad
    }
}

/// Length of edge `e` for any finite corners: the difference is moved by a
/// power of two to [1, 2) before squaring, so no square overflows or
/// underflows (edges of 2^-900 are not zero); the result is bit for bit the
/// naive one wherever that does not overflow or underflow (so the naive one
/// is used there, the cheaper). Saturated at
/// `f64::MAX` when the length exceeds it.
fn edge_length(rest: &[DVec3], e: [u32; 2]) -> f64 {
    let (a, b) = (rest[e[0] as usize], rest[e[1] as usize]);
    let (d, twice) = match a - b {
        d if d.is_finite() => (d, false),
        _ => (0.5 * a - 0.5 * b, true), // the difference overflowed: halve first
    };
    let m = d.abs().max_element();
    if (1e-150..1e150).contains(&m) {
        return d.length(); // the common case: no square can overflow or underflow
    }
    if m == 0.0 {
        return 0.0;
    }
    let k = exponent(m);
    let len = mul_pow2(mul_pow2(d, -k).length(), k);
    (if twice { 2.0 * len } else { len }).min(f64::MAX)
}

/// Mean of finite non-negative `lengths` (0 for none), summed at the scale of
/// the largest so that the sum cannot overflow (bit for bit the naive mean
/// where that does not overflow or underflow).
fn mean_length(lengths: impl Iterator<Item = f64> + Clone) -> f64 {
    let (n, top) = lengths
        .clone()
        .fold((0usize, 0.0f64), |(n, m), x| (n + 1, m.max(x)));
    if top == 0.0 {
        return 0.0;
    }
    if top < 1e150 {
        return lengths.sum::<f64>() / n as f64; // the common case: no overflow
    }
    let k = exponent(top);
    mul_pow2(lengths.map(|x| mul_pow2(x, -k)).sum::<f64>() / n as f64, k)
}

fn check_finite(p: &[DVec3]) -> Result<()> {
    for (i, v) in p.iter().enumerate() {
        if let Some(&value) = v.as_ref().iter().find(|x| !x.is_finite()) {
            return Err(Error::NonFinite { vertex: i, value });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (
            vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn topology_of_a_quad() {
        let (v, f) = quad();
        let m = Mesh::new(v, f).unwrap();
        let t = m.topology();
        assert_eq!(t.edges.len(), 5);
        let diag = t.tri_edges[0][2];
        assert_eq!(t.edge_tris.row(diag as usize), &[0, 1]);
        assert_eq!(t.vertex_tris.row(0), &[0, 1]);
        assert!(m.share_vertex(0, 1));
    }

    #[test]
    fn bad_inputs_are_named() {
        let (v, _) = quad();
        assert!(matches!(
            Mesh::new(vec![], vec![[0, 1, 2]]),
            Err(Error::EmptyMesh(_))
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![]),
            Err(Error::EmptyMesh(_))
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 9]]),
            Err(Error::IndexOutOfRange { index: 9, .. })
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 1]]),
            Err(Error::RepeatedVertex { .. })
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 2], [2, 0, 1]]),
            Err(Error::DuplicateTriangle {
                first: 0,
                second: 1
            })
        ));
        let mut nan = v.clone();
        nan[2][1] = f64::NAN;
        assert!(matches!(
            Mesh::new(nan, vec![[0, 1, 2]]),
            Err(Error::NonFinite { vertex: 2, .. })
        ));
        // Zero-area triangles are valid: a segment, a point.
        let line = vec![[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]];
        assert!(Mesh::new(line, vec![[0, 1, 2]]).is_ok());
        assert!(Mesh::new(vec![[1., 2., 3.]; 3], vec![[0, 1, 2]]).is_ok());
        let m = Mesh::new(v, vec![[0, 1, 2]]).unwrap();
        assert!(matches!(
            m.check_positions(&[DVec3::ZERO]),
            Err(Error::PositionsLength { .. })
        ));
    }

    #[test]
    fn mean_edge_length_at_any_scale() {
        let (v, f) = quad();
        let unit = Mesh::new(v.clone(), f.clone()).unwrap().mean_edge_length();
        assert_eq!(unit, (4.0 + 2f64.sqrt()) / 5.0);
        for e in [-1000, -900, 600, 1000, 1022] {
            let s = 2f64.powi(e.max(-1000)) * 2f64.powi(e - e.max(-1000));
            let scaled = v.iter().map(|p| p.map(|x| x * s)).collect();
            let got = Mesh::new(scaled, f.clone()).unwrap().mean_edge_length();
            assert_eq!(got, unit * s, "2^{e}: bit for bit the unit mean, scaled");
        }
        // Corners at -MAX and +MAX: the edge exceeds f64, the mean saturates.
        let far = vec![[-f64::MAX, 0., 0.], [f64::MAX, 0., 0.], [0., 1., 0.]];
        let m = Mesh::new(far, vec![[0, 1, 2]]).unwrap().mean_edge_length();
        assert!(m.is_finite() && m > 0.6 * f64::MAX, "{m:e}");
    }
}
