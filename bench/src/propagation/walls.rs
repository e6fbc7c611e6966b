//! The rooms as pyroomacoustics takes them. Its natural input is one
//! polygon wall per planar face (a box is 6 rectangles, the L-room's floor
//! one L-shaped polygon): its image-source search branches on every wall,
//! so handing it one wall per triangle costs it orders of magnitude and
//! finds a path through a shared edge once per triangle. The polygons are
//! the outlines of each face's coplanar triangles, so they are exact for
//! any scene whose faces are simple polygons, whatever generator made it.

use std::collections::HashMap;

use frusta_engine::scene::Scene;
use glam::{DQuat, DVec3};

/// The 1 kHz octave band: pyroomacoustics gets one absorption per wall.
const BAND_1K: usize = 4;
/// Two triangles' unit normals closer than this (`1 - cos`) are coplanar.
const SAME_NORMAL: f64 = 1e-9;
/// Vertices closer than this (metres) are one corner.
const SAME_POINT_M: f64 = 1e-6;

/// One wall: corners counter-clockwise seen from inside the room (its
/// normal points into the air), and the energy absorption at 1 kHz
/// (area-weighted over its triangles).
#[derive(Clone, Debug)]
pub struct Wall {
    pub corners: Vec<DVec3>,
    pub absorption: f64,
}

struct Triangle {
    corners: [DVec3; 3],
    absorption: f64,
}

impl Triangle {
    fn normal(&self) -> DVec3 {
        let [a, b, c] = self.corners;
        (b - a).cross(c - a)
    }
}

/// Every triangle of `scene` in world space, in `f64`.
fn world_triangles(scene: &Scene) -> Vec<Triangle> {
    let mut out = Vec::new();
    for object in &scene.objects {
        let q = object.transform.rotation;
        let rotation = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into());
        let translation = object.transform.translation.as_dvec3();
        let positions = object.mesh.positions();
        for (t, &m) in object.mesh.triangles().iter().zip(&object.materials) {
            let corners = t.map(|i| rotation * positions[i as usize].as_dvec3() + translation);
            let absorption = scene
                .materials
                .get(usize::from(m))
                .map_or(0.0, |m| f64::from(m.absorption[BAND_1K]));
            out.push(Triangle {
                corners,
                absorption,
            });
        }
    }
    out
}

/// One wall per world triangle: the input the first version of this
/// benchmark gave pyroomacoustics, kept as the `pyroomacoustics-triangles`
/// row.
pub fn per_triangle(scene: &Scene) -> Vec<Wall> {
    world_triangles(scene)
        .into_iter()
        .map(|t| Wall {
            corners: t.corners.to_vec(),
            absorption: t.absorption,
        })
        .collect()
}

/// One wall per connected planar face: the boundary of its coplanar,
/// equally facing triangles, with collinear corners dropped. An error if
/// a face is not a simple polygon (a hole, or two parts touching at a
/// corner), which pyroomacoustics' walls can't represent.
pub fn polygons(scene: &Scene) -> Result<Vec<Wall>, String> {
    let triangles = world_triangles(scene);
    let scale = triangles
        .iter()
        .flat_map(|t| t.corners)
        .fold(1.0f64, |m, p| m.max(p.abs().max_element()));
    // Faces: triangles with the same facing unit normal and offset.
    let mut faces: Vec<(DVec3, f64, Vec<usize>)> = Vec::new();
    for (i, t) in triangles.iter().enumerate() {
        let Some(n) = t.normal().try_normalize() else {
            continue;
        };
        let d = n.dot(t.corners[0]);
        match faces
            .iter_mut()
            .find(|(m, e, _)| 1.0 - m.dot(n) < SAME_NORMAL && (e - d).abs() < 1e-9 * scale)
        {
            Some(face) => face.2.push(i),
            None => faces.push((n, d, vec![i])),
        }
    }
    let mut walls = Vec::new();
    for (normal, _, members) in &faces {
        let area: f64 = members
            .iter()
            .map(|&t| 0.5 * triangles[t].normal().length())
            .sum();
        let absorption = members
            .iter()
            .map(|&t| 0.5 * triangles[t].normal().length() * triangles[t].absorption)
            .sum::<f64>()
            / area;
        let mut outline_area = 0.0;
        for corners in outlines(&triangles, members, *normal)? {
            let a = newell(&corners).dot(*normal) / 2.0;
            if a <= 0.0 {
                return Err(format!("a face with normal {normal} has a hole"));
            }
            outline_area += a;
            walls.push(Wall {
                corners,
                absorption,
            });
        }
        if (outline_area - area).abs() > 1e-9 * area.max(1.0) {
            return Err(format!(
                "the outline of the face with normal {normal} covers {outline_area} m^2, its triangles {area} m^2"
            ));
        }
    }
    Ok(walls)
}

/// Twice the polygon's vector area (Newell's method).
fn newell(corners: &[DVec3]) -> DVec3 {
    (0..corners.len())
        .map(|i| corners[i].cross(corners[(i + 1) % corners.len()]))
        .sum()
}

