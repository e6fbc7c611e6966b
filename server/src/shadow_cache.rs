//! The shadow data (world-space triangles, welded edges, parts) of the
//! scene last asked about, kept for the next shadow or visibility query:
//! making it walks every triangle (about 94 ms in hall-200k, 4 ms in
//! hall-10k: `bench/results/shadows.txt`, scene ms), and a client
//! rendering frames of a moving light or camera asks about the same
//! geometry again and again.
//!
//! One scene at a time, of at most [`KEEP_MAX_TRIANGLES`] (about 250 MiB
//! of shadow data; a larger scene's is made per query, as before), so the
//! memory it holds stays bounded. It is keyed by the acoustic scene's state
//! ([`AcousticScene::state`](frusta_engine::acoustics::AcousticScene::state)),
//! unique in the process and new with every edit, so a moved object, or
//! a scene deleted and uploaded again under the same id, is never served
//! stale data.

use std::sync::{Arc, Mutex};

use frusta_engine::acoustics::AcousticScene;
use frusta_engine::shadows::ShadowScene;

/// The most triangles a kept scene may have.
pub const KEEP_MAX_TRIANGLES: usize = 1 << 21;

#[derive(Default)]
pub struct ShadowCache(Mutex<Option<(u64, Arc<ShadowScene>)>>);

impl ShadowCache {
    /// The shadow data of `scene` (read under its entry's lock): the kept
    /// one if it is of this state, else made (outside the cache's lock)
    /// and kept in its place unless the scene is too large to keep.
    pub fn get(&self, scene: &AcousticScene) -> Arc<ShadowScene> {
        let state = scene.state();
        if let Some((_, kept)) = self.lock().as_ref().filter(|(s, _)| *s == state) {
            return Arc::clone(kept);
        }
        let shadows = Arc::new(ShadowScene::new(scene.bvh()));
        let triangles = scene.bvh().triangle_count();
        if triangles <= KEEP_MAX_TRIANGLES {
            *self.lock() = Some((state, Arc::clone(&shadows)));
        }
        shadows
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Option<(u64, Arc<ShadowScene>)>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use crate::routes::test_support::*;

    /// The kept shadow data of scene `id` as a query would get it.
    fn shadows_of(server: &TestServer, id: &str) -> Arc<frusta_engine::shadows::ShadowScene> {
        let entry = server.state.registry().get(id).expect("the scene");
        let live = entry.read();
        server.state.shadow_cache().get(&live.acoustic)
    }

    #[tokio::test]
    async fn kept_while_the_scene_stays_and_made_again_after_an_edit_or_a_new_upload() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let first = shadows_of(&server, "box");
        assert!(Arc::ptr_eq(&first, &shadows_of(&server, "box")));
        // An edit moves the revision: the panel's shadow data is stale.
        server.translate("box", "panel", [1.0, 0.0, 0.0]).await;
        let moved = shadows_of(&server, "box");
        assert!(!Arc::ptr_eq(&first, &moved));
        assert!(Arc::ptr_eq(&moved, &shadows_of(&server, "box")));
        // Deleted and uploaded again under the same id: another scene at
        // the same revision.
        server.send(delete("/v1/scenes/box")).await;
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        assert!(!Arc::ptr_eq(&moved, &shadows_of(&server, "box")));
    }
}
