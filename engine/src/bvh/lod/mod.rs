//! Ray-traced levels of detail in the hierarchy: R-LODs (Yoon, Lauterbach
//! and Manocha 2006). Every inner node of a mesh tree carries a plane
//! fitted to the triangles below it, and a ray whose footprint is wider
//! than the node's error stops there and meets the plane instead of
//! walking on to the triangles. Features smaller than the error the query
//! allows cost nothing, and the answer says how large an error it took.
//!
//! Fitting is a refit on the tree's topology, like the OBBs of
//! [`super::obb`]: area-weighted moments summed bottom-up give each node's
//! plane by PCA (the covariance's eigenvector of least eigenvalue), then
//! one pass over each node's triangles gives its deviation: the farthest
//! corner from the plane, in f64, rounded up. A node's error combines its
//! size and deviation as the paper does (the radius of a sphere holding
//! the node's bounding sphere and the slab of its deviation, by volume),
//! and is raised to its children's so that it grows towards the root: a
//! query that may use a node may use everything below it.
//!
//! The plane is met only inside the node's box grown by the deviation (the
//! paper's extension against cracks between neighbouring planes). That
//! closes the cracks for rays that meet the surface steeply; a ray grazing
//! it can meet a node's triangles where the plane lies outside the grown
//! box, and pass a crack. Distances are in the ray's units (`t`), errors
//! in the mesh's: they agree for unit directions.
//!
//! ```
//! use frusta_engine::bvh::lod::{closest_hit, LodOptions, LodTree};
//! use frusta_engine::bvh::{BuildOptions, MeshBvh};
//! use frusta_engine::geometry::{shapes, Ray};
//! use glam::Vec3;
//!
//! let sphere = MeshBvh::build(&shapes::icosphere(1.0, 4), &BuildOptions::default());
//! let lods = LodTree::fit(&sphere);
//! let ray = Ray::new(Vec3::new(0.0, 0.0, 10.0), Vec3::NEG_Z);
//! let exact = closest_hit(&sphere, &lods, &ray, &LodOptions::EXACT).unwrap().unwrap();
//! assert_eq!(exact.error, 0.0);
//! let coarse = LodOptions { max_error: 0.5, cone: None };
//! let near = closest_hit(&sphere, &lods, &ray, &coarse).unwrap().unwrap();
//! assert!(near.error > 0.0 && (near.hit.t - exact.hit.t).abs() <= near.error);
//! ```

mod simplify;

use glam::{DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use super::moments::Moments;
use super::ray_queries;
use super::wide::Bvh4;
use super::{MeshBvh, MeshHit};
use crate::geometry::{Aabb, Ray};
use crate::{Error, Result};

pub(crate) use simplify::check_bound;
pub use simplify::{simplify, simplify_scene, simplify_scene_on, Simplified, SimplifiedScene};

/// A node's level of detail: the plane `normal · p = offset`, facing the
/// side most of its triangles face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodPlane {
    pub normal: Vec3,
    pub offset: f32,
    /// Farthest triangle corner below the node from the plane.
    pub deviation: f32,
    /// The error the plane stands for (see the module doc): at least the
    /// node's bounding radius, and at least every descendant's error.
    /// Infinite where no plane fits (no area).
    pub error: f32,
    /// The largest triangle below the node (mesh index): what a hit on
    /// the plane reports, for its material.
    pub triangle: u32,
}

/// A ray's cone: the radius of its footprint is `spread + angle * d` at
/// distance `d` along the ray (`angle`, the tangent of the half-angle,
/// close to the half-angle itself for narrow cones: a pixel's, a frustum
/// cell's or a tail ray's share of the sphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub spread: f32,
    pub angle: f32,
}

/// What error a query allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodOptions {
    /// Largest node error used, in the mesh's units; 0 is exact geometry.
    pub max_error: f32,
    /// Without a cone only `max_error` bounds the nodes used; with one,
    /// also the footprint where the ray enters the node.
    pub cone: Option<Cone>,
}

impl LodOptions {
    /// Exact geometry: no plane is ever used.
    pub const EXACT: Self = Self {
        max_error: 0.0,
        cone: None,
    };

