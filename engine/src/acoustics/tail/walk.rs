//! One ray's random walk through the scene, and the tally of the energy it
//! hands the listeners.

use std::f64::consts::PI;
use std::ops::Range;

use glam::{DVec3, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_pcg::Pcg64;

use super::region::Region;
use super::{Room, TailInput, BIN_S};
use crate::acoustics::surfaces::{Plane, SurfaceGroup, NO_GROUP};
use crate::acoustics::AcousticScene;
use crate::deadline::{Deadline, CLOCK_PERIOD};
use crate::geometry::Ray;
use crate::scene::BAND_COUNT;
use crate::Result;

/// Energy per band.
type Energy = [f64; BAND_COUNT];

/// A ray stops this far below its starting energy in every band (−60 dB).
const STOP_FRACTION: f64 = 1e-6;
/// Diffuse reflections up to this order always rain; later ones rain by
/// roulette (see [`Walk::rain_chance`]).
const ALWAYS_RAIN_ORDER: u32 = 2;
/// Rain samples wanted per listener and histogram bin: later hits are
/// many times more (every live ray hits a surface every mean free path),
/// so most would only refine bins already well sampled.
const RAIN_PER_BIN: f64 = 64.0;

/// The most surface hits one ray follows: a ray caught between two close
/// parallel planes must not run for ever.
const MAX_HITS: u32 = 1 << 16;

/// Energy per listener and bin, and counts, summed over some rays.
pub(super) struct Tally {
    /// `energy[listener][bin][band]`.
    pub energy: Vec<Vec<Energy>>,
    pub reflections: u64,
    pub shadow_rays: u64,
}

impl Tally {
    pub fn new(listeners: usize) -> Self {
        Self {
            energy: vec![Vec::new(); listeners],
            reflections: 0,
            shadow_rays: 0,
        }
    }

    pub fn add(&mut self, other: &Tally) {
        for (mine, theirs) in self.energy.iter_mut().zip(&other.energy) {
            if mine.len() < theirs.len() {
                mine.resize(theirs.len(), [0.0; BAND_COUNT]);
            }
            for (m, t) in mine.iter_mut().zip(theirs) {
                for (a, b) in m.iter_mut().zip(t) {
                    *a += b;
                }
            }
        }
        self.reflections += other.reflections;
        self.shadow_rays += other.shadow_rays;
    }

    /// Adds `energy · weight` at `listener`, arriving at `time_s`.
    fn deposit(&mut self, listener: usize, time_s: f64, energy: &[f32; BAND_COUNT], weight: f64) {
        let bin = (time_s / BIN_S) as usize;
        let bins = &mut self.energy[listener];
        if bins.len() <= bin {
            bins.resize(bin + 1, [0.0; BAND_COUNT]);
        }
        for (slot, &e) in bins[bin].iter_mut().zip(energy) {
            *slot += f64::from(e) * weight;
        }
    }
}

/// What a walk hands the listeners, whoever they are: the walk itself
/// depends on the source alone, so a stream can keep its events and hand
/// them to listeners that move ([`Recorded`]).
#[derive(Clone, Copy, Debug)]
pub(super) enum Event {
    /// A leg a listener's sphere may count.
    Leg {
        origin: DVec3,
        dir: DVec3,
        leg: f64,
        travelled: f64,
        energy: Energy,
    },
    /// Diffusely reflected energy leaving `point` (facing `facing`).
    Rain {
        point: DVec3,
        facing: DVec3,
        travelled: f64,
        energy: Energy,
    },
}

/// An [`Event`] in single precision, 64 bytes instead of 128: positions
/// to well under a millimetre, times to under a microsecond, energies to
/// 1e-7 of their value. Every tail is counted from events so rounded,
/// kept or not.
#[derive(Clone, Copy, Debug)]
pub(super) struct Recorded {
    /// The leg's origin or the rain's point.
    at: Vec3,
    /// The leg's direction or the rain's facing.
    towards: Vec3,
    /// The leg's length; negative for rain.
    leg: f32,
    travelled: f32,
    energy: [f32; BAND_COUNT],
}

impl From<&Event> for Recorded {
    fn from(e: &Event) -> Self {
        let energy = |e: &Energy| e.map(|v| v as f32);
        match e {
            Event::Leg {
                origin,
                dir,
                leg,
                travelled,
                energy: en,
            } => Self {
                at: origin.as_vec3(),
                towards: dir.as_vec3(),
                leg: *leg as f32,
                travelled: *travelled as f32,
                energy: energy(en),
            },
            Event::Rain {
                point,
                facing,
                travelled,
                energy: en,
            } => Self {
                at: point.as_vec3(),
                towards: facing.as_vec3(),
                leg: -1.0,
                travelled: *travelled as f32,
                energy: energy(en),
            },
        }
    }
}

/// A material's energy fractions per band, and what the walk derives from
/// them at every hit, worked out once per trace for the active bands.
struct Surface {
    reflected: Energy,
    transmitted: Energy,
    /// The diffusely reflected share, `(1 − α) s`: the rain's.
    rain: Energy,
    /// Whether any band scatters.
    scatters: bool,
    /// Whether any band passes through.
    transmits: bool,
    /// The chance a reflection is diffuse: the scattering's mean over the
    /// active bands.
    p_diffuse: f64,
    /// Each band's factor on a diffuse reflection, `(1 − α) s / p_diffuse`,
    /// and on a specular one, `(1 − α)(1 − s) / (1 − p_diffuse)`: reflected,
    /// then re-weighted for the choice.
    diffuse: Energy,
    specular: Energy,
}

impl Surface {
    /// For a material id the table lacks: a perfect specular reflector.
    const REFLECTING: Surface = Surface {
        reflected: [1.0; BAND_COUNT],
        transmitted: [0.0; BAND_COUNT],
        rain: [0.0; BAND_COUNT],
        scatters: false,
        transmits: false,
        p_diffuse: 0.0,
        diffuse: [0.0; BAND_COUNT],
        specular: [1.0; BAND_COUNT],
    };

    fn of(m: &crate::scene::Material, active: &[bool; BAND_COUNT]) -> Self {
        let reflected = m.absorption.map(|a| 1.0 - f64::from(a));
        let scattered = m.scattering.map(f64::from);
        let transmitted = m.transmission.map(f64::from);
        let p_diffuse = mean(&scattered, &active.map(f64::from));
        let each = |f: &dyn Fn(f64) -> f64| std::array::from_fn(|b| reflected[b] * f(scattered[b]));
        Self {
            reflected,
            transmitted,
            rain: each(&|s| s),
            scatters: scattered.iter().any(|&s| s > 0.0),
            transmits: transmitted.iter().any(|&t| t > 0.0),
            p_diffuse,
            diffuse: each(&|s| s / p_diffuse),
            specular: each(&|s| (1.0 - s) / (1.0 - p_diffuse)),
        }
    }
}

/// The mean of `fraction` weighted by `weights` (0 where they are all 0).
/// Bands a trace leaves out weigh 0: a ray carries no energy in them.
fn mean(fraction: &Energy, weights: &Energy) -> f64 {
    let (sum, weight) = fraction
        .iter()
        .zip(weights)
        .fold((0.0, 0.0), |(sum, weight), (f, w)| {
            (sum + f * w, weight + w)
        });
    if weight > 0.0 {
        sum / weight
    } else {
        0.0
    }
}

/// Everything the rays of one source share.
pub(super) struct Walk<'a> {
    scene: &'a AcousticScene,
    surfaces: Vec<Surface>,
    source: DVec3,
    /// Rays in all, and the seed's shift of their starting lattice: of
    /// every ray's height (a fraction of its stratum) and of its azimuth.
    rays: usize,
    shift: f64,
    turn: f64,
    /// The chance that a diffuse reflection past [`ALWAYS_RAIN_ORDER`]
    /// sends its shadow rays, its energy then divided by it (unbiased):
    /// [`RAIN_PER_BIN`] over the hits all rays make in one bin,
    /// `rays · c Δt / (4V/S)`, at most 1.
    rain_chance: f64,
    exact_order: u32,
    /// Each ray's starting energy per active band.
    start: Energy,
    max_length_m: f64,
    /// How far off a surface a ray restarts, so it does not hit it again.
    offset: f64,
    seed: u64,
}

