//! The reflecting surfaces of a scene as sound sees them: every triangle in
//! world space, grouped into planes.
//!
//! Specular paths depend on planes, not on triangles: an image source is the
//! source mirrored in a plane, and a wall split into many triangles mirrors
//! like one. Grouping coplanar triangles of one material lets a frustum that
//! straddles two triangles of a wall spawn one secondary frustum instead of
//! two, and gives each image source one canonical plane, so that the same
//! path found by neighbouring frusta is recognised as the same.

use std::collections::HashMap;

use glam::{DQuat, DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use crate::query::SceneBvh;
use crate::scene::MaterialId;

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
    /// Leaf-order slot (within its object) of each triangle, in mesh order.
    mesh_slot: Vec<u32>,
    groups: Vec<SurfaceGroup>,
    /// Length of the scene box's diagonal: the scale of every tolerance.
    scale: f64,
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
        let mut corners = Vec::with_capacity(total as usize);
        let mut materials = Vec::with_capacity(total as usize);
        for i in bvh.instances() {
            corners.par_extend(i.bvh().leaf_triangles().par_iter().map(|tri| {
                tri.map(|p| {
                    if i.is_identity() {
                        p
                    } else {
                        i.to_world().transform_point(p)
                    }
                })
            }));
            materials.extend(
                i.bvh()
                    .prim_ids()
                    .iter()
                    .map(|&t| i.materials().get(t as usize).copied().unwrap_or(0)),
            );
        }
        let b = bvh.bounds();
        let scale = if b.is_empty() {
            1.0
        } else {
            f64::from((b.max - b.min).length()).max(f64::MIN_POSITIVE)
        };
        // Planes from the object-frame vertices moved in f64: world
        // corners are rounded to f32, which would tilt a rotated wall's
        // plane by up to 1e-7 and move a fourth-order image by tens of
        // micrometres.
        let mut planes = Vec::with_capacity(total as usize);
        for i in bvh.instances() {
            let q = i.to_world().rotation;
            let rotation =
                DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
            let translation = i.to_world().translation.as_dvec3();
            planes.par_extend(i.bvh().leaf_triangles().par_iter().map(|tri| {
                triangle_plane(&tri.map(|p| rotation * DVec3::from(Vec3::from(p)) + translation))
            }));
        }
        let (slot_group, groups) = group_planes(&planes, &materials, scale);
        let mut mesh_group = vec![NO_GROUP; total as usize];
        let mut mesh_slot = vec![0; total as usize];
        for (o, i) in bvh.instances().iter().enumerate() {
            let base = object_base[o] as usize;
            for (slot, &t) in i.bvh().prim_ids().iter().enumerate() {
                mesh_group[base + t as usize] = slot_group[base + slot];
                mesh_slot[base + t as usize] = slot as u32;
            }
        }
        Self {
            object_base,
            corners,
            slot_group,
            mesh_group,
            mesh_slot,
            groups,
            scale,
        }
    }

    pub fn groups(&self) -> &[SurfaceGroup] {
        &self.groups
    }

    pub fn group(&self, g: u32) -> &SurfaceGroup {
        &self.groups[g as usize]
    }

    /// Diagonal of the scene's bounding box, in metres.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    pub fn triangle_count(&self) -> usize {
        self.corners.len()
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

    /// A triangle of `group` containing `p` (a point on the group's plane)
    /// to within `tol` metres, as `(object, mesh-order triangle)`. A linear
    /// scan: for points on an edge between planes, where a ray query
    /// reports either side.
    pub fn triangle_at(&self, group: u32, p: DVec3, tol: f64) -> Option<(u32, u32)> {
        let flat = (0..self.mesh_group.len()).find(|&i| {
            if self.mesh_group[i] != group {
                return false;
            }
            let object = self.object_base.partition_point(|&b| b as usize <= i) - 1;
            let slot = self.mesh_slot[i] as usize + self.object_base[object] as usize;
            let [a, b, c] = self.corners[slot].map(|q| DVec3::from(glam::Vec3::from(q)));
            let n = (b - a).cross(c - a).normalize_or_zero();
            [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| {
                let edge = v - u;
                let len = edge.length();
                len > 0.0 && edge.cross(p - u).dot(n) / len >= -tol
            })
        })?;
        let object = self.object_base.partition_point(|&b| b as usize <= flat) - 1;
        Some((
            object as u32,
            (flat - self.object_base[object] as usize) as u32,
        ))
    }
}

/// Assigns each triangle a group of coplanar triangles with its material.
///
/// Planes are matched by quantising the normal (sign made canonical, since a
/// two-sided partition mirrors the same way from either side) and the
/// offset; each group's plane is that of its largest triangle, the most
/// accurately known. Coplanar triangles that straddle a quantisation step
/// land in two groups, which costs one extra frustum, never a path.
fn group_planes(
    planes: &[Option<(Plane, f64)>],
    materials: &[MaterialId],
    scale: f64,
) -> (Vec<u32>, Vec<SurfaceGroup>) {
    const NORMAL_STEP: f64 = 1e-5;
    let offset_step = scale * 1e-6;
    let mut index: HashMap<(i64, i64, i64, i64, MaterialId), u32> = HashMap::new();
    let mut groups: Vec<SurfaceGroup> = Vec::new();
    let mut best_area: Vec<f64> = Vec::new();
    let slot_group = planes
        .iter()
        .zip(materials)
        .map(|(plane, &material)| {
            let Some((plane, area)) = plane else {
                return NO_GROUP;
            };
            let q = |x: f64, step: f64| (x / step).round() as i64;
            let key = (
                q(plane.normal.x, NORMAL_STEP),
                q(plane.normal.y, NORMAL_STEP),
                q(plane.normal.z, NORMAL_STEP),
                q(plane.offset, offset_step),
                material,
            );
            let g = *index.entry(key).or_insert_with(|| {
                groups.push(SurfaceGroup {
                    plane: *plane,
                    material,
                });
                best_area.push(0.0);
                groups.len() as u32 - 1
            });
            if *area > best_area[g as usize] {
                best_area[g as usize] = *area;
                groups[g as usize].plane = *plane;
            }
            g
        })
        .collect();
    (slot_group, groups)
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
        assert_eq!(s.groups().len(), 6);
        let mut offsets: Vec<f64> = s.groups().iter().map(|g| g.plane.offset).collect();
        offsets.sort_by(f64::total_cmp);
        assert_eq!(offsets, vec![0.0, 0.0, 0.0, 3.0, 6.0, 10.0]);
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
