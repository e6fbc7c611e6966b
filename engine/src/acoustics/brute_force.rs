//! The independent reference: every specular path found by brute force in
//! `f64`, from the scene description alone.
//!
//! Every accuracy claim of the frustum tracer is checked against this
//! module, so it shares nothing with the tracer's exact stage: no BVH, no
//! ray query, no plane groups ([`Surfaces`](super::surfaces)), no
//! validation ([`path`](super::path)), no gains
//! ([`propagation`](super::propagation)). It reads a [`Scene`] (meshes,
//! transforms, materials), moves every triangle into world space in `f64`,
//! and then
//! - groups triangles into planar faces by their plane alone (material
//!   does not split a face: a door in a wall mirrors like the wall);
//! - enumerates every sequence of reflections and transmissions over the
//!   faces, up to the order asked for, never the same face twice in a row;
//! - constructs each sequence's points backwards from the listener through
//!   the image sources, and requires every point to lie inside a triangle
//!   of its face (a transmission inside a triangle whose material
//!   transmits);
//! - tests every leg for occlusion against every triangle of the scene;
//! - computes the pressure gain from the closed form: the product over the
//!   events of `√(1 − α)` (reflection) or `√τ` (transmission) of the
//!   triangle met, over the path length, times the air's attenuation.
//!
//! It is slow on purpose (faces^order sequences, each leg against every
//! triangle) and serves tests and benchmarks only. Its own tests check it
//! against the closed-form image sources of a box and hand-built cases.
//!
//! ```
//! use frusta_engine::acoustics::brute_force::BruteForce;
//! use frusta_engine::scene::{generate::BoxRoom, Material, Scene};
//! use glam::{DVec3, Vec3};
//!
//! let room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0)).generate().unwrap();
//! let scene = Scene::single_object("room", room, Material::uniform("w", 0.1).unwrap()).unwrap();
//! let reference = BruteForce::new(&scene);
//! let paths = reference.paths(DVec3::new(2.0, 3.0, 1.5), DVec3::new(7.0, 2.0, 1.2), 1, None);
//! // The direct path and one reflection off each of the six walls.
//! assert_eq!(paths.len(), 7);
//! ```

use glam::{DQuat, DVec3};
use rayon::prelude::*;

use crate::scene::{Material, MaterialId, Scene, BAND_COUNT};

/// Closer than this, spherical spreading is held at its value here (the
/// tracer's convention for a source at the listener).
const MIN_SPREADING_M: f64 = 1e-3;
/// Two unit normals closer than this (`1 - cos`) belong to one plane.
const SAME_NORMAL: f64 = 1e-10;
/// Two offsets closer than this, relative to the scene's size, belong to
/// one plane.
const SAME_OFFSET: f64 = 1e-9;
/// A point whose barycentric coordinates are all above `-INSIDE` lies in
/// the triangle: rounding of the constructed point, relative to the
/// triangle's size.
const INSIDE: f64 = 1e-9;
/// Intersections within this fraction of a leg's ends are the surfaces
/// the leg starts or ends on, or the listener's and source's own walls.
const LEG_END: f64 = 1e-9;

/// One surface a reference path meets.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceEvent {
    pub transmission: bool,
    /// Object index in the scene and triangle index in its mesh.
    pub object: usize,
    pub triangle: usize,
    pub material: MaterialId,
    /// The face's unit normal (sign canonical) and offset, `normal · p =
    /// offset`.
    pub normal: DVec3,
    pub offset: f64,
    pub point: DVec3,
}

/// One specular path of the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferencePath {
    /// The source mirrored in every reflecting face, in order.
    pub image_source: DVec3,
    pub events: Vec<ReferenceEvent>,
    /// Sum of the legs, metres.
    pub length: f64,
    /// Linear pressure amplitude per octave band, relative to the source
    /// level at 1 m.
    pub pressure_gain: [f64; BAND_COUNT],
}

impl ReferencePath {
    pub fn order(&self) -> usize {
        self.events.len()
    }
}

struct WorldTriangle {
    corners: [DVec3; 3],
    object: usize,
    triangle: usize,
    material: MaterialId,
    face: usize,
}

