//! The reflecting surfaces of a scene as sound sees them: every triangle in
//! world space, grouped into planes.
//!
//! Specular paths depend on planes, not on triangles: an image source is the
//! source mirrored in a plane, and a wall split into many triangles mirrors
//! like one. Grouping coplanar triangles of one material lets a frustum that
//! straddles two triangles of a wall spawn one secondary frustum instead of
//! two, and gives each image source one canonical plane, so that the same
//! path found by neighbouring frusta is recognised as the same.

mod groups;

use glam::{DQuat, DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use crate::bvh::traverse::{Flow, OverlapTest};
use crate::bvh::SceneBvh;
use crate::geometry::Aabb;
use crate::scene::MaterialId;
use groups::GroupTable;

/// A plane `normal · p = offset` with a unit normal, in `f64` so that image
/// sources mirrored several times stay exact to well below a millimetre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub normal: DVec3,
    pub offset: f64,
}

impl Plane {
    /// Signed distance of `p` from the plane, positive on the normal's side.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// `p` mirrored in the plane.
    #[inline]
    pub fn mirror(&self, p: DVec3) -> DVec3 {
        p - 2.0 * self.distance(p) * self.normal
    }

    /// Direction `v` mirrored in the plane.
    #[inline]
    pub fn mirror_vector(&self, v: DVec3) -> DVec3 {
        v - 2.0 * self.normal.dot(v) * self.normal
    }
}

/// Coplanar triangles of one material.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceGroup {
    pub plane: Plane,
    pub material: MaterialId,
}

/// Group id of triangles with no area: they are never hit and reflect nothing.
pub const NO_GROUP: u32 = u32::MAX;

/// World-space triangles of a scene in the leaf order of each object's tree
/// (so frustum traversal reads them contiguously), and their plane groups.
///
/// Each object owns a contiguous range of the flat arrays, so moving or
/// deforming one object rewrites only its range and its groups' shares
/// ([`Self::update_object`]).
#[derive(Clone, Debug, Default)]
pub struct Surfaces {
    /// Per object, the index of its first triangle in the flat arrays.
    object_base: Vec<u32>,
    /// World corners, in leaf order within each object.
    corners: Vec<[Vec3A; 3]>,
    /// Group of each triangle, in leaf order.
    slot_group: Vec<u32>,
    /// Group of each triangle, in mesh order (for ray hits).
    mesh_group: Vec<u32>,
    groups: GroupTable,
    /// Length of the scene box's diagonal: the scale of every tolerance.
    scale: f64,
    /// New with every full build (which renumbers the groups), so that
    /// what keeps group ids can tell when they went stale.
    numbering: u64,
}

impl Surfaces {
    /// Collects the world triangles of `bvh` and groups them into planes.
    pub fn new(bvh: &SceneBvh) -> Self {
        let mut object_base = Vec::with_capacity(bvh.object_count());
        let mut total = 0u32;
        for i in bvh.instances() {
            object_base.push(total);
            total += i.bvh().triangle_count() as u32;
        }
        let scale = scene_scale(bvh);
        let n = total as usize;
        let mut s = Self {
            object_base,
            corners: vec![[Vec3A::ZERO; 3]; n],
            slot_group: vec![NO_GROUP; n],
            mesh_group: vec![NO_GROUP; n],
            groups: GroupTable::new(scale),
            scale,
            numbering: {
                static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
                NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            },
        };
        for object in 0..bvh.object_count() {
            s.place_object(bvh, object);
        }
        s
    }

    /// Brings one object's triangles and groups up to date after it moved
    /// or changed shape in `bvh`: time proportional to the object, unless
    /// its triangle count changed or the scene's size changed enough to move
    /// the grouping's quantisation step (then everything is rebuilt).
    pub fn update_object(&mut self, bvh: &SceneBvh, object: usize) {
        let (start, end) = self.range(object);
        let same_count = bvh
            .instances()
            .get(object)
            .is_some_and(|i| i.bvh().triangle_count() == end - start);
        let scale = scene_scale(bvh);
        if !same_count || !self.groups.fits_scale(scale) {
            *self = Self::new(bvh);
            return;
        }
        self.scale = scale;
        self.groups
            .remove_object(object as u32, &self.slot_group[start..end]);
        self.place_object(bvh, object);
    }

