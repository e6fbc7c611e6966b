//! One handler file per resource.

pub mod collisions;
pub mod health;
pub mod impulse_responses;
pub mod large_body;
pub mod materials;
pub mod objects;
pub mod occlusion;
pub mod rays;
pub mod scenes;
pub mod shadows;
pub mod stream;
pub mod visibility;

#[cfg(test)]
mod bad_input_props;
#[cfg(test)]
pub(crate) mod test_support;
