//! Procedural rooms for tests and benchmarks. Every generator yields a
//! closed, consistently oriented surface with shared vertices whose normals
//! point into the air, with per-triangle material slot names (`"floor"`,
//! `"walls"`, ...) that a scene maps to materials.

mod box_room;
mod cells;
mod hall;
mod l_room;
mod two_rooms;

pub use box_room::BoxRoom;
pub use hall::Hall;
pub use l_room::LRoom;
pub use two_rooms::TwoRooms;

use crate::{Error, Result};

/// Generators refuse parameters that would produce more triangles than
/// this: such a request is a typo, not a scene.
pub const MAX_GENERATED_TRIANGLES: u64 = 50_000_000;

/// Rejects a generator request whose triangle count exceeds the cap.
fn check_triangle_budget(generator: &str, triangles: u64) -> Result<()> {
    if triangles > MAX_GENERATED_TRIANGLES {
        return Err(Error::LimitExceeded(format!(
            "{generator} would generate {triangles} triangles; the limit is {MAX_GENERATED_TRIANGLES}"
        )));
    }
    Ok(())
}

/// Rejects a length that is not finite and positive.
/// Default for every generator's `subdivisions` field.
fn one() -> u32 {
    1
}

/// The extent `max - min` of a room, each side checked to be positive.
fn checked_size(generator: &str, min: glam::Vec3, max: glam::Vec3) -> Result<glam::Vec3> {
    let size = max - min;
    for (what, v) in [
        ("max.x - min.x", size.x),
        ("max.y - min.y", size.y),
        ("max.z - min.z", size.z),
    ] {
        check_positive(generator, what, v)?;
    }
    Ok(size)
}

/// Subdivisions as a count, checked to lie in `1..=MAX_SUBDIVISIONS`.
/// Most subdivisions a generator takes: far past any triangle budget, and
/// small enough that triangle counts (up to its cube) cannot overflow.
const MAX_SUBDIVISIONS: u32 = 10_000;

fn checked_subdivisions(generator: &str, subdivisions: u32) -> Result<u64> {
    if !(1..=MAX_SUBDIVISIONS).contains(&subdivisions) {
        return Err(Error::InvalidScene(format!(
            "{generator}.subdivisions is {subdivisions}; it must lie in 1..={MAX_SUBDIVISIONS}"
        )));
    }
    Ok(u64::from(subdivisions))
}

fn check_positive(generator: &str, what: &str, value: f32) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        return Err(Error::InvalidScene(format!(
            "{generator}.{what} is {value}; it must be a finite positive length in metres"
        )));
    }
    Ok(())
}

/// Closedness and orientation checks shared by the generator tests.
#[cfg(test)]
pub(crate) mod check {
    use std::collections::HashMap;

    use crate::scene::RawMesh;

    /// Asserts every edge is used by exactly two triangles with opposite
    /// directions and no triangle is degenerate; returns the signed volume,
    /// negative when normals point inwards.
    pub fn closed_signed_volume(mesh: &RawMesh) -> f64 {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        let mut volume = 0.0f64;
        for &[a, b, c] in &mesh.triangles {
            for e in [(a, b), (b, c), (c, a)] {
                *edges.entry(e).or_default() += 1;
            }
            let [p, q, r] = [a, b, c].map(|i| mesh.positions[i as usize].as_dvec3());
            assert!((q - p).cross(r - p).length() > 1e-9, "degenerate triangle");
            volume += p.dot(q.cross(r)) / 6.0;
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times in one direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no opposite");
        }
        volume
    }
}
