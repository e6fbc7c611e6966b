//! [`AcousticScene`]: a scene's hierarchy, materials and plane groups kept
//! together, so that a move or a deformation updates all three at once.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DVec3, Vec3};

use super::beams::Beams;
use super::diffraction::{EdgeScene, Edges};
use super::path::{dedup_paths, validate, Event, ValidPath};
use super::surfaces::Surfaces;
use super::tracer::{trace, trace_beams, TraceInput, TraceOptions, TraceStats};
use crate::bvh::lod::{check_bound, simplify_scene, simplify_scene_on, SimplifiedScene};
use crate::bvh::{BuildOptions, UpdateReport};
use crate::deadline::Deadline;
use crate::geometry::{RigidTransform, TriangleMesh, MAX_COORDINATE};
use crate::query::SceneBvh;
use crate::scene::{check_material_table, Material, MaterialId, Scene};
use crate::{Error, Result};

/// What sound propagation reads of a scene.
#[derive(Clone, Debug)]
pub struct AcousticScene {
    /// Changed only by [`Self::set_materials`], which moves the revision:
    /// absorption decides where tracing stops, so caches key on it.
    materials: Vec<Material>,
    object_names: Vec<String>,
    bvh: SceneBvh,
    surfaces: Surfaces,
    /// Diffracting edges, found again per object as objects change.
    edges: Edges,
    /// Changes since the scene was built, counted on from a resumed
    /// count: what answers name.
    revision: u64,
    /// This state's identity for caches, new with every change.
    state: u64,
    /// Set when the scene stands for another within an error bound.
    lod: Option<Lod>,
}

/// How a [simplified](AcousticScene::simplified) scene stands for the one
/// it was made from.
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    /// The bound, m: every corner of the original lies within it of the
    /// simplified geometry.
    pub max_error_m: f32,
    /// Nodes of the objects' trees replaced by one polygon each.
    pub polygons: usize,
    /// Per object, per triangle, the original triangle it stands for:
    /// what answers name.
    origins: Vec<Vec<u32>>,
}

