//! The diffracting edges of a scene: where faces meet at an angle open to
//! the air of more than π (a wedge), or where a thin surface ends (a free
//! edge, open by 2π: a half-plane).
//!
//! Triangle sides are matched by their world corners, so an edge is found
//! whatever the mesh's vertex sharing. Around each matched side the faces'
//! directions are sorted by angle; the largest gap between neighbours is
//! where the air is, and it diffracts only if it exceeds π by
//! [`MIN_TURN`]: a flat seam, a room's inside corner, or a wall meeting
//! another in a T has no such gap. Triangle orientation is never read,
//! since acoustic surfaces are two-sided. A side that another surface
//! touches (a pillar standing on the floor, a panel flush with a wall)
//! is a junction, not an edge. Collinear pieces between the same two
//! plane groups are merged into one edge, so a wall split into many
//! triangles has one edge per side, as a path finds one point on it.

use std::collections::HashMap;

use glam::{DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use crate::acoustics::surfaces::{Surfaces, NO_GROUP};
use crate::geometry::Aabb;
use crate::query::SceneBvh;

/// The smallest turn between two faces (the air's angle minus π) that
/// diffracts, radians: below it a seam is treated as flat. A cylinder of
/// 16 facets turns by 22.5° at each seam.
pub const MIN_TURN: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// One diffracting edge, in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Edge {
    pub start: DVec3,
    pub end: DVec3,
    /// Unit vector from `start` to `end`.
    pub axis: DVec3,
    pub length: f64,
    /// Unit vector perpendicular to the edge, into face 0.
    face0: DVec3,
    /// `axis × face0`: turning from `face0` towards it enters the air.
    turn: DVec3,
    /// The air's angle from face 0 to face 1, in `(π + MIN_TURN, 2π]`
    /// (`2π` for a free edge, whose two faces are one).
    pub wedge: f64,
    /// Plane groups of face 0 and face 1 (the same for a free edge).
    pub groups: [u32; 2],
    /// A triangle of face 0, `(object, mesh-order triangle)`: what a path
    /// reports it meets.
    pub object: u32,
    pub triangle: u32,
}

/// Where a point lies around an edge: cylindrical coordinates about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AroundEdge {
    /// Angle from face 0 through the air, in `[0, 2π)`.
    pub angle: f64,
    /// Distance from the edge's line.
    pub radius: f64,
    /// Position along the axis, from `start`.
    pub along: f64,
}

impl Edge {
    /// `p` in the edge's cylindrical coordinates.
    pub fn around(&self, p: DVec3) -> AroundEdge {
        let v = p - self.start;
        let along = v.dot(self.axis);
        let (x, y) = (v.dot(self.face0), v.dot(self.turn));
        let mut angle = y.atan2(x);
        if angle < 0.0 {
            angle += std::f64::consts::TAU;
        }
        AroundEdge {
            angle,
            radius: x.hypot(y),
            along,
        }
    }

    /// The point `along` metres from `start`.
    pub fn point(&self, along: f64) -> DVec3 {
        self.start + self.axis * along
    }

    /// Whether an angle lies in the air's side, faces included.
    pub fn in_air(&self, angle: f64) -> bool {
        angle <= self.wedge
    }
}

/// Every diffracting edge of a scene, kept per object so that moving one
/// object finds its edges again in time proportional to it. Edges between
/// objects are not looked for: objects are separate meshes, and where
/// one touches another its sides are junctions.
#[derive(Clone, Debug, Default)]
pub struct Edges {
    per_object: Vec<Vec<Edge>>,
    /// Each object's world box when its edges were found: a junction
    /// depends on the objects around, so a move finds again the edges of
    /// every object near the mover's old or new place.
    bounds: Vec<Aabb>,
    /// The surfaces' group numbering the edges' groups belong to.
    numbering: u64,
}

impl Edges {
    pub fn new(bvh: &SceneBvh, surfaces: &Surfaces) -> Self {
        let objects = 0..bvh.object_count();
        Self {
            per_object: objects
                .clone()
                .map(|o| object_edges(bvh, surfaces, o))
                .collect(),
            bounds: objects.map(|o| object_bounds(surfaces, o)).collect(),
            numbering: surfaces.numbering(),
        }
    }

