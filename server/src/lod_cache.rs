//! Simplified scenes for impulse responses with levels of detail
//! (`lod_error_m`), kept for the next request at the same bound: a
//! simplification walks the trees the scene already holds (their planes
//! fitted once per object, on first use: about half a build) and builds
//! the result (`bench/results/lod.txt`, setup: 2.9-3.2 s for 20 million
//! triangles at 1-2 m), and a stream asks for the same one at every
//! update.
//!
//! Keyed by the acoustic scene's state (process-unique, new with every
//! edit, so an edited or re-uploaded scene is never served stale) and the
//! bound's bits. After rigid moves and material edits, which leave every
//! mesh of the upload as it was (its versions, `LiveScene::mesh_versions`,
//! say so without comparing meshes), the kept simplification of the
//! scene's earlier state is moved and given the materials instead of made
//! again: simplification works in each object's own frame. Each distinct
//! bound is a simplification of its own. At most [`KEEP`] are kept, of at
//! most [`KEEP_MAX_TRIANGLES`] simplified triangles together, the least
//! recently used dropped first: the memory held stays bounded. A
//! simplification larger than that is made again at every request.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use frusta_engine::acoustics::AcousticScene;
use frusta_engine::geometry::RigidTransform;
use frusta_engine::scene::{Material, Scene};

use crate::error::ApiError;
use crate::registry::LiveScene;
use crate::shadow_cache::KEEP_MAX_TRIANGLES;

/// Simplified scenes kept.
pub const KEEP: usize = 4;

/// A simplified scene and what it was made from.
struct Kept {
    id: String,
    state: u64,
    bound: u32,
    /// The scene it stands for: its objects' mesh versions and
    /// transforms, and its materials.
    mesh_versions: Vec<u64>,
    transforms: Vec<RigidTransform>,
    materials: Vec<Material>,
    triangles: usize,
    scene: Arc<AcousticScene>,
}

pub struct LodCache {
    kept: Mutex<Vec<Kept>>,
    /// Simplifications made (not taken or moved from a kept one).
    made: AtomicU64,
    /// Simplified triangles kept at most, together.
    budget: usize,
}

impl Default for LodCache {
    fn default() -> Self {
        Self::with_budget(KEEP_MAX_TRIANGLES)
    }
}

impl LodCache {
    fn with_budget(budget: usize) -> Self {
        Self {
            kept: Mutex::default(),
            made: AtomicU64::new(0),
            budget,
        }
    }

    /// Scene `id`'s acoustic scene simplified within `bound` m, from
    /// `live` (read under its entry's lock): the kept one if there is one
    /// of this state and bound, else one moved from the kept one of an
    /// earlier state with the same meshes, else made (outside the cache's
    /// lock); kept in either case if it fits. `None` where the bound
    /// replaces nothing (below every level of detail's error): the scene's
    /// own geometry answers, not a copy of it built again.
    pub fn get(
        &self,
        id: &str,
        live: &LiveScene,
        bound: f32,
    ) -> Result<Option<Arc<AcousticScene>>, ApiError> {
        let key = (live.acoustic.state(), bound.to_bits());
        let earlier = {
            let mut kept = self.lock();
            if let Some(i) = kept.iter().position(|k| (k.state, k.bound) == key) {
                let hit = kept.remove(i);
                let scene = Arc::clone(&hit.scene);
                kept.push(hit);
                return Ok(Some(scene));
            }
            let same_meshes =
                |k: &Kept| k.id == id && k.bound == key.1 && k.mesh_versions == live.mesh_versions;
            kept.iter().position(same_meshes).map(|i| kept.remove(i))
        };
        let scene = match earlier.and_then(|k| moved(&k, &live.scene)) {
            Some(scene) => scene,
            None => match live
                .acoustic
                .simplified_from(&live.scene, bound)
                .map_err(ApiError::from_engine)?
            {
                Some(scene) => {
                    self.made.fetch_add(1, Ordering::Relaxed);
                    scene
                }
                None => return Ok(None),
            },
        };
        let scene = Arc::new(scene);
        let triangles = scene.bvh().triangle_count();
        if triangles <= self.budget {
            let mut kept = self.lock();
            while kept.len() >= KEEP
                || kept.iter().map(|k| k.triangles).sum::<usize>() + triangles > self.budget
            {
                kept.remove(0);
            }
            kept.push(Kept {
                id: id.to_owned(),
                state: key.0,
                bound: key.1,
                mesh_versions: live.mesh_versions.clone(),
                transforms: live.scene.objects.iter().map(|o| o.transform).collect(),
                materials: live.scene.materials.clone(),
                triangles,
                scene: Arc::clone(&scene),
            });
        }
        Ok(Some(scene))
    }