    /// Whether a node of error `error` entered at distance `t` (the ray's
    /// direction of length `dir_length`) stands for its triangles.
    #[inline]
    fn allows(&self, error: f32, t: f32, dir_length: f32) -> bool {
        error < self.max_error
            && self
                .cone
                .is_none_or(|c| error <= c.spread + c.angle * t * dir_length)
    }
}

/// A hit on the triangles or on a level of detail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodHit {
    /// On a plane: its normal, the node's largest triangle, and `u = v = 0`.
    pub hit: MeshHit,
    /// The error of the plane met, in the mesh's units; 0 on a triangle.
    pub error: f32,
}

/// The levels of detail of one mesh tree, node by node.
#[derive(Clone, Debug, Default)]
pub struct LodTree {
    planes: Vec<LodPlane>,
    /// Each plane's error again, packed: the walk reads it at every inner
    /// node, sixteen to a cache line, and the plane only where it is used.
    errors: Vec<f32>,
    /// The smallest error of any node.
    least_error: f32,
    /// The tree's topology and pose when fitted (see [`Bvh4`]).
    fitted: (u64, u64),
}

impl LodTree {
    /// Fits every node's plane to the triangles below it.
    pub fn fit(mesh: &MeshBvh) -> Self {
        let tree = mesh.wide();
        let nodes = &tree.nodes;
        let triangles = mesh.leaf_triangles();
        // Moments and orienting normals, leaves in parallel, then up.
        let leaf_sums = |n: &super::wide::Node4| {
            let mut m = Moments::default();
            let mut facing = DVec3::ZERO;
            for (first, count) in n.leaves() {
                for t in &triangles[first as usize..(first + count) as usize] {
                    m.add(&Moments::triangle(t));
                    facing += area_normal(t);
                }
            }
            (m, facing)
        };
        let mut sums: Vec<(Moments, DVec3)> = nodes.par_iter().map(leaf_sums).collect();
        for i in (0..nodes.len()).rev() {
            for c in nodes[i].inner_children() {
                let (m, f) = sums[c];
                sums[i].0.add(&m);
                sums[i].1 += f;
            }
        }
        let mut planes: Vec<LodPlane> = (0..nodes.len())
            .into_par_iter()
            .map(|i| fit_node(mesh, i, &sums[i]))
            .collect();
        for i in (0..nodes.len()).rev() {
            // A child with no plane (no area: nothing there to hit) never
            // stands for anything, and leaves its ancestors usable.
            for c in nodes[i].inner_children() {
                if planes[c].error.is_finite() {
                    planes[i].error = planes[i].error.max(planes[c].error);
                }
            }
        }
        let errors: Vec<f32> = planes.iter().map(|p| p.error).collect();
        Self {
            least_error: errors.iter().copied().fold(f32::INFINITY, f32::min),
            errors,
            planes,
            fitted: (tree.topology, tree.pose),
        }
    }

    /// The plane of wide node `node`.
    pub fn plane(&self, node: usize) -> &LodPlane {
        &self.planes[node]
    }

    /// The smallest error of any node: a bound at or below it replaces
    /// nothing.
    pub fn least_error(&self) -> f32 {
        self.least_error
    }

    /// Whether these planes were fitted to `mesh` as it is now.
    pub fn fits(&self, mesh: &MeshBvh) -> bool {
        self.fitted == (mesh.wide().topology, mesh.wide().pose)
    }

    pub fn memory_bytes(&self) -> usize {
        self.planes.capacity() * std::mem::size_of::<LodPlane>() + self.errors.capacity() * 4
    }
}

/// `(b - a) x (c - a)`: twice the area along the normal.
fn area_normal(t: &[Vec3A; 3]) -> DVec3 {
    let [a, b, c] = t.map(|p| Vec3::from(p).as_dvec3());
    (b - a).cross(c - a)
}