    /// Finds `object`'s edges again after it moved or changed shape, and
    /// those of the objects it left or came to touch.
    pub fn update_object(&mut self, bvh: &SceneBvh, surfaces: &Surfaces, object: usize) {
        if self.per_object.len() != bvh.object_count() || self.numbering != surfaces.numbering() {
            *self = Self::new(bvh, surfaces);
            return;
        }
        let reach = Vec3A::splat((1e-5 * surfaces.scale()) as f32);
        let grown = |b: Aabb| Aabb::new(b.min - reach, b.max + reach);
        let old = grown(self.bounds[object]);
        self.bounds[object] = object_bounds(surfaces, object);
        let new = grown(self.bounds[object]);
        for o in 0..self.per_object.len() {
            let near = self.bounds[o].overlaps(&old) || self.bounds[o].overlaps(&new);
            if o == object || near {
                self.per_object[o] = object_edges(bvh, surfaces, o);
            }
        }
    }

    pub fn iter(&self) -> impl Iterator<Item = &Edge> {
        self.per_object.iter().flatten()
    }

    pub fn len(&self) -> usize {
        self.per_object.iter().map(Vec::len).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The world box of `object`'s triangles.
fn object_bounds(surfaces: &Surfaces, object: usize) -> Aabb {
    surfaces
        .object_slots(object)
        .map(|slot| {
            let c = surfaces.slot(slot).0;
            Aabb::of_triangle(c[0], c[1], c[2])
        })
        .fold(Aabb::EMPTY, Aabb::union)
}

/// A triangle side, keyed by its corners' bits, lower corner first.
type SideKey = ([u32; 3], [u32; 3]);

/// `-0.0` is made `+0.0` first, so that corners equal as numbers match.
fn bits(p: Vec3A) -> [u32; 3] {
    Vec3::from(p).to_array().map(|c| (c + 0.0).to_bits())
}

/// One piece of an edge before merging.
struct Piece {
    start: DVec3,
    end: DVec3,
    face0: DVec3,
    wedge: f64,
    groups: [u32; 2],
    slot: usize,
}

fn object_edges(bvh: &SceneBvh, surfaces: &Surfaces, object: usize) -> Vec<Edge> {
    let slots = surfaces.object_slots(object);
    let mut sides: Vec<(SideKey, usize, usize)> = Vec::with_capacity(3 * slots.len());
    for slot in slots.clone() {
        let (corners, group) = surfaces.slot(slot);
        if group == NO_GROUP {
            continue;
        }
        for i in 0..3 {
            let (a, b) = (bits(corners[i]), bits(corners[(i + 1) % 3]));
            let key = if a <= b { (a, b) } else { (b, a) };
            sides.push((key, slot, (i + 2) % 3));
        }
    }
    sides.par_sort_unstable_by_key(|s| s.0);
    let tol = 1e-6 * surfaces.scale();
    let runs: Vec<&[(SideKey, usize, usize)]> = sides.chunk_by(|a, b| a.0 == b.0).collect();
    let pieces: Vec<Piece> = runs
        .par_iter()
        .with_min_len(1024)
        .filter_map(|run| {
            let (a, b) = run[0].0;
            let [a, b] = [a, b].map(|k| Vec3::from_array(k.map(f32::from_bits)).as_dvec3());
            wedge_piece(bvh, surfaces, a, b, run, tol)
        })
        .collect();
    merge(bvh, surfaces, object, pieces, tol)
}

/// The wedge the faces around side `a`-`b` leave open to the air, if it
/// diffracts: the faces of its own triangles (`run`) and of any other
/// surface meeting the side at its middle (a wall standing on a floor
/// closes the floor's free edge; a mesh with a T-junction, or a corner of
/// two objects, still has its wedge).
fn wedge_piece(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    a: DVec3,
    b: DVec3,
    run: &[(SideKey, usize, usize)],
    tol: f64,
) -> Option<Piece> {
    use std::f64::consts::{PI, TAU};
    // One direction per line (first non-zero component positive), so that
    // pieces of one edge agree on their faces' order and merge.
    let d = b - a;
    let forward = [d.x, d.y, d.z].into_iter().find(|&c| c != 0.0)? > 0.0;
    let (a, b) = if forward { (a, b) } else { (b, a) };
    let axis = (b - a).normalize_or_zero();
    // Each face's direction away from the edge, in its group's plane.
    let mut faces: Vec<(DVec3, u32, usize)> = run
        .iter()
        .filter_map(|&(_, slot, opposite)| {
            let (corners, group) = surfaces.slot(slot);
            let n = surfaces.group(group).plane.normal;
            let v = corners[opposite].as_dvec3() - a;
            let v = v - axis * v.dot(axis);
            let v = (v - n * v.dot(n)).normalize_or_zero();
            (v != DVec3::ZERO).then_some((v, group, slot))
        })
        .collect();
    let own = |slot: usize| run.iter().any(|s| s.1 == slot);
    faces.extend(surfaces.faces_at(bvh, (a + b) * 0.5, axis, tol, own)?);
    let first = faces.first()?.0;
    let turn = axis.cross(first);
    let mut angles: Vec<(f64, usize)> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let t = f.0.dot(turn).atan2(f.0.dot(first));
            (if t < 0.0 { t + TAU } else { t }, i)
        })
        .collect();
    angles.sort_by(|x, y| x.0.total_cmp(&y.0));
    // The largest gap, from face `angles[i]` turning forward to the next.
    let (gap, from, to) = (0..angles.len())
        .map(|i| {
            let j = (i + 1) % angles.len();
            // The last gap wraps round; faces in one direction (a
            // triangle's side lying on another face) leave none between.
            let gap = if j == 0 {
                angles[0].0 + TAU - angles[i].0
            } else {
                angles[j].0 - angles[i].0
            };
            (gap, angles[i].1, angles[j].1)
        })
        .max_by(|x, y| x.0.total_cmp(&y.0))?;
    if gap <= PI + MIN_TURN {
        return None;
    }
    // The triangle reported is the object's own (face 0's if it is).
    let slot = if own(faces[from].2) {
        faces[from].2
    } else {
        run[0].1
    };
    Some(Piece {
        start: a,
        end: b,
        face0: faces[from].0,
        wedge: gap.min(TAU),
        groups: [faces[from].1, faces[to].1],
        slot,
    })
}

