//! [`AcousticScene`]: a scene's hierarchy, materials and plane groups kept
//! together, so that a move or a deformation updates all three at once.

use glam::{DVec3, Vec3};

use super::path::{dedup_paths, validate, Event, ValidPath};
use super::surfaces::Surfaces;
use super::tracer::{trace, TraceInput, TraceOptions, TraceStats};
use crate::bvh::{BuildOptions, UpdateReport};
use crate::geometry::{RigidTransform, TriangleMesh};
use crate::query::SceneBvh;
use crate::scene::{Material, MaterialId, Scene};
use crate::{Error, Result};

/// What sound propagation reads of a scene.
#[derive(Clone, Debug)]
pub struct AcousticScene {
    pub materials: Vec<Material>,
    pub object_names: Vec<String>,
    bvh: SceneBvh,
    surfaces: Surfaces,
}

/// The paths found from one source to each listener.
#[derive(Clone, Debug, Default)]
pub struct FoundPaths {
    /// Per listener, validated paths sorted by length.
    pub paths: Vec<Vec<ValidPath>>,
    pub stats: TraceStats,
}

impl AcousticScene {
    pub fn new(scene: &Scene) -> Self {
        let bvh = SceneBvh::build(scene, &BuildOptions::default());
        let surfaces = Surfaces::new(&bvh);
        Self {
            materials: scene.materials.clone(),
            object_names: scene.objects.iter().map(|o| o.name.clone()).collect(),
            bvh,
            surfaces,
        }
    }

    pub fn bvh(&self) -> &SceneBvh {
        &self.bvh
    }

    pub fn surfaces(&self) -> &Surfaces {
        &self.surfaces
    }

    /// Moves an object rigidly.
    pub fn set_transform(&mut self, object: usize, transform: RigidTransform) -> Result<()> {
        self.bvh.set_transform(object, transform)?;
        self.surfaces = Surfaces::new(&self.bvh);
        Ok(())
    }

    /// Gives an object new geometry: its tree is refitted or rebuilt.
    pub fn update_mesh(
        &mut self,
        object: usize,
        mesh: &TriangleMesh,
        materials: &[MaterialId],
        threshold: f32,
    ) -> Result<UpdateReport> {
        let report = self.bvh.update_mesh(object, mesh, materials, threshold)?;
        self.surfaces = Surfaces::new(&self.bvh);
        Ok(report)
    }

    /// Checks that a source or listener position can be simulated.
    pub fn check_point(&self, what: &str, p: Vec3) -> Result<DVec3> {
        if !p.is_finite() {
            return Err(Error::InvalidScene(format!(
                "{what} position {p} is not finite"
            )));
        }
        Ok(p.as_dvec3())
    }

    /// Traces frusta from `source` and returns the validated specular paths
    /// to every listener: each proposal is de-duplicated and checked exactly.
    pub fn find_paths(
        &self,
        source: DVec3,
        listeners: &[DVec3],
        options: &TraceOptions,
    ) -> FoundPaths {
        use rayon::prelude::*;
        let input = TraceInput {
            bvh: &self.bvh,
            surfaces: &self.surfaces,
            materials: &self.materials,
            source,
            listeners,
        };
        let (mut proposals, stats) = trace(&input, options);
        let paths = proposals
            .par_iter_mut()
            .zip(listeners)
            .map(|(events, &listener)| {
                // The direct path is always proposed; every frustum of
                // order >= 1 containing the listener proposes its events.
                events.push(Vec::new());
                events.sort_unstable();
                events.dedup();
                let mut found: Vec<ValidPath> = events
                    .par_iter()
                    .filter_map(|e: &Vec<Event>| {
                        validate(&self.bvh, &self.surfaces, source, listener, e)
                    })
                    .collect();
                found.sort_by(|a, b| a.length.total_cmp(&b.length));
                dedup_paths(&mut found);
                found
            })
            .collect();
        FoundPaths { paths, stats }
    }
}