    /// Writes `object`'s world corners and groups into its range.
    fn place_object(&mut self, bvh: &SceneBvh, object: usize) {
        let inst = &bvh.instances()[object];
        let (start, end) = self.range(object);
        let tris = inst.bvh().leaf_triangles();
        self.corners[start..end]
            .par_iter_mut()
            .with_min_len(4096)
            .zip(tris.par_iter())
            .for_each(|(out, tri)| {
                *out = if inst.is_identity() {
                    *tri
                } else {
                    tri.map(|p| inst.to_world().transform_point(p))
                }
            });
        // Planes from the object-frame vertices moved in f64: world
        // corners are rounded to f32, which would tilt a rotated wall's
        // plane by up to 1e-7 and move a fourth-order image by tens of
        // micrometres.
        let q = inst.to_world().rotation;
        let rotation = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
        let translation = inst.to_world().translation.as_dvec3();
        let planes: Vec<Option<(Plane, f64)>> = tris
            .par_iter()
            .with_min_len(4096)
            .map(|tri| {
                triangle_plane(&tri.map(|p| rotation * DVec3::from(Vec3::from(p)) + translation))
            })
            .collect();
        let ids = inst.bvh().prim_ids();
        let materials: Vec<MaterialId> = ids
            .iter()
            .map(|&t| inst.materials().get(t as usize).copied().unwrap_or(0))
            .collect();
        self.groups.add_object(
            object as u32,
            start,
            &planes,
            &materials,
            &mut self.slot_group[start..end],
        );
        for (slot, &t) in ids.iter().enumerate() {
            self.mesh_group[start + t as usize] = self.slot_group[start + slot];
        }
    }

    /// The flat index range of `object`'s triangles.
    fn range(&self, object: usize) -> (usize, usize) {
        let start = self.object_base[object] as usize;
        let end = self
            .object_base
            .get(object + 1)
            .map_or(self.corners.len(), |&b| b as usize);
        (start, end)
    }

    /// The live plane groups with their ids.
    pub fn groups(&self) -> impl Iterator<Item = (u32, &SurfaceGroup)> {
        self.groups.iter()
    }

    /// How many plane groups there are.
    pub fn group_count(&self) -> usize {
        self.groups.len()
    }

    pub fn group(&self, g: u32) -> &SurfaceGroup {
        self.groups.get(g)
    }

