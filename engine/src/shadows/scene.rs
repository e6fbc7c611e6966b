//! The scene data every shadow query keeps, and the queries: shadow
//! images through a camera and the visibility of a light from points.

use std::time::Instant;

use glam::Vec3;

use super::camera::{Camera, GBuffer};
use super::eye::Eye;
use super::occluders::{Occluders, Topology};
use super::selective::{ms, resolve, ShadowStats, Target};
use super::{AreaLight, Light, PointLight, ShadowOptions};
use crate::bvh::SceneBvh;
use crate::{Error, Result};

/// A shadow image: per pixel the fraction of the light its surface sees
/// (for hard shadows 0 or 1; pixels that see no surface are 1).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowImage {
    pub width: u32,
    pub height: u32,
    pub visibility: Vec<f32>,
    pub stats: ShadowStats,
}

/// Hard shadows of `light` seen through `camera` (a [`ShadowScene`] made
/// for this call: keep one to answer many).
pub fn hard_shadows(
    world: &SceneBvh,
    camera: &Camera,
    light: &PointLight,
    options: &ShadowOptions,
) -> Result<ShadowImage> {
    ShadowScene::new(world).hard_shadows(world, camera, light, options)
}

/// What shadow queries need of a world beyond its trees: its triangles in
/// world space and how they join (welded edges, connected parts). It
/// depends only on the geometry, so one serves every camera and light
/// until an object moves or deforms.
pub struct ShadowScene {
    pub(super) occluders: Occluders,
    pub(super) topology: Topology,
    /// Time it took to make, in milliseconds.
    pub build_ms: f64,
}

impl ShadowScene {
    pub fn new(world: &SceneBvh) -> Self {
        let start = Instant::now();
        let occluders = Occluders::of(world);
        let topology = Topology::of(world, &occluders);
        Self {
            occluders,
            topology,
            build_ms: ms(start),
        }
    }

    /// The surface each pixel of `camera` sees (the G-buffer every method
    /// shares).
    pub fn gbuffer(&self, camera: &Camera) -> Result<GBuffer> {
        camera.check()?;
        Ok(GBuffer::render(camera, &self.occluders))
    }

    /// Shadows of `light` seen through `camera`; `world` must be the one
    /// this was made from. Each pixel holds the fraction of the light its
    /// surface sees: 0 or 1 for a point light, a share of the light's
    /// `options.samples`² samples for an area light.
    ///
    /// Every method shares the G-buffer; they differ only in how each
    /// receiver's visibility is decided, so their images are comparable
    /// pixel for pixel, and [`Method::Selective`] equals [`Method::Full`]
    /// on every one. For an area light, [`Method::ShadowMap`] reads the
    /// plain map of its centre (hard: the baseline).
    pub fn shadows(
        &self,
        world: &SceneBvh,
        camera: &Camera,
        light: &Light,
        options: &ShadowOptions,
    ) -> Result<ShadowImage> {
        camera.check()?;
        light.check()?;
        options.check()?;
        let start = Instant::now();
        let mut stats = ShadowStats::default();
        let gbuffer = GBuffer::render(camera, &self.occluders);
        stats.gbuffer_ms = ms(start);
        let target = |i: usize| self.surface_target(&gbuffer, camera, i);
        let layout = (camera.width as usize, camera.height as usize);
        let visibility = self.resolve_light(world, light, layout, target, options, &mut stats);
        stats.total_ms = ms(start);
        Ok(ShadowImage {
            width: camera.width,
            height: camera.height,
            visibility,
            stats,
        })
    }

    /// How much of `light` each of `points` (anywhere: listeners, seats)
    /// sees, by the same methods as [`Self::shadows`]; `world` must be the
    /// one this was made from.
    pub fn visibility(
        &self,
        world: &SceneBvh,
        light: &Light,
        points: &[Vec3],
        options: &ShadowOptions,
    ) -> Result<PointVisibility> {
        light.check()?;
        options.check()?;
        check_points(points)?;
        let start = Instant::now();
        let mut stats = ShadowStats::default();
        let target = |i: usize| Some(Target::air(points[i]));
        let layout = (points.len(), 1);
        let fraction = self.resolve_light(world, light, layout, target, options, &mut stats);
        stats.total_ms = ms(start);
        Ok(PointVisibility { fraction, stats })
    }

    /// [`Self::shadows`] of a point light.
    pub fn hard_shadows(
        &self,
        world: &SceneBvh,
        camera: &Camera,
        light: &PointLight,
        options: &ShadowOptions,
    ) -> Result<ShadowImage> {
        self.shadows(world, camera, &Light::Point(*light), options)
    }

    /// [`Self::shadows`] of an area light.
    pub fn soft_shadows(
        &self,
        world: &SceneBvh,
        camera: &Camera,
        light: &AreaLight,
        options: &ShadowOptions,
    ) -> Result<ShadowImage> {
        self.shadows(world, camera, &Light::Area(*light), options)
    }

    /// The visibility of `light` from the targets, laid out `layout.0` by
    /// `layout.1` (an image, or a row of points).
    fn resolve_light(
        &self,
        world: &SceneBvh,
        light: &Light,
        layout: (usize, usize),
        target: impl Fn(usize) -> Option<Target> + Sync,
        options: &ShadowOptions,
        stats: &mut ShadowStats,
    ) -> Vec<f32> {
        let eye = match light {
            Light::Point(l) => Eye::point(l.position),
            Light::Spot(l) => Eye::spot(l),
            Light::Directional(l) => Eye::parallel(l.unit().expect("checked on entry"), world),
            Light::Area(l) => return self.resolve_area(world, l, layout, target, options, stats),
        };
        resolve(
            &self.occluders,
            &self.topology,
            world,
            eye,
            layout.0 * layout.1,
            target,
            options,
            stats,
        )
    }
}

impl ShadowScene {
    /// The surface pixel `i` of `gbuffer` (seen through `camera`) sees,
    /// if any, as a target.
    pub(super) fn surface_target(
        &self,
        gbuffer: &GBuffer,
        camera: &Camera,
        i: usize,
    ) -> Option<Target> {
        let r = gbuffer.receivers[i].as_ref()?;
        let part = self.topology.objects[r.object as usize].part[r.slot as usize];
        let seen = r.normal.dot(camera.position - r.point) >= 0.0;
        Some(Target {
            point: r.point,
            surface: Some((r.normal, part)),
            front: if seen { r.normal } else { -r.normal },
        })
    }
}

/// Most points one visibility query may ask about.
pub const MAX_POINTS: usize = 1 << 20;

/// How much of a light each point sees.
#[derive(Clone, Debug, PartialEq)]
pub struct PointVisibility {
    /// Per point the fraction of the light's samples it sees (a point
    /// light: 0 or 1).
    pub fraction: Vec<f32>,
    /// `receivers` counts the points, `pip_pixels` those traced.
    pub stats: ShadowStats,
}

pub(super) fn check_points(points: &[Vec3]) -> Result<()> {
    if points.len() > MAX_POINTS {
        return Err(Error::LimitExceeded(format!(
            "{} points asked about; at most {MAX_POINTS}",
            points.len()
        )));
    }
    match points
        .iter()
        .position(|p| !p.is_finite() || p.abs().max_element() > 1e15)
    {
        Some(i) => Err(Error::InvalidPosition {
            what: format!("point {i}"),
            value: format!("{:?}", points[i]),
        }),
        None => Ok(()),
    }
}
