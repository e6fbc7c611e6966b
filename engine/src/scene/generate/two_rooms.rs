//! Two rooms joined by a door: the "Boxes" scene of C. Lauterbach's
//! dissertation (UNC 2010), a standard test for sound reaching a room
//! through an opening (diffraction, coupled reverberation).

use std::collections::BTreeMap;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::cells::{boundary, Face};
use super::check_positive;
use crate::scene::RawMesh;
use crate::{Error, Result};

/// Room A spans `x ∈ [origin.x, origin.x + length_a]`, then a wall of
/// `wall_thickness`, then room B of `length_b`; both are `width` deep (y)
/// and `height` tall (z). A door `door_width × door_height`, standing on the
/// floor and centred at `y = origin.y + door_offset` (default: mid-width),
/// pierces the shared wall. The result is one closed surface, normals into
/// the air. Slots: `floor`, `ceiling`, `walls`, and `partition` for both
/// faces of the shared wall and the door's jambs and lintel (its threshold
/// is `floor`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwoRooms {
    #[serde(default)]
    pub origin: Vec3,
    pub length_a: f32,
    pub length_b: f32,
    pub width: f32,
    pub height: f32,
    #[serde(default = "default_wall")]
    pub wall_thickness: f32,
    #[serde(default = "default_door_width")]
    pub door_width: f32,
    #[serde(default = "default_door_height")]
    pub door_height: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub door_offset: Option<f32>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, String>,
}

fn default_wall() -> f32 {
    0.2
}
fn default_door_width() -> f32 {
    1.0
}
fn default_door_height() -> f32 {
    2.0
}

impl TwoRooms {
    /// Lauterbach's proportions: two 5 × 4 × 3 m rooms.
    pub fn boxes() -> Self {
        Self {
            origin: Vec3::ZERO,
            length_a: 5.0,
            length_b: 5.0,
            width: 4.0,
            height: 3.0,
            wall_thickness: default_wall(),
            door_width: default_door_width(),
            door_height: default_door_height(),
            door_offset: None,
            materials: BTreeMap::new(),
        }
    }

    pub fn generate(&self) -> Result<RawMesh> {
        for (what, v) in [
            ("length_a", self.length_a),
            ("length_b", self.length_b),
            ("width", self.width),
            ("height", self.height),
            ("wall_thickness", self.wall_thickness),
            ("door_width", self.door_width),
            ("door_height", self.door_height),
        ] {
            check_positive("two_rooms", what, v)?;
        }
        if !self.origin.is_finite() {
            return Err(Error::InvalidScene("two_rooms.origin is not finite".into()));
        }
        let centre = self.door_offset.unwrap_or(self.width / 2.0);
        let (d0, d1) = (
            centre - self.door_width / 2.0,
            centre + self.door_width / 2.0,
        );
        if !(d0 > 0.0 && d1 < self.width) || self.door_height >= self.height {
            return Err(Error::InvalidScene(format!(
                "two_rooms: the door (y {d0}..{d1}, height {}) must lie strictly inside the \
                 {} × {} m shared wall",
                self.door_height, self.width, self.height
            )));
        }
        let o = self.origin;
        let xa = o.x + self.length_a;
        let xb = xa + self.wall_thickness;
        let xs = [o.x, xa, xb, xb + self.length_b];
        let ys = [o.y, o.y + d0, o.y + d1, o.y + self.width];
        let zs = [o.z, o.z + self.door_height, o.z + self.height];
        // Rooms are cell columns 0 and 2; the door is the one wall cell of air.
        let air = |[i, j, k]: [usize; 3]| i != 1 || (j == 1 && k == 0);
        let slot = |mesh: &mut RawMesh, f: Face| {
            mesh.intern(match (f.axis, f.positive) {
                (2, true) => "floor",
                _ if f.cell[0] == 1 => "partition",
                (0, true) if f.cell[0] == 2 => "partition",
                (0, false) if f.cell[0] == 0 => "partition",
                (2, false) => "ceiling",
                _ => "walls",
            })
        };
        let mut mesh = RawMesh::default();
        boundary(&mut mesh, [&xs, &ys, &zs], air, true, slot);
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::check::closed_signed_volume;

    #[test]
    fn one_closed_inward_surface_through_the_door() {
        let r = TwoRooms::boxes();
        let m = r.generate().unwrap();
        let volume = 2.0 * 5.0 * 4.0 * 3.0 + 0.2 * 1.0 * 2.0;
        assert!((closed_signed_volume(&m) + volume).abs() < 1e-3);
        assert!(m.names.iter().any(|n| n == "partition"));
        // Only the outer end walls (x = 0 and x = 10.2) are plain x-facing walls.
        let walls = m.names.iter().position(|n| n == "walls").unwrap() as u32;
        for (t, tri) in m.triangles.iter().enumerate() {
            let x = tri.map(|i| m.positions[i as usize].x);
            if x[0] == x[1] && x[1] == x[2] && m.triangle_names[t] == Some(walls) {
                assert!(x[0] == 0.0 || (x[0] - 10.2).abs() < 1e-5, "{x:?}");
            }
        }
    }

    #[test]
    fn rejects_a_door_outside_the_wall() {
        let mut r = TwoRooms::boxes();
        r.door_height = 3.0;
        assert!(r.generate().is_err());
        let mut r = TwoRooms::boxes();
        r.door_offset = Some(0.2);
        assert!(r.generate().is_err());
    }
}
