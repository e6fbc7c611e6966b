//! Crash-safe persistence of scenes and their edits in one embedded redb
//! database in the data directory.
//!
//! A scene is its self-contained JSON document plus overlays: the latest
//! transform and the latest vertex positions of each edited object, and
//! the latest material table. An edit therefore writes a few bytes (a
//! transform, the materials) or one object's positions, never the whole
//! scene, which keeps streamed object updates and material edits cheap. Every
//! call is one redb write transaction committed with fsync before it
//! returns, so what the server acknowledged survives `kill -9`, and a
//! half-written transaction is discarded on the next open.

use std::path::Path;

use frusta_engine::geometry::RigidTransform;
use frusta_engine::scene::Material;
use glam::Vec3;
use redb::{Database, ReadableTable, TableDefinition};
use serde::{Deserialize, Serialize};

/// Scene id -> [`SceneMeta`] as JSON.
const META: TableDefinition<&str, &[u8]> = TableDefinition::new("scene_meta");
/// Scene id -> scene document (engine JSON format, inline meshes).
const DOCUMENTS: TableDefinition<&str, &str> = TableDefinition::new("scene_documents");
/// (scene id, object index) -> transform as JSON.
const TRANSFORMS: TableDefinition<(&str, u32), &[u8]> = TableDefinition::new("object_transforms");
/// (scene id, object index) -> vertex positions, little-endian f32 x, y, z.
const POSITIONS: TableDefinition<(&str, u32), &[u8]> = TableDefinition::new("object_positions");
/// Scene id -> the whole material table as JSON (a list of engine
/// materials), replacing the document's.
const MATERIALS: TableDefinition<&str, &[u8]> = TableDefinition::new("scene_materials");
/// Scene id -> its revision after the last stored edit (absent: 0), so a
/// restart does not take revisions back.
const REVISIONS: TableDefinition<&str, u64> = TableDefinition::new("scene_revisions");
/// Store-wide flags, such as whether the bundled scenes were ever added.
const FLAGS: TableDefinition<&str, bool> = TableDefinition::new("flags");

const SEEDED: &str = "bundled_scenes_added";

/// A storage failure; boxed because redb's error is large and this one
/// travels through every edit's `Result`.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct StoreError(Box<redb::Error>);

impl<E: Into<redb::Error>> From<E> for StoreError {
    fn from(e: E) -> Self {
        Self(Box::new(e.into()))
    }
}

pub type StoreResult<T> = Result<T, StoreError>;

/// What the service knows about a scene besides its geometry.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SceneMeta {
    /// SHA-256 (hex) of the API key that created the scene; `None` for
    /// bundled scenes and servers without keys.
    pub owner: Option<String>,
    pub created_unix_ms: u64,
    pub bundled: bool,
    /// SHA-256 (hex) of what was uploaded (media type, query and body):
    /// the same upload to the same id again is a retry, answered with the
    /// stored scene. `None` for bundled scenes and older records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upload_digest: Option<String>,
}

/// One object's edit as stored: what changed of it.
pub struct ObjectOverlay<'a> {
    pub object: u32,
    pub transform: Option<&'a RigidTransform>,
    pub positions: Option<&'a [Vec3]>,
}

/// A scene as read back at startup.
pub struct StoredScene {
    pub id: String,
    pub meta: SceneMeta,
    pub document: String,
    pub transforms: Vec<(u32, RigidTransform)>,
    pub positions: Vec<(u32, Vec<Vec3>)>,
    /// The material table of the last material edit, if any.
    pub materials: Option<Vec<Material>>,
    /// The revision after the last stored edit.
    pub revision: u64,
}

pub struct Store {
    db: Database,
}

impl Store {
    /// Opens (or creates) `dir/scenes.redb`; redb repairs an interrupted
    /// write on open.
    pub fn open(dir: &Path) -> StoreResult<Self> {
        std::fs::create_dir_all(dir).map_err(redb::Error::Io)?;
        let db = Database::create(dir.join("scenes.redb"))?;
        let txn = db.begin_write()?;
        {
            // Create every table so readers never meet a missing one.
            txn.open_table(META)?;
            txn.open_table(DOCUMENTS)?;
            txn.open_table(TRANSFORMS)?;
            txn.open_table(POSITIONS)?;
            txn.open_table(MATERIALS)?;
            txn.open_table(REVISIONS)?;
            txn.open_table(FLAGS)?;
        }
        txn.commit()?;
        Ok(Self { db })
    }

    /// Whether the bundled scenes were added once already; a deleted
    /// bundled scene then stays deleted.
    pub fn seeded(&self) -> StoreResult<bool> {
        let txn = self.db.begin_read()?;
        let flags = txn.open_table(FLAGS)?;
        Ok(flags.get(SEEDED)?.is_some_and(|v| v.value()))
    }