impl<'a> Walk<'a> {
    pub fn new(scene: &'a AcousticScene, source: DVec3, input: &TailInput, free_path: f64) -> Self {
        let share = 4.0 * PI / f64::from(input.options.rays);
        let mut rng = ChaCha8Rng::seed_from_u64(input.options.seed);
        rng.set_stream(u64::MAX);
        let (shift, turn) = (rng.random::<f64>(), 2.0 * PI * rng.random::<f64>());
        Self {
            scene,
            surfaces: scene
                .materials()
                .iter()
                .map(|m| Surface::of(m, &input.active_bands))
                .collect(),
            source,
            rays: input.options.rays as usize,
            shift,
            turn,
            rain_chance: (RAIN_PER_BIN * free_path
                / (f64::from(input.options.rays) * input.speed_of_sound * BIN_S))
                .min(1.0),
            exact_order: input.exact_order,
            start: input.active_bands.map(|a| if a { share } else { 0.0 }),
            max_length_m: input.options.max_length_s * input.speed_of_sound,
            offset: 1e-6 * scene.surfaces().scale().max(1e-3),
            seed: input.options.seed,
        }
    }

    /// Walks rays `rays`, handing every event to `emit`; returns the
    /// surface hits.
    pub fn rays(
        &self,
        rays: Range<usize>,
        deadline: &Deadline,
        emit: &mut impl FnMut(Event),
    ) -> Result<u64> {
        let mut hits = 0;
        for (i, ray) in rays.enumerate() {
            if i as u64 % CLOCK_PERIOD == 0 {
                deadline.check()?;
            }
            hits += self.ray(self.direction(ray), &mut ray_rng(self.seed, ray), emit);
        }
        Ok(hits)
    }

