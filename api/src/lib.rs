//! `frusta-api`: what travels between `frusta-server` and its clients. One
//! module per resource, each with the request and answer types of its
//! routes (and, for streams, the frames in both directions), all with
//! serde and OpenAPI schemas. The server serves these types and documents
//! them in `/openapi.json`; `frusta-client` parses answers into them. So
//! the contract is written once, and an engine refactor cannot change it
//! unnoticed: answers are converted from engine types here, field by field.

pub mod collisions;
pub mod impulse_responses;
pub mod materials;
pub mod objects;
pub mod occlusion;
pub mod problem;
pub mod rays;
pub mod scenes;
pub mod schemas;
pub mod shadows;
pub mod stream;

pub use problem::Problem;