    pub fn mark_seeded(&self) -> StoreResult<()> {
        self.write(|txn| {
            txn.open_table(FLAGS)?.insert(SEEDED, true)?;
            Ok(())
        })
    }

    /// Stores a scene's whole document, replacing any earlier one and its
    /// overlays (the document already includes them).
    pub fn put_scene(&self, id: &str, meta: &SceneMeta, document: &str) -> StoreResult<()> {
        let meta = serde_json::to_vec(meta).expect("metadata serialises");
        self.write(|txn| {
            txn.open_table(META)?.insert(id, meta.as_slice())?;
            txn.open_table(DOCUMENTS)?.insert(id, document)?;
            clear_overlays(txn, id)
        })
    }

    pub fn delete_scene(&self, id: &str) -> StoreResult<()> {
        self.write(|txn| {
            txn.open_table(META)?.remove(id)?;
            txn.open_table(DOCUMENTS)?.remove(id)?;
            clear_overlays(txn, id)
        })
    }

    /// Stores a scene's new material table (its document is unchanged)
    /// and its revision after the edit.
    pub fn put_materials(
        &self,
        id: &str,
        materials: &[Material],
        revision: u64,
    ) -> StoreResult<()> {
        let bytes = serde_json::to_vec(materials).expect("materials serialise");
        self.write(|txn| {
            txn.open_table(MATERIALS)?.insert(id, bytes.as_slice())?;
            txn.open_table(REVISIONS)?.insert(id, revision)?;
            Ok(())
        })
    }

    /// Stores object edits (new transforms and vertex positions) and the
    /// scene's revision after them in one transaction: after a crash, all
    /// of them are stored or none.
    pub fn put_object_edits(
        &self,
        id: &str,
        edits: &[ObjectOverlay<'_>],
        revision: u64,
    ) -> StoreResult<()> {
        self.write(|txn| {
            txn.open_table(REVISIONS)?.insert(id, revision)?;
            let mut transforms = txn.open_table(TRANSFORMS)?;
            let mut positions = txn.open_table(POSITIONS)?;
            for edit in edits {
                if let Some(t) = edit.transform {
                    let bytes = serde_json::to_vec(t).expect("transform serialises");
                    transforms.insert((id, edit.object), bytes.as_slice())?;
                }
                if let Some(p) = edit.positions {
                    let bytes: Vec<u8> = p
                        .iter()
                        .flat_map(|p| p.to_array())
                        .flat_map(f32::to_le_bytes)
                        .collect();
                    positions.insert((id, edit.object), bytes.as_slice())?;
                }
            }
            Ok(())
        })
    }

    /// Every stored scene with its overlays, ordered by id.
    pub fn load_all(&self) -> StoreResult<Vec<StoredScene>> {
        let txn = self.db.begin_read()?;
        let meta = txn.open_table(META)?;
        let documents = txn.open_table(DOCUMENTS)?;
        let transforms = txn.open_table(TRANSFORMS)?;
        let positions = txn.open_table(POSITIONS)?;
        let materials = txn.open_table(MATERIALS)?;
        let revisions = txn.open_table(REVISIONS)?;
        let mut out = Vec::new();
        for entry in meta.iter()? {
            let (id, m) = entry?;
            let id = id.value().to_owned();
            let Some(document) = documents.get(id.as_str())? else {
                continue;
            };
            let meta: SceneMeta = serde_json::from_slice(m.value())
                .map_err(|e| corrupt(format!("metadata of scene {id}: {e}")))?;
            let table = match materials.get(id.as_str())? {
                Some(m) => Some(
                    serde_json::from_slice(m.value())
                        .map_err(|e| corrupt(format!("materials of scene {id}: {e}")))?,
                ),
                None => None,
            };
            let mut scene = StoredScene {
                meta,
                document: document.value().to_owned(),
                transforms: Vec::new(),
                positions: Vec::new(),
                materials: table,
                revision: revisions.get(id.as_str())?.map_or(0, |r| r.value()),
                id,
            };
            let key = scene.id.as_str();
            for entry in transforms.range((key, 0)..=(key, u32::MAX))? {
                let (k, v) = entry?;
                let t = serde_json::from_slice(v.value())
                    .map_err(|e| corrupt(format!("transform in scene {key}: {e}")))?;
                scene.transforms.push((k.value().1, t));
            }
            for entry in positions.range((key, 0)..=(key, u32::MAX))? {
                let (k, v) = entry?;
                scene
                    .positions
                    .push((k.value().1, decode_positions(v.value())));
            }
            out.push(scene);
        }
        Ok(out)
    }

    fn write(&self, f: impl FnOnce(&redb::WriteTransaction) -> StoreResult<()>) -> StoreResult<()> {
        let txn = self.db.begin_write()?;
        f(&txn)?;
        txn.commit()?;
        Ok(())
    }
}

fn clear_overlays(txn: &redb::WriteTransaction, id: &str) -> StoreResult<()> {
    txn.open_table(TRANSFORMS)?
        .retain_in((id, 0)..=(id, u32::MAX), |_, _| false)?;
    txn.open_table(POSITIONS)?
        .retain_in((id, 0)..=(id, u32::MAX), |_, _| false)?;
    txn.open_table(MATERIALS)?.remove(id)?;
    txn.open_table(REVISIONS)?.remove(id)?;
    Ok(())
}

fn decode_positions(bytes: &[u8]) -> Vec<Vec3> {
    bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            Vec3::new(f(0), f(4), f(8))
        })
        .collect()
}