/// The plane of node `i` from its moments, with its deviation and error.
fn fit_node(mesh: &MeshBvh, i: usize, (moments, facing): &(Moments, DVec3)) -> LodPlane {
    let tree = mesh.wide();
    let triangles = mesh.leaf_triangles();
    let unusable = LodPlane {
        normal: Vec3::Z,
        offset: 0.0,
        deviation: f32::INFINITY,
        error: f32::INFINITY,
        triangle: 0,
    };
    let Some((mean, axes)) = moments.principal() else {
        return unusable;
    };
    let mut normal = axes[0].normalize_or_zero();
    if normal == DVec3::ZERO || !normal.is_finite() {
        return unusable;
    }
    if normal.dot(*facing) < 0.0 {
        normal = -normal;
    }
    // The plane as stored (f32), so the deviation bounds what is met.
    let normal32 = normal.as_vec3();
    let offset32 = normal32.as_dvec3().dot(mean) as f32;
    let (n, offset) = (normal32.as_dvec3(), f64::from(offset32));
    let (mut deviation, mut largest) = (0.0f64, (0.0f64, 0u32));
    for_each_leaf_below(tree, i, |first, count| {
        for slot in first..first + count {
            let t = &triangles[slot as usize];
            for p in t {
                deviation = deviation.max((n.dot(Vec3::from(*p).as_dvec3()) - offset).abs());
            }
            let area = area_normal(t).length();
            if area > largest.0 {
                largest = (area, mesh.prim_ids()[slot as usize]);
            }
        }
    });
    let bounds = tree.nodes[i].aabb();
    let radius = f64::from((bounds.max - bounds.min).length()) * 0.5;
    // The sphere whose volume is the bounding sphere's and the deviation
    // slab's (2 deviation thick over the sphere's great disc) together.
    let error = (radius.powi(3) + 1.5 * deviation * radius * radius).cbrt();
    LodPlane {
        normal: normal32,
        offset: offset32,
        deviation: round_up(deviation),
        error: round_up(error),
        triangle: largest.1,
    }
}

/// `x` as an f32 no smaller than it.
fn round_up(x: f64) -> f32 {
    // x >= 0 here, so the next f32 up is the next bit pattern.
    let y = x as f32;
    if f64::from(y) < x {
        f32::from_bits(y.to_bits() + 1)
    } else {
        y
    }
}

/// Calls `leaf(first, count)` for every leaf below wide node `node`.
fn for_each_leaf_below(tree: &Bvh4, node: usize, mut leaf: impl FnMut(u32, u32)) {
    let mut stack = vec![node];
    while let Some(i) = stack.pop() {
        let n = &tree.nodes[i];
        n.leaves().for_each(|(first, count)| leaf(first, count));
        stack.extend(n.inner_children());
    }
}

/// The nearest hit of `ray` on `mesh`, where every node whose level of
/// detail `options` allows (an error strictly below the bound and at most
/// the cone's footprint where the ray enters the node) is met as its plane
/// (clipped to its box grown by its deviation) instead of its triangles;
/// of a plane and a triangle at one distance, the triangle. Exact (the same answer as
/// [`MeshBvh::closest_hit`]) with [`LodOptions::EXACT`]. Fails when `lods`
/// was not fitted to the mesh as it is now.
pub fn closest_hit(
    mesh: &MeshBvh,
    lods: &LodTree,
    ray: &Ray,
    options: &LodOptions,
) -> Result<Option<LodHit>> {
    if !lods.fits(mesh) {
        return Err(Error::InvalidOption {
            field: "lod".into(),
            reason: "was fitted to another tree than this mesh's, or before it moved; \
                     fit it again"
                .into(),
        });
    }
    let some_plane_allowed = options.max_error > lods.least_error;
    if !some_plane_allowed {
        // No plane can be used: the plain walk, without asking at nodes.
        let hit = mesh.closest_hit(ray);
        return Ok(hit.map(|hit| LodHit { hit, error: 0.0 }));
    }
    let nodes = &mesh.wide().nodes;
    let dir_length = ray.dir.length();
    let mut plane_hit: Option<LodHit> = None;
    let open = |node: usize, entry: f32, t_max: &mut f32| {
        if !options.allows(lods.errors[node], entry, dir_length) {
            return true;
        }
        let lod = &lods.planes[node];
        if let Some(t) = meet_plane(lod, &nodes[node].aabb(), ray, *t_max) {
            // Boxes stay open past it as past a triangle's hit, so a
            // triangle at the same distance is still met (and wins).
            *t_max = t + t.abs() * ray_queries::BOUND_SLACK;
            plane_hit = Some(LodHit {
                hit: MeshHit {
                    t,
                    triangle: lod.triangle,
                    u: 0.0,
                    v: 0.0,
                    normal: lod.normal,
                },
                error: lod.error,
            });
        }
        false
    };
    let triangle_hit = ray_queries::closest_hit_pruned(mesh, ray, open);
    Ok(match (triangle_hit, plane_hit) {
        (Some(h), Some(p)) if h.t <= p.hit.t => Some(LodHit { hit: h, error: 0.0 }),
        (_, Some(p)) => Some(p),
        (Some(h), None) => Some(LodHit { hit: h, error: 0.0 }),
        (None, None) => None,
    })
}

