//! An L-shaped room: the simplest non-convex room, where some surfaces hide
//! others from a source, so visibility and diffraction paths matter.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

use super::cells::{boundary, room_slot, split};
use super::{check_positive, check_triangle_budget};
use crate::scene::RawMesh;
use crate::{Error, Result};

/// The box `min..max` with the corner `x > max.x - cutout.x, y > max.y -
/// cutout.y` removed over the full height. Normals inward; slots `floor`,
/// `ceiling`, `walls`; every grid interval split into `subdivisions` parts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LRoom {
    pub min: Vec3,
    pub max: Vec3,
    /// Size of the removed corner in x and y.
    pub cutout: Vec2,
    #[serde(default = "super::one")]
    pub subdivisions: u32,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, String>,
}

impl LRoom {
    pub fn generate(&self) -> Result<RawMesh> {
        let size = super::checked_size("l_room", self.min, self.max)?;
        check_positive("l_room", "cutout.x", self.cutout.x)?;
        check_positive("l_room", "cutout.y", self.cutout.y)?;
        if self.cutout.x >= size.x || self.cutout.y >= size.y {
            return Err(Error::InvalidScene(format!(
                "l_room.cutout {:?} must be smaller than the room's floor {:?}",
                self.cutout.to_array(),
                [size.x, size.y]
            )));
        }
        let s = super::checked_subdivisions("l_room", self.subdivisions)?;
        // Three cells of the 2×2×1 grid, six faces per cell at most.
        check_triangle_budget("l_room", 3 * 6 * 2 * s * s * s)?;
        let s = s as usize;
        let (lo, hi) = (self.min, self.max);
        let xs = split(&[lo.x, hi.x - self.cutout.x, hi.x], s);
        let ys = split(&[lo.y, hi.y - self.cutout.y, hi.y], s);
        let zs = split(&[lo.z, hi.z], s);
        let air = |[i, j, _]: [usize; 3]| i < s || j < s;
        let mut mesh = RawMesh::default();
        boundary(&mut mesh, [&xs, &ys, &zs], air, true, room_slot);
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::check::closed_signed_volume;

    fn room() -> LRoom {
        LRoom {
            min: Vec3::ZERO,
            max: Vec3::new(12.0, 10.0, 3.0),
            cutout: Vec2::new(5.0, 4.0),
            subdivisions: 1,
            materials: BTreeMap::new(),
        }
    }

    #[test]
    fn closed_inward_and_non_convex() {
        for s in [1, 2] {
            let mut r = room();
            r.subdivisions = s;
            let m = r.generate().unwrap();
            let volume = (12.0 * 10.0 - 5.0 * 4.0) * 3.0;
            assert!((closed_signed_volume(&m) + volume).abs() < 1e-3);
            // Floor and ceiling: 3 cells each; walls: 8 wall segments (2 split in 2 cells).
            let quads = (3 + 3 + 8) * (s * s) as usize;
            assert_eq!(m.triangles.len(), 2 * quads);
        }
    }

    #[test]
    fn rejects_a_cutout_as_large_as_the_room() {
        let mut r = room();
        r.cutout.x = 12.0;
        assert!(r.generate().is_err());
    }
}
