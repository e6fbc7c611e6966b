//! A parametric theatre/cathedral-like hall: the large, detailed scene for
//! benchmarks. A box shell holds a stage, two rows of round pillars, rows
//! of seat blocks split by a central aisle and side balconies. Its detail
//! follows one knob, `target_triangles`, spent on seat blocks and pillars,
//! so the same hall can be traced at 10 k or 200 k triangles.
//!
//! Each part is a closed surface oriented towards the air: the shell inward,
//! the solids (stage, pillars, seats, balconies) outward. Solids stand on
//! the floor or against a wall, touching it without sharing vertices, so the
//! whole is a union of closed components with no T-junctions within any.

use std::collections::BTreeMap;
use std::f32::consts::TAU;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::cells::{boundary, room_slot, split};
use super::{check_positive, MAX_GENERATED_TRIANGLES};
use crate::scene::RawMesh;
use crate::{Error, Result};

/// Hall parameters; every field has a default, so `{}` is a valid hall.
/// Slots: `floor`, `ceiling`, `walls`, `stage`, `pillars`, `seats`,
/// `balconies`. The hall spans `[0, length] × [0, width] × [0, height]`,
/// stage at `x = 0`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Hall {
    pub length: f32,
    pub width: f32,
    pub height: f32,
    pub pillars_per_side: u32,
    pub seat_rows: u32,
    pub balconies: bool,
    /// Desired triangle count; the result lands within a few percent.
    pub target_triangles: u64,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, String>,
}

impl Default for Hall {
    fn default() -> Self {
        Self {
            length: 40.0,
            width: 24.0,
            height: 16.0,
            pillars_per_side: 6,
            seat_rows: 14,
            balconies: true,
            target_triangles: 10_000,
            materials: BTreeMap::new(),
        }
    }
}

/// Triangles of the shell: a box whose faces are split 4 × 4.
const SHELL_SUBDIVISIONS: usize = 4;
const SEAT_HEIGHT: f32 = 0.5;
const STAGE_HEIGHT: f32 = 1.0;
const BALCONY_THICKNESS: f32 = 0.5;
/// Coarsest pillar: an octagon prism in one storey.
const MIN_PILLAR_SEGMENTS: u64 = 8;

/// How finely seats and pillars are tessellated.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Detail {
    /// Each seat block face is split `seat_subdivisions²` ways.
    seat_subdivisions: u64,
    /// Pillar sides around the circumference.
    pillar_segments: u64,
    /// Pillar storeys (rings - 1).
    pillar_storeys: u64,
}

impl Hall {
    fn fixed_triangles(&self) -> u64 {
        let shell = 12 * (SHELL_SUBDIVISIONS * SHELL_SUBDIVISIONS) as u64;
        let balconies = if self.balconies { 2 * 12 } else { 0 };
        shell + 12 + balconies
    }

    fn seat_blocks(&self) -> u64 {
        2 * u64::from(self.seat_rows)
    }

    fn pillars(&self) -> u64 {
        2 * u64::from(self.pillars_per_side)
    }

    fn triangles(&self, d: Detail) -> u64 {
        self.fixed_triangles()
            + self.seat_blocks() * 12 * d.seat_subdivisions * d.seat_subdivisions
            + self.pillars() * 2 * d.pillar_segments * (d.pillar_storeys + 1)
    }

    /// Spends about half the budget on seats (coarse steps), the rest on
    /// pillars (fine steps), so the total lands near the target.
    fn detail(&self) -> Result<Detail> {
        let coarsest = Detail {
            seat_subdivisions: 1,
            pillar_segments: MIN_PILLAR_SEGMENTS,
            pillar_storeys: 1,
        };
        let minimum = self.triangles(coarsest);
        let target = self.target_triangles;
        if target < minimum || target > MAX_GENERATED_TRIANGLES {
            return Err(Error::InvalidScene(format!(
                "hall.target_triangles is {target}; with these parameters it must lie in \
                 {minimum}..={MAX_GENERATED_TRIANGLES}"
            )));
        }
        let free = (target - self.fixed_triangles()) as f64;
        let per_block = 0.5 * free / (12 * self.seat_blocks()) as f64;
        let seat_subdivisions = (per_block.sqrt().round() as u64).max(1);
        let seats = self.seat_blocks() * 12 * seat_subdivisions * seat_subdivisions;
        let left = target.saturating_sub(self.fixed_triangles() + seats);
        let per_pillar = left as f64 / self.pillars() as f64;
        let pillar_segments = ((per_pillar / 2.0).sqrt().round() as u64).max(MIN_PILLAR_SEGMENTS);
        let rings = (per_pillar / (2 * pillar_segments) as f64).round() as u64;
        Ok(Detail {
            seat_subdivisions,
            pillar_segments,
            pillar_storeys: rings.saturating_sub(1).max(1),
        })
    }

    fn check(&self) -> Result<()> {
        for (what, v, least) in [
            ("length", self.length, 10.0),
            ("width", self.width, 8.0),
            ("height", self.height, 5.0),
        ] {
            check_positive("hall", what, v)?;
            if v < least {
                return Err(Error::InvalidScene(format!(
                    "hall.{what} is {v} m; the layout needs at least {least} m"
                )));
            }
        }
        for (what, v) in [
            ("pillars_per_side", self.pillars_per_side),
            ("seat_rows", self.seat_rows),
        ] {
            if !(1..=1000).contains(&v) {
                return Err(Error::InvalidScene(format!(
                    "hall.{what} is {v}; it must lie in 1..=1000"
                )));
            }
        }
        Ok(())
    }

