//! The cloth model: a mesh, its springs, lumped masses, gravity and pins.
//!
//! SI units throughout: metres, kilograms, seconds, newtons. Vertex masses are
//! lumped from rest areas: `m_i = density * sum(area of triangles at i) / 3`.
//! External forces: gravity `m_i g` and air drag `-air_drag * m_i * v_i`.

use super::springs::{Moduli, Springs};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// Standard gravity (m/s^2), pointing down the z axis.
pub const GRAVITY: DVec3 = DVec3::new(0.0, 0.0, -9.81);

/// Material parameters of a cloth.
///
/// The defaults are cotton-like: 150 g/m^2 (cotton fabrics weigh 100-200 g/m^2),
/// stiff in stretch so that a sheet hanging from its corners stretches by a few
/// percent under its own weight, about ten times softer in shear, and easy to
/// bend, so it drapes and folds. Stiffnesses follow `k = modulus * A / L^2`
/// (see [`super::springs`]), so they do not depend on the mesh's resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Mass per unit area (kg/m^2).
    pub density: f64,
    /// Stretch modulus (N/m).
    pub stretch: f64,
    /// Shear modulus (N/m).
    pub shear: f64,
    /// Bend modulus (N/m) of the bend springs.
    pub bend: f64,
    /// Stiffness-proportional spring damping time (s): `kd = damping * k`.
    pub damping: f64,
    /// Air drag rate (1/s): force `-air_drag * m * v` on every vertex.
    pub air_drag: f64,
}

impl Material {
    /// Cotton-like defaults (see the type's doc).
    pub const COTTON: Material = Material {
        density: 0.15,
        stretch: 400.0,
        shear: 40.0,
        bend: 2.0,
        damping: 0.005,
        air_drag: 0.05,
    };

    /// Silk-like: light (80 g/m^2), soft in shear and very easy to bend, so it
    /// falls in many small folds.
    pub const SILK: Material = Material {
        density: 0.08,
        stretch: 300.0,
        shear: 15.0,
        bend: 0.3,
        damping: 0.003,
        air_drag: 0.1,
    };

    /// Denim-like: heavy (400 g/m^2), stiff in stretch and shear, hard to
    /// bend, so it keeps large, round folds.
    pub const DENIM: Material = Material {
        density: 0.4,
        stretch: 1500.0,
        shear: 200.0,
        bend: 20.0,
        damping: 0.01,
        air_drag: 0.03,
    };

    /// The presets by name: cotton (the default), silk, denim.
    pub const PRESETS: [(&'static str, Material); 3] = [
        ("cotton", Material::COTTON),
        ("silk", Material::SILK),
        ("denim", Material::DENIM),
    ];

    /// The preset called `name`; the error lists the names.
    pub fn preset(name: &str) -> Result<Material> {
        crate::error::parse_name(name, &Material::PRESETS, |(n, _)| n, "material").map(|(_, m)| m)
    }

    /// Checks every parameter is finite and in range (density > 0, the rest >= 0).
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("density", self.density, self.density > 0.0),
            ("stretch", self.stretch, self.stretch >= 0.0),
            ("shear", self.shear, self.shear >= 0.0),
            ("bend", self.bend, self.bend >= 0.0),
            ("damping", self.damping, self.damping >= 0.0),
            ("air_drag", self.air_drag, self.air_drag >= 0.0),
        ];
        for (name, value, ok) in checks {
            if !(ok && value.is_finite()) {
                return Err(Error::InvalidParameter(format!(
                    "material {name} must be finite and in range, got {value}"
                )));
            }
        }
        Ok(())
    }

    /// The spring moduli of this material.
    pub fn moduli(&self) -> Moduli {
        Moduli {
            stretch: self.stretch,
            shear: self.shear,
            bend: self.bend,
            damping: self.damping,
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Material::COTTON
    }
}

/// Kinetic, gravitational and elastic energy of a cloth state (J).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energy {
    /// `sum m v^2 / 2`.
    pub kinetic: f64,
    /// `-sum m g . x` (zero at z = 0 under the default gravity).
    pub gravity: f64,
    /// `sum k (l - L)^2 / 2` over all springs.
    pub elastic: f64,
}

impl Energy {
    /// Total energy.
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravity + self.elastic
    }
}

/// A cloth: mesh, springs, masses, gravity and pinned vertices.
#[derive(Debug, Clone)]
pub struct Cloth {
    mesh: Arc<Mesh>,
    material: Material,
    springs: Springs,
    mass: Vec<f64>,
    pinned: Vec<bool>,
    gravity: DVec3,
}

