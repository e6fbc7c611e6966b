//! Surfaces of unions of grid cells. Rooms built from the cells of one
//! rectilinear grid share every vertex where faces meet, so the surface is
//! closed and free of T-junctions by construction: a box, an L, or two rooms
//! joined by a door are all just different sets of cells.

use std::collections::HashMap;

use glam::Vec3;

use crate::scene::RawMesh;

/// Where a boundary face lies: the cell it bounds, the axis it is
/// perpendicular to and whether its normal points along `+axis`.
#[derive(Clone, Copy, Debug)]
pub struct Face {
    pub cell: [usize; 3],
    pub axis: usize,
    pub positive: bool,
}

/// Inserts `parts - 1` evenly spaced lines into every interval.
pub fn split(lines: &[f32], parts: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity((lines.len().saturating_sub(1)) * parts + 1);
    for w in lines.windows(2) {
        for k in 0..parts {
            out.push(w[0] + (w[1] - w[0]) * k as f32 / parts as f32);
        }
    }
    out.extend(lines.last());
    out
}

/// Appends the boundary between the cells where `inside` holds and all
/// others (or the outside of the grid). With `into_inside`, normals point
/// into the inside cells (rooms: inside is air); otherwise out of them
/// (solid objects standing in air). `slot` names each face's material.
pub fn boundary(
    mesh: &mut RawMesh,
    axes: [&[f32]; 3],
    inside: impl Fn([usize; 3]) -> bool,
    into_inside: bool,
    mut slot: impl FnMut(&mut RawMesh, Face) -> u32,
) {
    let n = axes.map(|a| a.len() - 1);
    let mut vertices: HashMap<[usize; 3], u32> = HashMap::new();
    let mut vertex = |mesh: &mut RawMesh, g: [usize; 3]| {
        *vertices.entry(g).or_insert_with(|| {
            mesh.push_vertex(Vec3::new(axes[0][g[0]], axes[1][g[1]], axes[2][g[2]]))
        })
    };
    for i in 0..n[0] {
        for j in 0..n[1] {
            for k in 0..n[2] {
                let cell = [i, j, k];
                if !inside(cell) {
                    continue;
                }
                for axis in 0..3 {
                    for side in 0..2 {
                        let mut nb = cell;
                        let open = if side == 0 {
                            cell[axis] > 0 && {
                                nb[axis] -= 1;
                                inside(nb)
                            }
                        } else {
                            cell[axis] + 1 < n[axis] && {
                                nb[axis] += 1;
                                inside(nb)
                            }
                        };
                        if open {
                            continue;
                        }
                        // The min face's normal points into the cell along +axis.
                        let positive = (side == 0) == into_inside;
                        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                        let corner = |du: usize, dv: usize| {
                            let mut g = cell;
                            g[axis] += side;
                            g[u] += du;
                            g[v] += dv;
                            g
                        };
                        // (u, v, axis) is right-handed, so this order faces +axis.
                        let mut quad = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                        if !positive {
                            quad.reverse();
                        }
                        let quad = quad.map(|g| vertex(mesh, g));
                        let name = slot(
                            mesh,
                            Face {
                                cell,
                                axis,
                                positive,
                            },
                        );
                        mesh.push_quad(quad, Some(name));
                    }
                }
            }
        }
    }
}

/// The usual room slots: `floor` faces up, `ceiling` faces down, the rest
/// are `walls`.
pub fn room_slot(mesh: &mut RawMesh, face: Face) -> u32 {
    mesh.intern(match (face.axis, face.positive) {
        (2, true) => "floor",
        (2, false) => "ceiling",
        _ => "walls",
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::check::closed_signed_volume;

    #[test]
    fn split_inserts_even_lines() {
        assert_eq!(split(&[0.0, 1.0, 3.0], 2), vec![0.0, 0.5, 1.0, 2.0, 3.0]);
    }

    #[test]
    fn solid_and_hollow_cubes_are_closed_with_opposite_orientation() {
        let axes = [0.0, 1.0, 2.0];
        for (into, sign) in [(true, -1.0), (false, 1.0)] {
            let mut m = RawMesh::default();
            boundary(&mut m, [&axes; 3], |_| true, into, |m, _| m.intern("x"));
            assert_eq!(m.triangles.len(), 6 * 4 * 2);
            assert_eq!(m.positions.len(), 26);
            assert!((closed_signed_volume(&m) - sign * 8.0).abs() < 1e-9);
        }
    }
}
