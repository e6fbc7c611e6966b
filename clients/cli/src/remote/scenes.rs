//! `frusta scenes`: list, upload and delete the scenes a server holds.

use std::error::Error;
use std::fs::File;
use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

use clap::Subcommand;
use frusta_client::api::scenes::CreateQuery;
use frusta_client::Client;
use frusta_engine::scene::load::extension;
use frusta_engine::scene::Scene;
use serde_json::Value;

use crate::progress;

#[derive(Subcommand)]
pub enum ScenesCommand {
    /// List the server's scenes.
    List {
        /// Print the server's JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Upload a scene and print its id. A `.json` scene document or a
    /// `.gltf` file is loaded here first, so the mesh files it references
    /// come along; `.obj` and `.glb` files are sent as they are, as one
    /// object named after the file.
    Upload {
        /// Scene file: `.json`, `.gltf`, `.obj` or `.glb`.
        path: PathBuf,
        /// The new scene's id (letters, digits, `-`, `_`); without it the
        /// server makes one from the file name (JSON, glTF) or `scene`.
        #[arg(long)]
        id: Option<String>,
    },
    /// Delete a scene and its stored edits.
    Delete {
        /// The scene's id, as `scenes list` shows it.
        id: String,
    },
}

pub fn run(client: &Client, command: &ScenesCommand) -> Result<(), Box<dyn Error>> {
    match command {
        ScenesCommand::List { json } => list(client, *json),
        ScenesCommand::Upload { path, id } => upload(client, path, id.as_deref()),
        ScenesCommand::Delete { id } => {
            client.delete_scene(id)?;
            println!("deleted {id}");
            Ok(())
        }
    }
}

fn list(client: &Client, as_json: bool) -> Result<(), Box<dyn Error>> {
    let list = client.scenes()?;
    if as_json {
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    let width = list
        .scenes
        .iter()
        .map(|s| s.id.len())
        .max()
        .unwrap_or(0)
        .max(2);
    println!(
        "{:<width$}  {:>10}  {:>7}  {:>8}",
        "id", "triangles", "objects", "revision"
    );
    for s in &list.scenes {
        println!(
            "{:<width$}  {:>10}  {:>7}  {:>8}",
            s.id,
            s.triangles,
            s.objects.len(),
            s.revision
        );
    }
    Ok(())
}

/// What goes over the wire for a scene file.
struct Upload {
    content_type: &'static str,
    len: u64,
    body: Box<dyn Read>,
    /// `object=NAME` for mesh uploads, which the server makes one object of.
    object: Option<String>,
}

impl Upload {
    fn new(path: &Path) -> Result<Self, Box<dyn Error>> {
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let mesh = |content_type| -> Result<Self, Box<dyn Error>> {
            let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(Self {
                content_type,
                len: file.metadata()?.len(),
                body: Box::new(file),
                object: Some(stem.clone()),
            })
        };
        match extension(path).as_deref() {
            Some("obj") => mesh("model/obj"),
            Some("glb") => mesh("model/gltf-binary"),
            _ => {
                // The server reads no files, so referenced meshes are
                // inlined here; the name makes the server's default id.
                let mut doc: Value = serde_json::from_str(&Scene::load(path)?.to_json()?)?;
                doc["name"] = Value::String(stem);
                let bytes = serde_json::to_vec(&doc)?;
                Ok(Self {
                    content_type: "application/json",
                    len: bytes.len() as u64,
                    body: Box::new(Cursor::new(bytes)),
                    object: None,
                })
            }
        }
    }
}

fn upload(client: &Client, path: &Path, id: Option<&str>) -> Result<(), Box<dyn Error>> {
    let upload = Upload::new(path)?;
    let query = CreateQuery {
        id: id.map(str::to_owned),
        object: upload.object,
        material: None,
    };
    let bar = progress::bytes(upload.len, progress::shown(false));
    bar.set_message(format!("uploading {}", path.display()));
    let created = client.upload(
        &query,
        upload.content_type,
        upload.len,
        bar.wrap_read(upload.body),
    );
    bar.finish_and_clear();
    println!("{}", created?.id);
    Ok(())
}
