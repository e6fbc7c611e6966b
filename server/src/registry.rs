//! The scenes the service holds: each one live in memory (its scene, its
//! acoustic hierarchy) and in the [`Store`], edited under one write lock
//! so that what is stored and what is served never diverge.

use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use frusta_api::objects::{EditAction, EditReport};
use frusta_engine::acoustics::AcousticScene;
use frusta_engine::bvh::{UpdateReport, DEFAULT_REBUILD_THRESHOLD};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::{check_material_table, Material, Scene};
use glam::Vec3;
use tokio::sync::watch;

use crate::error::ApiError;
use crate::store::{ObjectOverlay, SceneMeta, Store, StoredScene};

/// A scene as served: the engine scene (what is persisted) and its
/// acoustic form (what is queried), always in step.
pub struct LiveScene {
    pub scene: Scene,
    pub acoustic: AcousticScene,
    /// Per object, its mesh's version: process-unique, new with the upload
    /// and with every vertex edit, so a cache tells an unchanged mesh (of
    /// this upload) without comparing it.
    pub mesh_versions: Vec<u64>,
    pub build_ms: f64,
    /// Set by [`Registry::delete`] under the write lock: an edit that
    /// looked the scene up before the delete finds it here and fails,
    /// instead of writing the scene back into the store.
    deleted: bool,
}

/// A new mesh version (see [`LiveScene::mesh_versions`]).
fn next_mesh_version() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

pub struct SceneEntry {
    pub id: String,
    pub meta: SceneMeta,
    /// The objects' names in index order; objects are never added or
    /// removed, so these are read without the scene's lock.
    pub object_names: Vec<String>,
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

    /// Tells the streams the engine's new revision after an edit.
    fn announce(&self, live: &LiveScene) -> u64 {
        let revision = live.acoustic.revision();
        self.revisions.send_replace(Some(revision));
        revision
    }
}

/// A new object state: either or both of a transform and vertex positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectEdit {
    pub rotation: Option<[f32; 4]>,
    pub translation: Option<[f32; 3]>,
    pub vertices: Option<Vec<Vec3>>,
}

impl ObjectEdit {
    /// Everything an edit of the object `current` can fail on: finite
    /// values, a rotation that can be normalised, the vertex count, a new
    /// mesh that would load. A stream checks each update on arrival, so one
    /// bad update cannot sink the others merged with it.
    pub fn check(&self, current: &TriangleMesh) -> Result<(), ApiError> {
        let vertex_count = current.vertex_count();
        let rotation = self
            .rotation
            .map_or(glam::Quat::IDENTITY, glam::Quat::from_array);
        let translation = self.translation.map_or(Vec3::ZERO, Vec3::from_array);
        RigidTransform::new(rotation, translation).map_err(ApiError::from_engine)?;
        if let Some(vertices) = &self.vertices {
            if vertices.len() != vertex_count {
                return Err(ApiError::from_engine(
                    frusta_engine::Error::VertexCountMismatch {
                        expected: vertex_count,
                        actual: vertices.len(),
                    },
                ));
            }
            // Everything the new mesh will be checked for (finite, in
            // range, not all degenerate): a stream merges this edit with
            // others, which a bad one would sink.
            frusta_engine::geometry::check_mesh(vertices, current.triangles())
                .map_err(ApiError::from_engine)?;
        }
        Ok(())
    }

    /// `newer` applied after this edit: each field it sets replaces ours.
    pub fn merge(&mut self, newer: ObjectEdit) {
        self.rotation = newer.rotation.or(self.rotation);
        self.translation = newer.translation.or(self.translation);
        if newer.vertices.is_some() {
            self.vertices = newer.vertices;
        }
    }
}

pub struct Registry {
    scenes: RwLock<BTreeMap<String, Arc<SceneEntry>>>,
    store: Store,
    budget: Mutex<Budget>,
    /// Test hook run once right after an upload's reservation: lets a test
    /// send a competing request at exactly that point.
    #[cfg(test)]
    pub(crate) after_reserve: Mutex<Option<Box<dyn FnOnce() + Send>>>,
}