    pub fn generate(&self) -> Result<RawMesh> {
        self.check()?;
        let d = self.detail()?;
        let (l, w, h) = (self.length, self.width, self.height);
        let mut mesh = RawMesh::default();
        let shell = [l, w, h].map(|v| split(&[0.0, v], SHELL_SUBDIVISIONS));
        boundary(
            &mut mesh,
            [&shell[0], &shell[1], &shell[2]],
            |_| true,
            true,
            room_slot,
        );

        let stage = (
            Vec3::ZERO.with_y(0.2 * w),
            Vec3::new(0.15 * l, 0.8 * w, STAGE_HEIGHT),
        );
        solid_box(&mut mesh, stage, 1, "stage");

        if self.balconies {
            let z = 0.4 * h;
            for (y0, y1) in [(0.0, 0.12 * w), (0.88 * w, w)] {
                let b = (
                    Vec3::new(0.3 * l, y0, z),
                    Vec3::new(l, y1, z + BALCONY_THICKNESS),
                );
                solid_box(&mut mesh, b, 1, "balconies");
            }
        }

        let rows = self.seat_rows as usize;
        let pitch = 0.7 * l / rows as f32;
        for r in 0..rows {
            let x0 = 0.25 * l + r as f32 * pitch;
            for (y0, y1) in [(0.25 * w, 0.46 * w), (0.54 * w, 0.75 * w)] {
                let b = (
                    Vec3::new(x0, y0, 0.0),
                    Vec3::new(x0 + 0.6 * pitch, y1, SEAT_HEIGHT),
                );
                solid_box(&mut mesh, b, d.seat_subdivisions as usize, "seats");
            }
        }

        let per_side = self.pillars_per_side as usize;
        for i in 0..per_side {
            let x = l * (0.25 + 0.7 * (i as f32 + 0.5) / per_side as f32);
            for y in [0.2 * w, 0.8 * w] {
                pillar(&mut mesh, [x, y], 0.02 * w, h, d);
            }
        }
        debug_assert_eq!(mesh.triangles.len() as u64, self.triangles(d));
        Ok(mesh)
    }
}

/// A box standing in air, normals outward, faces split `s × s`.
fn solid_box(mesh: &mut RawMesh, (lo, hi): (Vec3, Vec3), s: usize, slot: &str) {
    let axes = [0, 1, 2].map(|a| split(&[lo[a], hi[a]], s));
    let name = mesh.intern(slot);
    boundary(
        mesh,
        [&axes[0], &axes[1], &axes[2]],
        |_| true,
        false,
        |_, _| name,
    );
}

/// A floor-to-ceiling round pillar: a prism of `pillar_segments` sides in
/// `pillar_storeys` storeys, capped by fans, normals outward.
fn pillar(mesh: &mut RawMesh, [cx, cy]: [f32; 2], radius: f32, height: f32, d: Detail) {
    let name = Some(mesh.intern("pillars"));
    let (m, storeys) = (d.pillar_segments as usize, d.pillar_storeys as usize);
    let rings: Vec<Vec<u32>> = (0..=storeys)
        .map(|j| {
            let z = height * j as f32 / storeys as f32;
            (0..m)
                .map(|i| {
                    let (s, c) = (TAU * i as f32 / m as f32).sin_cos();
                    mesh.push_vertex(Vec3::new(cx + radius * c, cy + radius * s, z))
                })
                .collect()
        })
        .collect();
    for j in 0..storeys {
        for i in 0..m {
            let k = (i + 1) % m;
            let quad = [rings[j][i], rings[j][k], rings[j + 1][k], rings[j + 1][i]];
            mesh.push_quad(quad, name);
        }
    }
    let bottom = mesh.push_vertex(Vec3::new(cx, cy, 0.0));
    let top = mesh.push_vertex(Vec3::new(cx, cy, height));
    for i in 0..m {
        let k = (i + 1) % m;
        mesh.push_triangle([bottom, rings[0][k], rings[0][i]], name);
        mesh.push_triangle([top, rings[storeys][i], rings[storeys][k]], name);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::check::closed_signed_volume;

    fn hall(target: u64) -> Hall {
        Hall {
            target_triangles: target,
            ..Hall::default()
        }
    }

    #[test]
    fn hits_triangle_targets_and_is_closed_and_oriented() {
        for target in [10_000u64, 200_000] {
            let m = hall(target).generate().unwrap();
            let n = m.triangles.len() as f64;
            assert!((n / target as f64 - 1.0).abs() < 0.15, "{n} for {target}");
            let v = closed_signed_volume(&m);
            assert!(v < 0.0 && v > -40.0 * 24.0 * 16.0, "{v}");
        }
    }

    #[test]
    fn is_deterministic() {
        assert_eq!(
            hall(20_000).generate().unwrap(),
            hall(20_000).generate().unwrap()
        );
    }

    #[test]
    fn rejects_absurd_parameters() {
        assert!(hall(10)
            .generate()
            .unwrap_err()
            .to_string()
            .contains("target_triangles"));
        assert!(hall(60_000_000).generate().is_err());
        let mut h = hall(10_000);
        h.seat_rows = 0;
        assert!(h.generate().is_err());
        h = hall(10_000);
        h.height = f32::INFINITY;
        assert!(h.generate().is_err());
    }
}