    /// Diagonal of the scene's bounding box, in metres.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    pub fn triangle_count(&self) -> usize {
        self.corners.len()
    }

    /// Total area of the triangles, m², and the volume they enclose, m³:
    /// the magnitude of the sum of signed tetrahedra from the origin
    /// (divergence theorem), exact for a closed mesh of either winding and
    /// meaningless for an open one, which the caller must bound.
    pub fn area_and_volume(&self) -> (f64, f64) {
        let (area, volume) = self
            .corners
            .iter()
            .map(|c| {
                let [a, b, c] = c.map(|p| p.as_dvec3());
                let cross = (b - a).cross(c - a);
                (0.5 * cross.length(), a.dot(b.cross(c)) / 6.0)
            })
            .fold((0.0, 0.0), |(sa, sv), (a, v)| (sa + a, sv + v));
        (area, volume.abs())
    }

    /// Which numbering of the groups this is: it changes only when every
    /// group was found again.
    pub fn numbering(&self) -> u64 {
        self.numbering
    }

    /// The flat slots of `object`'s triangles.
    pub(crate) fn object_slots(&self, object: usize) -> std::ops::Range<usize> {
        let (start, end) = self.range(object);
        start..end
    }

    /// First flat index of `object`'s triangles.
    #[inline]
    pub(crate) fn object_base(&self, object: usize) -> usize {
        self.object_base[object] as usize
    }

    /// World corners and group of the triangle at flat leaf-order index `i`.
    #[inline]
    pub(crate) fn slot(&self, i: usize) -> (&[Vec3A; 3], u32) {
        (&self.corners[i], self.slot_group[i])
    }

    /// Group of triangle `triangle` (mesh order) of `object`.
    #[inline]
    pub fn group_of(&self, object: u32, triangle: u32) -> u32 {
        self.mesh_group[self.object_base[object as usize] as usize + triangle as usize]
    }

    /// The first triangle, as `(object, mesh-order triangle)`, of `group`
    /// containing `p` (a point on the group's plane) to within `tol` metres:
    /// for points on an edge between planes, where a ray query reports
    /// either side. Candidates come from a box query on `bvh` around `p`,
    /// grown by `tol` plus the plane tolerance of the grouping (coplanar to
    /// within about 1e-5 of the scene's size). The edge test accepts points
    /// up to `tol / sin(angle / 2)` beyond a corner of angle `angle`, so at
    /// corners sharper than about 6 degrees a point the old linear scan
    /// accepted can fall outside the box; such a point is then matched to
    /// another triangle of the group or to none, and the path is refused.
    pub fn triangle_at(
        &self,
        bvh: &SceneBvh,
        group: u32,
        p: DVec3,
        tol: f64,
    ) -> Option<(u32, u32)> {
        let mut best: Option<(u32, u32)> = None;
        self.slots_near(bvh, p, tol + 2e-5 * self.scale, |object, slot, triangle| {
            let found = (object, triangle);
            if self.slot_group[slot] == group
                && best.is_none_or(|b| found < b)
                && contains(&self.corners[slot], p, tol)
            {
                best = Some(found);
            }
        });
        best
    }

    /// The faces of other triangles (those `own` rejects, by flat slot)
    /// meeting the line through `p` along unit `axis` at `p`, as their
    /// directions away from the line (both ways for a face the line runs
    /// across), with group and slot; `None` if one meets `p` at an angle
    /// to the line (the line pierces it, or ends on it).
    pub(crate) fn faces_at(
        &self,
        bvh: &SceneBvh,
        p: DVec3,
        axis: DVec3,
        tol: f64,
        own: impl Fn(usize) -> bool,
    ) -> Option<Vec<(DVec3, u32, usize)>> {
        let mut faces = Vec::new();
        let mut pierced = false;
        self.slots_near(bvh, p, tol, |_, slot, _| {
            let group = self.slot_group[slot];
            if pierced || group == NO_GROUP || own(slot) {
                return;
            }
            let corners = &self.corners[slot];
            let plane = &self.groups.get(group).plane;
            let d = plane.distance(p);
            if d.abs() > tol || !contains(corners, p - d * plane.normal, tol) {
                return;
            }
            if plane.normal.dot(axis).abs() > 1e-6 {
                pierced = true;
                return;
            }
            let across = axis.cross(plane.normal).normalize();
            let sides = corners.map(|c| (c.as_dvec3() - p).dot(across));
            if sides.iter().any(|&x| x > tol) {
                faces.push((across, group, slot));
            }
            if sides.iter().any(|&x| x < -tol) {
                faces.push((-across, group, slot));
            }
        });
        (!pierced).then_some(faces)
    }

    /// Calls `visit(object, flat slot, mesh-order triangle)` for every
    /// triangle whose leaf box comes within `reach` metres of `p` (a box
    /// query on `bvh`).
    fn slots_near(
        &self,
        bvh: &SceneBvh,
        p: DVec3,
        reach: f64,
        mut visit: impl FnMut(u32, usize, u32),
    ) {
        let reach = reach as f32;
        let centre = p.as_vec3a();
        let query = Aabb::new(centre - Vec3A::splat(reach), centre + Vec3A::splat(reach));
        bvh.walk_objects(&OverlapTest::new(query), 0.0, |object, inst, _| {
            let local = if inst.is_identity() {
                query
            } else {
                query.transformed(inst.to_object())
            };
            let base = self.object_base(object as usize);
            let ids = inst.bvh().prim_ids();
            inst.bvh()
                .wide()
                .walk(&OverlapTest::new(local), 0.0, |first, count, _| {
                    let slots = first as usize..(first + count) as usize;
                    for (slot, &triangle) in slots.clone().zip(&ids[slots]) {
                        visit(object, base + slot, triangle);
                    }
                    Flow::Continue(())
                });
            Flow::Continue(())
        });
    }
}

/// Whether `p`, on the triangle's plane, lies within `tol` of each of its
/// edges' inner sides.
fn contains(corners: &[Vec3A; 3], p: DVec3, tol: f64) -> bool {
    let [a, b, c] = corners.map(|q| DVec3::from(Vec3::from(q)));
    let n = (b - a).cross(c - a).normalize_or_zero();
    [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| {
        let edge = v - u;
        let len = edge.length();
        len > 0.0 && edge.cross(p - u).dot(n) / len >= -tol
    })
}

/// Length of the scene box's diagonal, at least the smallest positive f64.
fn scene_scale(bvh: &SceneBvh) -> f64 {
    let b = bvh.bounds();
    if b.is_empty() {
        1.0
    } else {
        f64::from((b.max - b.min).length()).max(f64::MIN_POSITIVE)
    }
}

