//! The engine's error type: every way that input can be invalid, with a
//! message a user can act on, and its [`Cause`], which tells a caller (the
//! server's status codes) whose fault it was.

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
    #[error("{field} {reason}")]
    InvalidOption { field: String, reason: String },
    #[error("{what} position {value} is not finite or lies beyond 1e15 m")]
    InvalidPosition { what: String, value: String },
    #[error("{0}")]
    LimitExceeded(String),
    #[error("{given} materials cannot replace {current}: triangles refer to every one")]
    MaterialTableShrinks { current: usize, given: usize },
    #[error("a refit needs the same {expected} triangles, got {actual}")]
    TriangleCountMismatch { expected: usize, actual: usize },
    #[error("cannot read {path}: {reason}")]
    Io { path: String, reason: String },
    #[error("cannot use the file reference {path}: {reason}")]
    InvalidPath { path: String, reason: String },
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

/// Whose fault an [`Error`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cause {
    /// The input is invalid; the message names what to change.
    Input,
    /// The input is valid but larger than a limit allows.
    Limit,
    /// The computation ran out of time.
    Deadline,
    /// The caller cancelled the computation.
    Cancelled,
    /// Reading or writing files or audio failed: the caller's environment,
    /// not the input.
    Environment,
}

impl Error {
    /// Whose fault the error is.
    pub fn cause(&self) -> Cause {
        match self {
            Error::InObject { source, .. } => source.cause(),
            Error::LimitExceeded(_) => Cause::Limit,
            Error::DeadlineExceeded { .. } => Cause::Deadline,
            Error::Cancelled => Cause::Cancelled,
            Error::Io { .. } | Error::Audio { .. } => Cause::Environment,
            _ => Cause::Input,
        }
    }

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
