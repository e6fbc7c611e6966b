//! The part of the room around a listener that its receiver sphere
//! counts: what the listener sees, out to the first surface in every
//! direction of a cube map, and no farther than the sphere may grow.
//!
//! The track-length estimator `E ℓ / V` wants a sphere whose every part
//! rays can cross. A whole sphere kept clear of every surface stays
//! within the listener's clearance, often a metre or so to the floor, and
//! in a room that barely scatters the late energy rides on few image
//! sources, each caught by such a sphere only by chance: that chance is
//! the estimate's spread. Here the sphere grows on, and what is counted
//! is its part inside the region: a leg counts where the middle of its
//! chord lies in the region, and the volume is the region's within the
//! radius. The region is the union of one cone per texel, each cut at the
//! distance its centre ray travels, so membership and volume agree
//! exactly. A chord counts whole by its middle: exact in a convex room,
//! approximate where a chord crosses the edge of what the listener sees
//! (a door, a pillar), and within the smallest sphere a thin wall is not
//! seen at all (as before the region).

use glam::DVec3;
use rayon::prelude::*;

use crate::acoustics::AcousticScene;
use crate::geometry::Ray;

/// Texels per cube-face side: 6 · 16² = 1536 rays per listener, a few
/// degrees each.
const SIDE: usize = 16;
const TEXELS: usize = 6 * SIDE * SIDE;
/// The memory a region holds: four arrays of about one `f64` per texel.
pub(super) const BYTES: u64 = (4 * (TEXELS + 1) * std::mem::size_of::<f64>()) as u64;

/// A listener's region: per cube-map texel, the depth the region reaches.
pub(super) struct Region {
    listener: DVec3,
    /// Per texel, how far the region reaches along it, m.
    depth: Vec<f64>,
    /// The depths ascending.
    sorted: Vec<f64>,
    /// `below[i]`: the sum of `Ω d³ / 3` over the `i` shallowest texels.
    below: Vec<f64>,
    /// `beyond[i]`: the solid angle of the texels from the `i`-th
    /// shallowest on.
    beyond: Vec<f64>,
}

impl Region {
    /// The region of `listener`: in each texel's direction out to the
    /// first surface, but at least `min` (a listener near a wall keeps a
    /// whole smallest sphere) and at most `max`. With `min >= max`, the
    /// ball of radius `min`, found without casting.
    pub fn new(scene: &AcousticScene, listener: DVec3, min: f64, max: f64) -> Self {
        let depth: Vec<f64> = (0..TEXELS)
            .into_par_iter()
            .map(|t| {
                if min >= max {
                    return min;
                }
                let ray = Ray::new(listener.as_vec3(), texel_direction(t).as_vec3())
                    .with_range(0.0, max as f32);
                let hit = scene
                    .bvh()
                    .closest_triangle(&ray)
                    .map_or(max, |h| f64::from(h.t));
                hit.clamp(min, max)
            })
            .collect();
        let mut order: Vec<usize> = (0..TEXELS).collect();
        order.sort_by(|&a, &b| depth[a].total_cmp(&depth[b]));
        let sorted: Vec<f64> = order.iter().map(|&t| depth[t]).collect();
        let mut below = vec![0.0; TEXELS + 1];
        let mut beyond = vec![0.0; TEXELS + 1];
        for (i, &t) in order.iter().enumerate() {
            below[i + 1] = below[i] + texel_solid_angle(t) * depth[t].powi(3) / 3.0;
        }
        for (i, &t) in order.iter().enumerate().rev() {
            beyond[i] = beyond[i + 1] + texel_solid_angle(t);
        }
        Self {
            listener,
            depth,
            sorted,
            below,
            beyond,
        }
    }

    /// The farthest the region reaches.
    pub fn reach(&self) -> f64 {
        self.sorted[TEXELS - 1]
    }

    /// The region's volume within `r` of the listener.
    pub fn volume(&self, r: f64) -> f64 {
        let i = self.sorted.partition_point(|&d| d < r);
        self.below[i] + self.beyond[i] * r.powi(3) / 3.0
    }

    /// Whether `p` lies in the region.
    #[inline]
    pub fn contains(&self, p: DVec3) -> bool {
        let to = p - self.listener;
        to.length_squared() < self.depth[texel_of(to)].powi(2)
    }
}

/// The texel of direction `d` (any length; zero and NaN go to some texel).
#[inline]
fn texel_of(d: DVec3) -> usize {
    let a = d.abs();
    // The face by the major axis and its sign; (u, v) the other two over
    // the major one.
    let (face, major, u, v) = if a.x >= a.y && a.x >= a.z {
        (usize::from(d.x < 0.0), a.x, d.y, d.z)
    } else if a.y >= a.z {
        (2 + usize::from(d.y < 0.0), a.y, d.z, d.x)
    } else {
        (4 + usize::from(d.z < 0.0), a.z, d.x, d.y)
    };
    let cell = |c: f64| (((c / major + 1.0) * 0.5 * SIDE as f64) as usize).min(SIDE - 1);
    (face * SIDE + cell(u)) * SIDE + cell(v)
}

/// Texel `t`'s face, and its edges' face coordinates in u and in v.
fn texel_square(t: usize) -> (usize, [f64; 2], [f64; 2]) {
    let (face, i, j) = (t / (SIDE * SIDE), (t / SIDE) % SIDE, t % SIDE);
    let at = |k: usize| 2.0 * k as f64 / SIDE as f64 - 1.0;
    (face, [at(i), at(i + 1)], [at(j), at(j + 1)])
}