/// Triangles served and reserved, and the ids of uploads in flight: one
/// lock, so checking a limit or an id and claiming it are one step. It is
/// taken before the scene map's lock, never while holding it.
#[derive(Default)]
struct Budget {
    served: usize,
    reserved: usize,
    /// Ids of uploads in flight, each with what identifies its upload
    /// (caller and content), so that a retry can be told from a rival.
    ids: HashMap<String, Option<String>>,
}

/// An upload's claim on its id and triangles, from its checks until its
/// scene is served (or it fails); dropping it releases the claim.
pub struct Reservation<'a> {
    registry: &'a Registry,
    pub id: String,
    triangles: usize,
}

impl Drop for Reservation<'_> {
    fn drop(&mut self) {
        let mut budget = self.registry.budget();
        budget.ids.remove(&self.id);
        budget.reserved -= self.triangles;
    }
}

impl Registry {
    /// Loads every stored scene. A stored scene that no longer builds is
    /// logged and left in the store untouched, never deleted.
    pub fn load(store: Store) -> Result<Self, ApiError> {
        let stored = store.load_all().map_err(ApiError::storage)?;
        let registry = Self {
            scenes: RwLock::new(BTreeMap::new()),
            store,
            budget: Mutex::default(),
            #[cfg(test)]
            after_reserve: Mutex::default(),
        };
        for s in stored {
            let id = s.id.clone();
            match restore(s) {
                Ok((meta, scene, revision)) => registry.insert(id, meta, scene, revision),
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

    /// Triangles of the scenes served (edits keep triangle counts).
    pub fn total_triangles(&self) -> usize {
        self.budget().served
    }

    fn budget(&self) -> std::sync::MutexGuard<'_, Budget> {
        self.budget.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Claims an id and `triangles` of the `max_total` budget for an
    /// upload: `id`, or with `id: None` the first free of `slug`,
    /// `slug-2`, ... Fails if the id is served or claimed (saying so
    /// when the claim is this same `upload`, a retry), or if the
    /// triangles served and claimed would exceed the budget.
    pub fn reserve(
        &self,
        id: Option<String>,
        slug: &str,
        triangles: usize,
        max_total: usize,
        upload: Option<&str>,
    ) -> Result<Reservation<'_>, ApiError> {
        let mut budget = self.budget();
        let taken = |id: &str| budget.ids.contains_key(id) || self.get(id).is_ok();
        let id = match id {
            Some(id)
                if upload.is_some()
                    && budget.ids.get(&id).map(Option::as_deref) == Some(upload) =>
            {
                return Err(ApiError::UploadInFlight(id))
            }
            Some(id) if taken(&id) => return Err(ApiError::SceneExists(id)),
            Some(id) => id,
            None => (1..)
                .map(|n| match n {
                    1 => slug.to_owned(),
                    n => format!("{slug}-{n}"),
                })
                .find(|id| !taken(id))
                .unwrap_or_else(|| slug.to_owned()),
        };
        let held = budget.served + budget.reserved;
        if held.saturating_add(triangles) > max_total {
            return Err(ApiError::ServerFull(format!(
                "the server holds {held} triangles and takes at most {max_total} in all; delete a scene first"
            )));
        }
        budget.ids.insert(id.clone(), upload.map(str::to_owned));
        budget.reserved += triangles;
        drop(budget);
        // Made before the test hook runs, so a hook that panics releases
        // the claim as any failure after this point does.
        let reservation = Reservation {
            registry: self,
            id,
            triangles,
        };
        #[cfg(test)]
        {
            // Taken before it runs: the hook may upload (and so reserve) too.
            let hook = self
                .after_reserve
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take();
            if let Some(hook) = hook {
                hook();
            }
        }
        Ok(reservation)
    }

    /// Stores and serves a new scene under its reservation. Blocking
    /// (builds and fsyncs). What is stored is first read back as a
    /// restart reads it, so nothing is acknowledged that would not load.
    pub fn create(
        &self,
        reservation: Reservation<'_>,
        meta: SceneMeta,
        scene: Scene,
    ) -> Result<(), ApiError> {
        let document = reloadable(&scene)?;
        let id = reservation.id.clone();
        self.store
            .put_scene(&id, &meta, &document)
            .map_err(ApiError::storage)?;
        self.insert(id, meta, scene, 0);
        Ok(())
    }

    /// Serves `scene` under `id`, its revisions counted on from
    /// `revision` (0 for a new upload, the stored count after a restart).
    fn insert(&self, id: String, meta: SceneMeta, scene: Scene, revision: u64) {
        let start = Instant::now();
        let mut acoustic = AcousticScene::new(&scene);
        acoustic.resume_revision(revision);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        tracing::info!(scene = %id, triangles = scene.triangle_count(), build_ms, "scene ready");
        let entry = SceneEntry {
            id: id.clone(),
            meta,
            object_names: scene.objects.iter().map(|o| o.name.clone()).collect(),
            live: RwLock::new(LiveScene {
                mesh_versions: scene.objects.iter().map(|_| next_mesh_version()).collect(),
                scene,
                acoustic,
                build_ms,
                deleted: false,
            }),
            revisions: watch::Sender::new(Some(revision)),
        };
        let triangles = entry.read().scene.triangle_count();
        // Locks in the order budget, then scenes, as `reserve` takes them.
        // Until the upload's reservation is dropped its triangles count
        // twice: a moment in which a competing upload may be refused,
        // never one in which the budget can be exceeded.
        let mut budget = self.budget();
        budget.served += triangles;
        let mut scenes = self.scenes.write().unwrap_or_else(|e| e.into_inner());
        scenes.insert(id, Arc::new(entry));
    }

    /// Deletes the scene `entry` is (the one whose owner the caller
    /// checked): if it is gone already, even if its id was taken again
    /// since, nothing is deleted and the answer is 404.
    pub fn delete(&self, entry: &SceneEntry) -> Result<(), ApiError> {
        let id = entry.id.as_str();
        // Hold the scene's lock so no edit lands between the two steps.
        let mut live = entry.write();
        if live.deleted {
            return Err(ApiError::SceneNotFound(id.to_owned()));
        }
        self.store.delete_scene(id).map_err(ApiError::storage)?;
        live.deleted = true;
        self.scenes
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        self.budget().served -= live.scene.triangle_count();
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
        let mut reports = self.edit_objects(entry, &[(object, edit.clone())])?;
        Ok(reports.remove(0))
    }

    /// Several object edits as one: all are validated before any is
    /// stored or applied, so an invalid one leaves every object as it was.
    /// One report per edit. Blocking.
    pub fn edit_objects(
        &self,
        entry: &SceneEntry,
        edits: &[(usize, ObjectEdit)],
    ) -> Result<Vec<EditReport>, ApiError> {
        let (reports, ()) = self.edit_objects_around(entry, edits, |_, _| Ok(()), |_, ()| ())?;
        Ok(reports)
    }

    /// [`edit_objects`](Self::edit_objects) with a query on each side,
    /// under the same write lock: `before` sees the scene as it was and the
    /// checked edits, `after` the scene with them applied, so a collision
    /// query and the motion it is about are one atomic step. Nothing is
    /// stored or applied when an edit is invalid or `before` fails.
    /// Blocking.
    pub fn edit_objects_around<B, R>(
        &self,
        entry: &SceneEntry,
        edits: &[(usize, ObjectEdit)],
        before: impl FnOnce(&LiveScene, &[PreparedEdit]) -> Result<B, ApiError>,
        after: impl FnOnce(&LiveScene, B) -> R,
    ) -> Result<(Vec<EditReport>, R), ApiError> {
        let mut live = entry.write();
        if live.deleted {
            return Err(ApiError::SceneNotFound(entry.id.clone()));
        }
        let prepared = edits
            .iter()
            .map(|(object, edit)| prepare(&live, *object, edit))
            .collect::<Result<Vec<_>, _>>()?;
        let seen = before(&live, &prepared)?;
        let overlays: Vec<ObjectOverlay<'_>> = prepared
            .iter()
            .map(|p| ObjectOverlay {
                object: p.object as u32,
                transform: p.transform.as_ref(),
                positions: p.mesh.as_ref().map(|m| m.positions()),
            })
            .collect();
        // Each transform and each new mesh is one change of the engine's.
        let changes: u64 = prepared
            .iter()
            .map(|p| u64::from(p.transform.is_some()) + u64::from(p.mesh.is_some()))
            .sum();
        self.store
            .put_object_edits(&entry.id, &overlays, live.acoustic.revision() + changes)
            .map_err(ApiError::storage)?;
        let mut reports = Vec::with_capacity(prepared.len());
        for PreparedEdit {
            object,
            transform,
            mesh,
        } in prepared
        {
            let start = Instant::now();
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
                live.mesh_versions[object] = next_mesh_version();
            }
            let revision = entry.announce(&live);
            reports.push(EditReport {
                revision,
                action: match update.map(|u| u.action) {
                    None => EditAction::Transform,
                    Some(frusta_engine::bvh::UpdateAction::Refit) => EditAction::Refit,
                    Some(frusta_engine::bvh::UpdateAction::Rebuild) => EditAction::Rebuild,
                },
                degradation: update.and_then(|u| u.degradation),
                elapsed_ms: start.elapsed().as_secs_f64() * 1e3,
            });
        }
        Ok((reports, after(&live, seen)))
    }

    /// Replaces materials by name (coefficients only) and adds new ones;
    /// material ids of triangles stay as they are. Blocking.
    pub fn edit_materials(
        &self,
        entry: &SceneEntry,
        materials: Vec<Material>,
    ) -> Result<u64, ApiError> {
        let mut live = entry.write();
        if live.deleted {
            return Err(ApiError::SceneNotFound(entry.id.clone()));
        }
        let mut scene = live.scene.clone();
        let mut index: HashMap<String, usize> = scene
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| (m.name.clone(), i))
            .collect();
        for m in materials {
            match index.get(&m.name) {
                Some(&i) => scene.materials[i] = m,
                None => {
                    index.insert(m.name.clone(), scene.materials.len());
                    scene.materials.push(m);
                }
            }
        }
        // Checked as the engine and a restart will check it, before it is
        // stored.
        check_material_table(live.scene.materials.len(), &scene.materials)
            .map_err(ApiError::from_engine)?;
        self.store
            .put_materials(&entry.id, &scene.materials, live.acoustic.revision() + 1)
            .map_err(ApiError::storage)?;
        live.acoustic
            .set_materials(scene.materials.clone())
            .map_err(ApiError::from_engine)?;
        live.scene = scene;
        Ok(entry.announce(&live))
    }
}