    /// The starting direction of ray `ray`: point `ray` of a spherical
    /// Fibonacci lattice of all the rays, its heights shifted within their
    /// strata and its azimuths turned by the seed (so each ray is uniform
    /// over its stratum, and the estimate unbiased). Stratified in height
    /// above all: floors and ceilings are horizontal (scenes are z up), and
    /// the late decay of a room whose floor and ceiling absorb most rides
    /// on the few near-horizontal rays between its walls. Exactly as many
    /// rays leave at every elevation whatever the seed, where a randomly
    /// turned lattice puts a varying few there: in the 10 x 6 x 3 m box
    /// with a carpet and a tiled ceiling that cut the worst of its decay
    /// times over eight seeds from 1.4 to 1.1 just-noticeable differences
    /// (to 0.7 with the spheres' regions, see [`Receivers`]).
    fn direction(&self, ray: usize) -> DVec3 {
        lattice_direction(ray, self.rays, self.shift, self.turn)
    }

    fn ray(&self, start: DVec3, rng: &mut Pcg64, emit: &mut impl FnMut(Event)) -> u64 {
        let mut origin = self.source;
        let mut dir = start;
        let mut energy = self.start;
        let stop = STOP_FRACTION * self.start.iter().fold(0.0, |m: f64, &e| m.max(e));
        let mut travelled = 0.0;
        // Events so far; whether all were specular (reflections or
        // transmissions); whether the last was a diffuse reflection.
        let mut order = 0u32;
        let mut specular = true;
        let mut after_diffuse = false;
        while order < MAX_HITS {
            let remaining = self.max_length_m - travelled;
            let ray = Ray::new(origin.as_vec3(), dir.as_vec3()).with_range(0.0, remaining as f32);
            let hit = self.scene.bvh().closest_triangle(&ray);
            let leg = hit.map_or(remaining, |h| f64::from(h.t));
            let exact = specular && order <= self.exact_order;
            if !(after_diffuse || exact) {
                emit(Event::Leg {
                    origin,
                    dir,
                    leg,
                    travelled,
                    energy,
                });
            }
            let Some(hit) = hit else { break };
            travelled += leg;
            order += 1;
            if travelled >= self.max_length_m {
                break;
            }
            let point = origin + dir * leg;
            let surfaces = self.scene.surfaces();
            let group = surfaces.group_of(hit.object, hit.triangle);
            if group == NO_GROUP {
                // A triangle of no area (see `NO_GROUP`) is not hit in
                // practice; should rounding report one, the ray ends there
                // rather than reflect off a plane it does not have.
                break;
            }
            // The plane of the triangle's group, in world space, unit
            // length and in `f64` already (the triangle's own normal to
            // within the grouping's 1e-5 rounding), and its material.
            let SurfaceGroup {
                plane: Plane { normal, .. },
                material,
            } = *surfaces.group(group);
            // The normal on the side the ray came from. A sign picked, not
            // a branch: which side a ray meets is a coin toss, and the
            // branch had been a quarter of the tail's mispredictions.
            let side = if dir.dot(normal) < 0.0 { 1.0 } else { -1.0 };
            let facing = normal * side;
            let surface = self.surface(material);
            let chance = if order <= ALWAYS_RAIN_ORDER {
                1.0
            } else {
                self.rain_chance
            };
            if surface.scatters && (chance >= 1.0 || rng.random::<f64>() < chance) {
                let mut diffuse = energy;
                for (d, r) in diffuse.iter_mut().zip(&surface.rain) {
                    *d *= r / chance;
                }
                emit(Event::Rain {
                    point: point + facing * self.offset,
                    facing,
                    travelled,
                    energy: diffuse,
                });
            }
            // Without transmission the chance of passing is 0 (still drawn
            // below, so a seed's rays stay the same), and the ray ends
            // only where no active band reflects anything.
            let p_through = if surface.transmits {
                let through = mean(&surface.transmitted, &energy);
                let back = mean(&surface.reflected, &energy);
                if through + back <= 0.0 {
                    break;
                }
                through / (through + back)
            } else {
                let back: f64 = surface
                    .reflected
                    .iter()
                    .zip(&energy)
                    .map(|(r, e)| r * e)
                    .sum();
                if back <= 0.0 {
                    break;
                }
                0.0
            };
            if rng.random::<f64>() < p_through {
                for (e, t) in energy.iter_mut().zip(&surface.transmitted) {
                    *e *= t / p_through;
                }
                origin = point - facing * self.offset;
                after_diffuse = false;
            } else {
                let diffusely = rng.random::<f64>() < surface.p_diffuse;
                let factors = if diffusely {
                    &surface.diffuse
                } else {
                    &surface.specular
                };
                // Divided by the chance of reflecting only where it is not
                // 1: two loops, so that walls that pass nothing do not
                // compute (and discard) a division per band.
                if p_through > 0.0 {
                    let reflects = 1.0 - p_through;
                    for (e, f) in energy.iter_mut().zip(factors) {
                        *e *= f / reflects;
                    }
                } else {
                    for (e, f) in energy.iter_mut().zip(factors) {
                        *e *= f;
                    }
                }
                dir = if diffusely {
                    lambert_direction(rng, facing)
                } else {
                    dir - 2.0 * dir.dot(normal) * normal
                };
                origin = point + facing * self.offset;
                specular &= !diffusely;
                after_diffuse = diffusely;
            }
            if energy.iter().all(|&e| e < stop) {
                break;
            }
        }
        u64::from(order)
    }

