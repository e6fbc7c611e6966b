//! Acoustics: from sound arrivals at a listener to what a listener hears.
//!
//! [`signal`] turns a list of arrivals into impulse responses, ISO 3382-1
//! room parameters, WAV files and auralized audio.

pub mod signal;