/// The boundary loops of one face's triangles, in their winding.
fn outlines(
    triangles: &[Triangle],
    members: &[usize],
    normal: DVec3,
) -> Result<Vec<Vec<DVec3>>, String> {
    // Corners by position, so meshes that repeat vertices still share edges.
    let mut points: Vec<DVec3> = Vec::new();
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut id = |p: DVec3| {
        let key = (p / SAME_POINT_M).round().as_i64vec3().to_array();
        *index.entry(key).or_insert_with(|| {
            points.push(p);
            points.len() - 1
        })
    };
    let corners: Vec<[usize; 3]> = members
        .iter()
        .map(|&t| triangles[t].corners.map(&mut id))
        .collect();
    // Directed edges, split where another corner lies on them (a
    // T-junction), so that an inner edge cancels its reverse exactly.
    let mut edges: HashMap<(usize, usize), i32> = HashMap::new();
    for tri in &corners {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (pa, pb) = (points[a], points[b]);
            let mut on: Vec<(f64, usize)> = (0..points.len())
                .filter(|&v| v != a && v != b)
                .filter_map(|v| {
                    let s = (points[v] - pa).dot(pb - pa) / pa.distance_squared(pb);
                    let off = points[v].distance(pa + s * (pb - pa));
                    (s > 0.0 && s < 1.0 && off < SAME_POINT_M).then_some((s, v))
                })
                .collect();
            on.sort_by(|x, y| x.0.total_cmp(&y.0));
            let chain: Vec<usize> = std::iter::once(a)
                .chain(on.into_iter().map(|(_, v)| v))
                .chain(std::iter::once(b))
                .collect();
            for w in chain.windows(2) {
                *edges.entry((w[0], w[1])).or_default() += 1;
            }
        }
    }
    let mut next: HashMap<usize, usize> = HashMap::new();
    for (&(a, b), &n) in &edges {
        let surplus = n - edges.get(&(b, a)).copied().unwrap_or(0);
        if surplus == 1 {
            if next.insert(a, b).is_some() {
                return Err(format!(
                    "the face with normal {normal} touches itself at {}",
                    points[a]
                ));
            }
        } else if surplus > 1 {
            return Err(format!("the face with normal {normal} overlaps itself"));
        }
    }
    let mut loops = Vec::new();
    while let Some(&start) = next.keys().min() {
        let mut ring = vec![start];
        let mut at = next.remove(&start).expect("start has an edge");
        while at != start {
            ring.push(at);
            at = next
                .remove(&at)
                .ok_or_else(|| format!("the outline of the face with normal {normal} is open"))?;
        }
        loops.push(without_collinear(
            &ring.iter().map(|&v| points[v]).collect::<Vec<_>>(),
        ));
    }
    Ok(loops)
}

/// The corners where the outline turns.
fn without_collinear(ring: &[DVec3]) -> Vec<DVec3> {
    let n = ring.len();
    (0..n)
        .filter(|&i| {
            let (prev, p, next) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            let (u, v) = (p - prev, next - p);
            u.cross(v).length() > 1e-9 * u.length() * v.length()
        })
        .map(|i| ring[i])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use frusta_engine::scene::generate::BoxRoom;
    use frusta_engine::scene::Material;
    use glam::Vec3;

    fn corner_set(w: &Wall) -> Vec<[i64; 3]> {
        let mut c: Vec<[i64; 3]> = w
            .corners
            .iter()
            .map(|p| p.round().as_i64vec3().to_array())
            .collect();
        c.sort();
        c
    }

    #[test]
    fn a_subdivided_box_is_six_rectangles_facing_in() {
        let room = BoxRoom {
            subdivisions: 4,
            ..BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0))
        };
        let mesh = room.generate().unwrap();
        let scene =
            Scene::single_object("room", mesh, Material::uniform("w", 0.1).unwrap()).unwrap();
        let walls = polygons(&scene).unwrap();
        assert_eq!(walls.len(), 6);
        let centre = DVec3::new(5.0, 3.0, 1.5);
        for w in &walls {
            assert_eq!(w.corners.len(), 4);
            assert!((w.absorption - 0.1).abs() < 1e-6);
            let inward = newell(&w.corners).dot(centre - w.corners[0]);
            assert!(inward > 0.0, "{w:?}");
        }
        assert!(walls
            .iter()
            .any(|w| corner_set(w) == [[0, 0, 0], [0, 6, 0], [10, 0, 0], [10, 6, 0]]));
    }

    #[test]
    fn the_l_room_has_eight_walls_and_an_l_shaped_floor() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/l-room.json");
        let walls = polygons(&Scene::load(&path).unwrap()).unwrap();
        assert_eq!(walls.len(), 8);
        let floor: Vec<&Wall> = walls
            .iter()
            .filter(|w| w.corners.iter().all(|p| p.z.abs() < 1e-9))
            .collect();
        assert_eq!(floor.len(), 1);
        // 12 x 10 m minus the 5 x 4 m corner: six corners, 100 m^2.
        assert_eq!(floor[0].corners.len(), 6);
        assert!((newell(&floor[0].corners).length() / 2.0 - 100.0).abs() < 1e-9);
    }
}