    fn surface(&self, material: u16) -> &Surface {
        self.surfaces
            .get(material as usize)
            .unwrap_or(&Surface::REFLECTING)
    }
}

/// The listeners a walk's events are handed to, and what they count.
///
/// A leg counts at a listener's sphere by the track-length estimator,
/// `E ℓ / V`: unbiased for any radius over which the energy density is
/// smooth, as long as every part of the sphere counted can be crossed (see
/// [`Region`]). A fixed radius sized for a few crossings per bin does not
/// get better with more rays: it shrinks as they grow, and in a room that
/// barely scatters the late energy rides on a few image sources, each
/// caught by chance. So the radius grows with the path's length `L`: a ray
/// of the lattice of `N` stands for the solid angle `4π / N`, a tube of
/// cross-section `4π L² / N` from its image source, and a sphere of that
/// cross-section (radius `2L / √N`) is crossed by about one ray per image
/// source, whatever `N`. It grows from the radius sized for a few
/// crossings per bin to half a mean free path, and only its part in the
/// listener's region, what the listener sees, counts.
pub(super) struct Receivers<'a> {
    scene: &'a AcousticScene,
    listeners: &'a [DVec3],
    /// The smallest sphere's radius, also the rain's nearest distance.
    radius: f64,
    /// Per listener, the part of the room its sphere counts.
    regions: Vec<Region>,
    /// Radius per metre of path: `2 / √N`, or 0 for a fixed radius.
    growth: f64,
    /// Rain of a smaller Lambert weight than this sends its shadow ray
    /// only by roulette (see [`Self::rain`]); 0 in an open scene, whose
    /// free path says nothing of the distances rain travels.
    rain_weight: f64,
    speed: f64,
    max_length_m: f64,
}