/// An edit checked against the object as it is: the new transform and
/// the new mesh it asks for.
#[derive(Debug)]
pub struct PreparedEdit {
    pub object: usize,
    pub transform: Option<RigidTransform>,
    pub mesh: Option<TriangleMesh>,
}

fn prepare(live: &LiveScene, object: usize, edit: &ObjectEdit) -> Result<PreparedEdit, ApiError> {
    let Some(current) = live.scene.objects.get(object) else {
        return Err(ApiError::UnknownObject(format!(
            "#{object} (the scene has {})",
            live.scene.objects.len()
        )));
    };
    // The checks a stream makes on arrival, then what needs the object.
    edit.check(&current.mesh)?;
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
        Some(v) => Some(
            TriangleMesh::new(v.clone(), current.mesh.triangles().to_vec())
                .map_err(ApiError::from_engine)?,
        ),
        None => None,
    };
    Ok(PreparedEdit {
        object,
        transform,
        mesh,
    })
}

/// The scene's stored document, once it has been read back the way a
/// restart reads it: a write that would not reload is refused, not
/// acknowledged and lost at the next start.
fn reloadable(scene: &Scene) -> Result<String, ApiError> {
    let document = scene.to_json().map_err(ApiError::from_engine)?;
    Scene::from_json_str(&document, None).map_err(|e| {
        ApiError::Invalid(format!(
            "the scene would not load after a restart, so it is not stored: {e}"
        ))
    })?;
    Ok(document)
}

