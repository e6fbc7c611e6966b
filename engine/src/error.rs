//! The engine's error type: every way that input can be invalid, with a
//! message a user can act on.

/// Everything that can go wrong when building scenes and hierarchies.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum Error {
    #[error("mesh has no triangles")]
    EmptyMesh,
    #[error("mesh has no vertices")]
    NoVertices,
    #[error("vertex {vertex} has a non-finite coordinate ({value:?})")]
    NonFiniteVertex { vertex: usize, value: [f32; 3] },
    #[error("vertex {vertex} coordinate {value:?} exceeds the supported magnitude {limit:e}")]
    VertexOutOfRange {
        vertex: usize,
        value: [f32; 3],
        limit: f32,
    },
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertex_count: usize,
    },
    #[error("every triangle of the mesh has zero area, so there is no surface to hit")]
    AllTrianglesDegenerate,
    #[error("expected {expected} vertex positions, got {actual}: a refit cannot change the vertex count")]
    VertexCountMismatch { expected: usize, actual: usize },
    #[error("transform is not rigid or not finite: {0}")]
    InvalidTransform(String),
    #[error("invalid material {name:?}: {reason}")]
    InvalidMaterial { name: String, reason: String },
    #[error("unknown material {0:?}")]
    UnknownMaterial(String),
    #[error("material list has {actual} entries for {expected} triangles")]
    MaterialCountMismatch { expected: usize, actual: usize },
    #[error("object {name:?}: {source}")]
    InObject { name: String, source: Box<Error> },
    #[error("duplicate object name {0:?}")]
    DuplicateObject(String),
    #[error("unknown object {0:?}")]
    UnknownObject(String),
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    #[error("cannot read {path}: {reason}")]
    Io { path: String, reason: String },
    #[error("cannot parse {what}: {reason}")]
    Parse { what: String, reason: String },
    #[error("invalid audio option: {0}")]
    InvalidAudio(String),
    #[error("audio file {path}: {reason}")]
    Audio { path: String, reason: String },
    #[error("computation stopped at its deadline of {limit_ms} ms; nothing partial is returned")]
    DeadlineExceeded { limit_ms: u64 },
    #[error("computation cancelled; nothing partial is returned")]
    Cancelled,
}

impl Error {
    /// Wraps an error with the name of the object it happened in.
    pub fn in_object(self, name: &str) -> Error {
        Error::InObject {
            name: name.to_owned(),
            source: Box::new(self),
        }
    }
}

/// The engine's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
