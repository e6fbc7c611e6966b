//! The scenes the service holds: each one live in memory (its scene, its
//! acoustic hierarchy) and in the [`Store`], edited under one write lock
//! so that what is stored and what is served never diverge.

use std::collections::BTreeMap;
use std::sync::{Arc, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use frusta_engine::acoustics::AcousticScene;
use frusta_engine::bvh::{UpdateReport, DEFAULT_REBUILD_THRESHOLD};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::{Material, Scene};
use glam::Vec3;
use tokio::sync::watch;

use crate::error::ApiError;
use crate::store::{SceneMeta, Store, StoredScene};

/// A scene as served: the engine scene (what is persisted) and its
/// acoustic form (what is queried), always in step.
pub struct LiveScene {
    pub scene: Scene,
    pub acoustic: AcousticScene,
    /// Bumped by every edit; responses carry it so a client can tell which
    /// state of the scene an answer belongs to.
    pub revision: u64,
    pub build_ms: f64,
}

pub struct SceneEntry {
    pub id: String,
    pub meta: SceneMeta,
    live: RwLock<LiveScene>,
    /// Streams watch this to recompute when someone else edits the scene;
    /// it closes when the scene is deleted.
    revisions: watch::Sender<Option<u64>>,
}

impl SceneEntry {
    pub fn read(&self) -> RwLockReadGuard<'_, LiveScene> {
        self.live.read().unwrap_or_else(|e| e.into_inner())
    }

    fn write(&self) -> RwLockWriteGuard<'_, LiveScene> {
        self.live.write().unwrap_or_else(|e| e.into_inner())
    }

    /// The scene's revision as it changes; `None` once it is deleted.
    pub fn watch(&self) -> watch::Receiver<Option<u64>> {
        self.revisions.subscribe()
    }

    fn bump(&self, live: &mut LiveScene) -> u64 {
        live.revision += 1;
        self.revisions.send_replace(Some(live.revision));
        live.revision
    }
}

/// What an object edit did, for the response and the metrics.
#[derive(Clone, Copy, Debug, serde::Serialize, utoipa::ToSchema)]
pub struct EditReport {
    pub revision: u64,
    /// `transform` (only the top level changed), `refit` or `rebuild`.
    pub action: &'static str,
    /// Bounding-volume degradation after a refit (Lauterbach 4.1.5).
    pub degradation: Option<f32>,
    pub elapsed_ms: f64,
}

/// A new object state: either or both of a transform and vertex positions.
#[derive(Clone, Debug, Default)]
pub struct ObjectEdit {
    pub rotation: Option<[f32; 4]>,
    pub translation: Option<[f32; 3]>,
    pub vertices: Option<Vec<Vec3>>,
}

pub struct Registry {
    scenes: RwLock<BTreeMap<String, Arc<SceneEntry>>>,
    store: Store,
}

impl Registry {
    /// Loads every stored scene. A stored scene that no longer builds is
    /// logged and left in the store untouched, never deleted.
    pub fn load(store: Store) -> Result<Self, ApiError> {
        let stored = store.load_all().map_err(ApiError::storage)?;
        let registry = Self {
            scenes: RwLock::new(BTreeMap::new()),
            store,
        };
        for s in stored {
            let id = s.id.clone();
            match restore(s) {
                Ok((meta, scene)) => registry.insert(id, meta, scene),
                Err(e) => tracing::error!(scene = %id, error = %e, "stored scene does not load"),
            }
        }
        Ok(registry)
    }

    pub fn store(&self) -> &Store {
        &self.store
    }

    pub fn get(&self, id: &str) -> Result<Arc<SceneEntry>, ApiError> {
        self.scenes
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .get(id)
            .cloned()
            .ok_or_else(|| ApiError::SceneNotFound(id.to_owned()))
    }

    pub fn list(&self) -> Vec<Arc<SceneEntry>> {
        let scenes = self.scenes.read().unwrap_or_else(|e| e.into_inner());
        scenes.values().cloned().collect()
    }

    pub fn total_triangles(&self) -> usize {
        self.list()
            .iter()
            .map(|e| e.read().scene.triangle_count())
            .sum()
    }

    /// Stores and serves a new scene. Blocking (builds and fsyncs).
    pub fn create(&self, id: String, meta: SceneMeta, scene: Scene) -> Result<(), ApiError> {
        if self.get(&id).is_ok() {
            return Err(ApiError::SceneExists(id));
        }
        let document = scene.to_json().map_err(ApiError::from_engine)?;
        self.store
            .put_scene(&id, &meta, &document)
            .map_err(ApiError::storage)?;
        self.insert(id, meta, scene);
        Ok(())
    }

