//! A mesh standing for another within an error bound: the tree's levels of
//! detail cut where their error first falls below the bound. Every highest
//! node whose error is below it becomes one rectangle in its plane, the
//! smallest around its triangles' corners projected there; every triangle
//! not under such a node, and every flat node's, is kept as it is, with
//! its vertices.
//!
//! What a frustum tracer needs in a detailed scene: features smaller than
//! the bound (seats, mouldings, slats) cost nothing, and the simplified
//! mesh is a plain mesh, so every exact method runs on it unchanged and
//! is exact for it. One rectangle per node, not the fan of its hull:
//! rounded to f32, a fan's slivers each get a slightly different plane,
//! so a plane group each, and frusta multiply. Gaps narrower than a node
//! close; neighbouring rectangles share no vertices, and between them are
//! the cracks and overlaps of the R-LOD paper, at most the bound wide.
//!
//! ```
//! use frusta_engine::bvh::lod::simplify;
//! use frusta_engine::geometry::shapes;
//!
//! let sphere = shapes::icosphere(1.0, 4);
//! let coarse = simplify(&sphere, 0.5).unwrap();
//! assert!(coarse.mesh.triangle_count() < sphere.triangle_count() / 4);
//! let exact = simplify(&sphere, 0.0).unwrap();
//! assert_eq!(exact.mesh, sphere);
//! ```

use glam::{DVec2, DVec3, Vec3};

use super::{for_each_leaf_below, LodTree};
use crate::bvh::{BuildOptions, MeshBvh, SceneBvh};
use crate::geometry::TriangleMesh;
use crate::scene::{Scene, SceneObject};
use crate::{Error, Result};

/// A mesh standing for another (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Simplified {
    pub mesh: TriangleMesh,
    /// Per triangle of `mesh`, the original triangle it stands for: itself,
    /// or the largest below a polygon's node (where its material comes
    /// from).
    pub origin: Vec<u32>,
    /// Nodes replaced by their polygons.
    pub polygons: usize,
}

/// `mesh` with every highest node of its tree whose level of detail has
/// an error below `max_error` (in the mesh's units) replaced by its
/// polygon: every corner of `mesh` lies within `max_error` of the result
/// (up to f32 rounding).
/// A bound of 0 (or one below every node's error) gives the mesh itself.
pub fn simplify(mesh: &TriangleMesh, max_error: f32) -> Result<Simplified> {
    check_bound(max_error)?;
    let bvh = MeshBvh::build(mesh, &BuildOptions::default());
    let lods = LodTree::fit(&bvh);
    cut(mesh, &bvh, &lods, max_error)
}

/// Refuses a bound that is not a finite distance of at least 0.
pub(crate) fn check_bound(max_error: f32) -> Result<()> {
    if max_error.is_finite() && max_error >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidOption {
            field: "lod_error_m".into(),
            reason: format!("must be a finite distance of at least 0, not {max_error}"),
        })
    }
}

/// A scene with every object [simplified](simplify) in its own frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifiedScene {
    pub scene: Scene,
    /// Per object, per triangle of its simplified mesh, the original
    /// triangle it stands for (see [`Simplified::origin`]).
    pub origins: Vec<Vec<u32>>,
    /// Nodes replaced by their polygons, over all objects.
    pub polygons: usize,
}

/// `scene` with every object [simplified](simplify) in its own frame, each
/// polygon of the material of the triangle it stands for.
pub fn simplify_scene(scene: &Scene, max_error: f32) -> Result<SimplifiedScene> {
    simplify_objects(scene, max_error, |_, mesh| simplify(mesh, max_error))
}