/// Where `ray` meets `lod`'s plane within `[t_min, t_max]` inside `bounds`
/// grown by the deviation.
#[inline]
fn meet_plane(lod: &LodPlane, bounds: &Aabb, ray: &Ray, t_max: f32) -> Option<f32> {
    let n = Vec3A::from(lod.normal);
    let t = (lod.offset - n.dot(ray.origin)) / n.dot(ray.dir);
    if !(t >= ray.t_min && t <= t_max) {
        return None;
    }
    let p = ray.origin + ray.dir * t;
    let scale = bounds.min.abs().max(bounds.max.abs()).max_element();
    let grow = Vec3A::splat(lod.deviation + 1e-6 * scale);
    (p.cmpge(bounds.min - grow).all() && p.cmple(bounds.max + grow).all()).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::geometry::{shapes, TriangleMesh};

    fn bvh(mesh: &TriangleMesh) -> MeshBvh {
        MeshBvh::build(mesh, &BuildOptions::default())
    }

    /// The farthest corner below node `i` from its plane, in f64 from the
    /// mesh itself (not the tree's corner copies).
    fn brute_deviation(mesh: &TriangleMesh, b: &MeshBvh, lod: &LodPlane, i: usize) -> f64 {
        let mut worst = 0.0f64;
        for_each_leaf_below(b.wide(), i, |first, count| {
            for slot in first..first + count {
                let t = mesh.triangles()[b.prim_ids()[slot as usize] as usize];
                for k in t {
                    let p = mesh.positions()[k as usize].as_dvec3();
                    let d = lod.normal.as_dvec3().dot(p) - f64::from(lod.offset);
                    worst = worst.max(d.abs());
                }
            }
        });
        worst
    }

    #[test]
    fn a_tessellated_plane_is_its_own_level_of_detail() {
        // A 1 km square of 2 x 64 x 64 triangles at z = 3, tilted about x.
        let n = 64u32;
        let tilt = glam::Quat::from_rotation_x(0.3);
        let positions: Vec<Vec3> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| (i, j)))
            .map(|(i, j)| {
                let at = |k: u32| 1000.0 * (k as f32 / n as f32 - 0.5);
                tilt * Vec3::new(at(i), at(j), 3.0)
            })
            .collect();
        let corner = |i: u32, j: u32| j * (n + 1) + i;
        let triangles = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let (a, b, c, d) = (
                    corner(i, j),
                    corner(i + 1, j),
                    corner(i + 1, j + 1),
                    corner(i, j + 1),
                );
                [[a, b, c], [a, c, d]]
            })
            .collect();
        let mesh = TriangleMesh::new(positions, triangles).unwrap();
        let b = bvh(&mesh);
        let lods = LodTree::fit(&b);
        let up = tilt * Vec3::Z;
        for i in 0..b.wide().nodes.len() {
            let lod = lods.plane(i);
            assert!(lod.normal.dot(up) > 1.0 - 1e-6, "node {i}: {lod:?}");
            assert!((lod.offset - 3.0).abs() < 1e-3, "node {i}: {lod:?}");
            assert!(lod.deviation < 1e-3, "node {i}: {lod:?}");
        }
    }

    #[test]
    fn deviations_bound_every_corner_and_errors_grow_to_the_root() {
        for mesh in [shapes::icosphere(2.0, 4), shapes::torus(3.0, 1.0, 40, 20)] {
            let b = bvh(&mesh);
            let lods = LodTree::fit(&b);
            let nodes = &b.wide().nodes;
            for (i, node) in nodes.iter().enumerate() {
                let lod = lods.plane(i);
                let brute = brute_deviation(&mesh, &b, lod, i);
                assert!(
                    f64::from(lod.deviation) >= brute,
                    "node {i}: {brute} > {lod:?}"
                );
                assert!(f64::from(lod.deviation) <= brute * 1.001 + 1e-5, "node {i}");
                let radius = (node.aabb().max - node.aabb().min).length() * 0.5;
                // The error is at least the radius; the corners lie in the
                // node's box, at most its diameter from a plane through the
                // mean.
                assert!(lod.error >= radius, "node {i}");
                assert!(lod.deviation <= 2.0 * radius * 1.001 + 1e-5, "node {i}");
                for c in node.inner_children() {
                    assert!(lod.error >= lods.plane(c).error, "node {i} above {c}");
                }
            }
        }
    }

    #[test]
    fn a_sphere_s_deviation_is_within_its_nodes_sagitta() {
        // A cap of a sphere of radius R under a chord of half-length h
        // departs from the best plane by at most its sagitta,
        // R - sqrt(R^2 - h^2), and h is at most the node's radius.
        let r = 2.0f64;
        let mesh = shapes::icosphere(r as f32, 5);
        let b = bvh(&mesh);
        let lods = LodTree::fit(&b);
        let mut checked = 0;
        for (i, n) in b.wide().nodes.iter().enumerate() {
            let h = f64::from((n.aabb().max - n.aabb().min).length()) * 0.5;
            if h < 0.5 * r {
                let sagitta = r - (r * r - h * h).sqrt();
                assert!(f64::from(lods.plane(i).deviation) <= sagitta * 1.01 + 1e-5);
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
    }

    fn rays_from_inside(n: usize) -> Vec<Ray> {
        // Directions on a spiral over the whole sphere, from near the centre.
        (0..n)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f32 + 0.5) / n as f32;
                let phi = k as f32 * 2.399_963;
                let s = (1.0 - z * z).sqrt();
                Ray::new(
                    Vec3::new(0.01, -0.02, 0.03),
                    Vec3::new(s * phi.cos(), s * phi.sin(), z),
                )
            })
            .collect()
    }

    #[test]
    fn queries_that_allow_no_plane_are_the_exact_closest_hit() {
        // Bound 0 takes the plain walk; a zero cone walks past every node
        // through the hook, and must still find the same hits.
        let no_footprint = LodOptions {
            max_error: f32::INFINITY,
            cone: Some(Cone {
                spread: 0.0,
                angle: 0.0,
            }),
        };
        for mesh in [shapes::icosphere(2.0, 4), shapes::torus(3.0, 1.0, 40, 20)] {
            let b = bvh(&mesh);
            let lods = LodTree::fit(&b);
            for ray in rays_from_inside(2000) {
                for options in [LodOptions::EXACT, no_footprint] {
                    let got = closest_hit(&b, &lods, &ray, &options).unwrap();
                    assert_eq!(got.map(|h| h.hit), b.closest_hit(&ray), "{ray:?}");
                    assert!(got.is_none_or(|h| h.error == 0.0));
                }
            }
        }
    }

    #[test]
    fn footprints_count_distance_not_the_ray_parameter() {
        // The same ray with a direction three times as long meets the same
        // plane at a third of the parameter.
        let b = bvh(&shapes::icosphere(2.0, 5));
        let lods = LodTree::fit(&b);
        let options = LodOptions {
            max_error: 1.0,
            cone: Some(Cone {
                spread: 0.01,
                angle: 0.02,
            }),
        };
        let origin = Vec3::new(0.3, 0.2, 30.0);
        let unit = Ray::new(origin, Vec3::NEG_Z);
        let long = Ray::new(origin, Vec3::NEG_Z * 3.0);
        let a = closest_hit(&b, &lods, &unit, &options).unwrap().unwrap();
        let c = closest_hit(&b, &lods, &long, &options).unwrap().unwrap();
        assert!(a.error > 0.0, "{a:?}");
        assert_eq!(a.error, c.error);
        assert!(
            (a.hit.t - 3.0 * c.hit.t).abs() <= 1e-4 * a.hit.t,
            "{a:?} {c:?}"
        );
    }

    #[test]
    fn a_centimetre_patch_gets_its_own_plane() {
        // The covariance of a 1 cm patch in metres lies below the
        // eigensolver's absolute thresholds unless it is scaled: a bowl
        // 1 cm across, flattened to a slope, must still face up.
        let mesh = shapes::icosphere(0.005, 4);
        let bowl: Vec<Vec3> = mesh
            .positions()
            .iter()
            .map(|p| Vec3::new(p.x, p.y, 0.2 * p.z.abs()))
            .collect();
        let bowl = TriangleMesh::new(bowl, mesh.triangles().to_vec()).unwrap();
        let b = bvh(&bowl);
        let lods = LodTree::fit(&b);
        let root = lods.plane(0);
        assert!(root.normal.z.abs() > 0.9, "{root:?}");
        assert!(f64::from(root.deviation) >= brute_deviation(&bowl, &b, root, 0));
    }

    #[test]
    fn no_ray_leaks_out_of_a_closed_mesh_through_lod_cracks() {
        let mesh = shapes::icosphere(2.0, 6);
        let b = bvh(&mesh);
        let lods = LodTree::fit(&b);
        let mut counts = Vec::new();
        for max_error in [0.05, 0.2, 0.5, 1.0] {
            let options = LodOptions {
                max_error,
                cone: None,
            };
            let mut planes = 0;
            for ray in rays_from_inside(20_000) {
                let h = closest_hit(&b, &lods, &ray, &options)
                    .unwrap()
                    .unwrap_or_else(|| panic!("leaked at {max_error}: {ray:?}"));
                planes += usize::from(h.error > 0.0);
                // The displacement along the ray stays within the error
                // (the rays meet the sphere nearly head-on).
                let exact = b.closest_hit(&ray).unwrap();
                assert!((h.hit.t - exact.t).abs() <= h.error, "{max_error}: {h:?}");
            }
            counts.push(planes);
        }
        // More rays stop at planes as the bound grows: the test is not empty.
        assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{counts:?}");
        assert!(counts[0] > 0 && counts[3] > 15_000, "{counts:?}");
    }

    #[test]
    fn a_wider_cone_or_bound_never_walks_deeper() {
        let mesh = shapes::icosphere(2.0, 5);
        let b = bvh(&mesh);
        let lods = LodTree::fit(&b);
        let ray = Ray::new(Vec3::new(0.3, 0.2, 30.0), Vec3::NEG_Z);
        let mut last = f32::INFINITY;
        for (max_error, angle) in [
            (0.0, 0.0),
            (0.1, 0.001),
            (0.1, 0.01),
            (1.0, 0.01),
            (1.0, 0.1),
        ] {
            let options = LodOptions {
                max_error,
                cone: Some(Cone { spread: 0.0, angle }),
            };
            let h = closest_hit(&b, &lods, &ray, &options).unwrap().unwrap();
            // Coarser queries stop at nodes of larger error, never smaller.
            assert!(h.error == 0.0 || last == f32::INFINITY || h.error >= last);
            if h.error > 0.0 {
                last = h.error;
            }
        }
        assert!(last.is_finite(), "the coarsest query used a plane");
    }

    #[test]
    fn stale_planes_are_refused() {
        let mesh = shapes::icosphere(1.0, 2);
        let mut b = bvh(&mesh);
        let lods = LodTree::fit(&b);
        b.refit(&mesh).unwrap();
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(closest_hit(&b, &lods, &ray, &LodOptions::EXACT).is_err());
    }
}