impl Cloth {
    /// A cloth over `mesh` (rest shape = the mesh's rest positions) with the
    /// vertices in `pins` fixed in place. Errors on a bad material or a pin index
    /// out of range.
    pub fn new(mesh: Arc<Mesh>, material: Material, pins: &[u32]) -> Result<Cloth> {
        material.validate()?;
        let n = mesh.n_vertices();
        let mut pinned = vec![false; n];
        for &p in pins {
            let slot = pinned.get_mut(p as usize).ok_or_else(|| {
                Error::InvalidParameter(format!(
                    "pin {p} is out of range: the mesh has {n} vertices"
                ))
            })?;
            *slot = true;
        }
        let springs = Springs::new(&mesh, &material.moduli());
        let mass = lumped_masses(&mesh, material.density);
        Ok(Cloth {
            mesh,
            material,
            springs,
            mass,
            pinned,
            gravity: GRAVITY,
        })
    }

    /// Sets the gravitational acceleration (m/s^2); errors if not finite.
    pub fn set_gravity(&mut self, g: DVec3) -> Result<()> {
        if !g.is_finite() {
            return Err(Error::InvalidParameter(format!(
                "gravity must be finite, got {g}"
            )));
        }
        self.gravity = g;
        Ok(())
    }

    /// The mesh.
    pub fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// The material.
    pub fn material(&self) -> &Material {
        &self.material
    }

    /// The springs.
    pub fn springs(&self) -> &Springs {
        &self.springs
    }

    /// Lumped vertex masses (kg).
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// Which vertices are pinned.
    pub fn pinned(&self) -> &[bool] {
        &self.pinned
    }

    /// Gravitational acceleration (m/s^2).
    pub fn gravity(&self) -> DVec3 {
        self.gravity
    }

    /// Total mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Inverse masses, zero for pinned vertices (they do not respond to impulses).
    pub fn inverse_masses(&self) -> Vec<f64> {
        self.mass
            .iter()
            .zip(&self.pinned)
            .map(|(&m, &p)| if p { 0.0 } else { 1.0 / m })
            .collect()
    }

    /// Energy of the state (`x`, `v`), both of the mesh's length.
    pub fn energy(&self, x: &[DVec3], v: &[DVec3]) -> Energy {
        let kinetic = self
            .mass
            .iter()
            .zip(v)
            .map(|(m, v)| 0.5 * m * v.length_squared())
            .sum();
        let gravity = self
            .mass
            .iter()
            .zip(x)
            .map(|(m, x)| -m * self.gravity.dot(*x))
            .sum();
        let elastic = (0..self.springs.len())
            .map(|s| self.springs.energy(s, x))
            .sum();
        Energy {
            kinetic,
            gravity,
            elastic,
        }
    }
}

/// `m_i = density * (sum of rest areas of the triangles at i) / 3`.
fn lumped_masses(mesh: &Mesh, density: f64) -> Vec<f64> {
    let mut mass = vec![0.0; mesh.n_vertices()];
    for (t, tri) in mesh.triangles().iter().enumerate() {
        let [a, b, c] = mesh.corners(mesh.rest(), t);
        let share = density * 0.5 * (b - a).cross(c - a).length() / 3.0;
        for &v in tri {
            mass[v as usize] += share;
        }
    }
    // A vertex in no triangle still needs a positive mass for the solve; the
    // mesh has at least one non-degenerate triangle, so a positive mass exists.
    let fill = mass
        .iter()
        .cloned()
        .filter(|&m| m > 0.0)
        .fold(f64::INFINITY, f64::min);
    mass.iter_mut()
        .filter(|m| **m <= 0.0)
        .for_each(|m| *m = fill);
    mass
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::grid;

    #[test]
    fn masses_add_up_to_density_times_area() {
        let (v, f) = grid(5, 2.0);
        let cloth = Cloth::new(Arc::new(Mesh::new(v, f).unwrap()), Material::COTTON, &[0]).unwrap();
        assert!((cloth.total_mass() - 0.15 * 4.0).abs() < 1e-12);
        assert_eq!(cloth.inverse_masses()[0], 0.0);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let (v, f) = grid(3, 1.0);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        assert!(matches!(
            Cloth::new(mesh.clone(), Material::COTTON, &[9]),
            Err(Error::InvalidParameter(_))
        ));
        let bad = Material {
            density: -1.0,
            ..Material::COTTON
        };
        assert!(matches!(
            Cloth::new(mesh.clone(), bad, &[]),
            Err(Error::InvalidParameter(_))
        ));
        for (name, m) in Material::PRESETS {
            assert_eq!(Material::preset(name).unwrap(), m);
            m.validate().unwrap();
        }
        assert!(matches!(
            Material::preset("tweed"),
            Err(Error::InvalidParameter(_))
        ));
        let nan = Material {
            stretch: f64::NAN,
            ..Material::COTTON
        };
        assert!(nan.validate().is_err());
        let mut c = Cloth::new(mesh, Material::COTTON, &[]).unwrap();
        assert!(c.set_gravity(DVec3::new(0.0, f64::INFINITY, 0.0)).is_err());
    }
}
