//! The scenes the clients upload, small so that uploads, edits and
//! impulse responses stay cheap and the soak exercises the service
//! rather than the tracer: a JSON box room with a dynamic door, and an
//! OBJ box.

use glam::Vec3;

use crate::rays::SplitMix64;
use crate::serve::Points;

/// The door's quad in its object frame (`x = 3`, `y` in 1..2), its top
/// at `DOOR_TOP`; vertex edits move the top edge.
const DOOR_TOP: f32 = 2.0;

/// A scene a client uploaded and may change.
pub struct Own {
    pub id: String,
    /// JSON rooms have a `door`; OBJ uploads are one object, `room`.
    pub json: bool,
    pub points: Points,
}

impl Own {
    /// The object that edits move.
    pub fn object(&self) -> &'static str {
        if self.json {
            "door"
        } else {
            "room"
        }
    }
}

/// A `w x d x 3` m box room (48 triangles) with a door in a plane across
/// it, as `scenes/README.md` writes them; sizes vary per upload.
pub fn json_room(rng: &mut SplitMix64) -> (String, Points) {
    let (w, d) = (6.0 + 2.0 * rng.next_f32(), 5.0 + rng.next_f32());
    let doc = serde_json::json!({
        "name": "soak-room",
        "materials": { "walls": { "absorption": 0.2 } },
        "objects": [
            { "name": "room", "material": "walls",
              "mesh": { "box_room": { "min": [0, 0, 0], "max": [w, d, 3], "subdivisions": 2 } } },
            { "name": "door", "material": "walls", "dynamic": true,
              "mesh": { "vertices": door(DOOR_TOP), "triangles": [[0, 1, 2], [0, 2, 3]] } }
        ]
    });
    // Source before the door, listeners behind it.
    let points = Points {
        source: Vec3::new(1.5, 2.5, 1.5),
        listeners: (Vec3::new(4.0, 0.5, 1.0), Vec3::new(5.5, d - 0.5, 2.0)),
    };
    (doc.to_string(), points)
}

/// The door's four vertices, its top edge at `top`.
pub fn door(top: f32) -> [[f32; 3]; 4] {
    [
        [3.0, 1.0, 0.0],
        [3.0, 2.0, 0.0],
        [3.0, 2.0, top],
        [3.0, 1.0, top],
    ]
}

/// New door vertices, the top edge 1.8-2.4 m up (the mesh's order).
pub fn door_edit(rng: &mut SplitMix64) -> [[f32; 3]; 4] {
    door(1.8 + 0.6 * rng.next_f32())
}

/// An `application/octet-stream` vertex edit: little-endian f32 x, y, z
/// per vertex.
pub fn le_bytes(vertices: &[[f32; 3]]) -> Vec<u8> {
    vertices
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect()
}

/// A 10 x 6 x 3 m box, faces counter-clockwise seen from inside (so
/// normals point into the air), in plaster: the shoebox's size, so the
/// shoebox's points serve.
pub const OBJ_ROOM: &str = "\
o room
usemtl plaster
v 0 0 0
v 10 0 0
v 10 6 0
v 0 6 0
v 0 0 3
v 10 0 3
v 10 6 3
v 0 6 3
f 1 2 3 4
f 5 8 7 6
f 1 5 6 2
f 4 3 7 8
f 1 4 8 5
f 2 6 7 3
";