/// The unit direction through texel `t`'s centre.
fn texel_direction(t: usize) -> DVec3 {
    let (face, u, v) = texel_square(t);
    let (u, v) = (0.5 * (u[0] + u[1]), 0.5 * (v[0] + v[1]));
    let sign = if face % 2 == 0 { 1.0 } else { -1.0 };
    match face / 2 {
        0 => DVec3::new(sign, u, v),
        1 => DVec3::new(v, sign, u),
        _ => DVec3::new(u, v, sign),
    }
    .normalize()
}

/// Texel `t`'s solid angle: the square `[u0, u1] × [v0, v1]` of a cube
/// face at distance 1 seen from the centre, from the integral
/// `A(u, v) = atan(u v / √(u² + v² + 1))` at its corners.
fn texel_solid_angle(t: usize) -> f64 {
    let (_, u, v) = texel_square(t);
    let a = |u: f64, v: f64| (u * v).atan2((u * u + v * v + 1.0).sqrt());
    a(u[1], v[1]) - a(u[0], v[1]) - a(u[1], v[0]) + a(u[0], v[0])
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use glam::Vec3;

    use super::*;
    use crate::scene::generate::BoxRoom;
    use crate::scene::{Material, Scene};

    #[test]
    fn texels_cover_the_sphere_once() {
        let total: f64 = (0..TEXELS).map(texel_solid_angle).sum();
        assert!((total - 4.0 * PI).abs() < 1e-9, "{total}");
        for t in 0..TEXELS {
            assert_eq!(texel_of(texel_direction(t)), t);
        }
        for d in [
            DVec3::X,
            -DVec3::Y,
            DVec3::Z,
            DVec3::ONE,
            -DVec3::ONE,
            DVec3::ZERO,
        ] {
            assert!(texel_of(d) < TEXELS);
        }
    }

    fn box_room() -> AcousticScene {
        let room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
        let scene = Scene::single_object(
            "room",
            room.generate().unwrap(),
            Material::uniform("w", 0.1).unwrap(),
        )
        .unwrap();
        AcousticScene::new(&scene)
    }

    /// Two 5 x 4 x 3 m rooms through a 1 x 2 m door: the region holds the
    /// listener's room and what it sees of the other through the door.
    #[test]
    fn the_next_room_is_in_the_region_only_through_the_door() {
        let rooms = Scene::single_object(
            "rooms",
            crate::scene::generate::TwoRooms::boxes()
                .generate()
                .unwrap(),
            Material::uniform("w", 0.1).unwrap(),
        )
        .unwrap();
        let scene = AcousticScene::new(&rooms);
        let listener = DVec3::new(3.0, 2.0, 1.0);
        let region = Region::new(&scene, listener, 0.1, 20.0);
        // Through the door (y 1.5..2.5, z 0..2, at x 5..5.2), and behind
        // the partition beside it.
        assert!(region.contains(DVec3::new(7.0, 2.0, 1.0)));
        assert!(!region.contains(DVec3::new(7.0, 0.5, 1.0)));
        assert!(!region.contains(DVec3::new(5.5, 2.0, 2.8)));
        assert!(region.contains(DVec3::new(0.5, 0.5, 2.5)));
        // All of room A (60 m³) and the cone of room B seen through the
        // door (about 0.4 sr from 2.2 to 7.2 m away), not all of B.
        let all = region.volume(1e3);
        assert!(all > 75.0 && all < 110.0, "{all}");
    }

    #[test]
    fn a_box_rooms_region_is_the_box_and_within_the_clearance_a_ball() {
        let scene = box_room();
        let listener = DVec3::new(7.0, 2.0, 1.2);
        let region = Region::new(&scene, listener, 0.1, 100.0);
        // Within the clearance (1.2 m to the floor), the whole ball.
        let ball = 4.0 / 3.0 * PI;
        assert!((region.volume(1.0) / ball - 1.0).abs() < 1e-12);
        // Far beyond it, the box's 180 m³ but for the faceting of the cones.
        let all = region.volume(1e3);
        assert!((all / 180.0 - 1.0).abs() < 0.03, "{all}");
        // The farthest corner, (0, 6, 3), is 8.26 m away; texels' centre
        // rays fall a little short of it.
        let reach = region.reach();
        assert!(reach <= 8.26 && reach > 7.5, "{reach}");
        assert!(region.contains(DVec3::new(2.0, 4.0, 2.0)));
        assert!(!region.contains(DVec3::new(11.0, 2.0, 1.2)));
        assert!(!region.contains(DVec3::new(7.0, 2.0, -0.5)));
        // Capped: a ball of the cap within the room.
        let capped = Region::new(&scene, listener, 0.1, 2.0);
        assert_eq!(capped.reach(), 2.0);
        let cut = capped.volume(2.0);
        assert!(cut < 4.0 / 3.0 * PI * 8.0 && cut > 0.8 * 4.0 / 3.0 * PI * 8.0);
        assert!(!capped.contains(DVec3::new(7.0, 2.0, -0.1)));
        // Without casting.
        let ball = Region::new(&scene, listener, 0.5, 0.5);
        assert!((ball.volume(0.5) / (4.0 / 3.0 * PI * 0.125) - 1.0).abs() < 1e-12);
    }
}