fn corrupt(message: String) -> StoreError {
    redb::Error::Corrupted(message).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("frusta-store-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn meta() -> SceneMeta {
        SceneMeta {
            owner: Some("abc".into()),
            created_unix_ms: 7,
            bundled: false,
            upload_digest: None,
        }
    }

    #[test]
    fn scenes_and_overlays_survive_reopening() {
        let dir = temp_dir("reopen");
        {
            let store = Store::open(&dir).expect("open");
            store
                .put_scene("a", &meta(), "{\"objects\":[]}")
                .expect("put");
            store.put_scene("b", &meta(), "{}").expect("put");
            let t = RigidTransform::from_translation(Vec3::new(1.0, 2.0, 3.0));
            let positions = [Vec3::X, Vec3::new(0.5, -2.0, 1e-7)];
            store
                .put_object_edits(
                    "a",
                    &[
                        ObjectOverlay {
                            object: 1,
                            transform: Some(&t),
                            positions: None,
                        },
                        ObjectOverlay {
                            object: 0,
                            transform: None,
                            positions: Some(&positions),
                        },
                    ],
                    2,
                )
                .expect("edits");
            let felt = Material::uniform("felt", 0.7).unwrap();
            store
                .put_materials("a", std::slice::from_ref(&felt), 3)
                .expect("materials");
            store.put_materials("b", &[felt], 1).expect("materials");
            store.delete_scene("b").expect("delete");
        }
        let store = Store::open(&dir).expect("reopen");
        let scenes = store.load_all().expect("load");
        std::fs::remove_dir_all(&dir).expect("clean up");
        assert_eq!(scenes.len(), 1);
        let a = &scenes[0];
        assert_eq!(a.id, "a");
        assert_eq!(a.meta.owner.as_deref(), Some("abc"));
        assert_eq!(a.document, "{\"objects\":[]}");
        assert_eq!(a.transforms.len(), 1);
        assert_eq!(a.transforms[0].0, 1);
        assert_eq!(a.transforms[0].1.translation, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            a.positions,
            vec![(0, vec![Vec3::X, Vec3::new(0.5, -2.0, 1e-7)])]
        );
        assert_eq!(
            a.materials,
            Some(vec![Material::uniform("felt", 0.7).unwrap()])
        );
        assert_eq!(a.revision, 3);
    }

    #[test]
    fn replacing_a_document_drops_its_overlays_only() {
        let dir = temp_dir("replace");
        let store = Store::open(&dir).expect("open");
        let t = RigidTransform::from_translation(Vec3::Z);
        store.put_scene("a", &meta(), "old").expect("put");
        store.put_scene("ab", &meta(), "other").expect("put");
        let moved = [ObjectOverlay {
            object: 0,
            transform: Some(&t),
            positions: None,
        }];
        store.put_object_edits("a", &moved, 1).expect("transform");
        store.put_object_edits("ab", &moved, 1).expect("transform");
        let felt = [Material::uniform("felt", 0.7).unwrap()];
        store.put_materials("a", &felt, 2).expect("materials");
        store.put_materials("ab", &felt, 2).expect("materials");
        store.put_scene("a", &meta(), "new").expect("replace");
        let scenes = store.load_all().expect("load");
        std::fs::remove_dir_all(&dir).expect("clean up");
        assert_eq!(scenes[0].document, "new");
        assert!(scenes[0].transforms.is_empty());
        assert!(scenes[0].materials.is_none());
        assert_eq!(scenes[0].revision, 0, "a new document counts from 0");
        assert_eq!(scenes[1].transforms.len(), 1, "a prefix id keeps its edits");
        assert!(scenes[1].materials.is_some());
        assert_eq!(scenes[1].revision, 2);
    }

    #[test]
    fn seeding_is_remembered() {
        let dir = temp_dir("seeded");
        let store = Store::open(&dir).expect("open");
        assert!(!store.seeded().expect("read"));
        store.mark_seeded().expect("mark");
        drop(store);
        let store = Store::open(&dir).expect("reopen");
        let seeded = store.seeded().expect("read");
        std::fs::remove_dir_all(&dir).expect("clean up");
        assert!(seeded);
    }
}