impl<'a> Receivers<'a> {
    /// Spheres of the room's radius growing to its reach within each
    /// listener's region, or of the radius alone when the options fix it.
    /// Errors: the deadline passed while the regions were cast.
    pub fn new(
        scene: &'a AcousticScene,
        listeners: &'a [DVec3],
        input: &TailInput,
        room: &Room,
        deadline: &Deadline,
    ) -> Result<Self> {
        let radius = room.radius;
        let fixed = input.options.receiver_radius_m.is_some();
        let reach = if fixed { radius } else { room.sphere_reach() };
        let regions = listeners
            .iter()
            .map(|&l| {
                deadline.check()?;
                Ok(Region::new(scene, l, radius, reach))
            })
            .collect::<Result<_>>()?;
        Ok(Self {
            scene,
            listeners,
            radius,
            regions,
            growth: if fixed {
                0.0
            } else {
                2.0 / f64::from(input.options.rays).sqrt()
            },
            rain_weight: if room.closed {
                1.0 / (PI * room.free_path.max(radius).powi(2))
            } else {
                0.0
            },
            speed: input.speed_of_sound,
            max_length_m: input.options.max_length_s * input.speed_of_sound,
        })
    }

    /// Counts one event at every listener; its energies are widened only
    /// where they are counted (most legs miss every sphere).
    #[inline]
    pub fn take(&self, event: &Recorded, tally: &mut Tally) {
        let (at, towards) = (event.at.as_dvec3(), event.towards.as_dvec3());
        let travelled = f64::from(event.travelled);
        if event.leg >= 0.0 {
            let leg = f64::from(event.leg);
            self.cross_spheres(at, towards, leg, travelled, &event.energy, tally);
        } else {
            self.rain(at, towards, travelled, &event.energy, tally);
        }
    }

