//! Simplified scenes for impulse responses with levels of detail
//! (`lod_error_m`), kept for the next request at the same bound: a
//! simplification fits planes to every node of every object's tree and
//! builds the result (about 0.25-0.36 s in hall-200k, 33 s for 20 million
//! triangles: `bench/results/lod.txt`, setup), and a stream asks for the
//! same one at every update.
//!
//! Keyed by the acoustic scene's state (process-unique, new with every
//! edit, so an edited or re-uploaded scene is simplified again, never
//! served stale) and the bound's bits. At most [`KEEP`] are kept, the
//! least recently used dropped first, and only of scenes of at most
//! [`KEEP_MAX_TRIANGLES`]: the memory held stays bounded.

use std::sync::{Arc, Mutex};

use frusta_engine::acoustics::AcousticScene;

use crate::error::ApiError;
use crate::registry::LiveScene;
use crate::shadow_cache::KEEP_MAX_TRIANGLES;

/// Simplified scenes kept.
pub const KEEP: usize = 4;

/// A simplified scene and what it was made from.
struct Kept {
    state: u64,
    bound: u32,
    scene: Arc<AcousticScene>,
}

#[derive(Default)]
pub struct LodCache(Mutex<Vec<Kept>>);

impl LodCache {
    /// `live`'s acoustic scene simplified within `bound` m (read under its
    /// entry's lock): the kept one if there is one of this state and
    /// bound, else made (outside the cache's lock) and kept.
    pub fn get(&self, live: &LiveScene, bound: f32) -> Result<Arc<AcousticScene>, ApiError> {
        let key = (live.acoustic.state(), bound.to_bits());
        {
            let mut kept = self.lock();
            if let Some(i) = kept.iter().position(|k| (k.state, k.bound) == key) {
                let hit = kept.remove(i);
                let scene = Arc::clone(&hit.scene);
                kept.push(hit);
                return Ok(scene);
            }
        }
        let scene =
            Arc::new(AcousticScene::simplified(&live.scene, bound).map_err(ApiError::from_engine)?);
        if live.scene.triangle_count() <= KEEP_MAX_TRIANGLES {
            let mut kept = self.lock();
            if kept.len() >= KEEP {
                kept.remove(0);
            }
            kept.push(Kept {
                state: key.0,
                bound: key.1,
                scene: Arc::clone(&scene),
            });
        }
        Ok(scene)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Kept>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
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
            .get(&live, bound)
            .expect("simplified")
    }

    #[tokio::test]
    async fn kept_per_state_and_bound_and_made_again_after_an_edit() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let first = simplified(&server, "box", 0.5);
        assert_eq!(first.lod_error_m(), 0.5);
        assert!(Arc::ptr_eq(&first, &simplified(&server, "box", 0.5)));
        assert!(!Arc::ptr_eq(&first, &simplified(&server, "box", 0.25)));
        server.translate("box", "panel", [1.0, 0.0, 0.0]).await;
        let moved = simplified(&server, "box", 0.5);
        assert!(!Arc::ptr_eq(&first, &moved));
        let panel = |s: &AcousticScene| s.bvh().instances()[1].to_world().translation;
        assert_eq!(panel(&moved), panel(&first) + glam::Vec3::X);
    }

    #[tokio::test]
    async fn at_most_keep_are_kept_the_least_recently_used_dropped() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let first = simplified(&server, "box", 1.0);
        for k in 0..super::KEEP {
            simplified(&server, "box", 2.0 + k as f32);
        }
        assert!(!Arc::ptr_eq(&first, &simplified(&server, "box", 1.0)));
        // Used again, the oldest is kept over one made before it.
        let again = simplified(&server, "box", 3.0);
        simplified(&server, "box", 9.0);
        assert!(Arc::ptr_eq(&again, &simplified(&server, "box", 3.0)));
    }
}
