//! Soft shadows: the fraction of an area light each receiver sees.
//!
//! Full ray tracing traces every sample of every receiver. Selective
//! tracing first asks each receiver's hull ([`super::penumbra`]) whether
//! the receiver is surely lit or surely in the umbra, and traces the
//! samples of the rest, the penumbra. Both draw the same samples, so they
//! agree on every pixel.

use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::area::AreaLight;
use super::eye::Eye;
use super::light_map::RAY_ERROR;
use super::penumbra::{any_hit_among, Bounds, Candidate, Cover, Hull, Pool};
use super::scene::ShadowScene;
use super::selective::{ms, resolve, shadow_ray, ShadowStats, Target};
use super::{Method, ShadowOptions};
use crate::bvh::SceneBvh;
use crate::geometry::Ray;

impl ShadowScene {
    /// The visibility of `light` from the targets by `options.method`;
    /// they are laid out `layout.0` by `layout.1` (an image, or a row of
    /// points), and neighbours are proven together.
    pub(super) fn resolve_area(
        &self,
        world: &SceneBvh,
        light: &AreaLight,
        layout: (usize, usize),
        target: impl Fn(usize) -> Option<Target> + Sync,
        options: &ShadowOptions,
        stats: &mut ShadowStats,
    ) -> Vec<f32> {
        let (occluders, topology) = (&self.occluders, &self.topology);
        let n = layout.0 * layout.1;
        if options.method == Method::ShadowMap {
            let centre = light.centre;
            return resolve(
                occluders,
                topology,
                world,
                Eye::point(centre),
                n,
                target,
                options,
                stats,
            );
        }
        let per_receiver = (options.samples * options.samples) as u64;
        let traced = |i: usize, t: &Target, samples: &mut Vec<Vec3>| {
            seen_share(light, t, i, options, samples, |r| world.any_hit(r))
        };
        stats.receivers = (0..n)
            .into_par_iter()
            .filter(|&i| target(i).is_some())
            .count() as u64;
        if options.method == Method::Full {
            let t = Instant::now();
            let v = (0..n)
                .into_par_iter()
                .map_init(Vec::new, |s, i| target(i).map_or(1.0, |t| traced(i, &t, s)))
                .collect();
            stats.pip_pixels = stats.receivers;
            stats.rays = stats.receivers * per_receiver;
            stats.trace_ms = ms(t);
            return v;
        }
        let t = Instant::now();
        let proven: Vec<Vec<(usize, Answer)>> = groups(layout)
            .into_par_iter()
            .map_init(Scratch::default, |scratch, group| {
                self.prove_group(world, light, &target, group, options, scratch)
            })
            .collect();
        let mut answers = vec![Answer::Proven(1.0); n];
        for (i, answer) in proven.into_iter().flatten() {
            answers[i] = answer;
        }
        stats.classify_ms = ms(t);
        let t = Instant::now();
        let v = answers
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |s, (i, a)| match *a {
                Answer::Proven(v) | Answer::Traced(v) => v,
                Answer::Open => target(i).map_or(1.0, |t| traced(i, &t, s)),
            })
            .collect();
        stats.pip_pixels = answers
            .iter()
            .filter(|a| !matches!(a, Answer::Proven(_)))
            .count() as u64;
        stats.rays = stats.pip_pixels * per_receiver;
        stats.trace_ms = ms(t);
        v
    }
}

/// Neighbouring targets are proven together, 4 x 4 pixels or 16 points
/// in a row: larger groups walk less but sort through more triangles per
/// receiver.
const GROUP_SIDE: usize = 4;

/// The groups of a layout: pixel blocks of an image, runs of points.
fn groups((width, height): (usize, usize)) -> Vec<Group> {
    let (w, h) = if height == 1 {
        (GROUP_SIDE * GROUP_SIDE, 1)
    } else {
        (GROUP_SIDE, GROUP_SIDE)
    };
    let mut out = Vec::with_capacity(width.div_ceil(w) * height.div_ceil(h));
    for y in (0..height).step_by(h) {
        for x in (0..width).step_by(w) {
            out.push(Group {
                width,
                x: x..(x + w).min(width),
                y: y..(y + h).min(height),
            });
        }
    }
    out
}

/// A block of targets.
struct Group {
    width: usize,
    x: std::ops::Range<usize>,
    y: std::ops::Range<usize>,
}

impl Group {
    fn indices(&self) -> impl Iterator<Item = usize> + '_ {
        self.y
            .clone()
            .flat_map(move |y| self.x.clone().map(move |x| y * self.width + x))
    }
}