    /// The track-length estimate of the leg `origin + dir · [0, leg]`,
    /// `travelled` metres from the source, at every listener's sphere
    /// (its radius set by the path's length where the leg passes nearest).
    fn cross_spheres(
        &self,
        origin: DVec3,
        dir: DVec3,
        leg: f64,
        travelled: f64,
        energy: &[f32; BAND_COUNT],
        tally: &mut Tally,
    ) {
        for (l, (&listener, region)) in self.listeners.iter().zip(&self.regions).enumerate() {
            let to = listener - origin;
            let along = to.dot(dir);
            let miss2 = to.length_squared() - along * along;
            let reach = region.reach();
            if miss2 >= reach * reach {
                continue;
            }
            let path = travelled + along.clamp(0.0, leg);
            let r = (self.growth * path).max(self.radius).min(reach);
            let r2 = r * r;
            if miss2 >= r2 {
                continue;
            }
            let half = (r2 - miss2).sqrt();
            let (enter, exit) = ((along - half).max(0.0), (along + half).min(leg));
            let chord = exit - enter;
            if chord <= 0.0 || !region.contains(origin + dir * (0.5 * (enter + exit))) {
                continue;
            }
            tally.deposit(l, path / self.speed, energy, chord / region.volume(r));
        }
    }

    /// Sends the diffusely reflected `energy` at `point` (facing `facing`)
    /// to every listener in front of it that it can see, by Lambert's law.
    /// Closer than the sphere radius, the distance is held at the radius:
    /// the sphere is the listener's size, and the variance stays bounded.
    ///
    /// The shadow rays are most of a replayed tail's work, and most go to
    /// far points that add little (the rain of every octave of distance
    /// adds about as much, and there are more points the farther). So rain
    /// weighing less than [`Self::rain_weight`] (a point a mean free path
    /// away, head on) is sent only by roulette, with a chance of its share
    /// of that weight, and counted divided by it: unbiased, and the far
    /// half of a hall's rain costs a fraction of its shadow rays. The draw
    /// hashes the event, so a replay draws what the trace drew.
    fn rain(
        &self,
        point: DVec3,
        facing: DVec3,
        travelled: f64,
        energy: &[f32; BAND_COUNT],
        tally: &mut Tally,
    ) {
        for (l, &listener) in self.listeners.iter().enumerate() {
            let to = listener - point;
            let distance = to.length();
            let cos = to.dot(facing) / distance;
            if cos.is_nan() || cos <= 0.0 || travelled + distance > self.max_length_m {
                continue;
            }
            let weight = cos / (PI * distance.max(self.radius).powi(2));
            let chance = (weight / self.rain_weight).min(1.0);
            if chance < 1.0 && unit_hash([point.x, point.y, point.z, travelled]) >= chance {
                continue;
            }
            tally.shadow_rays += 1;
            let shadow = Ray::segment(point.as_vec3(), listener.as_vec3());
            if self.scene.bvh().any_hit(&shadow) {
                continue;
            }
            tally.deposit(
                l,
                (travelled + distance) / self.speed,
                energy,
                weight / chance,
            );
        }
    }
}

