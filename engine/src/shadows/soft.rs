//! Soft shadows: the fraction of an area light each receiver sees.
//!
//! Full ray tracing traces every sample of every receiver. Selective
//! tracing first asks each receiver's hull ([`super::penumbra`]) whether
//! the receiver is surely lit or surely in the umbra, and traces the
//! samples of the rest, the penumbra. Both draw the same samples, so they
//! agree on every pixel.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::area::AreaLight;
use super::camera::GBuffer;
use super::hard::{check_points, ShadowScene};
use super::penumbra::{Cover, Hull};
use super::selective::{ms, resolve, shadow_ray, ShadowStats, Target};
use super::{Camera, Method, PointVisibility, ShadowImage, ShadowOptions};
use crate::bvh::SceneBvh;
use crate::Result;

impl ShadowScene {
    /// Soft shadows of `light` seen through `camera`; `world` must be the
    /// one this was made from. Each pixel holds the fraction of its
    /// `options.samples`² light samples it sees; [`Method::ShadowMap`]
    /// reads the plain map of the light's centre (hard, the baseline).
    pub fn soft_shadows(
        &self,
        world: &SceneBvh,
        camera: &Camera,
        light: &AreaLight,
        options: &ShadowOptions,
    ) -> Result<ShadowImage> {
        camera.check()?;
        light.check()?;
        options.check()?;
        let start = Instant::now();
        let mut stats = ShadowStats::default();
        let gbuffer = GBuffer::render(camera, &self.occluders);
        stats.gbuffer_ms = ms(start);
        let target = |i: usize| self.surface_target(&gbuffer, i);
        let n = gbuffer.receivers.len();
        let visibility = self.resolve_area(world, light, n, target, options, &mut stats);
        stats.total_ms = ms(start);
        Ok(ShadowImage {
            width: camera.width,
            height: camera.height,
            visibility,
            stats,
        })
    }

    /// How much of `light` each of `points` (anywhere) sees, by the same
    /// samples and proofs as [`Self::soft_shadows`].
    pub fn area_visibility(
        &self,
        world: &SceneBvh,
        light: &AreaLight,
        points: &[Vec3],
        options: &ShadowOptions,
    ) -> Result<PointVisibility> {
        light.check()?;
        options.check()?;
        check_points(points)?;
        let start = Instant::now();
        let mut stats = ShadowStats::default();
        let target = |i: usize| {
            Some(Target {
                point: points[i],
                surface: None,
            })
        };
        let fraction = self.resolve_area(world, light, points.len(), target, options, &mut stats);
        stats.total_ms = ms(start);
        Ok(PointVisibility { fraction, stats })
    }

    /// The visibility of `light` from targets `0..n` by `options.method`.
    fn resolve_area(
        &self,
        world: &SceneBvh,
        light: &AreaLight,
        n: usize,
        target: impl Fn(usize) -> Option<Target> + Sync,
        options: &ShadowOptions,
        stats: &mut ShadowStats,
    ) -> Vec<f32> {
        let (occluders, topology) = (&self.occluders, &self.topology);
        if options.method == Method::ShadowMap {
            let centre = light.centre;
            return resolve(
                occluders, topology, world, centre, n, target, options, stats,
            );
        }
        let side = options.samples;
        let per_receiver = (side * side) as u64;
        let traced = |i: usize, t: &Target, samples: &mut Vec<Vec3>| {
            light.samples(t.point, i as u64, options.seed, side, samples);
            let clear = samples
                .iter()
                .filter(|&&s| !world.any_hit(&shadow_ray(t.point, s)))
                .count();
            clear as f32 / per_receiver as f32
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
        let proofs: Vec<Option<Cover>> = (0..n)
            .into_par_iter()
            .map_init(Vec::new, |candidates, i| {
                let t = target(i)?;
                let hull = Hull::new(t.point, light.frame(t.point), occluders.scale);
                Some(match hull {
                    Some(h) if h.candidates(world, occluders, topology, candidates) => {
                        h.prove(candidates, occluders, topology)
                    }
                    _ => Cover::Unknown,
                })
            })
            .collect();
        stats.classify_ms = ms(t);
        let t = Instant::now();
        let v = proofs
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |s, (i, p)| match p {
                Some(Cover::Lit) | None => 1.0,
                Some(Cover::Umbra) => 0.0,
                Some(Cover::Unknown) => target(i).map_or(1.0, |t| traced(i, &t, s)),
            })
            .collect();
        stats.pip_pixels = proofs
            .iter()
            .filter(|p| **p == Some(Cover::Unknown))
            .count() as u64;
        stats.rays = stats.pip_pixels * per_receiver;
        stats.trace_ms = ms(t);
        v
    }
}