/// [`simplify_scene`] on the trees `world` holds for `scene`'s objects
/// (built from them, refitted as they moved or deformed): nothing is built
/// again, and each object's levels of detail, fitted on first use, serve
/// every later bound ([`Instance::lods`](crate::bvh::Instance::lods)).
/// Where the trees were built from the objects as they are, the result is
/// [`simplify_scene`]'s; a refitted tree cuts differently, within the same
/// bound. The trees must be of `scene`'s meshes as they are (a tree of
/// other corners would cut by the wrong planes): refused where `world` does
/// not hold one tree per object with the object's triangle count, and
/// checked corner by corner in debug builds.
pub fn simplify_scene_on(
    scene: &Scene,
    world: &SceneBvh,
    max_error: f32,
) -> Result<SimplifiedScene> {
    let instances = world.instances();
    if instances.len() != scene.objects.len() {
        return Err(Error::InvalidScene(format!(
            "{} trees for {} objects",
            instances.len(),
            scene.objects.len()
        )));
    }
    simplify_objects(scene, max_error, |i, mesh| {
        let bvh = instances[i].bvh();
        if bvh.triangle_count() != mesh.triangle_count() {
            return Err(Error::TriangleCountMismatch {
                expected: mesh.triangle_count(),
                actual: bvh.triangle_count(),
            });
        }
        debug_assert!(
            bvh.prim_ids()
                .iter()
                .zip(bvh.leaf_triangles())
                .all(|(&t, corners)| *corners == mesh.corners(t as usize)),
            "object {i}'s tree is not of its mesh"
        );
        cut(mesh, bvh, &instances[i].lods(), max_error)
    })
}

/// `scene` with object `i`'s mesh replaced by `simplify_object(i, mesh)`.
fn simplify_objects(
    scene: &Scene,
    max_error: f32,
    simplify_object: impl Fn(usize, &TriangleMesh) -> Result<Simplified>,
) -> Result<SimplifiedScene> {
    check_bound(max_error)?;
    let mut polygons = 0;
    let mut origins = Vec::with_capacity(scene.objects.len());
    let objects = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let s = simplify_object(i, &o.mesh)?;
            polygons += s.polygons;
            let object = SceneObject {
                materials: s.origin.iter().map(|&t| o.materials[t as usize]).collect(),
                mesh: s.mesh,
                name: o.name.clone(),
                transform: o.transform,
                dynamic: o.dynamic,
            };
            origins.push(s.origin);
            Ok(object)
        })
        .collect::<Result<_>>()?;
    Ok(SimplifiedScene {
        scene: Scene {
            materials: scene.materials.clone(),
            objects,
        },
        origins,
        polygons,
    })
}

/// [`simplify`] with the tree and its planes at hand.
fn cut(mesh: &TriangleMesh, bvh: &MeshBvh, lods: &LodTree, max_error: f32) -> Result<Simplified> {
    if max_error <= lods.least_error || mesh.triangle_count() == 0 {
        return Ok(Simplified {
            mesh: mesh.clone(),
            origin: (0..mesh.triangle_count() as u32).collect(),
            polygons: 0,
        });
    }
    let tree = bvh.wide();
    let mut kept = Vec::new();
    let mut out = Polygons::default();
    let mut stack = vec![0usize];
    let keep_below = |i: usize, kept: &mut Vec<u32>| {
        for_each_leaf_below(tree, i, |first, count| {
            kept.extend_from_slice(&bvh.prim_ids()[first as usize..(first + count) as usize]);
        });
    };
    while let Some(i) = stack.pop() {
        let plane = lods.plane(i);
        // Flat: everything below is flat too, and kept as it is.
        if plane.deviation <= FLAT * plane.error {
            keep_below(i, &mut kept);
            continue;
        }
        if lods.errors[i] < max_error && plane.deviation < max_error && out.add(mesh, bvh, lods, i)
        {
            continue;
        }
        let node = &tree.nodes[i];
        for (first, count) in node.leaves() {
            kept.extend_from_slice(&bvh.prim_ids()[first as usize..(first + count) as usize]);
        }
        stack.extend(node.inner_children());
    }
    kept.sort_unstable();
    // The kept triangles' vertices, renumbered in order, then the polygons'.
    let mut index = vec![u32::MAX; mesh.vertex_count()];
    let mut positions = Vec::new();
    let mut triangles = Vec::with_capacity(kept.len() + out.triangles.len());
    for &t in &kept {
        triangles.push(mesh.triangles()[t as usize].map(|v| {
            let slot = &mut index[v as usize];
            if *slot == u32::MAX {
                *slot = positions.len() as u32;
                positions.push(mesh.positions()[v as usize]);
            }
            *slot
        }));
    }
    let base = positions.len() as u32;
    positions.extend(&out.positions);
    triangles.extend(out.triangles.iter().map(|t| t.map(|v| v + base)));
    let mut origin = kept;
    origin.extend(&out.origin);
    // A rectangle reaches past its node's corners by up to the node's
    // size: near the coordinate limit that is refused like any vertex.
    Ok(Simplified {
        mesh: TriangleMesh::new(positions, triangles)?,
        origin,
        polygons: out.count,
    })
}

