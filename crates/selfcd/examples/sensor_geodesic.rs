//! Dumps the sensor's geodesic distances (fast marching on the rest mesh,
//! `sensor::geodesic`) from a few source vertices to every vertex they reach,
//! in mean-edge units, with the time per field: the input of
//! `scripts/geodesic_check.py`, which compares them with exact polyhedral
//! geodesics (potpourri3d's edge-flip solver).
//!
//! ```text
//! cargo run --release -p selfcd --example sensor_geodesic -- MESH.obj [SOURCES] [REACH] > out.csv
//! ```
//! Output: a `# unit L` line (mean rest edge length), then `source,target,distance`
//! lines (vertex ids, distance in mean edges); a last comment line gives the
//! mean time per field.

#[path = "common/obj.rs"]
mod obj;

use selfcd::sensor::geodesic::Marcher;
use selfcd::sensor::SurfacePoint;
use selfcd::{DVec3, Mesh};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (v, f) = obj::read_obj(&args[1]);
    let sources: usize = args.get(2).map_or(8, |s| s.parse().unwrap());
    let reach: f64 = args.get(3).map_or(12.0, |s| s.parse().unwrap());
    let mesh = Mesh::new(v, f).unwrap();
    let unit = mesh.mean_edge_length();
    let rest: Vec<DVec3> = mesh.rest().iter().map(|&p| p / unit).collect();
    let (mut marcher, mut dist) = (Marcher::default(), Vec::new());
    let mut seconds = 0.0;
    println!("# unit {unit:e}");
    println!("source,target,distance");
    for s in 0..sources {
        // Spread the sources over the triangle list (deterministic).
        let tri = (s * mesh.n_triangles() / sources) as u32;
        let vertex = mesh.triangles()[tri as usize][0];
        let source = SurfacePoint {
            tri,
            bary: [1.0, 0.0, 0.0],
        };
        let t0 = std::time::Instant::now();
        marcher.distance_field(&mesh, &rest, &source, reach, &mut dist);
        seconds += t0.elapsed().as_secs_f64();
        for (w, d) in dist.iter().enumerate() {
            if d.is_finite() && w as u32 != vertex {
                println!("{vertex},{w},{d}");
            }
        }
    }
    println!("# seconds per field {:.3e}", seconds / sources as f64);
}