/// A stored scene with its overlays applied.
/// The stored document with its overlays. An overlay that no longer
/// applies (written by an older server that checked less) is logged and
/// skipped: the object keeps its previous state, the scene stays served.
/// With it, the revision to resume from: the stored one, or one more where
/// an edit was skipped.
fn restore(s: StoredScene) -> frusta_engine::Result<(SceneMeta, Scene, u64)> {
    let mut scene = Scene::from_json_str(&s.document, None)?;
    let mut skips = 0;
    let skipped = |object: u32, e: frusta_engine::Error| {
        tracing::error!(scene = %s.id, object, error = %e, "stored object edit does not load; skipped");
    };
    if let Some(materials) = s.materials {
        match check_material_table(scene.materials.len(), &materials) {
            Ok(()) => scene.materials = materials,
            Err(e) => {
                tracing::error!(scene = %s.id, error = %e, "stored material table does not load; skipped");
                skips += 1;
            }
        }
    }
    for (object, t) in s.transforms {
        if let Some(o) = scene.objects.get_mut(object as usize) {
            match t.validated() {
                Ok(t) => o.transform = t,
                Err(e) => {
                    skipped(object, e);
                    skips += 1;
                }
            }
        }
    }
    for (object, positions) in s.positions {
        if let Some(o) = scene.objects.get_mut(object as usize) {
            match TriangleMesh::new(positions, o.mesh.triangles().to_vec()) {
                Ok(mesh) => o.mesh = mesh,
                Err(e) => {
                    skipped(object, e);
                    skips += 1;
                }
            }
        }
    }
    // A skipped edit leaves a state the stored revision did not name.
    let revision = s.revision + u64::from(skips > 0);
    Ok((s.meta, scene, revision))
}