/// A node whose corners all lie this close to its plane, relative to its
/// error (about its size), is flat: its triangles are kept, exact. A
/// tessellated wall then stays the one plane it is, where a polygon per
/// node would split it into slightly different planes (one frustum each).
const FLAT: f32 = 1e-4;

/// The polygons of the cut so far.
#[derive(Default)]
struct Polygons {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    origin: Vec<u32>,
    count: usize,
    /// Scratch: the node's corners in the plane.
    points: Vec<DVec2>,
}

impl Polygons {
    /// Node `node`'s polygon: the smallest rectangle in its plane around
    /// its corners projected there, as two triangles wound
    /// counter-clockwise about the plane's normal. False, adding nothing,
    /// where the corners span no area (the node is then walked into).
    ///
    /// The plane is the node's own (least squares), or that of its largest
    /// triangle where every corner lies as close to that one: a polygon of
    /// clutter on a floor then lies in the floor's plane, and reflects with
    /// it as one.
    fn add(&mut self, mesh: &TriangleMesh, bvh: &MeshBvh, lods: &LodTree, node: usize) -> bool {
        let plane = lods.plane(node);
        let triangles = bvh.leaf_triangles();
        let corners = || {
            let mut all = Vec::new();
            for_each_leaf_below(bvh.wide(), node, |first, count| {
                for t in &triangles[first as usize..(first + count) as usize] {
                    all.extend(t.iter().map(|p| Vec3::from(*p).as_dvec3()));
                }
            });
            all
        };
        let corners = corners();
        let own = plane.normal.as_dvec3().normalize();
        let [a, b, c] = mesh
            .corners(plane.triangle as usize)
            .map(|p| Vec3::from(p).as_dvec3());
        let mut largest = (b - a).cross(c - a).normalize_or_zero();
        // Facing the side the node's plane faces (most of its triangles').
        if largest.dot(own) < 0.0 {
            largest = -largest;
        }
        let deviation = |n: DVec3, offset: f64| {
            corners
                .iter()
                .fold(0.0f64, |m, p| m.max((n.dot(*p) - offset).abs()))
        };
        let (normal, offset) = if largest != DVec3::ZERO
            && deviation(largest, largest.dot(a)) <= f64::from(plane.deviation)
        {
            (largest, largest.dot(a))
        } else {
            (own, f64::from(plane.offset))
        };
        let (u, v) = normal.any_orthonormal_pair();
        let centre = normal * offset;
        self.points.clear();
        self.points.extend(corners.iter().map(|p| {
            let p = *p - centre;
            DVec2::new(p.dot(u), p.dot(v))
        }));
        let hull = convex_hull(&mut self.points);
        let Some(rectangle) = smallest_rectangle(&hull) else {
            return false;
        };
        let base = self.positions.len() as u32;
        self.positions.extend(
            rectangle
                .iter()
                .map(|p| (centre + u * p.x + v * p.y).as_vec3()),
        );
        for k in [1, 2] {
            self.triangles.push([base, base + k, base + k + 1]);
            self.origin.push(plane.triangle);
        }
        self.count += 1;
        true
    }
}

