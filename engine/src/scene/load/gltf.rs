//! glTF 2.0 meshes (`.gltf` with embedded or side-car buffers, `.glb`): every
//! triangle primitive of every mesh instance in the scene graph, with the
//! node transforms baked in, merged into one mesh. glTF material names
//! become the triangles' material names.

use std::path::Path;

use glam::{Mat4, Vec3};
use gltf::mesh::Mode;

use super::{read, resolve_relative};
use crate::scene::RawMesh;
use crate::{Error, Result};

/// Node visits allowed: guards against cyclic or explosively shared node
/// graphs in malformed files.
const MAX_NODE_VISITS: usize = 1_000_000;
const MAX_NODE_DEPTH: usize = 1_000;

/// Triangles a file may instantiate (nodes sharing meshes included) when
/// the caller sets no budget of its own.
const MAX_GLTF_TRIANGLES: u64 = 50_000_000;

/// Loads a `.gltf` or `.glb` file; side-car buffers are looked up next to it.
pub fn load_gltf(path: &Path) -> Result<RawMesh> {
    parse_gltf(&read(path)?, path.parent(), MAX_GLTF_TRIANGLES).map_err(|e| match e {
        Error::Parse { reason, .. } => Error::Parse {
            what: path.display().to_string(),
            reason,
        },
        other => other,
    })
}

fn parse_error(reason: impl ToString) -> Error {
    Error::Parse {
        what: "glTF".into(),
        reason: reason.to_string(),
    }
}

