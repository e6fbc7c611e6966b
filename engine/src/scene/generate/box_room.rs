//! The shoebox: the reference room of room acoustics, with an exact
//! image-source solution to test against.

use std::collections::BTreeMap;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::cells::{boundary, room_slot, split};
use super::check_triangle_budget;
use crate::scene::RawMesh;
use crate::Result;

/// An axis-aligned box room, normals inward, each face split into
/// `subdivisions²` quads (12·s² triangles). Slots: `floor` (z = min),
/// `ceiling` (z = max), `walls`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxRoom {
    pub min: Vec3,
    pub max: Vec3,
    #[serde(default = "super::one")]
    pub subdivisions: u32,
    /// Slot name to material name.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, String>,
}

impl BoxRoom {
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self {
            min,
            max,
            subdivisions: 1,
            materials: BTreeMap::new(),
        }
    }

    pub fn generate(&self) -> Result<RawMesh> {
        super::checked_size("box_room", self.min, self.max)?;
        let s = super::checked_subdivisions("box_room", self.subdivisions)?;
        check_triangle_budget("box_room", 12 * s * s)?;
        let s = s as usize;
        let axes = [0, 1, 2].map(|a| split(&[self.min[a], self.max[a]], s));
        let mut mesh = RawMesh::default();
        boundary(
            &mut mesh,
            [&axes[0], &axes[1], &axes[2]],
            |_| true,
            true,
            room_slot,
        );
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::check::closed_signed_volume;

    #[test]
    fn closed_inward_with_12_s_squared_triangles() {
        for s in [1, 3] {
            let mut room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
            room.subdivisions = s;
            let m = room.generate().unwrap();
            assert_eq!(m.triangles.len(), 12 * (s * s) as usize);
            assert!((closed_signed_volume(&m) + 180.0).abs() < 1e-3);
            let floor = m.names.iter().position(|n| n == "floor").unwrap() as u32;
            let t = m
                .triangle_names
                .iter()
                .position(|&n| n == Some(floor))
                .unwrap();
            let [a, b, c] = m.triangles[t].map(|i| m.positions[i as usize]);
            assert!(
                (b - a).cross(c - a).z > 0.0,
                "floor normal points up into the room"
            );
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(BoxRoom::new(Vec3::ONE, Vec3::ZERO).generate().is_err());
        let mut r = BoxRoom::new(Vec3::ZERO, Vec3::ONE);
        r.subdivisions = 0;
        assert!(r.generate().is_err());
        r.subdivisions = 10_000;
        let err = r.generate().unwrap_err().to_string();
        assert!(err.contains("limit"), "{err}");
        assert!(BoxRoom::new(Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 1.0))
            .generate()
            .is_err());
    }
}