/// Joins collinear pieces between the same faces' planes (and, for free
/// edges, on the same line, to rounding) that touch or overlap. A free
/// edge whose pieces round to different lines stays in pieces; a path
/// meeting it where two touch is found twice, and the search keeps one.
fn merge(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    object: usize,
    pieces: Vec<Piece>,
    tol: f64,
) -> Vec<Edge> {
    let quantum = (1e-6 * surfaces.scale()).max(f64::MIN_POSITIVE);
    let mut lines: HashMap<([u32; 2], [i64; 6]), Vec<Piece>> = HashMap::new();
    for p in pieces {
        let axis = (p.end - p.start).normalize();
        // The line: its direction, and its point nearest the origin.
        let foot = p.start - axis * p.start.dot(axis);
        let q = |v: f64, step: f64| (v / step).round() as i64;
        // Two planes meet in one line (whose pieces may still open to
        // different quarters: the first face's direction tells them
        // apart); a free edge's plane has many lines.
        let key = if p.groups[0] != p.groups[1] {
            [
                q(p.face0.x, 1e-3),
                q(p.face0.y, 1e-3),
                q(p.face0.z, 1e-3),
                0,
                0,
                0,
            ]
        } else {
            [
                q(axis.x, 1e-6),
                q(axis.y, 1e-6),
                q(axis.z, 1e-6),
                q(foot.x, quantum),
                q(foot.y, quantum),
                q(foot.z, quantum),
            ]
        };
        lines.entry((p.groups, key)).or_default().push(p);
    }
    let ids = bvh.instances()[object].bvh().prim_ids();
    let base = surfaces.object_base(object);
    let mut edges = Vec::new();
    let mut keys: Vec<_> = lines.keys().copied().collect();
    keys.sort_unstable();
    for key in keys {
        let mut line = lines.remove(&key).unwrap_or_default();
        let axis = (line[0].end - line[0].start).normalize();
        line.sort_by(|x, y| x.start.dot(axis).total_cmp(&y.start.dot(axis)));
        let mut current: Option<(Piece, f64)> = None;
        for p in line {
            let (s, e) = (p.start.dot(axis), p.end.dot(axis));
            current = match current {
                Some((mut c, end)) if s <= end + tol => {
                    if e > end {
                        c.end = p.end;
                    }
                    Some((c, end.max(e)))
                }
                other => {
                    if let Some((c, _)) = other {
                        edges.push(edge(c, ids, base, object));
                    }
                    Some((p, e))
                }
            };
        }
        if let Some((c, _)) = current {
            edges.push(edge(c, ids, base, object));
        }
    }
    edges
}

