//! The cloth simulator of the paper (section 4): mass-spring cloth, implicit
//! Euler with filtered conjugate gradients, constraint-filtered collision response.
//!
//! - [`springs`]: stretch, shear and bend springs; force and PSD Jacobian of one spring.
//! - [`model`]: [`Cloth`] (masses from rest areas, gravity, pins) and [`Material`].
//! - [`matrix`]: the flat sparse 3x3-block matrix and deterministic parallel kernels.
//! - [`multigrid`]: the aggregation multigrid of the solve's preconditioners
//!   (a V-cycle, or the coarse part of the two-level form).
//! - [`solver`]: backward Euler system and the filtered PCG (Baraff & Witkin 1998).
//! - [`response`]: self-contact in the solve, impulses, continuous collisions, and the end-of-step correction.
//! - [`sim`]: [`Simulation`], stepping a cloth with a detector.
//! - [`scenes`]: the paper's three scenes, [`PaperScene`].

pub mod matrix;
pub mod model;
pub mod multigrid;
pub mod obstacle;
pub mod response;
pub mod scenes;
pub mod sim;
pub mod solver;
pub mod springs;

pub use model::{Cloth, Energy, Material};
pub use response::ContactParams;
pub use scenes::PaperScene;
pub use sim::{SimOptions, Simulation, StepStats};
pub use solver::{PcgOptions, Preconditioner};
