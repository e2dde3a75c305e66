// Temporary: Mesh::new N times on a 200k grid or an obj (not committed).
use selfcd::scene::{grid, grid_side_for};
use selfcd::Mesh;
#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/obj.rs"]
mod obj;
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let reps: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let (v, f) = if args[0].ends_with(".obj") {
        obj::read_obj(&args[0])
    } else {
        grid(grid_side_for(args[0].parse().unwrap()), 1.0)
    };
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let (v, f) = (v.clone(), f.clone());
        let t0 = std::time::Instant::now();
        let m = Mesh::new(v, f).unwrap();
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(&m);
    }
    println!("Mesh::new best {best:.2} ms");
}