fn edge(p: Piece, ids: &[u32], base: usize, object: usize) -> Edge {
    let axis = (p.end - p.start).normalize();
    Edge {
        start: p.start,
        end: p.end,
        axis,
        length: p.start.distance(p.end),
        face0: p.face0,
        turn: axis.cross(p.face0),
        wedge: p.wedge,
        groups: p.groups,
        object: object as u32,
        triangle: ids[p.slot - base],
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{PI, TAU};

    use super::*;
    use crate::bvh::BuildOptions;
    use crate::geometry::{shapes, RigidTransform, TriangleMesh};
    use crate::scene::{Material, Scene, SceneObject};

    fn scene_of(meshes: Vec<TriangleMesh>) -> Scene {
        let objects = meshes
            .into_iter()
            .enumerate()
            .map(|(i, mesh)| SceneObject {
                name: format!("o{i}"),
                materials: vec![0; mesh.triangle_count()],
                mesh,
                transform: RigidTransform::IDENTITY,
                dynamic: true,
            })
            .collect();
        Scene {
            materials: vec![Material::uniform("m", 0.1).unwrap()],
            objects,
        }
    }

    fn edges_of(meshes: Vec<TriangleMesh>) -> Edges {
        let bvh = SceneBvh::build(&scene_of(meshes), &BuildOptions::default());
        let surfaces = Surfaces::new(&bvh);
        Edges::new(&bvh, &surfaces)
    }

    fn quad(corners: [[f32; 3]; 4]) -> TriangleMesh {
        TriangleMesh::new(
            corners.iter().map(|&c| Vec3::from(c)).collect(),
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    /// A cube split 4 x 4 per face has 12 edges of 3π/2 (merged from 4
    /// pieces each), the faces' seams none.
    #[test]
    fn a_subdivided_cube_has_twelve_right_angle_edges() {
        let edges = edges_of(vec![shapes::cube(1.0, 4)]);
        assert_eq!(edges.len(), 12);
        for e in edges.iter() {
            assert!((e.wedge - 1.5 * PI).abs() < 1e-9, "{}", e.wedge);
            assert!((e.length - 2.0).abs() < 1e-6, "{}", e.length);
            // The cube lies in the solid wedge: its centre is not in air.
            assert!(!e.in_air(e.around(DVec3::ZERO).angle));
            // A point beyond both faces is.
            let out = (e.start + e.end) * 1.5;
            assert!(e.in_air(e.around(out).angle));
        }
    }

    /// A thin plate has four free edges; a wall standing on it meets it
    /// in a junction (no edge) and adds its three free sides.
    #[test]
    fn free_edges_end_where_another_surface_meets_them() {
        let floor = || quad([[-5., -5., 0.], [5., -5., 0.], [5., 5., 0.], [-5., 5., 0.]]);
        let plate = edges_of(vec![floor()]);
        assert_eq!(plate.len(), 4);
        assert!(plate
            .iter()
            .all(|e| e.wedge == TAU && e.groups[0] == e.groups[1]));
        let wall = quad([[-2., 0., 0.], [2., 0., 0.], [2., 0., 3.], [-2., 0., 3.]]);
        let both = edges_of(vec![floor(), wall]);
        assert_eq!(both.len(), 4 + 3);
        // No edge runs along the wall's foot.
        let foot = |e: &Edge| e.start.z == 0.0 && e.end.z == 0.0 && e.start.y == 0.0;
        assert!(!both.iter().any(foot));
    }

    /// Two plates of separate objects meeting at a right angle along a
    /// side form one fold: each object sees the other's face there, so
    /// each finds the wedge (a path through it is found twice and kept
    /// once), not two free edges.
    #[test]
    fn a_corner_of_two_objects_is_a_wedge() {
        let a = quad([[0., -2., 0.], [1., -2., 0.], [1., 0., 0.], [0., 0., 0.]]);
        let b = quad([[0., 0., 0.], [1., 0., 0.], [1., 0., 2.], [0., 0., 2.]]);
        let edges = edges_of(vec![a, b]);
        let fold: Vec<&Edge> = edges.iter().filter(|e| e.wedge < TAU).collect();
        assert_eq!(fold.len(), 2);
        for e in &fold {
            assert!((e.wedge - 1.5 * PI).abs() < 1e-6, "{}", e.wedge);
            assert!(e.start.y == 0.0 && e.start.z == 0.0 && e.end.y == 0.0 && e.end.z == 0.0);
        }
        assert_eq!(edges.len(), 2 + 3 + 3);
    }

    /// A sheet folded by a right angle diffracts on its reflex side only;
    /// folded by 2° it is a flat seam. Angles are measured from face 0
    /// through the air.
    #[test]
    fn a_fold_diffracts_on_its_open_side() {
        let fold = |degrees: f64| {
            let a = degrees.to_radians();
            let far = Vec3::new(0.0, 2.0 * a.cos() as f32, 2.0 * a.sin() as f32);
            TriangleMesh::new(
                vec![
                    Vec3::new(0., 0., 0.),
                    Vec3::new(1., 0., 0.),
                    Vec3::new(1., -2., 0.),
                    Vec3::new(0., -2., 0.),
                    Vec3::new(1., 0., 0.) + far,
                    Vec3::new(0., 0., 0.) + far,
                ],
                vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [0, 4, 5]],
            )
            .unwrap()
        };
        // Faces along -y and along the fold's direction: folded up by 90°,
        // the air's side between them is 270°.
        let edges = edges_of(vec![fold(90.0)]);
        let inner: Vec<&Edge> = edges.iter().filter(|e| e.wedge < TAU).collect();
        assert_eq!(inner.len(), 1);
        let e = inner[0];
        assert!((e.wedge - 1.5 * PI).abs() < 1e-6, "{}", e.wedge);
        // Inside the fold (between the faces): the solid side.
        let inside = DVec3::new(0.5, -0.5, 0.5);
        assert!(!e.in_air(e.around(inside).angle));
        let below = DVec3::new(0.5, 0.5, -0.5);
        let a = e.around(below);
        assert!(e.in_air(a.angle), "{a:?}");
        assert!((a.along - 0.5).abs() < 1e-9 && (a.radius - 0.5f64.hypot(0.5)).abs() < 1e-9);
        // On the air's bisector: 135° from either face.
        assert!((a.angle - 0.75 * PI).abs() < 1e-6, "{a:?}");
        // The fold and three free sides of each face.
        assert_eq!(edges.len(), 7);
        // Opened to 178°, the fold is a flat seam.
        let flat = edges_of(vec![fold(2.0)]);
        assert_eq!(flat.len(), 6);
        assert!(flat.iter().all(|e| e.wedge == TAU));
    }

    /// Moving an object finds its edges again, in its new place, as a
    /// build from scratch does.
    #[test]
    fn moving_an_object_moves_its_edges() {
        use glam::Quat;
        let floor = quad([[-5., -5., 0.], [5., -5., 0.], [5., 5., 0.], [-5., 5., 0.]]);
        let scene = scene_of(vec![floor, shapes::cube(0.5, 2)]);
        let mut bvh = SceneBvh::build(&scene, &BuildOptions::default());
        let mut surfaces = Surfaces::new(&bvh);
        let mut edges = Edges::new(&bvh, &surfaces);
        let key = |e: &Edges| {
            let mut v: Vec<_> = e
                .iter()
                .map(|e| {
                    (
                        e.start.to_array().map(|c| (c * 1e4).round() as i64),
                        (e.wedge * 1e6) as i64,
                    )
                })
                .collect();
            v.sort_unstable();
            v
        };
        let spin = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.4);
        // Floating, then standing on the floor (its bottom edges become
        // junctions), then astride the floor's free edge at x = 5 (which
        // becomes a junction too, though the floor did not move, as do
        // the cube's bottom edges where they lie on the floor: one whole
        // and the halves of two), then spun in the air (the floor's edge
        // comes back).
        let moves = [
            (Quat::IDENTITY, Vec3::new(1.0, 2.0, 3.0)),
            (Quat::IDENTITY, Vec3::new(1.0, 2.0, 0.5)),
            (Quat::IDENTITY, Vec3::new(5.0, 0.0, 0.5)),
            (spin, Vec3::new(-2.0, 1.0, 2.0)),
        ];
        for (count, (rotation, shift)) in [16, 12, 14, 16].into_iter().zip(moves) {
            bvh.set_transform(1, RigidTransform::new(rotation, shift).unwrap())
                .unwrap();
            surfaces.update_object(&bvh, 1);
            edges.update_object(&bvh, &surfaces, 1);
            let fresh = Edges::new(&bvh, &Surfaces::new(&bvh));
            assert_eq!(key(&edges), key(&fresh), "{shift}");
            assert_eq!(edges.len(), count, "{shift}");
        }
    }
}