/// The plane of a triangle with its normal's sign made canonical (first
/// non-zero component positive), and its area; `None` for zero area.
fn triangle_plane(&[a, b, c]: &[DVec3; 3]) -> Option<(Plane, f64)> {
    let n = (b - a).cross(c - a);
    let len = n.length();
    if len <= 0.0 || !len.is_finite() {
        return None;
    }
    let mut normal = n / len;
    let flip = if normal.x != 0.0 {
        normal.x < 0.0
    } else if normal.y != 0.0 {
        normal.y < 0.0
    } else {
        normal.z < 0.0
    };
    if flip {
        normal = -normal;
    }
    let offset = normal.dot((a + b + c) / 3.0);
    Some((Plane { normal, offset }, 0.5 * len))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::generate::BoxRoom;
    use crate::scene::{Material, Scene};
    use glam::Vec3;

    fn box_surfaces(subdivisions: u32) -> Surfaces {
        let mut room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
        room.subdivisions = subdivisions;
        let scene = Scene::single_object(
            "room",
            room.generate().unwrap(),
            Material::uniform("w", 0.1).unwrap(),
        )
        .unwrap();
        Surfaces::new(&SceneBvh::build(&scene, &BuildOptions::default()))
    }

    #[test]
    fn a_subdivided_box_has_six_planes() {
        let s = box_surfaces(4);
        assert_eq!(s.triangle_count(), 12 * 16);
        assert_eq!(s.group_count(), 6);
        let mut offsets: Vec<f64> = s.groups().map(|(_, g)| g.plane.offset).collect();
        offsets.sort_by(f64::total_cmp);
        assert_eq!(offsets, vec![0.0, 0.0, 0.0, 3.0, 6.0, 10.0]);
    }

    /// Everything a query can observe of `s`, with group ids replaced by
    /// the group's plane and material, so that two tables that number the
    /// same groups differently compare equal.
    type Observed = Vec<([Vec3A; 3], Option<(DVec3, f64, MaterialId)>)>;

    fn observed(s: &Surfaces) -> Observed {
        let g = |g: u32| {
            (g != NO_GROUP).then(|| {
                let group = s.group(g);
                (group.plane.normal, group.plane.offset, group.material)
            })
        };
        let mut out: Vec<_> = (0..s.triangle_count())
            .map(|i| {
                let (corners, group) = s.slot(i);
                (*corners, g(group))
            })
            .collect();
        out.extend(s.mesh_group.iter().map(|&m| ([Vec3A::ZERO; 3], g(m))));
        out
    }

    /// A room, a floor panel of the floor's material larger than any floor
    /// triangle (so it gives the floor's group its plane) and a ball, moved
    /// around: the object-by-object update matches a build from scratch
    /// after every move.
    #[test]
    fn updating_one_object_matches_building_everything() {
        use crate::geometry::{shapes, RigidTransform, TriangleMesh};
        use crate::scene::SceneObject;
        use glam::Quat;
        let mut room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
        room.subdivisions = 4;
        let room = room.generate().unwrap();
        let room = TriangleMesh::new(room.positions, room.triangles).unwrap();
        let panel = TriangleMesh::new(
            vec![
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(5.0, 1.0, 0.0),
                Vec3::new(5.0, 4.0, 0.0),
                Vec3::new(1.0, 4.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let object = |name: &str, mesh: TriangleMesh| SceneObject {
            name: name.into(),
            materials: vec![0; mesh.triangle_count()],
            mesh,
            transform: RigidTransform::IDENTITY,
            dynamic: true,
        };
        let scene = Scene {
            materials: vec![Material::uniform("w", 0.1).unwrap()],
            objects: vec![
                object("room", room),
                object("panel", panel),
                object("ball", shapes::icosphere(0.5, 2)),
            ],
        };
        let mut bvh = SceneBvh::build(&scene, &BuildOptions::default());
        let mut surfaces = Surfaces::new(&bvh);
        let floor_groups = surfaces.group_count();
        let spin = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.4);
        let moves = [
            (1, Quat::IDENTITY, Vec3::new(2.0, 0.5, 0.0)),
            (2, spin, Vec3::new(5.0, 3.0, 1.5)),
            (1, Quat::IDENTITY, Vec3::new(2.0, 0.5, 1.0)),
            (2, spin.inverse(), Vec3::new(4.0, 2.0, 1.0)),
            (1, spin, Vec3::new(1.0, 1.0, 1.0)),
            (1, Quat::IDENTITY, Vec3::ZERO),
        ];
        for (object, rotation, shift) in moves {
            let t = RigidTransform::new(rotation, shift).unwrap();
            bvh.set_transform(object, t).unwrap();
            surfaces.update_object(&bvh, object);
            let fresh = Surfaces::new(&bvh);
            assert_eq!(
                surfaces.group_count(),
                fresh.group_count(),
                "{object} {shift}"
            );
            assert_eq!(observed(&surfaces), observed(&fresh), "{object} {shift}");
        }
        assert_eq!(surfaces.group_count(), floor_groups);
    }

    #[test]
    fn mirror_is_an_involution() {
        let p = Plane {
            normal: DVec3::new(0.0, 0.6, 0.8),
            offset: 2.0,
        };
        let x = DVec3::new(1.0, -3.0, 7.5);
        assert!((p.mirror(p.mirror(x)) - x).length() < 1e-12);
        assert!((p.distance(p.mirror(x)) + p.distance(x)).abs() < 1e-12);
    }

    #[test]
    fn zero_area_triangles_have_no_group() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!(triangle_plane(&t).is_none());
    }
}