pub fn now_unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

#[cfg(test)]
mod tests {
    use axum::body::Body;
    use axum::http::{Request, StatusCode};
    use tower::ServiceExt;

    use crate::routes::test_support::*;
    use crate::{router, AppState};

    /// Materials named `prefix0`, `prefix1`, ... as a PATCH body.
    fn materials(prefix: &str, count: usize) -> String {
        let entries: Vec<String> = (0..count)
            .map(|i| format!(r#""{prefix}{i}": {{"absorption": 0.1}}"#))
            .collect();
        format!(r#"{{"materials": {{{}}}}}"#, entries.join(", "))
    }

    fn ids(server: &TestServer) -> Vec<String> {
        let scenes = server.state.registry().list();
        scenes.iter().map(|e| e.id.clone()).collect()
    }

    #[tokio::test]
    async fn a_write_that_would_not_reload_is_refused_and_nothing_is_lost() {
        let server = TestServer::new();
        // An OBJ with an empty object name used to answer 201 and vanish
        // at the next start.
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let request = Request::post("/v1/scenes?id=tri&object=")
            .header("content-type", "model/obj")
            .body(Body::from(obj))
            .unwrap();
        let (status, _, problem) = server.send(request).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{problem}");
        assert!(!ids(&server).contains(&"tri".to_owned()));
        // Material edits past the material-id range used to answer 200 and
        // lose the scene at the next start.
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let uri = "/v1/scenes/box/materials";
        let (status, _, body) = server.send(patch_json(uri, &materials("a", 40_000))).await;
        assert_eq!(status, StatusCode::OK, "{body}");
        let (status, _, problem) = server.send(patch_json(uri, &materials("b", 40_000))).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{problem}");
        assert!(
            problem["detail"].as_str().unwrap().contains("65536"),
            "{problem}"
        );
        let server = server.restart();
        let entry = server.state.registry().get("box").expect("reloaded");
        assert_eq!(entry.read().scene.materials.len(), 40_001);
    }

    #[tokio::test]
    async fn an_edit_that_loses_the_race_with_a_delete_does_not_bring_the_scene_back() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let registry = server.state.registry();
        // The edit looked the scene up before the delete ran.
        let entry = registry.get("box").unwrap();
        registry.delete(&entry).unwrap();
        // A second delete of the same entry finds it gone, even once the id
        // is taken again.
        let fresh = server.send(post_json("/v1/scenes?id=box", BOX_DOC));
        assert_eq!(fresh.await.0, StatusCode::CREATED);
        let e = registry.delete(&entry);
        assert!(matches!(e, Err(crate::error::ApiError::SceneNotFound(_))));
        registry.delete(&registry.get("box").unwrap()).unwrap();
        let material = frusta_engine::scene::Material::uniform("walls", 0.5).unwrap();
        let e = registry.edit_materials(&entry, vec![material]);
        assert!(matches!(e, Err(crate::error::ApiError::SceneNotFound(_))));
        let edit = super::ObjectEdit {
            translation: Some([0.0, 0.5, 0.0]),
            ..Default::default()
        };
        let e = registry.edit_object(&entry, 1, &edit);
        assert!(matches!(e, Err(crate::error::ApiError::SceneNotFound(_))));
        let server = server.restart();
        assert!(server.state.registry().get("box").is_err());
    }

    /// Sets a hook that, when an upload has made its reservation, sends
    /// `second` and records its status and problem type (if any).
    fn at_reservation(
        state: &AppState,
        second: Request<Body>,
    ) -> std::sync::mpsc::Receiver<(StatusCode, String)> {
        let (tx, rx) = std::sync::mpsc::channel();
        let handle = tokio::runtime::Handle::current();
        let app = router(state.clone());
        let hook = move || {
            let response = handle.block_on(app.oneshot(second)).unwrap();
            let status = response.status();
            let body = handle
                .block_on(axum::body::to_bytes(response.into_body(), usize::MAX))
                .unwrap();
            let problem: serde_json::Value = serde_json::from_slice(&body).unwrap_or_default();
            let kind = problem["type"].as_str().unwrap_or_default().to_owned();
            tx.send((status, kind)).unwrap();
        };
        *state.registry().after_reserve.lock().unwrap() = Some(Box::new(hook));
        rx
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn two_uploads_of_one_id_cannot_both_succeed() {
        let server = TestServer::new();
        let second = at_reservation(&server.state, post_json("/v1/scenes?id=twin", BOX_DOC));
        let (status, _, body) = server.send(post_json("/v1/scenes?id=twin", BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        assert_eq!(second.recv().unwrap().0, StatusCode::CONFLICT);
        // Automatic ids are reserved too.
        let doc = BOX_DOC.replacen('{', r#"{"name": "Auto", "#, 1);
        let second = at_reservation(&server.state, post_json("/v1/scenes", &doc));
        let (_, _, first) = server.send(post_json("/v1/scenes", &doc)).await;
        assert_eq!(second.recv().unwrap().0, StatusCode::CREATED);
        assert_eq!(first["id"], "auto");
        let mut all = ids(&server);
        all.sort();
        assert_eq!(all, ["auto", "auto-2", "shoebox", "twin"]);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_retry_while_its_upload_is_stored_is_told_so_then_answered() {
        let server = TestServer::new();
        let upload = || post_json("/v1/scenes?id=twin", BOX_DOC);
        let retry = at_reservation(&server.state, upload());
        let (status, _, body) = server.send(upload()).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        let (status, kind) = retry.recv().unwrap();
        assert_eq!(status, StatusCode::CONFLICT);
        assert_eq!(kind, "urn:frusta:problem:upload-in-flight");
        let (status, _, body) = server.send(upload()).await;
        assert_eq!(status, StatusCode::OK, "{body}");
        assert_eq!(body["id"], "twin");
        // Another body for a claimed id is a rival, not a retry.
        let rival = BOX_DOC.replacen('{', r#"{"name": "Rival", "#, 1);
        let second = at_reservation(&server.state, post_json("/v1/scenes?id=other", &rival));
        server.send(post_json("/v1/scenes?id=other", BOX_DOC)).await;
        assert_eq!(second.recv().unwrap().1, "urn:frusta:problem:scene-exists");
    }

    /// Revisions count on across a restart: answers after it never name
    /// a revision an earlier state had.
    #[tokio::test]
    async fn revisions_survive_a_restart() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        server.translate("box", "panel", [0.5, 0.0, 0.0]).await;
        let (status, _, edited) = server
            .send(patch_json(
                "/v1/scenes/box/materials",
                r#"{"materials": {"walls": {"absorption": 0.3}}}"#,
            ))
            .await;
        assert_eq!(status, StatusCode::OK, "{edited}");
        let both = r#"{"translation": [1, 0, 0], "vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2.5], [4, 1, 2]]}"#;
        let (status, _, edited) = server
            .send(patch_json("/v1/scenes/box/objects/panel", both))
            .await;
        assert_eq!(status, StatusCode::OK, "{edited}");
        let revision = |server: &TestServer| {
            server
                .state
                .registry()
                .get("box")
                .unwrap()
                .read()
                .acoustic
                .revision()
        };
        assert_eq!(revision(&server), 4);
        let server = server.restart();
        assert_eq!(revision(&server), 4);
        let (_, _, detail) = server.send(get("/v1/scenes/box")).await;
        assert_eq!(detail["revision"], 4);
        server.translate("box", "panel", [0.0, 0.5, 0.0]).await;
        assert_eq!(revision(&server), 5);
    }

    #[tokio::test]
    async fn a_stored_edit_that_no_longer_loads_costs_that_edit_not_the_scene() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let zero = frusta_engine::geometry::RigidTransform {
            rotation: glam::Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
            translation: glam::Vec3::X,
        };
        let overlay = crate::store::ObjectOverlay {
            object: 1,
            transform: Some(&zero),
            positions: None,
        };
        let registry = server.state.registry();
        registry
            .store()
            .put_object_edits("box", &[overlay], 1)
            .unwrap();
        let server = server.restart();
        let entry = server
            .state
            .registry()
            .get("box")
            .expect("the scene is still served");
        let live = entry.read();
        assert_eq!(
            live.scene.objects[1].transform,
            frusta_engine::geometry::RigidTransform::IDENTITY
        );
        // Not the stored edit's revision: that names the state it would
        // have made.
        assert_eq!(live.acoustic.revision(), 2);
    }

    #[tokio::test]
    async fn an_unexpected_failure_is_a_500_with_an_error_id_and_leaves_nothing() {
        let server = TestServer::new();
        *server.state.registry().after_reserve.lock().unwrap() =
            Some(Box::new(|| panic!("forced failure")));
        let (status, content_type, problem) = server
            .send(post_json("/v1/scenes?id=doomed", BOX_DOC))
            .await;
        assert_eq!(status, StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(problem["type"], "urn:frusta:problem:internal");
        let id = problem["error_id"].as_str().expect("an error id");
        assert!(!id.is_empty());
        // The claim on the id and triangles went with the failed job.
        let (status, _, body) = server
            .send(post_json("/v1/scenes?id=doomed", BOX_DOC))
            .await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        assert!(body.get("error_id").is_none());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn concurrent_uploads_cannot_exceed_the_triangle_budget() {
        // The shoebox (12) and one 14-triangle upload fit, two do not.
        let server = TestServer::with(|c| c.limits.max_total_triangles = 12 + 14 + 10);
        let second = at_reservation(&server.state, post_json("/v1/scenes?id=b", BOX_DOC));
        let (status, _, body) = server.send(post_json("/v1/scenes?id=a", BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        assert_eq!(second.recv().unwrap().0, StatusCode::INSUFFICIENT_STORAGE);
        assert_eq!(server.state.registry().total_triangles(), 26);
        // Deleting gives the triangles back.
        server.send(delete("/v1/scenes/a")).await;
        let (status, _, _) = server.send(post_json("/v1/scenes?id=b", BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED);
    }
}
