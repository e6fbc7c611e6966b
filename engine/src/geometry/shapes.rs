//! Closed, consistently oriented meshes with shared vertices, generated in
//! code: the test subjects for watertightness, refit and collision.
//! Triangles wind counter-clockwise seen from outside (normals point out).

use std::collections::HashMap;

use glam::Vec3;

use super::TriangleMesh;

/// The cube `[-h, h]^3`, each face split into `n x n` quads.
pub fn cube(half: f32, n: u32) -> TriangleMesh {
    let n = n.max(1);
    let mut builder = Welder::default();
    // For each face: normal axis, sign, and the two in-face axes such that
    // u x v points along the outward normal.
    for (axis, sign) in [
        (0, 1.0),
        (0, -1.0),
        (1, 1.0),
        (1, -1.0),
        (2, 1.0),
        (2, -1.0),
    ] {
        let (mut ua, mut va) = ((axis + 1) % 3, (axis + 2) % 3);
        if sign < 0.0 {
            std::mem::swap(&mut ua, &mut va);
        }
        let at = |i: u32, j: u32| {
            let mut p = [0.0; 3];
            p[axis] = sign * half;
            p[ua] = half * (2.0 * i as f32 / n as f32 - 1.0);
            p[va] = half * (2.0 * j as f32 / n as f32 - 1.0);
            Vec3::from(p)
        };
        for i in 0..n {
            for j in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                builder.triangle(a, b, c);
                builder.triangle(a, c, d);
            }
        }
    }
    builder.finish()
}

/// A unit-radius icosahedron subdivided `levels` times and projected onto
/// the sphere of `radius`: `20 * 4^levels` triangles.
pub fn icosphere(radius: f32, levels: u32) -> TriangleMesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| Vec3::from(p).normalize());
    let mut faces: Vec<[Vec3; 3]> = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ]
    .iter()
    .map(|f| f.map(|i: usize| v[i]))
    .collect();
    for _ in 0..levels {
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    (a + b).normalize(),
                    (b + c).normalize(),
                    (c + a).normalize(),
                );
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let mut builder = Welder::default();
    for [a, b, c] in faces {
        builder.triangle(a * radius, b * radius, c * radius);
    }
    builder.finish()
}

/// `mesh` with every triangle on corners of its own (three vertices each,
/// repeating positions): how meshes split for flat normals arrive.
pub fn unwelded(mesh: &TriangleMesh) -> TriangleMesh {
    let positions = mesh
        .triangles()
        .iter()
        .flat_map(|t| t.map(|v| mesh.positions()[v as usize]));
    let triangles = (0..mesh.triangle_count() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]);
    TriangleMesh::new(positions.collect(), triangles.collect()).expect("the same triangles")
}

/// A torus around the z axis with radii `major > minor`, `rings x sides`
/// quads.
pub fn torus(major: f32, minor: f32, rings: u32, sides: u32) -> TriangleMesh {
    let (rings, sides) = (rings.max(3), sides.max(3));
    let index = |i: u32, j: u32| (i % rings) * sides + (j % sides);
    let positions = (0..rings)
        .flat_map(|i| (0..sides).map(move |j| (i, j)))
        .map(|(i, j)| {
            let u = i as f32 / rings as f32 * std::f32::consts::TAU;
            let v = j as f32 / sides as f32 * std::f32::consts::TAU;
            let r = major + minor * v.cos();
            Vec3::new(r * u.cos(), r * u.sin(), minor * v.sin())
        })
        .collect();
    let triangles = (0..rings)
        .flat_map(|i| (0..sides).map(move |j| (i, j)))
        .flat_map(|(i, j)| {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            [[a, b, c], [a, c, d]]
        })
        .collect();
    TriangleMesh::new(positions, triangles).expect("torus parameters give a valid mesh")
}

/// Collects triangles and merges bit-identical vertices, so generated
/// meshes share vertices along every edge.
#[derive(Default)]
struct Welder {
    positions: Vec<Vec3>,
    index: HashMap<[u32; 3], u32>,
    triangles: Vec<[u32; 3]>,
}

impl Welder {
    fn vertex(&mut self, p: Vec3) -> u32 {
        let key = p.to_array().map(|c| (c + 0.0).to_bits());
        *self.index.entry(key).or_insert_with(|| {
            self.positions.push(p);
            (self.positions.len() - 1) as u32
        })
    }

    fn triangle(&mut self, a: Vec3, b: Vec3, c: Vec3) {
        let t = [self.vertex(a), self.vertex(b), self.vertex(c)];
        self.triangles.push(t);
    }

    fn finish(self) -> TriangleMesh {
        TriangleMesh::new(self.positions, self.triangles).expect("generated meshes are valid")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every directed edge appears once and its reverse once: closed and
    /// consistently oriented.
    fn assert_closed(m: &TriangleMesh) {
        let mut edges = HashMap::new();
        for t in m.triangles() {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
    }

    fn signed_volume(m: &TriangleMesh) -> f32 {
        (0..m.triangle_count())
            .map(|t| {
                let [a, b, c] = m.corners(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn shapes_are_closed_and_face_outwards() {
        let c = cube(1.0, 3);
        assert_eq!(c.triangle_count(), 6 * 9 * 2);
        assert_closed(&c);
        assert!((signed_volume(&c) - 8.0).abs() < 1e-4);
        let s = icosphere(2.0, 3);
        assert_eq!(s.triangle_count(), 20 * 64);
        assert_closed(&s);
        let v = signed_volume(&s);
        assert!(v > 0.0 && v < 4.0 / 3.0 * std::f32::consts::PI * 8.0);
        let t = torus(2.0, 0.5, 24, 12);
        assert_closed(&t);
        assert!(signed_volume(&t) > 0.0);
    }
}