/// Coplanar triangles.
struct Face {
    normal: DVec3,
    offset: f64,
    triangles: Vec<usize>,
    transmits: bool,
}

impl Face {
    fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    fn mirror(&self, p: DVec3) -> DVec3 {
        p - 2.0 * self.distance(p) * self.normal
    }
}

/// One step of a sequence: a face, and whether sound passes through it.
#[derive(Clone, Copy)]
struct Step {
    face: usize,
    transmission: bool,
}

/// A scene prepared for brute-force path search.
pub struct BruteForce {
    triangles: Vec<WorldTriangle>,
    faces: Vec<Face>,
    materials: Vec<Material>,
    steps: Vec<Step>,
}

impl BruteForce {
    /// Moves every triangle of `scene` into world space (in `f64`, from the
    /// object-frame vertices and the object's rotation and translation)
    /// and groups them into planar faces. Triangles without area are left
    /// out: they reflect nothing and block nothing.
    pub fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::new();
        for (o, object) in scene.objects.iter().enumerate() {
            let q = object.transform.rotation;
            let rotation =
                DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
            let translation = object.transform.translation.as_dvec3();
            let positions = object.mesh.positions();
            for (t, tri) in object.mesh.triangles().iter().enumerate() {
                let corners =
                    tri.map(|i| rotation * positions[i as usize].as_dvec3() + translation);
                triangles.push(WorldTriangle {
                    corners,
                    object: o,
                    triangle: t,
                    material: object.materials[t],
                    face: usize::MAX,
                });
            }
        }
        let scale = triangles
            .iter()
            .flat_map(|t| t.corners)
            .fold(1.0f64, |m, p| m.max(p.abs().max_element()));
        let mut faces: Vec<Face> = Vec::new();
        for (i, t) in triangles.iter_mut().enumerate() {
            let [a, b, c] = t.corners;
            let Some(normal) = canonical(normal_of(a, b, c)) else {
                continue;
            };
            let offset = normal.dot(a);
            let transmits = scene
                .materials
                .get(usize::from(t.material))
                .is_some_and(Material::transmits);
            let same = faces.iter().position(|f| {
                1.0 - f.normal.dot(normal) < SAME_NORMAL
                    && (f.offset - offset).abs() < SAME_OFFSET * scale
            });
            t.face = match same {
                Some(f) => {
                    faces[f].triangles.push(i);
                    faces[f].transmits |= transmits;
                    f
                }
                None => {
                    faces.push(Face {
                        normal,
                        offset,
                        triangles: vec![i],
                        transmits,
                    });
                    faces.len() - 1
                }
            };
        }
        // A face's plane is its largest triangle's, through its centroid:
        // where f32 vertices leave a face's triangles a hair off coplanar,
        // the largest is the most accurately known.
        for face in &mut faces {
            let area = |t: &usize| {
                let [a, b, c] = triangles[*t].corners;
                normal_of(a, b, c).length()
            };
            let largest = face
                .triangles
                .iter()
                .max_by(|x, y| area(x).total_cmp(&area(y)))
                .map(|&t| triangles[t].corners);
            if let Some([a, b, c]) = largest {
                face.normal = canonical(normal_of(a, b, c)).unwrap_or(face.normal);
                face.offset = face.normal.dot((a + b + c) / 3.0);
            }
        }
        let steps = faces
            .iter()
            .enumerate()
            .flat_map(|(face, f)| {
                let reflect = Step {
                    face,
                    transmission: false,
                };
                let transmit = Step {
                    face,
                    transmission: true,
                };
                std::iter::once(reflect).chain(f.transmits.then_some(transmit))
            })
            .collect();
        Self {
            triangles,
            faces,
            materials: scene.materials.clone(),
            steps,
        }
    }

    /// How many planar faces the scene has.
    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// How many event sequences [`Self::paths`] tries up to `max_order`:
    /// what its time grows with (each one costs a few point-in-face tests,
    /// and the survivors a leg test against every triangle).
    pub fn sequence_count(&self, max_order: usize) -> f64 {
        let e = self.steps.len() as f64;
        // After the first event, every event but those on the same face.
        let next = (e - 1.0).max(0.0);
        (0..max_order).map(|k| e * next.powi(k as i32)).sum::<f64>() + 1.0
    }

    /// Every specular path from `source` to `listener` of order at most
    /// `max_order`, sorted by length (ties by image source). With
    /// `air_db_per_m` (the attenuation coefficient per octave band), the
    /// gains include air absorption, `10^(−a·L/20)`.
    pub fn paths(
        &self,
        source: DVec3,
        listener: DVec3,
        max_order: usize,
        air_db_per_m: Option<&[f64; BAND_COUNT]>,
    ) -> Vec<ReferencePath> {
        let mut found: Vec<ReferencePath> = self
            .path(source, listener, &[], &[source], air_db_per_m)
            .into_iter()
            .collect();
        if max_order > 0 {
            found.par_extend(self.steps.par_iter().flat_map_iter(|&first| {
                let mut out = Vec::new();
                let mut sequence = vec![first];
                let mut images = vec![source, self.image(source, first)];
                self.extend(
                    listener,
                    max_order,
                    &mut sequence,
                    &mut images,
                    air_db_per_m,
                    &mut out,
                );
                out
            }));
        }
        found.sort_by(|a, b| {
            let (p, q) = (a.image_source, b.image_source);
            a.length
                .total_cmp(&b.length)
                .then(p.x.total_cmp(&q.x))
                .then(p.y.total_cmp(&q.y))
                .then(p.z.total_cmp(&q.z))
        });
        found
    }

    fn image(&self, p: DVec3, step: Step) -> DVec3 {
        if step.transmission {
            p
        } else {
            self.faces[step.face].mirror(p)
        }
    }

    /// Tries `sequence` and every continuation of it, depth first;
    /// `images[i]` is the source seen through `sequence[..i]`.
    fn extend(
        &self,
        listener: DVec3,
        max_order: usize,
        sequence: &mut Vec<Step>,
        images: &mut Vec<DVec3>,
        air_db_per_m: Option<&[f64; BAND_COUNT]>,
        out: &mut Vec<ReferencePath>,
    ) {
        out.extend(self.path(images[0], listener, sequence, images, air_db_per_m));
        if sequence.len() == max_order {
            return;
        }
        let last = sequence.last().map(|s| s.face);
        for &step in &self.steps {
            if Some(step.face) == last {
                continue;
            }
            let image = self.image(*images.last().unwrap(), step);
            sequence.push(step);
            images.push(image);
            self.extend(listener, max_order, sequence, images, air_db_per_m, out);
            sequence.pop();
            images.pop();
        }
    }

    /// The path `sequence` defines, if it is one.
    fn path(
        &self,
        source: DVec3,
        listener: DVec3,
        sequence: &[Step],
        images: &[DVec3],
        air_db_per_m: Option<&[f64; BAND_COUNT]>,
    ) -> Option<ReferencePath> {
        // Backwards from the listener: event i's point is where the line
        // from images[i + 1] to the next point crosses face i.
        let mut points = vec![listener; sequence.len() + 2];
        points[0] = source;
        let mut hit = vec![0; sequence.len()];
        for i in (0..sequence.len()).rev() {
            let face = &self.faces[sequence[i].face];
            let (from, to) = (images[i + 1], points[i + 2]);
            let (df, dt) = (face.distance(from), face.distance(to));
            // The face must separate the image from the point (a NaN
            // product separates nothing).
            if df * dt >= 0.0 || (df * dt).is_nan() {
                return None;
            }
            let p = from + (to - from) * (df / (df - dt));
            hit[i] = *face.triangles.iter().find(|&&t| {
                let tri = &self.triangles[t];
                inside(&tri.corners, p)
                    && (!sequence[i].transmission
                        || self.materials[usize::from(tri.material)].transmits())
            })?;
            points[i + 1] = p;
        }
        for leg in 0..=sequence.len() {
            let leaves = leg.checked_sub(1).map(|i| sequence[i].face);
            let enters = sequence.get(leg).map(|s| s.face);
            if self.blocked(points[leg], points[leg + 1], leaves, enters) {
                return None;
            }
        }
        let length: f64 = points.windows(2).map(|w| w[0].distance(w[1])).sum();
        let mut gain = [1.0 / length.max(MIN_SPREADING_M); BAND_COUNT];
        let events: Vec<ReferenceEvent> = sequence
            .iter()
            .zip(&hit)
            .zip(&points[1..])
            .map(|((step, &t), &point)| {
                let tri = &self.triangles[t];
                let m = &self.materials[usize::from(tri.material)];
                for (b, g) in gain.iter_mut().enumerate() {
                    *g *= if step.transmission {
                        f64::from(m.transmission[b]).sqrt()
                    } else {
                        (1.0 - f64::from(m.absorption[b])).sqrt()
                    };
                }
                let face = &self.faces[step.face];
                ReferenceEvent {
                    transmission: step.transmission,
                    object: tri.object,
                    triangle: tri.triangle,
                    material: tri.material,
                    normal: face.normal,
                    offset: face.offset,
                    point,
                }
            })
            .collect();
        if let Some(air) = air_db_per_m {
            for (g, a) in gain.iter_mut().zip(air) {
                *g *= 10f64.powf(-a * length / 20.0);
            }
        }
        Some(ReferencePath {
            image_source: *images.last()?,
            events,
            length,
            pressure_gain: gain,
        })
    }

    /// Whether any triangle crosses the open segment `a`–`b`; triangles of
    /// the faces the segment leaves and enters are skipped (a straight leg
    /// meets its own faces only at its ends).
    fn blocked(&self, a: DVec3, b: DVec3, leaves: Option<usize>, enters: Option<usize>) -> bool {
        self.triangles.iter().any(|t| {
            t.face != usize::MAX
                && Some(t.face) != leaves
                && Some(t.face) != enters
                && crosses(&t.corners, a, b)
        })
    }
}

