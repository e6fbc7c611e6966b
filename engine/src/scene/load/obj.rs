//! Wavefront OBJ meshes via `tobj`: polygons are triangulated, all objects
//! and groups are merged into one mesh, and `usemtl` names become the
//! triangles' material names. MTL files are never read: only the material
//! *names* matter, and the scene maps them to acoustic materials.

use std::path::Path;

use glam::Vec3;

use super::read;
use crate::scene::RawMesh;
use crate::{Error, Result};

/// Loads an OBJ file.
pub fn load_obj(path: &Path) -> Result<RawMesh> {
    let bytes = read(path)?;
    let text = String::from_utf8_lossy(&bytes);
    parse_obj(&text).map_err(|e| match e {
        Error::Parse { reason, .. } => Error::Parse {
            what: path.display().to_string(),
            reason,
        },
        other => other,
    })
}

/// Parses OBJ text.
pub fn parse_obj(text: &str) -> Result<RawMesh> {
    let names: Vec<String> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("usemtl"))
        .map(|rest| rest.trim().to_owned())
        .filter(|n| !n.is_empty())
        .collect();
    // tobj only keeps `usemtl` names it found in a material library, so offer
    // it a synthetic library holding exactly the names the file uses.
    let source = format!("mtllib frusta-usemtl-names\n{text}");
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let loader = |_: &Path| -> tobj::MTLLoadResult {
        let materials: Vec<tobj::Material> = names
            .iter()
            .map(|n| tobj::Material {
                name: n.clone(),
                ..Default::default()
            })
            .collect();
        let map = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        Ok((materials, map))
    };
    let (models, materials) = tobj::load_obj_buf(&mut source.as_bytes(), &options, loader)
        .map_err(|e| Error::Parse {
            what: "OBJ".into(),
            reason: e.to_string(),
        })?;
    let materials = materials.unwrap_or_default();
    let mut mesh = RawMesh::default();
    for model in models {
        let m = model.mesh;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        let name = m
            .material_id
            .and_then(|id| materials.get(id))
            .map(|mat| mesh.intern(&mat.name));
        for t in m.indices.chunks_exact(3) {
            mesh.push_triangle([t[0] + base, t[1] + base, t[2] + base], name);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::test_dir;

    const QUAD_AND_TRI: &str = "\
o thing
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
usemtl floor
f 1 2 3 4
usemtl walls
f 1 2 5
";

    #[test]
    fn triangulates_and_keeps_usemtl_names() {
        let dir = test_dir("obj");
        let path = dir.join("thing.obj");
        std::fs::write(&path, QUAD_AND_TRI).unwrap();
        let m = load_obj(&path).unwrap();
        assert_eq!(m.triangles.len(), 3);
        assert_eq!(m.triangle_name(0), Some("floor"));
        assert_eq!(m.triangle_name(1), Some("floor"));
        assert_eq!(m.triangle_name(2), Some("walls"));
        for t in &m.triangles {
            assert!(t.iter().all(|&i| (i as usize) < m.positions.len()));
        }
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn faces_without_usemtl_have_no_name() {
        let m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangle_name(0), None);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert!(parse_obj("v 0 0 0\nf 1 2 7\n").is_err());
        assert!(load_obj(Path::new("/nonexistent/x.obj")).is_err());
    }
}
