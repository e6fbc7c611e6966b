//! The signal-processing half of acoustics: everything downstream of the
//! arrivals a geometric simulation finds at a listener.
//!
//! - [`air`]: ISO 9613-1 air absorption and the speed of sound;
//! - [`head`]: the listener's orientation and a spherical-head model of the
//!   two ears;
//! - [`filter_bank`]: the zero-phase octave filter bank that turns per-band
//!   signals into one broadband signal;
//! - [`impulse_response`]: rendering arrivals into a mono or binaural
//!   impulse response;
//! - [`histogram`]: the late part as an energy histogram per band, and the
//!   Dirac sequence that renders it;
//! - [`room_parameters`]: ISO 3382-1 parameters (EDT, T20, T30, C50, C80,
//!   D50, Ts) from an echogram;
//! - [`wav`]: reading and writing WAV files;
//! - [`mod@convolve`]: FFT convolution and auralization of dry audio.

pub mod air;
pub mod convolve;
pub mod filter_bank;
pub mod head;
pub mod histogram;
pub mod impulse_response;
pub mod room_parameters;
pub mod wav;

pub use air::AirConditions;
pub use convolve::{auralize, convolve};
pub use filter_bank::filter_and_sum;
pub use head::{ear_responses, ListenerFrame};
pub use histogram::EnergyHistogram;
pub use impulse_response::{
    synthesize, synthesize_with_tail, Channels, ImpulseResponse, ImpulseResponseOptions,
};
pub use room_parameters::{per_band, per_band_with_tail, RoomParameters};
pub use wav::{read_wav, write_wav, write_wav_to};

/// One sound arrival at a listener.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    /// Propagation delay in seconds (path length / speed of sound).
    pub delay_s: f64,
    /// Unit vector from the listener toward where the sound arrives from (world frame).
    pub direction: glam::Vec3,
    /// Linear pressure amplitude per octave band relative to the source level at 1 m:
    /// material factors, 1/r spreading and (if enabled) air absorption already applied.
    pub pressure_gain: crate::scene::Bands,
}