/// A number in `[0, 1)` that looks uniform, from the bits of `values`
/// (SplitMix64's finaliser, Steele et al. 2014, over each word). The
/// event's alone, not the listener's index: a listener's tail does not
/// depend on which others share the call, or in what order.
fn unit_hash(values: [f64; 4]) -> f64 {
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let mut h = 0x9e37_79b9_7f4a_7c15;
    for v in values {
        h = mix(h ^ v.to_bits()).wrapping_add(0x9e37_79b9_7f4a_7c15);
    }
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The random stream of ray `ray` of seed `seed`: its own generator,
/// seeded (state and increment) from the two, so each ray draws the same
/// numbers whichever thread walks it, and in whatever order. PCG: a ray
/// draws three or four numbers a reflection.
fn ray_rng(seed: u64, ray: usize) -> Pcg64 {
    Pcg64::seed_from_u64(seed ^ (ray as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// Point `ray` of the spherical Fibonacci lattice of `rays` points, its
/// height `shift` (in `[0, 1)`) of the way down its stratum and its
/// azimuth turned by `turn`: stratum `ray` is the band of heights
/// `1 − 2 (ray + [0, 1)) / rays`, all of equal area.
fn lattice_direction(ray: usize, rays: usize, shift: f64, turn: f64) -> DVec3 {
    let z = 1.0 - 2.0 * (ray as f64 + shift) / rays as f64;
    let phi = PI * (3.0 - 5f64.sqrt()) * ray as f64 + turn;
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A direction in the hemisphere around `normal`, with density
/// proportional to the cosine from it (Lambert's law): a point uniform in
/// the unit disk, lifted onto the hemisphere (Malley's method). The disk's
/// point is drawn by rejection from its square, which costs 1.27 draws of
/// two numbers on average and no trigonometry: `sin_cos` had been a tenth
/// of a diffuse reflection's work.
fn lambert_direction(rng: &mut Pcg64, normal: DVec3) -> DVec3 {
    let (u, v) = normal.any_orthonormal_pair();
    let (x, y, r2) = loop {
        let x = 2.0 * rng.random::<f64>() - 1.0;
        let y = 2.0 * rng.random::<f64>() - 1.0;
        let r2 = x * x + y * y;
        if r2 < 1.0 {
            break (x, y, r2);
        }
    };
    // Unit length to rounding already: (u, v, normal) are orthonormal.
    u * x + v * y + normal * (1.0 - r2).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lambert's law, by its closed-form moments: over directions of
    /// density cos θ / π in the hemisphere, the mean of cos θ is 2/3 and of
    /// cos² θ is 1/2, and the azimuth is uniform (the mean tangential
    /// component is zero). Every direction is unit length and in front.
    #[test]
    fn lambert_directions_have_the_cosine_laws_moments() {
        let mut rng = Pcg64::seed_from_u64(5);
        let normal = DVec3::new(0.3, -0.5, 0.8).normalize();
        let (u, v) = normal.any_orthonormal_pair();
        let n = 200_000;
        let (mut cos, mut cos2, mut tangent) = (0.0, 0.0, DVec3::ZERO);
        for _ in 0..n {
            let d = lambert_direction(&mut rng, normal);
            assert!((d.length() - 1.0).abs() < 1e-12);
            let c = d.dot(normal);
            assert!(c >= 0.0, "{d} behind the surface");
            cos += c;
            cos2 += c * c;
            tangent += DVec3::new(d.dot(u), d.dot(v), 0.0);
        }
        let n = f64::from(n);
        // Standard errors are about 0.24 / √n = 5e-4; five of them.
        assert!((cos / n - 2.0 / 3.0).abs() < 3e-3, "{}", cos / n);
        assert!((cos2 / n - 0.5).abs() < 3e-3, "{}", cos2 / n);
        assert!((tangent / n).length() < 4e-3, "{}", tangent / n);
    }

    /// Every ray lies in its own band of heights, whatever the seed's shift
    /// and turn: exactly one ray per band of equal area. And over shifts
    /// and turns each ray covers its band uniformly: the mean direction of
    /// all rays over many draws is the sphere's, zero.
    #[test]
    fn the_lattice_puts_one_ray_in_each_band_of_heights() {
        let rays = 997;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut sum = DVec3::ZERO;
        for _ in 0..64 {
            let (shift, turn) = (rng.random::<f64>(), 2.0 * PI * rng.random::<f64>());
            let mut in_band = vec![0; rays];
            for ray in 0..rays {
                let d = lattice_direction(ray, rays, shift, turn);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let band = ((1.0 - d.z) / 2.0 * rays as f64).floor() as usize;
                in_band[band.min(rays - 1)] += 1;
                sum += d;
            }
            assert!(in_band.iter().all(|&n| n == 1), "a band without its ray");
        }
        let mean = sum / (64 * rays) as f64;
        assert!(mean.length() < 2e-3, "{mean}");
    }
}