/// The (unnormalised) normal of a triangle.
fn normal_of(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a)
}

/// The unit normal with a fixed sign (its first clearly non-zero component
/// positive), so both windings of a plane compare equal; `None` without
/// area.
fn canonical(n: DVec3) -> Option<DVec3> {
    let n = n.try_normalize()?;
    let first = n
        .to_array()
        .into_iter()
        .find(|c| c.abs() > 1e-6)
        .unwrap_or(1.0);
    Some(if first < 0.0 { -n } else { n })
}

/// Whether `p`, a point on the triangle's plane, lies in it (boundary
/// included, up to rounding): barycentric coordinates from sub-areas.
fn inside(corners: &[DVec3; 3], p: DVec3) -> bool {
    let [a, b, c] = *corners;
    let n = normal_of(a, b, c);
    let area = n.length_squared();
    [(a, b), (b, c), (c, a)]
        .into_iter()
        .all(|(u, v)| normal_of(u, v, p).dot(n) >= -INSIDE * area)
}

/// Whether the segment `a`–`b` crosses the triangle strictly between its
/// ends (Möller–Trumbore in `f64`, boundary included). A segment in the
/// triangle's plane does not cross it.
fn crosses(corners: &[DVec3; 3], a: DVec3, b: DVec3) -> bool {
    let [v0, v1, v2] = *corners;
    let (e1, e2, d) = (v1 - v0, v2 - v0, b - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() <= 1e-14 * d.length() * e1.length() * e2.length() {
        return false;
    }
    let s = a - v0;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    let edge = -1e-12;
    u >= edge && v >= edge && u + v <= 1.0 - edge && t > LEG_END && t < 1.0 - LEG_END
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::TriangleMesh;
    use crate::scene::generate::BoxRoom;
    use crate::scene::SceneObject;
    use glam::Vec3;

    const SIZE: DVec3 = DVec3::new(10.0, 6.0, 3.0);

    /// Absorption of wall `w` in band `b`: different for every wall and band.
    fn alpha(w: usize, b: usize) -> f32 {
        0.02 + 0.03 * w as f32 + 0.05 * b as f32
    }

    fn material(name: &str, absorption: [f32; BAND_COUNT], transmission: f32) -> Material {
        Material {
            name: name.into(),
            absorption,
            scattering: [0.0; BAND_COUNT],
            transmission: [transmission; BAND_COUNT],
        }
    }

    /// The 10 x 6 x 3 m box, walls split `subdivisions` times, with wall
    /// `2 * axis + (side at max)` made of material of the same index.
    fn box_scene(subdivisions: u32) -> Scene {
        let mut room = BoxRoom::new(Vec3::ZERO, SIZE.as_vec3());
        room.subdivisions = subdivisions;
        let mesh = room.generate().unwrap();
        let mesh = TriangleMesh::new(mesh.positions, mesh.triangles).unwrap();
        let materials = (0..mesh.triangle_count())
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                let centre = ((a + b + c) / 3.0).as_dvec3();
                let axis = (0..3)
                    .find(|&k| centre[k] < 1e-3 || centre[k] > SIZE[k] - 1e-3)
                    .unwrap();
                (2 * axis + usize::from(centre[axis] > 1.0)) as MaterialId
            })
            .collect();
        Scene {
            materials: (0..6)
                .map(|w| {
                    material(
                        &format!("wall{w}"),
                        std::array::from_fn(|b| alpha(w, b)),
                        0.0,
                    )
                })
                .collect(),
            objects: vec![SceneObject {
                name: "room".into(),
                mesh,
                materials,
                transform: Default::default(),
                dynamic: false,
            }],
        }
    }

    fn assert_close(a: f64, b: f64, rel: f64, what: &str) {
        assert!((a - b).abs() <= rel * b.abs(), "{what}: {a} vs {b}");
    }

    #[test]
    fn a_box_has_six_faces_however_its_walls_are_split() {
        for subdivisions in [1, 3] {
            let reference = BruteForce::new(&box_scene(subdivisions));
            assert_eq!(reference.face_count(), 6);
            // 6 x 5^(k-1) sequences of order k, plus the direct one.
            assert_eq!(reference.sequence_count(2), 1.0 + 6.0 + 30.0);
        }
    }

    #[test]
    fn air_attenuates_by_the_coefficient_over_the_length() {
        let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
        let reference = BruteForce::new(&box_scene(1));
        let air: [f64; BAND_COUNT] = std::array::from_fn(|b| 1e-3 * (b + 1) as f64);
        let dry = reference.paths(s, l, 2, None);
        let wet = reference.paths(s, l, 2, Some(&air));
        assert_eq!(dry.len(), 25);
        assert_eq!(dry.len(), wet.len());
        for (d, w) in dry.iter().zip(&wet) {
            for (b, a) in air.iter().enumerate() {
                let db = 20.0 * (d.pressure_gain[b] / w.pressure_gain[b]).log10();
                assert_close(db, a * d.length, 1e-9, "air");
            }
        }
    }

    /// A scene of the box plus one extra object.
    fn with_object(
        mut scene: Scene,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        m: Material,
    ) -> Scene {
        let id = scene.materials.len() as MaterialId;
        scene.materials.push(m);
        let mesh = TriangleMesh::new(positions, triangles).unwrap();
        scene.objects.push(SceneObject {
            name: "extra".into(),
            materials: vec![id; mesh.triangle_count()],
            mesh,
            transform: Default::default(),
            dynamic: false,
        });
        scene
    }

    /// A quad in the plane `x = x`, spanning `y0..y1`, `z0..z1`.
    fn quad_x(x: f32, y0: f32, y1: f32, z0: f32, z1: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (
            vec![
                Vec3::new(x, y0, z0),
                Vec3::new(x, y1, z0),
                Vec3::new(x, y1, z1),
                Vec3::new(x, y0, z1),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn an_occluding_panel_removes_exactly_the_paths_through_it() {
        let (s, l) = (DVec3::new(2.0, 3.0, 1.5), DVec3::new(8.0, 3.0, 1.5));
        let (v, t) = quad_x(5.0, 2.0, 4.0, 0.5, 2.5);
        let panel = material("panel", [0.5; BAND_COUNT], 0.0);
        let scene = with_object(box_scene(1), v, t, panel);
        let open = BruteForce::new(&box_scene(1)).paths(s, l, 1, None);
        let paths = BruteForce::new(&scene).paths(s, l, 1, None);
        assert_eq!(open.len(), 7);
        // The direct path and both end walls' paths run along y = 3,
        // z = 1.5 through the panel; floor, ceiling and side walls pass
        // around it; the panel's own plane does not separate the source's
        // image from the listener.
        assert_eq!(paths.len(), 4);
        assert!(paths
            .iter()
            .all(|p| p.order() == 1 && p.events[0].normal.x == 0.0));
        // Moved 1 cm below the direct line, the panel no longer blocks it.
        let (v, t) = quad_x(5.0, 2.0, 4.0, 0.5, 1.49);
        let scene = with_object(box_scene(1), v, t, material("p", [0.5; BAND_COUNT], 0.0));
        let paths = BruteForce::new(&scene).paths(s, l, 0, None);
        assert_eq!(paths.len(), 1);
    }

    #[test]
    fn a_reflection_point_just_outside_a_panel_is_no_path() {
        // Open space and a 2 x 2 m panel at x = 5 (y, z in [0, 2]). Source
        // and listener 1 m apart along y, 2 m in front of it: the
        // reflection point is (5, y, 1), inside for y <= 2.
        let panel = material("panel", std::array::from_fn(|b| 0.1 * b as f32), 0.0);
        let (v, t) = quad_x(5.0, 0.0, 2.0, 0.0, 2.0);
        let reference = BruteForce::new(&with_object(Scene::default(), v, t, panel));
        for (y, expected) in [(1.0, 2), (2.0 - 1e-6, 2), (2.0 + 1e-6, 1)] {
            let (s, l) = (DVec3::new(3.0, y - 0.5, 1.0), DVec3::new(3.0, y + 0.5, 1.0));
            let paths = reference.paths(s, l, 3, None);
            assert_eq!(paths.len(), expected, "y = {y}");
            assert_close(paths[0].length, 1.0, 1e-12, "direct");
            if let Some(p) = paths.get(1) {
                assert_close(p.length, 17f64.sqrt(), 1e-12, "length");
                assert!(p.events[0].point.distance(DVec3::new(5.0, y, 1.0)) < 1e-12);
                for b in 0..BAND_COUNT {
                    let g = (1.0 - f64::from(0.1 * b as f32)).sqrt() / 17f64.sqrt();
                    assert_close(p.pressure_gain[b], g, 1e-12, "gain");
                }
            }
        }
    }

    #[test]
    fn sound_crosses_a_transmitting_partition_only_through_it() {
        // The box cut in two at x = 5 by a door-like partition.
        let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
        let absorption = std::array::from_fn(|b| 0.3 + 0.05 * b as f32);
        let door = Material {
            transmission: std::array::from_fn(|b| 0.2 + 0.01 * b as f32),
            ..material("door", absorption, 0.0)
        };
        let tau = door.transmission;
        let (v, t) = quad_x(5.0, 0.0, 6.0, 0.0, 3.0);
        let reference = BruteForce::new(&with_object(box_scene(1), v, t, door));
        assert_eq!(reference.face_count(), 7);
        // Nothing reaches the listener without passing the door, and at
        // order 1 only the straight line does.
        let first = reference.paths(s, l, 1, None);
        assert_eq!(first.len(), 1);
        let p = &first[0];
        assert!(p.events[0].transmission);
        assert_close(p.length, s.distance(l), 1e-12, "length");
        assert!(p.image_source.distance(s) < 1e-12);
        for (&gain, t) in p.pressure_gain.iter().zip(tau) {
            assert_close(gain, f64::from(t).sqrt() / s.distance(l), 1e-12, "gain");
        }
        // Every longer path passes it exactly once, and reflects off no
        // wall on the wrong side.
        let paths = reference.paths(s, l, 3, None);
        assert!(paths.len() > 20, "{}", paths.len());
        for p in &paths {
            assert_eq!(p.events.iter().filter(|e| e.transmission).count(), 1);
            let door_at = p.events.iter().position(|e| e.transmission).unwrap();
            for (i, e) in p.events.iter().enumerate() {
                let source_side = e.point.x <= 5.0 + 1e-9;
                assert!(if i < door_at {
                    source_side
                } else {
                    e.point.x >= 5.0 - 1e-9
                });
            }
        }
    }
}
