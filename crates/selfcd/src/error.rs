//! Typed errors: every bad input is named, nothing panics.

use thiserror::Error;

/// Everything that can go wrong when building or querying the engine.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// The mesh has no vertices or no triangles.
    #[error("empty mesh: {0}")]
    EmptyMesh(&'static str),
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {triangle} refers to vertex {index}, but the mesh has {vertex_count} vertices"
    )]
    IndexOutOfRange {
        triangle: usize,
        index: u64,
        vertex_count: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({value})")]
    NonFinite { vertex: usize, value: f64 },
    /// A triangle uses the same vertex twice.
    #[error("triangle {triangle} repeats a vertex: {indices:?}")]
    RepeatedVertex { triangle: usize, indices: [u32; 3] },
    /// Two triangles have the same three vertices.
    #[error("triangles {first} and {second} have the same vertices")]
    DuplicateTriangle { first: usize, second: usize },
    /// A positions array does not match the mesh.
    #[error("positions have {got} vertices, the mesh has {expected}")]
    PositionsLength { expected: usize, got: usize },
    /// A parameter is outside its valid range.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// Memory for a buffer sized from the input could not be reserved.
    #[error("out of memory: {what} needs {bytes} bytes")]
    OutOfMemory { what: &'static str, bytes: u128 },
    /// A proximity query found more contacts than its limit (the output guard).
    #[error("proximity query stopped at {limit} contacts: thickness {thickness} is too large for this mesh (raise max_contacts to allow more)")]
    TooManyContacts { limit: usize, thickness: f64 },
    /// A long call was stopped by its caller (Ctrl-C in the Python bindings).
    #[error("interrupted")]
    Interrupted,
    /// The mesh's rest shape is not flat, and the method needs a flat one.
    #[error("rest shape is not flat (max distance {deviation:.3e} from its best plane, relative); {what} needs a flat rest shape")]
    CurvedRestShape { deviation: f64, what: &'static str },
}

/// Result with the engine's error type.
pub type Result<T> = std::result::Result<T, Error>;

/// Looks `s` up among `all` by `name`; the error lists the valid names.
/// One parser for every enum chosen by name (methods, scenes, states).
pub fn parse_name<T: Copy>(
    s: &str,
    all: &[T],
    name: impl Fn(T) -> &'static str,
    what: &str,
) -> Result<T> {
    all.iter().copied().find(|&x| name(x) == s).ok_or_else(|| {
        let names: Vec<_> = all.iter().map(|&x| name(x)).collect();
        Error::InvalidParameter(format!(
            "unknown {what} {s:?}; expected one of {}",
            names.join(", ")
        ))
    })
}

/// An empty vector with room for `n` items, or [`Error::OutOfMemory`] naming
/// `what` and the bytes asked for: for buffers sized from user input, where an
/// allocation failure must be an error, not an abort.
pub fn try_vec<T>(n: usize, what: &'static str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| Error::OutOfMemory {
        what,
        bytes: n as u128 * std::mem::size_of::<T>() as u128,
    })?;
    Ok(v)
}