    /// How many simplifications were made.
    pub fn made(&self) -> u64 {
        self.made.load(Ordering::Relaxed)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Kept>> {
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// `k`'s simplified scene with the transforms and materials of `now`,
/// whose meshes are `k`'s; `None` if one is refused.
fn moved(k: &Kept, now: &Scene) -> Option<AcousticScene> {
    let mut scene = (*k.scene).clone();
    for (i, (was, is)) in k.transforms.iter().zip(&now.objects).enumerate() {
        if *was != is.transform {
            scene.set_transform(i, is.transform).ok()?;
        }
    }
    if k.materials != now.materials {
        scene.set_materials(now.materials.clone()).ok()?;
    }
    Some(scene)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use frusta_engine::acoustics::AcousticScene;

    use crate::routes::test_support::*;

    /// Scene `id` simplified within `bound` as a request would get it.
    fn simplified(server: &TestServer, id: &str, bound: f32) -> Arc<AcousticScene> {
        let entry = server.state.registry().get(id).expect("the scene");
        let live = entry.read();
        server
            .state
            .lod_cache()
            .get(id, &live, bound)
            .expect("simplified")
            .expect("a bound that replaces something")
    }

    #[tokio::test]
    async fn kept_per_state_and_bound_and_made_again_after_an_edit() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let first = simplified(&server, "box", 7.5);
        assert_eq!(first.lod_error_m(), 7.5);
        assert!(Arc::ptr_eq(&first, &simplified(&server, "box", 7.5)));
        assert!(!Arc::ptr_eq(&first, &simplified(&server, "box", 7.25)));
        let made = server.state.lod_cache().made();
        server.translate("box", "panel", [1.0, 0.0, 0.0]).await;
        let moved = simplified(&server, "box", 7.5);
        assert!(!Arc::ptr_eq(&first, &moved));
        let panel = |s: &AcousticScene| s.bvh().instances()[1].to_world().translation;
        assert_eq!(panel(&moved), panel(&first) + glam::Vec3::X);
        // Moved, not simplified again: the meshes are as they were.
        assert_eq!(server.state.lod_cache().made(), made);
        // So with new materials, which it takes.
        let (status, _, answer) = server
            .send(patch_json(
                "/v1/scenes/box/materials",
                r#"{"materials": {"walls": "heavy_curtain"}}"#,
            ))
            .await;
        assert!(status.is_success(), "{answer}");
        let curtained = simplified(&server, "box", 7.5);
        assert_eq!(server.state.lod_cache().made(), made);
        let live = server.state.registry().get("box").expect("the scene");
        assert_eq!(curtained.materials(), live.read().acoustic.materials());
        assert_ne!(curtained.materials(), moved.materials());
        // New vertices are simplified again.
        let (status, _, answer) = server
            .send(patch_json(
                "/v1/scenes/box/objects/panel",
                r#"{"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2.5], [4, 1, 2.5]]}"#,
            ))
            .await;
        assert!(status.is_success(), "{answer}");
        let reshaped = simplified(&server, "box", 7.5);
        assert_eq!(server.state.lod_cache().made(), made + 1);
        let top = |s: &AcousticScene| s.bvh().instances()[1].bvh().bounds().max.z;
        assert_eq!(top(&reshaped), 2.5);
    }

    /// A bound below every level of detail's error replaces nothing: the
    /// scene's own geometry answers, and nothing is made or kept.
    #[tokio::test]
    async fn a_bound_that_replaces_nothing_makes_nothing() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let entry = server.state.registry().get("box").expect("the scene");
        let cache = server.state.lod_cache();
        // The panel's one node has an error of about 0.9 m, the room's 6.7;
        // at 1 m only the panel is under the bound, and it is flat.
        for bound in [0.5, 1.0] {
            let got = cache.get("box", &entry.read(), bound).expect("answered");
            assert!(got.is_none(), "{bound}");
        }
        assert_eq!(cache.made(), 0);
        assert!(cache
            .get("box", &entry.read(), 7.5)
            .expect("answered")
            .is_some());
        assert_eq!(cache.made(), 1);
    }

    /// Deleted and uploaded again under the same id with the same meshes
    /// but another name: simplified again, not moved from the kept one.
    #[tokio::test]
    async fn a_scene_uploaded_again_with_other_names_is_simplified_again() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        simplified(&server, "box", 7.5);
        let made = server.state.lod_cache().made();
        server.send(delete("/v1/scenes/box")).await;
        let renamed = BOX_DOC.replace("panel", "screen");
        server.send(post_json("/v1/scenes?id=box", &renamed)).await;
        let again = simplified(&server, "box", 7.5);
        assert_eq!(server.state.lod_cache().made(), made + 1);
        assert_eq!(again.object_names()[1], "screen");
    }

    /// The simplified triangles kept together stay within the budget, the
    /// least recently used dropped to make room; one larger than the whole
    /// budget is made at every request.
    #[tokio::test]
    async fn the_kept_triangles_stay_within_the_budget() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let entry = server.state.registry().get("box").expect("the scene");
        let live = entry.read();
        // Past the room's one node (error about 6.7 m) it is one rectangle,
        // the flat panel stays: 4 triangles a simplification.
        let cache = super::LodCache::with_budget(10);
        let get = |bound: f32| {
            cache
                .get("box", &live, bound)
                .expect("simplified")
                .expect("made")
        };
        for bound in [7.5, 7.25, 7.75] {
            get(bound);
        }
        assert_eq!(cache.made(), 3);
        get(7.75);
        assert_eq!(cache.made(), 3, "kept");
        get(7.5);
        assert_eq!(cache.made(), 4, "dropped for 7.75");
        let small = super::LodCache::with_budget(3);
        small.get("box", &live, 7.5).expect("simplified");
        small.get("box", &live, 7.5).expect("simplified");
        assert_eq!(small.made(), 2);
    }

    #[tokio::test]
    async fn at_most_keep_are_kept_the_least_recently_used_dropped() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        // Bounds past the room's node (error about 6.7 m).
        let first = simplified(&server, "box", 7.0);
        for k in 0..super::KEEP {
            simplified(&server, "box", 8.0 + k as f32);
        }
        assert!(!Arc::ptr_eq(&first, &simplified(&server, "box", 7.0)));
        // Used again, the oldest is kept over one made before it.
        let again = simplified(&server, "box", 9.0);
        simplified(&server, "box", 20.0);
        assert!(Arc::ptr_eq(&again, &simplified(&server, "box", 9.0)));
    }
}
