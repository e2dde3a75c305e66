//! The paper's three cloth scenes (section 5, figures 3, 5, 7), at any resolution.
//!
//! A 1 m x 1 m square cloth of `n x n` vertices ([`crate::scene::grid`]; the
//! paper's is 11 x 11 = 200 triangles), flat and horizontal in the z = 0
//! plane, at rest, cotton by default, under gravity along -z, pinned:
//! - `two-corners`: at two diagonal corners, (0, 0) and (1, 1);
//! - `corner`: at one corner, (0, 0);
//! - `center`: at the centre vertex (for even `n`, the grid vertex just below
//!   and left of the centre, at index `(n - 1) / 2` along each side).

use super::model::{Cloth, Material};
use super::sim::{SimOptions, Simulation};
use crate::detect::Method;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::scene::grid;
use std::str::FromStr;
use std::sync::Arc;

/// Side of the square cloth (m).
pub const SIZE: f64 = 1.0;

/// The paper's scenes, by their command-line names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PaperScene {
    /// Pinned at two diagonal corners (paper figure 3).
    TwoCorners,
    /// Pinned at one corner (paper figure 5).
    Corner,
    /// Pinned at the centre vertex (paper figure 7).
    Center,
}

impl PaperScene {
    /// Every scene, in the paper's order.
    pub const ALL: [PaperScene; 3] = [
        PaperScene::TwoCorners,
        PaperScene::Corner,
        PaperScene::Center,
    ];

    /// The scene's name.
    pub fn name(self) -> &'static str {
        match self {
            PaperScene::TwoCorners => "two-corners",
            PaperScene::Corner => "corner",
            PaperScene::Center => "center",
        }
    }

    /// The pinned vertices of an `n x n` grid (vertex `(i, j)` has index `j n + i`).
    pub fn pins(self, n: usize) -> Vec<u32> {
        let id = |i: usize, j: usize| (j * n + i) as u32;
        match self {
            PaperScene::TwoCorners => vec![id(0, 0), id(n - 1, n - 1)],
            PaperScene::Corner => vec![id(0, 0)],
            PaperScene::Center => vec![id((n - 1) / 2, (n - 1) / 2)],
        }
    }

    /// The scene's cloth at `n x n` vertices (n >= 2) with `material`.
    pub fn cloth(self, n: usize, material: Material) -> Result<Cloth> {
        if !(2..=4096).contains(&n) {
            return Err(Error::InvalidParameter(format!(
                "cloth resolution must be 2..=4096 vertices per side, got {n}"
            )));
        }
        let (v, f) = grid(n, SIZE);
        let mesh = Arc::new(Mesh::new(v, f)?);
        Cloth::new(mesh, material, &self.pins(n))
    }

    /// The scene at `n x n` vertices with default material and options,
    /// detecting self-contact with `method`.
    pub fn simulation(self, n: usize, method: Method) -> Result<Simulation> {
        let cloth = self.cloth(n, Material::default())?;
        let opts = SimOptions::for_cloth(&cloth);
        Simulation::new(cloth, method, opts)
    }
}

impl std::fmt::Display for PaperScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PaperScene {
    type Err = Error;
    fn from_str(s: &str) -> Result<PaperScene> {
        crate::error::parse_name(s, &PaperScene::ALL, PaperScene::name, "cloth scene")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_input_is_an_error() {
        for s in PaperScene::ALL {
            assert_eq!(s.name().parse::<PaperScene>().unwrap(), s);
        }
        assert!(matches!(
            "middle".parse::<PaperScene>(),
            Err(Error::InvalidParameter(_))
        ));
        assert!(matches!(
            PaperScene::Center.cloth(1, Material::default()),
            Err(Error::InvalidParameter(_))
        ));
        assert_eq!(PaperScene::Center.pins(11), vec![60]);
        assert_eq!(PaperScene::TwoCorners.pins(11), vec![0, 120]);
    }
}
