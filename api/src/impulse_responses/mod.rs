//! `POST /v1/scenes/{id}/impulse-responses`: what each listener hears from
//! each source. The request is here; the answer, which streams send too,
//! is in [`answer`].

mod answer;
mod request;

pub use answer::{
    BandParametersOut, ImpulseResponses, PairResponse, PathOut, StatsOut, SurfaceOut, TailStatsOut,
};
pub use request::{ImpulseResponseRequest, Point};
