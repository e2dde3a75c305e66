//! The timing examples run on the allocator the Python extension uses
//! (mimalloc, see crates/selfcd-py/Cargo.toml), so that their times are the
//! times a Python caller sees.

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;