    fn insert(&self, id: String, meta: SceneMeta, scene: Scene) {
        let start = Instant::now();
        let acoustic = AcousticScene::new(&scene);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        tracing::info!(scene = %id, triangles = scene.triangle_count(), build_ms, "scene ready");
        let entry = SceneEntry {
            id: id.clone(),
            meta,
            live: RwLock::new(LiveScene {
                scene,
                acoustic,
                revision: 0,
                build_ms,
            }),
            revisions: watch::Sender::new(Some(0)),
        };
        let mut scenes = self.scenes.write().unwrap_or_else(|e| e.into_inner());
        scenes.insert(id, Arc::new(entry));
    }

    pub fn delete(&self, id: &str) -> Result<(), ApiError> {
        let entry = self.get(id)?;
        // Hold the scene's lock so no edit lands between the two steps.
        let _live = entry.write();
        self.store.delete_scene(id).map_err(ApiError::storage)?;
        self.scenes
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        entry.revisions.send_replace(None);
        Ok(())
    }

    /// Moves and/or deforms one object: validated first, then stored, then
    /// applied, so a failed edit changes nothing and an acknowledged one
    /// is on disk. Blocking.
    pub fn edit_object(
        &self,
        entry: &SceneEntry,
        object: usize,
        edit: &ObjectEdit,
    ) -> Result<EditReport, ApiError> {
        let start = Instant::now();
        let mut live = entry.write();
        let Some(current) = live.scene.objects.get(object) else {
            return Err(ApiError::UnknownObject(format!(
                "#{object} (the scene has {})",
                live.scene.objects.len()
            )));
        };
        let transform = if edit.rotation.is_some() || edit.translation.is_some() {
            let rotation = edit
                .rotation
                .map_or(current.transform.rotation, glam::Quat::from_array);
            let translation = edit
                .translation
                .map_or(current.transform.translation, Vec3::from_array);
            Some(RigidTransform::new(rotation, translation).map_err(ApiError::from_engine)?)
        } else {
            None
        };
        let mesh = match &edit.vertices {
            Some(v) if v.len() != current.mesh.positions().len() => {
                return Err(ApiError::from_engine(
                    frusta_engine::Error::VertexCountMismatch {
                        expected: current.mesh.positions().len(),
                        actual: v.len(),
                    },
                ))
            }
            Some(v) => Some(
                TriangleMesh::new(v.clone(), current.mesh.triangles().to_vec())
                    .map_err(ApiError::from_engine)?,
            ),
            None => None,
        };
        let index = object as u32;
        if let Some(t) = &transform {
            self.store
                .put_transform(&entry.id, index, t)
                .map_err(ApiError::storage)?;
        }
        if let Some(m) = &mesh {
            self.store
                .put_positions(&entry.id, index, m.positions())
                .map_err(ApiError::storage)?;
        }
        let mut update: Option<UpdateReport> = None;
        if let Some(t) = transform {
            live.acoustic
                .set_transform(object, t)
                .map_err(ApiError::from_engine)?;
            live.scene.objects[object].transform = t;
        }
        if let Some(m) = mesh {
            let materials = live.scene.objects[object].materials.clone();
            update = Some(
                live.acoustic
                    .update_mesh(object, &m, &materials, DEFAULT_REBUILD_THRESHOLD)
                    .map_err(ApiError::from_engine)?,
            );
            live.scene.objects[object].mesh = m;
        }
        let revision = entry.bump(&mut live);
        Ok(EditReport {
            revision,
            action: match update.map(|u| u.action) {
                None => "transform",
                Some(frusta_engine::bvh::UpdateAction::Refit) => "refit",
                Some(frusta_engine::bvh::UpdateAction::Rebuild) => "rebuild",
            },
            degradation: update.and_then(|u| u.degradation),
            elapsed_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Replaces materials by name (coefficients only) and adds new ones;
    /// material ids of triangles stay as they are. Blocking.
    pub fn edit_materials(
        &self,
        entry: &SceneEntry,
        materials: Vec<Material>,
    ) -> Result<u64, ApiError> {
        let mut live = entry.write();
        let mut scene = live.scene.clone();
        for m in materials {
            match scene.materials.iter_mut().find(|old| old.name == m.name) {
                Some(old) => *old = m,
                None => scene.materials.push(m),
            }
        }
        let document = scene.to_json().map_err(ApiError::from_engine)?;
        self.store
            .put_scene(&entry.id, &entry.meta, &document)
            .map_err(ApiError::storage)?;
        live.acoustic.materials = scene.materials.clone();
        live.scene = scene;
        Ok(entry.bump(&mut live))
    }
}

/// A stored scene with its overlays applied.
fn restore(s: StoredScene) -> frusta_engine::Result<(SceneMeta, Scene)> {
    let mut scene = Scene::from_json_str(&s.document, None)?;
    for (object, t) in s.transforms {
        if let Some(o) = scene.objects.get_mut(object as usize) {
            o.transform = t.validated()?;
        }
    }
    for (object, positions) in s.positions {
        if let Some(o) = scene.objects.get_mut(object as usize) {
            o.mesh = TriangleMesh::new(positions, o.mesh.triangles().to_vec())?;
        }
    }
    Ok((s.meta, scene))
}

pub fn now_unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}