/// States come from one process-wide counter, so two scenes share one only
/// when one is an unchanged clone of the other: a cache keyed by the state
/// cannot mistake one scene, or one state of it, for another.
fn next_state() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
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
        let edges = Edges::new(&bvh, &surfaces);
        Self {
            materials: scene.materials.clone(),
            object_names: scene.objects.iter().map(|o| o.name.clone()).collect(),
            bvh,
            surfaces,
            edges,
            revision: 0,
            state: next_state(),
            lod: None,
        }
    }

    /// The acoustic scene of `scene` with every object's tree cut where
    /// its level of detail first has an error below `max_error_m` (see
    /// [`simplify_scene`]): features smaller than the bound cost no frusta.
    /// A bound of 0 is the exact scene. Answers on the result name the
    /// original triangles (the one each polygon stands for) and report the
    /// bound ([`SimulationStats::lod_error_m`]).
    ///
    /// [`SimulationStats::lod_error_m`]: super::SimulationStats::lod_error_m
    pub fn simplified(scene: &Scene, max_error_m: f32) -> Result<Self> {
        check_bound(max_error_m)?;
        if max_error_m == 0.0 {
            return Ok(Self::new(scene));
        }
        let simple = simplify_scene(scene, max_error_m)?;
        Ok(Self::standing_for(simple, max_error_m))
    }

    /// [`Self::simplified`] for `scene`, the scene this one was built from
    /// (as it has moved and changed since), cut on the trees this one
    /// already holds: no tree of the exact scene is built again, and each
    /// object's levels of detail are fitted once for every bound (see
    /// [`simplify_scene_on`]). What a service holding the exact scene
    /// does. `None` where the bound replaces nothing (0, below every
    /// level of detail's error, or only flat nodes under it): the result
    /// would be this scene's geometry, copied and built again, so this
    /// scene answers as it is. Refused on a scene that is itself
    /// simplified.
    pub fn simplified_from(&self, scene: &Scene, max_error_m: f32) -> Result<Option<Self>> {
        check_bound(max_error_m)?;
        if self.lod.is_some() {
            return Err(Error::InvalidScene(
                "a simplified scene is not simplified again".into(),
            ));
        }
        if !self.simplifies_at(max_error_m) {
            return Ok(None);
        }
        let simple = simplify_scene_on(scene, &self.bvh, max_error_m)?;
        Ok((simple.polygons > 0).then(|| Self::standing_for(simple, max_error_m)))
    }

    /// Whether a cut at `max_error_m` could replace anything: some object
    /// has a level of detail with an error below it (fitting each object's
    /// planes on first use).
    fn simplifies_at(&self, max_error_m: f32) -> bool {
        self.bvh
            .instances()
            .iter()
            .any(|o| o.bvh().triangle_count() > 0 && max_error_m > o.lods().least_error())
    }

    /// The acoustic scene of `simple`, standing for the scene it was
    /// simplified from within `max_error_m`; where no node was replaced
    /// (every triangle kept, in order), the exact scene it is, which says
    /// so (bound 0).
    fn standing_for(simple: SimplifiedScene, max_error_m: f32) -> Self {
        let mut out = Self::new(&simple.scene);
        out.lod = (simple.polygons > 0).then_some(Lod {
            max_error_m,
            polygons: simple.polygons,
            origins: simple.origins,
        });
        out
    }

    /// How this scene stands for another, if it was simplified.
    pub fn lod(&self) -> Option<&Lod> {
        self.lod.as_ref()
    }

    /// The error bound of the geometry answers are computed on, m (0:
    /// exact).
    pub fn lod_error_m(&self) -> f32 {
        self.lod.as_ref().map_or(0.0, |l| l.max_error_m)
    }

    /// The triangle of the scene this one stands for that `triangle`
    /// (mesh order) of `object` is, or stands for.
    pub fn original_triangle(&self, object: u32, triangle: u32) -> u32 {
        self.lod
            .as_ref()
            .and_then(|l| l.origins.get(object as usize)?.get(triangle as usize))
            .copied()
            .unwrap_or(triangle)
    }

    /// How many changes ([`Self::set_transform`], [`Self::update_mesh`],
    /// [`Self::set_materials`]) the scene has had since it was built (or
    /// since the count it [resumed](Self::resume_revision) from): the
    /// revision answers name, so a client can tell which state they
    /// belong to.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Continues the count of changes from `revision`: for a scene built
    /// again from a store that counted its changes before (a restarted
    /// service), so that revisions never go back. Ignored where it is
    /// below the count already made.
    pub fn resume_revision(&mut self, revision: u64) {
        self.revision = self.revision.max(revision);
    }

    /// This state's identity: process-unique and new with every change
    /// (also a refused one, since dropping a cache is always safe), so it
    /// differs between scenes. What traced beams are valid for.
    pub fn state(&self) -> u64 {
        self.state
    }

    /// Records a change: a new state, and one more revision if it took.
    fn changed<T>(&mut self, result: Result<T>) -> Result<T> {
        self.state = next_state();
        if result.is_ok() {
            self.revision += 1;
        }
        result
    }

    /// The material table; triangles hold indices into it.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    pub fn object_names(&self) -> &[String] {
        &self.object_names
    }

    /// Replaces the material table, checked by [`check_material_table`].
    /// Triangles keep their indices, so the table may grow or change
    /// coefficients but not shrink.
    pub fn set_materials(&mut self, materials: Vec<Material>) -> Result<()> {
        check_material_table(self.materials.len(), &materials)?;
        self.materials = materials;
        self.changed(Ok(()))
    }

    pub fn bvh(&self) -> &SceneBvh {
        &self.bvh
    }

    pub fn surfaces(&self) -> &Surfaces {
        &self.surfaces
    }

    /// The diffracting edges.
    pub fn edges(&self) -> &Edges {
        &self.edges
    }

    /// What a diffraction search reads.
    pub fn edge_scene(&self) -> EdgeScene<'_> {
        EdgeScene {
            bvh: &self.bvh,
            surfaces: &self.surfaces,
            edges: &self.edges,
        }
    }

    /// Moves an object rigidly.
    pub fn set_transform(&mut self, object: usize, transform: RigidTransform) -> Result<()> {
        let result = self.bvh.set_transform(object, transform);
        if result.is_ok() {
            self.surfaces.update_object(&self.bvh, object);
            self.edges.update_object(&self.bvh, &self.surfaces, object);
        }
        self.changed(result)
    }

    /// Gives an object new geometry: its tree is refitted or rebuilt.
    pub fn update_mesh(
        &mut self,
        object: usize,
        mesh: &TriangleMesh,
        materials: &[MaterialId],
        threshold: f32,
    ) -> Result<UpdateReport> {
        if self.lod.is_some() {
            // Its triangles are not the mesh's: simplify the new scene.
            return self.changed(Err(Error::InvalidScene(
                "a simplified scene takes no new vertices: simplify the updated scene".into(),
            )));
        }
        let result = self.bvh.update_mesh(object, mesh, materials, threshold);
        if result.is_ok() {
            self.surfaces.update_object(&self.bvh, object);
            self.edges.update_object(&self.bvh, &self.surfaces, object);
        }
        self.changed(result)
    }

    /// Checks that a source or listener position can be simulated: finite
    /// and within [`MAX_COORDINATE`] of the origin on every axis, as mesh
    /// vertices are (the schema fuzzer's sources at 1e16 to 3e38 m made the
    /// tracer fail in an edited shoebox).
    pub fn check_point(&self, what: &str, p: Vec3) -> Result<DVec3> {
        if !p.is_finite() || p.abs().max_element() > MAX_COORDINATE {
            return Err(Error::InvalidPosition {
                what: what.into(),
                value: p.to_string(),
            });
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
        self.find_paths_until(source, listeners, options, &Deadline::none())
            .expect("without a deadline, tracing cannot fail")
    }

    /// [`Self::find_paths`], stopping with an error at the deadline.
    pub(crate) fn find_paths_until(
        &self,
        source: DVec3,
        listeners: &[DVec3],
        options: &TraceOptions,
        deadline: &Deadline,
    ) -> Result<FoundPaths> {
        let input = self.trace_input(source);
        let (proposals, stats) = trace(&input, listeners, options, deadline)?;
        let paths = self.validate_proposals(source, listeners, proposals, deadline)?;
        Ok(FoundPaths { paths, stats })
    }

    /// Traces frusta from `source` and keeps them, to propose paths to
    /// any listeners later ([`Beams::proposals`]).
    pub fn trace_beams(&self, source: DVec3, options: &TraceOptions) -> Beams {
        trace_beams(&self.trace_input(source), options, &Deadline::none())
            .expect("without a deadline, tracing cannot fail")
    }

    pub(crate) fn trace_input(&self, source: DVec3) -> TraceInput<'_> {
        TraceInput {
            bvh: &self.bvh,
            surfaces: &self.surfaces,
            materials: &self.materials,
            source,
            apex_reach: 0.0,
            last_order_listeners: None,
        }
    }

    /// Per listener, the valid paths among its proposals, sorted by length.
    pub(crate) fn validate_proposals(
        &self,
        source: DVec3,
        listeners: &[DVec3],
        mut proposals: Vec<Vec<Vec<Event>>>,
        deadline: &Deadline,
    ) -> Result<Vec<Vec<ValidPath>>> {
        use rayon::prelude::*;
        proposals
            .par_iter_mut()
            .zip(listeners)
            .map(|(events, &listener)| {
                deadline.check()?;
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
                Ok(found)
            })
            .collect()
    }
}