/// Parses glTF or GLB bytes; relative buffer URIs resolve against `base`
/// and must stay inside it. A file whose node graph instantiates more
/// than `max_triangles` triangles is refused before any is built: a few
/// kilobytes of nodes listing a child twice, nested, make millions.
pub fn parse_gltf(bytes: &[u8], base: Option<&Path>, max_triangles: u64) -> Result<RawMesh> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(bytes).map_err(parse_error)?;
    let roots: Vec<gltf::Node> = match document.default_scene() {
        Some(scene) => scene.nodes().collect(),
        None => document.scenes().flat_map(|s| s.nodes()).collect(),
    };
    let triangles = instantiated_triangles(&document, &roots)?;
    if triangles > max_triangles {
        return Err(Error::LimitExceeded(format!(
            "the glTF instantiates {triangles} triangles; the limit is {max_triangles}"
        )));
    }
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            if uri.starts_with("data:") {
                continue;
            }
            if uri.contains([':', '%', '\\']) {
                return Err(parse_error(format!(
                    "buffer URI {uri:?} is not a plain relative file name or a data: URI"
                )));
            }
            resolve_relative(base, uri)?;
        }
    }
    let buffers = gltf::import_buffers(&document, base, blob).map_err(parse_error)?;
    let mut mesh = RawMesh::default();
    if roots.is_empty() {
        // No scene graph: take the meshes as they are.
        for m in document.meshes() {
            add_mesh(&mut mesh, &m, Mat4::IDENTITY, &buffers)?;
        }
        return Ok(mesh);
    }
    let mut stack: Vec<(gltf::Node, Mat4, usize)> =
        roots.into_iter().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    let mut visits = 0;
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if visits > MAX_NODE_VISITS || depth > MAX_NODE_DEPTH {
            return Err(parse_error("the node graph is cyclic or too large"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(m) = node.mesh() {
            add_mesh(&mut mesh, &m, world, &buffers)?;
        }
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    Ok(mesh)
}

/// Triangles the node graph under `roots` instantiates (every mesh if
/// there is no graph), from the accessors' counts: nothing is read or
/// built. Cyclic or over-deep graphs are errors.
fn instantiated_triangles(document: &gltf::Document, roots: &[gltf::Node]) -> Result<u64> {
    let mesh_triangles = |m: &gltf::Mesh| -> u64 {
        m.primitives()
            .map(|p| {
                let count = match p.indices() {
                    Some(indices) => indices.count(),
                    None => p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count()),
                };
                count as u64 / 3
            })
            .sum()
    };
    if roots.is_empty() {
        return Ok(document.meshes().map(|m| mesh_triangles(&m)).sum());
    }
    let per_mesh: Vec<u64> = document.meshes().map(|m| mesh_triangles(&m)).collect();
    let mut stack: Vec<(gltf::Node, usize)> = roots.iter().map(|n| (n.clone(), 0)).collect();
    let (mut visits, mut total) = (0usize, 0u64);
    while let Some((node, depth)) = stack.pop() {
        visits += 1;
        if visits > MAX_NODE_VISITS || depth > MAX_NODE_DEPTH {
            return Err(parse_error("the node graph is cyclic or too large"));
        }
        if let Some(m) = node.mesh() {
            total = total.saturating_add(per_mesh[m.index()]);
        }
        stack.extend(node.children().map(|c| (c, depth + 1)));
    }
    Ok(total)
}

fn add_mesh(
    out: &mut RawMesh,
    mesh: &gltf::Mesh,
    world: Mat4,
    buffers: &[gltf::buffer::Data],
) -> Result<()> {
    let label = mesh.name().map_or_else(
        || format!("mesh {}", mesh.index()),
        |n| format!("mesh {n:?}"),
    );
    // A mirroring transform turns counter-clockwise triangles clockwise.
    let mirrored = world.determinant() < 0.0;
    for prim in mesh.primitives() {
        let what = format!("{label} primitive {}", prim.index());
        if prim.mode() != Mode::Triangles {
            return Err(parse_error(format!(
                "{what} uses mode {:?}; only triangle lists are supported",
                prim.mode()
            )));
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| parse_error(format!("{what} has no POSITION attribute")))?
            .map(|p| world.transform_point3(Vec3::from(p)))
            .collect();
        let n = positions.len() as u32;
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..n).collect(),
        };
        if indices.len() % 3 != 0 {
            return Err(parse_error(format!(
                "{what} has {} indices, not a multiple of 3",
                indices.len()
            )));
        }
        if let Some(bad) = indices.iter().find(|&&i| i >= n) {
            return Err(parse_error(format!("{what} refers to vertex {bad} of {n}")));
        }
        let name = prim.material().name().map(|m| out.intern(m));
        let base = out.positions.len() as u32;
        out.positions.extend(positions);
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i + base);
            out.push_triangle(if mirrored { [a, c, b] } else { [a, b, c] }, name);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::test_dir;

    fn base64(bytes: &[u8]) -> String {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bytes.chunks(3) {
            let n = (u32::from(c[0]) << 16)
                | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                | u32::from(*c.get(2).unwrap_or(&0));
            for k in 0..4 {
                if k <= c.len() {
                    s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }

    /// One triangle (u16 indices) under a translated parent node.
    fn triangle_gltf(mode: u32, scale_x: f32) -> String {
        let mut buf = Vec::new();
        for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for v in p {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        for i in [0u16, 1, 2, 0] {
            buf.extend_from_slice(&i.to_le_bytes());
        }
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"translation": [0, 0, 5], "children": [1]}},
            {{"mesh": 0, "translation": [1, 0, 0], "scale": [{scale_x}, 1, 1]}}],
  "materials": [{{"name": "glass_window"}}],
  "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0, "mode": {mode}}}]}}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{data}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
                  {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}]
}}"#,
            len = buf.len(),
            data = base64(&buf)
        )
    }

    #[test]
    fn bakes_node_transforms_and_keeps_material_names() {
        let dir = test_dir("gltf");
        let path = dir.join("tri.gltf");
        std::fs::write(&path, triangle_gltf(4, 1.0)).unwrap();
        let m = load_gltf(&path).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!(m.positions[0], Vec3::new(1.0, 0.0, 5.0));
        assert_eq!(m.positions[1], Vec3::new(2.0, 0.0, 5.0));
        assert_eq!(m.triangle_name(0), Some("glass_window"));
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn mirroring_nodes_keep_the_facing() {
        let m = parse_gltf(triangle_gltf(4, -1.0).as_bytes(), None, 10).unwrap();
        let [a, b, c] = m.triangles[0].map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0);
    }

    #[test]
    fn rejects_non_triangle_modes_and_garbage() {
        let err = parse_gltf(triangle_gltf(1, 1.0).as_bytes(), None, 10).unwrap_err();
        assert!(err.to_string().contains("only triangle lists"), "{err}");
        assert!(parse_gltf(b"not gltf", None, 10).is_err());
    }

    #[test]
    fn refuses_buffers_outside_the_directory() {
        let text = triangle_gltf(4, 1.0);
        let start = text.find("data:").unwrap();
        let end = start + text[start..].find('"').unwrap();
        let evil = format!("{}../secret.bin{}", &text[..start], &text[end..]);
        let dir = test_dir("gltf-evil");
        assert!(parse_gltf(evil.as_bytes(), Some(&dir), 10).is_err());
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn an_instancing_bomb_is_refused_before_anything_is_built() {
        // 18 levels of nodes each listing its child twice: 2^18 instances
        // of one triangle in a few kilobytes.
        let text = triangle_gltf(4, 1.0);
        let levels = 18;
        let nodes: Vec<String> = (0..levels)
            .map(|i| format!(r#"{{"children": [{0}, {0}]}}"#, i + 1))
            .chain([r#"{"mesh": 0}"#.to_owned()])
            .collect();
        let start = text.find(r#""nodes": [{"#).unwrap();
        let end = start + text[start..].find("],\n  \"materials\"").unwrap() + 1;
        let bomb = format!(
            "{}\"nodes\": [{}]{}",
            &text[..start],
            nodes.join(", "),
            &text[end..]
        );
        let e = parse_gltf(bomb.as_bytes(), None, 100_000).unwrap_err();
        assert!(e.to_string().contains("262144 triangles"), "{e}");
        // Within the budget it builds every instance.
        let m = parse_gltf(bomb.as_bytes(), None, 1 << 18).unwrap();
        assert_eq!(m.triangles.len(), 1 << 18);
    }
}