/// What a group's proofs reuse.
#[derive(Default)]
struct Scratch {
    hulls: Vec<(usize, Target, Hull)>,
    pool: Pool,
    candidates: Vec<Candidate>,
    samples: Vec<Vec3>,
}

/// What a group's pass settles about a receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Answer {
    /// Proven lit (1) or in the umbra (0).
    Proven(f32),
    /// The share of samples seen, its rays traced against the proof's
    /// complete list of the triangles they may meet.
    Traced(f32),
    /// Left to rays through the world.
    Open,
}

/// The share of `light`'s samples that target `i` (`t`) sees, `blocked`
/// telling whether a shadow ray meets anything.
fn seen_share(
    light: &AreaLight,
    t: &Target,
    i: usize,
    options: &ShadowOptions,
    samples: &mut Vec<Vec3>,
    blocked: impl Fn(&Ray) -> bool,
) -> f32 {
    let side = options.samples;
    light.samples(t.point, i as u64, options.seed, side, samples);
    let clear = samples
        .iter()
        .filter(|&&s| t.faces(s) && !blocked(&shadow_ray(t.point, s)))
        .count();
    clear as f32 / (side * side) as f32
}

impl ShadowScene {
    /// The proofs of a group's targets. The group walks the world once
    /// with planes bounding all its hulls, and each hull then sorts
    /// through the triangles found; a group whose walk finds too many
    /// (its pixels far apart in depth) walks hull by hull. A receiver
    /// left unproven with a complete list of the triangles its hull may
    /// meet has its samples traced against those alone.
    fn prove_group(
        &self,
        world: &SceneBvh,
        light: &AreaLight,
        target: &(impl Fn(usize) -> Option<Target> + Sync),
        group: Group,
        options: &ShadowOptions,
        scratch: &mut Scratch,
    ) -> Vec<(usize, Answer)> {
        let (occluders, topology) = (&self.occluders, &self.topology);
        let mut out = Vec::with_capacity(group.x.len() * group.y.len());
        scratch.hulls.clear();
        for i in group.indices() {
            let Some(t) = target(i) else { continue };
            let frame = light.frame(t.point);
            match light_side(&t, frame, occluders.scale) {
                Some(false) => out.push((i, Answer::Proven(0.0))),
                None => out.push((i, Answer::Open)),
                Some(true) => match Hull::new(t.point, frame, occluders.scale) {
                    Some(h) => scratch.hulls.push((i, t, h)),
                    None => out.push((i, Answer::Open)),
                },
            }
        }
        // A proof sorting through more triangles than this costs more
        // than tracing the samples.
        let budget = (2 * options.samples * options.samples) as usize;
        let shared = Bounds::of(scratch.hulls.iter().map(|(_, _, h)| h))
            .is_some_and(|b| b.triangles(world, occluders, &mut scratch.pool, budget));
        for (i, t, hull) in &scratch.hulls {
            let found = shared
                || Bounds::of(std::iter::once(hull))
                    .is_some_and(|b| b.triangles(world, occluders, &mut scratch.pool, budget));
            let complete = found
                && hull.candidates(&scratch.pool, occluders, topology, &mut scratch.candidates);
            let answer = if !complete {
                Answer::Open
            } else {
                match hull.prove(&mut scratch.candidates, occluders, topology) {
                    Cover::Lit => Answer::Proven(1.0),
                    Cover::Umbra => Answer::Proven(0.0),
                    Cover::Unknown => {
                        let among = &scratch.candidates;
                        Answer::Traced(seen_share(
                            light,
                            t,
                            *i,
                            options,
                            &mut scratch.samples,
                            |r| any_hit_among(world, among, r),
                        ))
                    }
                }
            };
            out.push((*i, answer));
        }
        out
    }
}

/// Whether every sample of the light parallelogram `[c, u, v]` lies on the
/// side `t` receives light from (`Some(true)`), none does
/// (`Some(false)`), or some may (`None`), allowing for the samples'
/// rounding to `f32`.
fn light_side(t: &Target, [c, u, v]: [DVec3; 3], scale: f64) -> Option<bool> {
    if t.front == Vec3::ZERO {
        return Some(true);
    }
    let (p, n) = (t.point.as_dvec3(), t.front.as_dvec3());
    let reach = (c - p).length() + u.length() + v.length();
    let margin = RAY_ERROR * scale.max(c.abs().max_element() + reach) + 1e-6 * reach;
    let d = [c - u - v, c + u - v, c + u + v, c - u + v].map(|q| n.dot(q - p));
    if d.iter().all(|&d| d > margin) {
        Some(true)
    } else if d.iter().all(|&d| d < -margin) {
        Some(false)
    } else {
        None
    }
}
