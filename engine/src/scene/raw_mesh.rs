//! Mesh data as loaders and generators produce it, before materials are
//! resolved against a scene's material table: triangles carry material
//! *names* (OBJ `usemtl`, glTF material names, generator slots such as
//! `"floor"`), which the scene format maps to materials.

use glam::Vec3;

/// Positions, triangles and per-triangle material names.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Distinct material names, indexed by `triangle_names`.
    pub names: Vec<String>,
    /// One entry per triangle; `None` means "the object's default material".
    pub triangle_names: Vec<Option<u32>>,
}

impl RawMesh {
    /// Index of `name` in [`RawMesh::names`], adding it if new.
    pub fn intern(&mut self, name: &str) -> u32 {
        match self.names.iter().position(|n| n == name) {
            Some(i) => i as u32,
            None => {
                self.names.push(name.to_owned());
                (self.names.len() - 1) as u32
            }
        }
    }

    pub fn push_vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    pub fn push_triangle(&mut self, tri: [u32; 3], name: Option<u32>) {
        self.triangles.push(tri);
        self.triangle_names.push(name);
    }

    /// Two triangles for the quad `a b c d`, counter-clockwise seen from the
    /// side its normal faces.
    pub fn push_quad(&mut self, [a, b, c, d]: [u32; 4], name: Option<u32>) {
        self.push_triangle([a, b, c], name);
        self.push_triangle([a, c, d], name);
    }

    /// The material name of triangle `t`, if it has one.
    pub fn triangle_name(&self, t: usize) -> Option<&str> {
        self.triangle_names[t].map(|i| self.names[i as usize].as_str())
    }

    /// Appends another mesh, renumbering its vertices and names.
    pub fn append(&mut self, other: RawMesh) {
        let base = self.positions.len() as u32;
        let remap: Vec<u32> = other.names.iter().map(|n| self.intern(n)).collect();
        self.positions.extend(other.positions);
        for (tri, name) in other.triangles.into_iter().zip(other.triangle_names) {
            self.push_triangle(tri.map(|i| i + base), name.map(|n| remap[n as usize]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn append_renumbers_vertices_and_names() {
        let mut a = RawMesh::default();
        let n = a.intern("floor");
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| a.push_vertex(p));
        a.push_triangle(v, Some(n));
        let mut b = RawMesh::default();
        let m = b.intern("walls");
        let w = [Vec3::ZERO, Vec3::X, Vec3::Z].map(|p| b.push_vertex(p));
        b.push_triangle(w, Some(m));
        b.push_triangle(w, None);
        a.append(b);
        assert_eq!(a.triangles[1], [3, 4, 5]);
        assert_eq!(a.triangle_name(1), Some("walls"));
        assert_eq!(a.triangle_name(2), None);
        assert_eq!(a.intern("floor"), 0);
    }
}