/// The rectangle of least area around the convex polygon `hull`
/// (counter-clockwise), its corners counter-clockwise; one side lies on a
/// side of the hull (Freeman and Shapira 1975). `None` for no area.
fn smallest_rectangle(hull: &[DVec2]) -> Option<[DVec2; 4]> {
    if hull.len() < 3 {
        return None;
    }
    let mut best: Option<(f64, [DVec2; 4])> = None;
    for (k, &a) in hull.iter().enumerate() {
        let along = (hull[(k + 1) % hull.len()] - a).normalize_or_zero();
        if along == DVec2::ZERO {
            continue;
        }
        let across = along.perp();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in hull {
            let q = DVec2::new(p.dot(along), p.dot(across));
            (lo, hi) = (lo.min(q), hi.max(q));
        }
        let area = (hi - lo).element_product();
        if best.is_none_or(|(b, _)| area < b) {
            let at = |x: f64, y: f64| along * x + across * y;
            best = Some((
                area,
                [
                    at(lo.x, lo.y),
                    at(hi.x, lo.y),
                    at(hi.x, hi.y),
                    at(lo.x, hi.y),
                ],
            ));
        }
    }
    best.filter(|(area, _)| *area > 0.0).map(|(_, r)| r)
}

/// The convex hull of `points`, counter-clockwise, without collinear
/// points (Andrew's monotone chain: the lower chain left to right, then
/// the upper right to left); sorts `points`.
fn convex_hull(points: &mut [DVec2]) -> Vec<DVec2> {
    points.sort_unstable_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    let extend = |hull: &mut Vec<DVec2>, p: DVec2, floor: usize| {
        while hull.len() >= floor + 2 {
            let (o, a) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            if (a - o).perp_dot(p - o) > 0.0 {
                break;
            }
            hull.pop();
        }
        hull.push(p);
    };
    for &p in points.iter() {
        extend(&mut hull, p, 0);
    }
    hull.pop();
    let floor = hull.len();
    for &p in points.iter().rev() {
        extend(&mut hull, p, floor);
    }
    hull.pop();
    hull
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::closest_on_triangle;
    use crate::geometry::shapes;
    use crate::scene::Material;

    fn corners64(mesh: &TriangleMesh, t: usize) -> [DVec3; 3] {
        mesh.corners(t).map(|p| Vec3::from(p).as_dvec3())
    }

    /// The distance from `p` to `mesh` in f64, triangle by triangle
    /// (Ericson's closest point, from collision): the reference the
    /// simplification is checked against.
    fn distance_to(mesh: &TriangleMesh, p: DVec3) -> f64 {
        (0..mesh.triangle_count())
            .map(|t| p.distance(closest_on_triangle(p, corners64(mesh, t))))
            .fold(f64::INFINITY, f64::min)
    }

    /// A sphere (every node curved) at three bounds and three scales:
    /// fewer triangles as the bound grows, every original corner within
    /// the bound of the simplified surface, every triangle wound outwards,
    /// and every new corner within three bounds of an original one (a
    /// node's rectangle spans at most its diameter).
    #[test]
    fn every_corner_stays_within_the_bound() {
        for scale in [1e-3f32, 1.0, 1e4] {
            let sphere = shapes::icosphere(2.0 * scale, 4);
            let mut last = sphere.triangle_count();
            for bound in [0.3f32, 0.6, 1.2].map(|b| b * scale) {
                let s = simplify(&sphere, bound).unwrap();
                let at = format!("scale {scale}, bound {bound}");
                assert!(s.polygons > 0, "{at}: nothing simplified");
                assert!(s.mesh.triangle_count() < last, "{at}");
                last = s.mesh.triangle_count();
                for p in sphere.positions() {
                    let d = distance_to(&s.mesh, p.as_dvec3());
                    assert!(d <= f64::from(bound), "{at}: corner {p} is {d} away");
                }
                for t in 0..s.mesh.triangle_count() {
                    let [a, b, c] = corners64(&s.mesh, t);
                    assert!((b - a).cross(c - a).dot(a + b + c) > 0.0, "{at}: {t}");
                }
                for p in s.mesh.positions() {
                    let nearest = sphere
                        .positions()
                        .iter()
                        .map(|q| q.as_dvec3().distance(p.as_dvec3()))
                        .fold(f64::INFINITY, f64::min);
                    assert!(nearest <= 3.0 * f64::from(bound), "{at}: {p}");
                }
            }
        }
    }

    /// A tessellated tilted floor far from the origin is flat however large
    /// the bound: its triangles are kept as they are (one plane, not one
    /// per node).
    #[test]
    fn a_flat_floor_is_kept_exact() {
        let tilt = glam::Quat::from_rotation_x(0.3);
        let n = 16u32;
        let positions: Vec<Vec3> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| tilt * Vec3::new(i as f32, j as f32, 2.0)))
            .map(|p| p + Vec3::new(1000.0, -3000.0, 500.0))
            .collect();
        let corner = |i: u32, j: u32| j * (n + 1) + i;
        let triangles: Vec<[u32; 3]> = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let (a, b) = (corner(i, j), corner(i + 1, j));
                let (c, d) = (corner(i + 1, j + 1), corner(i, j + 1));
                [[a, b, c], [a, c, d]]
            })
            .collect();
        let floor = TriangleMesh::new(positions, triangles).unwrap();
        let s = simplify(&floor, 100.0).unwrap();
        assert_eq!(s.polygons, 0);
        let key = |m: &TriangleMesh, t: usize| m.corners(t).map(|p| Vec3::from(p).to_array());
        let mut before: Vec<_> = (0..floor.triangle_count())
            .map(|t| key(&floor, t))
            .collect();
        let mut after: Vec<_> = (0..s.mesh.triangle_count())
            .map(|t| key(&s.mesh, t))
            .collect();
        before.sort_by(|a, b| a.partial_cmp(b).unwrap());
        after.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(before, after);
    }

    /// Polygons take the material of what they stand for: a ball of one
    /// material above a floor of another, simplified together, keeps the
    /// floor's material on the floor and the ball's everywhere else.
    #[test]
    fn polygons_keep_their_material() {
        let ball = shapes::icosphere(0.5, 3);
        let mut positions: Vec<Vec3> = ball
            .positions()
            .iter()
            .map(|p| *p + Vec3::new(0.0, 0.0, 2.0))
            .collect();
        let mut triangles = ball.triangles().to_vec();
        let base = positions.len() as u32;
        positions.extend([
            Vec3::new(-5.0, -5.0, 0.0),
            Vec3::new(5.0, -5.0, 0.0),
            Vec3::new(5.0, 5.0, 0.0),
            Vec3::new(-5.0, 5.0, 0.0),
        ]);
        triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        let raw = crate::scene::RawMesh {
            positions,
            triangles,
            ..Default::default()
        };
        let mut scene =
            Scene::single_object("room", raw, Material::uniform("ball", 0.1).unwrap()).unwrap();
        scene
            .materials
            .push(Material::uniform("floor", 0.5).unwrap());
        let count = scene.objects[0].materials.len();
        scene.objects[0].materials[count - 2..].fill(1);
        let simple = simplify_scene(&scene, 0.4).unwrap();
        assert!(simple.polygons > 0);
        let o = &simple.scene.objects[0];
        assert_eq!(simple.origins[0].len(), o.mesh.triangle_count());
        assert!(o.mesh.triangle_count() < count);
        for (t, &m) in o.materials.iter().enumerate() {
            let on_floor = o.mesh.corners(t).iter().all(|p| p.z == 0.0);
            assert_eq!(m, u16::from(on_floor), "triangle {t}");
        }
    }

    /// A scene of one object, `mesh`.
    fn ball(mesh: &TriangleMesh) -> Scene {
        let raw = crate::scene::RawMesh {
            positions: mesh.positions().to_vec(),
            triangles: mesh.triangles().to_vec(),
            ..Default::default()
        };
        Scene::single_object("ball", raw, Material::uniform("m", 0.1).unwrap()).unwrap()
    }

    /// Cut on a scene's own trees: as a fresh build cuts where the trees
    /// were built from the objects as they are; after a deformation the
    /// tree was only refitted for (its levels of detail fitted before it),
    /// every corner still within the bound; refused on trees of another
    /// scene.
    #[test]
    fn a_scenes_own_trees_cut_within_the_bound() {
        let sphere = shapes::icosphere(2.0, 4);
        let mut scene = ball(&sphere);
        let mut world = SceneBvh::build(&scene, &BuildOptions::default());
        assert_eq!(
            simplify_scene_on(&scene, &world, 0.6).unwrap(),
            simplify_scene(&scene, 0.6).unwrap()
        );
        let squashed: Vec<Vec3> = sphere
            .positions()
            .iter()
            .map(|p| Vec3::new(1.5 * p.x, p.y, 0.4 * p.z))
            .collect();
        let mesh = TriangleMesh::new(squashed, sphere.triangles().to_vec()).unwrap();
        let materials = scene.objects[0].materials.clone();
        let report = world
            .update_mesh(0, &mesh, &materials, f32::INFINITY)
            .unwrap();
        assert_eq!(report.action, crate::bvh::UpdateAction::Refit);
        scene.objects[0].mesh = mesh.clone();
        for bound in [0.3f32, 0.6] {
            let s = simplify_scene_on(&scene, &world, bound).unwrap();
            let cut = &s.scene.objects[0].mesh;
            assert!(s.polygons > 0 && cut.triangle_count() < mesh.triangle_count());
            for p in mesh.positions() {
                let d = distance_to(cut, p.as_dvec3());
                assert!(
                    d <= f64::from(bound),
                    "bound {bound}: corner {p} is {d} away"
                );
            }
        }
        let other = ball(&shapes::icosphere(1.0, 2));
        assert!(simplify_scene_on(&other, &world, 0.6).is_err());
    }

    /// Trees of other corners with the same triangle count are caught in
    /// debug builds, not cut by the wrong planes.
    #[cfg(debug_assertions)]
    #[test]
    #[should_panic(expected = "tree is not of its mesh")]
    fn trees_of_other_corners_are_caught() {
        let world = SceneBvh::build(&ball(&shapes::icosphere(2.0, 2)), &BuildOptions::default());
        let _ = simplify_scene_on(&ball(&shapes::icosphere(1.0, 2)), &world, 0.5);
    }

    #[test]
    fn bounds_must_be_finite_distances() {
        let sphere = shapes::icosphere(1.0, 1);
        for bad in [f32::NAN, -1.0, f32::INFINITY] {
            let e = simplify(&sphere, bad).unwrap_err().to_string();
            assert!(e.contains("lod_error_m"), "{e}");
        }
    }

    /// The hull drops inner and collinear points; the rectangle around a
    /// turned square is the square itself.
    #[test]
    fn hull_and_rectangle_of_a_turned_square() {
        let turn = glam::DMat2::from_angle(0.4);
        let square = [
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (0.0, 1.0),
            (0.5, 0.0),
            (0.3, 0.6),
        ]
        .map(|(x, y)| turn * DVec2::new(x, y));
        let hull = convex_hull(&mut square.to_vec());
        assert_eq!(hull.len(), 4);
        let area: f64 = (0..4)
            .map(|k| hull[k].perp_dot(hull[(k + 1) % 4]))
            .sum::<f64>()
            / 2.0;
        assert!((area - 1.0).abs() < 1e-12, "counter-clockwise, area {area}");
        let r = smallest_rectangle(&hull).unwrap();
        let sides = (r[1] - r[0]).length() * (r[3] - r[0]).length();
        assert!((sides - 1.0).abs() < 1e-12, "{r:?}");
        assert!(smallest_rectangle(&hull[..2]).is_none());
        assert!(convex_hull(&mut [DVec2::ONE; 5]).len() < 3);
    }
}
