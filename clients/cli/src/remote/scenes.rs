//! `frusta scenes`: list, upload and delete the scenes a server holds.

use std::error::Error;
use std::fs::File;
use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

use clap::Subcommand;
use frusta_engine::scene::load::extension;
use frusta_engine::scene::Scene;
use serde::de::IgnoredAny;
use serde::Deserialize;
use serde_json::Value;
use ureq::SendBody;

use super::{segment, Server};
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

pub fn run(server: &Server, command: &ScenesCommand) -> Result<(), Box<dyn Error>> {
    match command {
        ScenesCommand::List { json } => list(server, *json),
        ScenesCommand::Upload { path, id } => upload(server, path, id.as_deref()),
        ScenesCommand::Delete { id } => {
            let path = format!("/v1/scenes/{}", segment(id));
            server.answer(server.delete(&path).call())?;
            println!("deleted {id}");
            Ok(())
        }
    }
}

#[derive(Deserialize)]
struct SceneList {
    scenes: Vec<SceneSummary>,
}

#[derive(Deserialize)]
struct SceneSummary {
    id: String,
    triangles: usize,
    objects: Vec<IgnoredAny>,
    revision: u64,
}

fn list(server: &Server, as_json: bool) -> Result<(), Box<dyn Error>> {
    let bytes = server.answer(server.get("/v1/scenes").call())?;
    if as_json {
        let doc: Value = serde_json::from_slice(&bytes)?;
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    let list: SceneList = serde_json::from_slice(&bytes)?;
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

#[derive(Deserialize)]
struct Created {
    id: String,
}

fn upload(server: &Server, path: &Path, id: Option<&str>) -> Result<(), Box<dyn Error>> {
    let upload = Upload::new(path)?;
    // A reader has no length of its own; giving it sends the body
    // length-delimited rather than chunked, which every proxy accepts.
    let mut request = server
        .post("/v1/scenes")
        .header("content-type", upload.content_type)
        .header("content-length", upload.len);
    if let Some(id) = id {
        request = request.query("id", id);
    }
    if let Some(object) = &upload.object {
        request = request.query("object", object);
    }
    let bar = progress::bytes(upload.len, progress::shown(false));
    bar.set_message(format!("uploading {}", path.display()));
    let mut body = bar.wrap_read(upload.body);
    let sent = request.send(SendBody::from_reader(&mut body));
    bar.finish_and_clear();
    let created: Created = serde_json::from_slice(&server.answer(sent)?)?;
    println!("{}", created.id);
    Ok(())
}
