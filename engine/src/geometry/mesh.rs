use glam::{Vec3, Vec3A};

use super::Aabb;
use crate::{Error, Result};

/// Largest coordinate magnitude a mesh may hold. The watertight test multiplies
/// coordinate differences; beyond this their products could overflow `f32`.
pub const MAX_COORDINATE: f32 = 1.0e15;

/// An indexed triangle mesh whose every index is in range and whose every
/// coordinate is finite: the invariant all hierarchies and queries rely on.
///
/// Zero-area triangles are allowed (scanned and CAD meshes have them); they
/// are never hit. A mesh with no area at all is rejected.
///
/// ```
/// use frusta_engine::geometry::TriangleMesh;
/// use glam::Vec3;
/// let bad = TriangleMesh::new(vec![Vec3::ZERO], vec![[0, 0, 1]]);
/// assert!(bad.unwrap_err().to_string().contains("refers to vertex 1"));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Checks the mesh and takes ownership of it.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        check_mesh(&positions, &triangles)?;
        Ok(Self {
            positions,
            triangles,
        })
    }

    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [Vec3A; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize].into(),
            self.positions[b as usize].into(),
            self.positions[c as usize].into(),
        ]
    }

    /// Unnormalised geometric normal `(b - a) x (c - a)` of triangle `t`:
    /// counter-clockwise winding faces the viewer.
    pub fn face_normal(&self, t: usize) -> Vec3A {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a)
    }

    pub fn area(&self, t: usize) -> f32 {
        0.5 * self.face_normal(t).length()
    }

    /// Triangles whose corners are collinear or coincide.
    pub fn degenerate_count(&self) -> usize {
        (0..self.triangles.len())
            .filter(|&t| self.face_normal(t) == Vec3A::ZERO)
            .count()
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::of_points(self.positions.iter().copied())
    }

    /// Replaces the vertex positions, keeping the connectivity: the input of a
    /// refit. The count must not change and the positions must be finite.
    pub fn set_positions(&mut self, positions: Vec<Vec3>) -> Result<()> {
        if positions.len() != self.positions.len() {
            return Err(Error::VertexCountMismatch {
                expected: self.positions.len(),
                actual: positions.len(),
            });
        }
        check_positions(&positions)?;
        self.positions = positions;
        Ok(())
    }
}

/// The checks of [`TriangleMesh::new`], on borrowed data: some triangles
/// and vertices, positions finite and in range, indices in range, and not
/// every triangle of zero area.
pub fn check_mesh(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<()> {
    if triangles.is_empty() {
        return Err(Error::EmptyMesh);
    }
    if positions.is_empty() {
        return Err(Error::NoVertices);
    }
    check_positions(positions)?;
    let n = positions.len();
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(Error::IndexOutOfRange {
                triangle: t,
                index,
                vertex_count: n,
            });
        }
    }
    let has_area = |&[a, b, c]: &[u32; 3]| {
        let [a, b, c] = [a, b, c].map(|i| Vec3A::from(positions[i as usize]));
        (b - a).cross(c - a) != Vec3A::ZERO
    };
    if !triangles.iter().any(has_area) {
        return Err(Error::AllTrianglesDegenerate);
    }
    Ok(())
}

/// Checks vertex positions as [`TriangleMesh::new`] does: finite and at
/// most [`MAX_COORDINATE`] in magnitude.
pub fn check_positions(positions: &[Vec3]) -> Result<()> {
    for (vertex, p) in positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(Error::NonFiniteVertex {
                vertex,
                value: p.to_array(),
            });
        }
        if p.abs().max_element() > MAX_COORDINATE {
            return Err(Error::VertexOutOfRange {
                vertex,
                value: p.to_array(),
                limit: MAX_COORDINATE,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Vec<Vec3> {
        vec![Vec3::ZERO, Vec3::X, Vec3::Y]
    }

    #[test]
    fn rejects_invalid_input_with_clear_errors() {
        assert_eq!(TriangleMesh::new(tri(), vec![]), Err(Error::EmptyMesh));
        assert_eq!(
            TriangleMesh::new(vec![], vec![[0, 1, 2]]),
            Err(Error::NoVertices)
        );
        let err = TriangleMesh::new(tri(), vec![[0, 1, 3]]).unwrap_err();
        assert_eq!(
            err,
            Error::IndexOutOfRange {
                triangle: 0,
                index: 3,
                vertex_count: 3
            }
        );
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut p = tri();
            p[1].y = bad;
            let err = TriangleMesh::new(p, vec![[0, 1, 2]]).unwrap_err();
            assert!(
                matches!(err, Error::NonFiniteVertex { vertex: 1, .. }),
                "{err}"
            );
        }
        let mut p = tri();
        p[2].z = 1e30;
        assert!(matches!(
            TriangleMesh::new(p, vec![[0, 1, 2]]),
            Err(Error::VertexOutOfRange { vertex: 2, .. })
        ));
        let line = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert_eq!(
            TriangleMesh::new(line, vec![[0, 1, 2], [0, 0, 1]]),
            Err(Error::AllTrianglesDegenerate)
        );
    }

    #[test]
    fn keeps_some_degenerate_triangles() {
        let m = TriangleMesh::new(tri(), vec![[0, 1, 2], [0, 0, 1]]).unwrap();
        assert_eq!(m.degenerate_count(), 1);
        assert_eq!(m.area(0), 0.5);
    }

    #[test]
    fn set_positions_checks_count_and_values() {
        let mut m = TriangleMesh::new(tri(), vec![[0, 1, 2]]).unwrap();
        assert!(matches!(
            m.set_positions(vec![Vec3::ZERO]),
            Err(Error::VertexCountMismatch {
                expected: 3,
                actual: 1
            })
        ));
        let mut p = tri();
        p[0].x = f32::NAN;
        assert!(m.set_positions(p).is_err());
        assert_eq!(
            m.positions(),
            &tri()[..],
            "a failed update keeps the old positions"
        );
    }
}
