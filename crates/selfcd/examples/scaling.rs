//! Scaling benchmark: grid cloths of 200, 20k and 200k triangles, flat /
//! crumpled / folded, every BVH method (and brute force up to 20k).
//!
//! `cargo run --release -p selfcd --example scaling [-- SIZES...]`

use selfcd::bench::{markdown, scaling};
use selfcd::scene::BenchState;
use selfcd::Method;

fn main() -> selfcd::Result<()> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if args.is_empty() {
        vec![200, 20_000, 200_000]
    } else {
        args
    };
    let mut rows = Vec::new();
    for &size in &sizes {
        let methods: Vec<Method> = Method::ALL
            .into_iter()
            .filter(|&m| m != Method::Brute || size <= 20_000)
            .collect();
        let reps = if size >= 100_000 { 5 } else { 11 };
        rows.extend(scaling(&[size], &BenchState::ALL, &methods, reps, |r| {
            eprintln!(
                "{} {} {}: {:.3} ms",
                r.triangles,
                r.state.name(),
                r.method,
                (r.refit_time + r.traverse_time) * 1e3
            )
        })?);
    }
    println!("{}", markdown(&rows));
    Ok(())
}
