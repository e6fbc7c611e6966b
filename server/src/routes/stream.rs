//! `GET /v1/scenes/{id}/stream`: a WebSocket on which the client sends
//! updates (sources, listeners, options, object moves) and the server
//! answers each with fresh impulse responses.
//!
//! Updates that arrive while a simulation runs are merged, newest value
//! winning, and simulated together when it ends: a slow engine skips
//! states instead of building a backlog. An edit by anyone else (another
//! stream, a `PATCH`) also triggers a new answer, and every answer names the
//! scene revision it was computed on, so streams on one scene agree.
//!
//! Protocol, client to server (text, JSON; every field optional):
//! `{"seq": 7, "sources": [{"position": [x,y,z]}], "listeners": [...],
//!   "options": {<simulation options>}, "objects": [{"object": "door",
//!   "translation": [x,y,z], "rotation": [x,y,z,w], "vertices": [...]}]}`.
//! Server to client, per source-listener pair: a text frame
//! `{"type": "impulse_response", "seq", "revision", "compute_ms", ...}`
//! (the fields of the HTTP route's responses), then a binary frame of
//! interleaved little-endian f32 samples. Object moves sent before any
//! source and listener are answered with `{"type": "objects_updated", ...}`.
//! An update may subscribe to collisions, `{"collisions": {<a collision
//! request without moves>}}`; from then on every answer starts with
//! `{"type": "collisions", "seq", "objects", ...}` (the fields of the
//! collision route's answer), a continuous query sweeping over the update's
//! own object moves. A stream may subscribe to impulse responses (by
//! sending sources and listeners), to collisions, or to both.
//! Errors are text frames `{"type": "error", "problem": <problem
//! document>}`; the stream stays open.

use std::time::Instant;

use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, State};
use axum::response::Response;
use axum::Extension;
use frusta_api::collisions::CollisionResponse;
use frusta_api::objects::EditReport;
use frusta_api::stream::{
    ObjectsUpdated, StreamAnswer, StreamCollisions, StreamFrame, StreamUpdate,
};
use frusta_engine::acoustics::{self, BeamCache, Cancel};
use tokio::sync::{mpsc, OwnedSemaphorePermit};

use crate::app::AppState;
use crate::auth::Caller;
use crate::collide::{self, Plan};
use crate::error::{ApiError, Problem};
use crate::registry::{ObjectEdit, SceneEntry};
use crate::routes::objects::{edit_of, object_index};
use crate::simulation::{self, IrRequest};

/// Opens a stream; see the module documentation for the protocol.
#[utoipa::path(get, path = "/v1/scenes/{id}/stream", tag = "acoustics",
    description = "A WebSocket: the client sends `StreamUpdate` messages (text), the server answers with impulse responses as they change; see the README",
    params(("id" = String, Path, description = "Scene id")),
    responses((status = 101, description = "Switching to the WebSocket protocol"),
        (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 503, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn connect(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
    ws: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    let entry = state.registry().get(&id)?;
    let ws = ws.map_err(|r| ApiError::BadUpgrade {
        status: r.status(),
        detail: r.body_text(),
    })?;
    let permit = state
        .streams()
        .clone()
        .try_acquire_owned()
        .map_err(|_| ApiError::Busy {
            queued: state.limits().max_streams,
        })?;
    let tasks = state.tasks().clone();
    Ok(ws.on_upgrade(move |socket| {
        tasks.track_future(Stream::new(state, caller, entry, permit).run(socket))
    }))
}

/// How long a closing client gets to take the server's Close frame.
const CLOSE_GRACE: std::time::Duration = std::time::Duration::from_secs(2);

/// Updates received and not yet simulated.
#[derive(Default)]
struct Pending {
    seq: Option<u64>,
    request: Option<IrRequest>,
    /// At most one edit per object, keyed by index (so `"panel"` and `"1"`
    /// are one object): later moves merge into it, newest value of each
    /// field winning, so a client outpacing the engine queues only the
    /// latest state.
    objects: Vec<(usize, ObjectEdit)>,
    /// A new collision subscription.
    collisions: Option<Plan>,
    /// Something changed since the last answer.
    dirty: bool,
}

struct Computed {
    seq: Option<u64>,
    revision: u64,
    compute_ms: f64,
    objects: Vec<EditReport>,
    collisions: Option<CollisionResponse>,
    responses: Vec<acoustics::Response>,
}

type JobResult = (BeamCache, Result<Computed, ApiError>);

struct Stream {
    state: AppState,
    caller: Caller,
    entry: std::sync::Arc<SceneEntry>,
    _permit: OwnedSemaphorePermit,
    pending: Pending,
    /// The last request simulated, which updates modify.
    current: Option<IrRequest>,
    /// The collision subscription, answered with every update.
    collisions: Option<Plan>,
    /// Absent while a job owns it.
    cache: Option<BeamCache>,
    /// The newest scene revision answered for.
    answered: Option<u64>,
    /// Cancelled when the stream ends, so a job whose client has left
    /// stops instead of holding a worker until it finishes.
    cancel: Cancel,
}

impl Stream {
    fn new(
        state: AppState,
        caller: Caller,
        entry: std::sync::Arc<SceneEntry>,
        permit: OwnedSemaphorePermit,
    ) -> Self {
        let max_beams = state.limits().max_cached_frusta;
        Self {
            state,
            caller,
            entry,
            _permit: permit,
            pending: Pending::default(),
            current: None,
            collisions: None,
            cache: Some(BeamCache::with_max_beams(max_beams)),
            answered: None,
            cancel: Cancel::new(),
        }
    }

    async fn run(mut self, mut socket: WebSocket) {
        self.state.metrics().streams.inc();
        let shutdown = self.state.shutdown_token().clone();
        let mut revisions = self.entry.watch();
        let (done_tx, mut done_rx) = mpsc::channel::<JobResult>(1);
        loop {
            if self.cache.is_some() && self.pending.dirty {
                self.start_job(done_tx.clone());
            }
            tokio::select! {
                message = socket.recv() => match message {
                    Some(Ok(Message::Text(text))) => {
                        if let Err(e) = self.merge(text.as_str()) {
                            if send_error(&mut socket, &e).await.is_err() { break; }
                        }
                    }
                    Some(Ok(Message::Binary(_))) => {
                        let e = ApiError::Invalid("updates are JSON text messages".into());
                        if send_error(&mut socket, &e).await.is_err() { break; }
                    }
                    Some(Ok(Message::Close(_))) => {
                        // The reply Close is queued, and goes out on the
                        // next read (RFC 6455 5.5.1), which then ends.
                        let drain = async { while let Some(Ok(_)) = socket.recv().await {} };
                        let _ = tokio::time::timeout(CLOSE_GRACE, drain).await;
                        break;
                    }
                    None | Some(Err(_)) => break,
                    Some(Ok(_)) => {}
                },
                Some((cache, result)) = done_rx.recv() => {
                    self.cache = Some(cache);
                    let sent = match result {
                        Ok(computed) => self.send_answers(&mut socket, computed).await,
                        Err(e) => send_error(&mut socket, &e).await,
                    };
                    if sent.is_err() { break; }
                }
                changed = revisions.changed() => {
                    let revision = *revisions.borrow_and_update();
                    match (changed, revision) {
                        (Ok(()), Some(r)) => {
                            let subscribed = self.current.is_some() || self.collisions.is_some();
                            if self.answered.is_some_and(|a| a < r) && subscribed {
                                self.pending.dirty = true;
                            }
                        }
                        _ => {
                            let e = ApiError::SceneNotFound(self.entry.id.clone());
                            let _ = send_error(&mut socket, &e).await;
                            let _ = socket.send(close(1000, "scene deleted")).await;
                            break;
                        }
                    }
                }
                () = shutdown.cancelled() => {
                    let _ = socket.send(close(1001, "server shutting down")).await;
                    break;
                }
            }
        }
        self.cancel.cancel();
        self.state.metrics().streams.dec();
    }

    /// Merges one client message into the pending update.
    fn merge(&mut self, text: &str) -> Result<(), ApiError> {
        let update: StreamUpdate =
            serde_json::from_str(text).map_err(|e| ApiError::Invalid(format!("update: {e}")))?;
        let base = self.pending.request.as_ref().or(self.current.as_ref());
        let sources = match (&update.sources, base) {
            (Some(s), _) => Some(simulation::positions("sources", s)?),
            (None, b) => b.map(|b| b.sources.clone()),
        };
        let listeners = match (&update.listeners, base) {
            (Some(l), _) => Some(simulation::positions("listeners", l)?),
            (None, b) => b.map(|b| b.listeners.clone()),
        };
        let lod_error_m = match (update.lod_error_m, base) {
            (Some(bound), _) => bound,
            (None, Some(b)) => b.lod_error_m,
            (None, None) => 0.0,
        };
        let options = match (update.options, base) {
            (Some(o), _) => o,
            (None, Some(b)) => b.options.clone(),
            (None, None) => Default::default(),
        };
        let mut edits = Vec::new();
        for m in update.objects.unwrap_or_default() {
            self.caller.may_change(&self.entry.meta)?;
            let index = object_index(&self.entry, &m.object)?;
            let edit = edit_of(&m.patch)?;
            edit.check(&self.entry.read().scene.objects[index].mesh)?;
            edits.push((index, edit));
        }
        let collisions = match &update.collisions {
            Some(c) if !c.moves.is_empty() => {
                return Err(ApiError::Invalid(
                    "collisions: a stream sends its moves in `objects`, not `moves`".into(),
                ))
            }
            Some(c) => Some(collide::plan(&self.entry, c)?),
            None => None,
        };
        let request = match (sources, listeners) {
            (Some(sources), Some(listeners)) => {
                let request = IrRequest {
                    sources,
                    listeners,
                    lod_error_m,
                    options,
                };
                request.check(self.state.limits())?;
                Some(request)
            }
            _ => None,
        };
        // Only a fully valid update changes anything.
        if let Some(r) = request {
            self.pending.request = Some(r);
        }
        for (object, edit) in edits {
            match self.pending.objects.iter_mut().find(|(o, _)| *o == object) {
                Some((_, queued)) => queued.merge(edit),
                None => self.pending.objects.push((object, edit)),
            }
        }
        if collisions.is_some() {
            self.pending.collisions = collisions;
        }
        self.pending.seq = update.seq.or(self.pending.seq);
        self.pending.dirty = self.pending.request.is_some()
            || self.current.is_some()
            || self.pending.collisions.is_some()
            || self.collisions.is_some()
            || !self.pending.objects.is_empty();
        Ok(())
    }

    /// Hands the pending update to the compute pool.
    fn start_job(&mut self, done: mpsc::Sender<JobResult>) {
        let mut pending = std::mem::take(&mut self.pending);
        if let Some(r) = pending.request.take() {
            self.current = Some(r);
        }
        if let Some(c) = pending.collisions.take() {
            self.collisions = Some(c);
        }
        let collisions = self.collisions.clone();
        // Without sources and listeners yet, object moves still apply.
        let request = self.current.clone();
        let Some(mut cache) = self.cache.take() else {
            return;
        };
        let state = self.state.clone();
        let entry = self.entry.clone();
        let cancel = self.cancel.clone();
        let max_beams = cache.max_beams();
        tokio::spawn(async move {
            let job_state = state.clone();
            let job = move || {
                let start = Instant::now();
                // The collision query and the simulation share one limit.
                let deadline = job_state.limits().compute_deadline();
                let result = (|| {
                    let (objects, collisions) = match &collisions {
                        Some(plan) => {
                            let (objects, found) = collide::run(
                                job_state.registry(),
                                &entry,
                                plan,
                                &pending.objects,
                                deadline,
                                Some(&cancel),
                                job_state.limits(),
                            )?;
                            (objects, Some(found))
                        }
                        None if pending.objects.is_empty() => (Vec::new(), None),
                        None => (
                            job_state
                                .registry()
                                .edit_objects(&entry, &pending.objects)?,
                            None,
                        ),
                    };
                    for report in &objects {
                        job_state.metrics().count_update(report.action.as_str());
                    }
                    let (revision, responses) = match &request {
                        Some(r) => {
                            let cache = Some(&mut cache);
                            simulation::run(
                                &entry,
                                r,
                                cache,
                                deadline,
                                Some(&cancel),
                                job_state.limits(),
                                job_state.lod_cache(),
                            )?
                        }
                        None => (entry.read().acoustic.revision(), Vec::new()),
                    };
                    Ok(Computed {
                        seq: pending.seq,
                        revision,
                        compute_ms: start.elapsed().as_secs_f64() * 1e3,
                        objects,
                        collisions,
                        responses,
                    })
                })();
                (cache, result)
            };
            let result = match state.compute().run(job).await {
                Ok(r) => r,
                Err(e) => (BeamCache::with_max_beams(max_beams), Err(e)),
            };
            let _ = done.send(result).await;
        });
    }

    async fn send_answers(
        &mut self,
        socket: &mut WebSocket,
        computed: Computed,
    ) -> Result<(), axum::Error> {
        self.answered = Some(computed.revision);
        if let Some(collisions) = computed.collisions {
            let frame = StreamFrame::Collisions(StreamCollisions {
                seq: computed.seq,
                objects: computed.objects.clone(),
                collisions,
            });
            socket.send(text(&frame)).await?;
            if computed.responses.is_empty() {
                return Ok(());
            }
        }
        if computed.responses.is_empty() {
            let moved = StreamFrame::ObjectsUpdated(ObjectsUpdated {
                seq: computed.seq,
                revision: computed.revision,
                objects: computed.objects,
            });
            return socket.send(text(&moved)).await;
        }
        let metrics = self.state.metrics();
        for response in &computed.responses {
            let answer = StreamFrame::ImpulseResponse(Box::new(StreamAnswer {
                seq: computed.seq,
                revision: computed.revision,
                compute_ms: computed.compute_ms,
                objects: computed.objects.clone(),
                pair: response.into(),
            }));
            socket.send(text(&answer)).await?;
            let samples = simulation::samples_le(response);
            socket.send(Message::Binary(samples.into())).await?;
            metrics.stream_updates.inc();
        }
        if let Some(first) = computed.responses.first() {
            if !first.stats.beams_reused {
                metrics.frusta.inc_by(first.stats.frusta);
            }
        }
        Ok(())
    }
}

async fn send_error(socket: &mut WebSocket, e: &ApiError) -> Result<(), axum::Error> {
    let problem = e.problem();
    socket.send(text(&StreamFrame::Error { problem })).await
}

/// A frame as a text message. Serialising strings, numbers and arrays
/// cannot fail.
fn text(frame: &StreamFrame) -> Message {
    Message::Text(serde_json::to_string(frame).unwrap_or_default().into())
}

fn close(code: u16, reason: &'static str) -> Message {
    Message::Close(Some(CloseFrame {
        code,
        reason: reason.into(),
    }))
}

#[cfg(test)]
#[path = "stream_merge_props.rs"]
mod merge_props;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::routes::test_support::*;

    pub(super) fn stream(server: &TestServer) -> Stream {
        let state = server.state.clone();
        let entry = state.registry().get("box").unwrap();
        let permit = state.streams().clone().try_acquire_owned().unwrap();
        Stream::new(state, Caller { key: None }, entry, permit)
    }

    #[tokio::test]
    async fn queued_object_edits_stay_one_per_object_newest_wins() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let mut stream = stream(&server);
        for i in 0..300 {
            let z = 2.0 + f64::from(i) * 1e-3;
            let update = format!(
                r#"{{"objects": [{{"object": "panel", "vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, {z}], [4, 1, {z}]]}}]}}"#
            );
            stream.merge(&update).unwrap();
        }
        stream
            .merge(r#"{"seq": 9, "objects": [{"object": "panel", "translation": [0, 1, 0]}]}"#)
            .unwrap();
        // A wrong vertex count is refused when it arrives.
        let short = r#"{"seq": 10, "objects": [{"object": "panel", "vertices": [[0, 0, 0]]}]}"#;
        assert!(stream.merge(short).is_err());
        // An update naming no object of the scene changes nothing.
        let ghost = r#"{"seq": 10, "objects": [{"object": "ghost", "translation": [0, 1, 0]}]}"#;
        assert!(stream.merge(ghost).is_err());
        assert_eq!(stream.pending.seq, Some(9));
        assert_eq!(stream.pending.objects.len(), 1);
        // "1" is the panel too.
        stream
            .merge(r#"{"objects": [{"object": "1", "rotation": [0, 0, 0, 1]}]}"#)
            .unwrap();
        assert_eq!(stream.pending.objects.len(), 1);
        let (object, edit) = &stream.pending.objects[0];
        assert_eq!(*object, 1);
        assert_eq!(edit.rotation, Some([0.0, 0.0, 0.0, 1.0]));
        assert_eq!(edit.translation, Some([0.0, 1.0, 0.0]));
        let top = edit.vertices.as_ref().unwrap()[2].z;
        assert!((top - 2.299).abs() < 1e-6, "{top}");
    }

    /// A stream's level-of-detail bound is kept until an update changes
    /// it; a bad one is refused and changes nothing.
    #[tokio::test]
    async fn the_level_of_detail_bound_is_kept_across_updates() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let mut stream = stream(&server);
        let points =
            r#""sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}]"#;
        stream
            .merge(&format!(r#"{{{points}, "lod_error_m": 0.5}}"#))
            .unwrap();
        let bound = |s: &Stream| s.pending.request.as_ref().map(|r| r.lod_error_m);
        assert_eq!(bound(&stream), Some(0.5));
        stream
            .merge(r#"{"listeners": [{"position": [6, 3, 1.2]}]}"#)
            .unwrap();
        assert_eq!(bound(&stream), Some(0.5));
        assert!(stream.merge(r#"{"lod_error_m": -1}"#).is_err());
        assert_eq!(bound(&stream), Some(0.5));
        stream.merge(r#"{"lod_error_m": 0}"#).unwrap();
        assert_eq!(bound(&stream), Some(0.0));
    }

    #[tokio::test]
    async fn an_update_with_one_invalid_edit_changes_no_object() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let registry = server.state.registry();
        let entry = registry.get("box").unwrap();
        let moved = ObjectEdit {
            translation: Some([0.0, 1.0, 0.0]),
            ..Default::default()
        };
        let wrong_count = ObjectEdit {
            vertices: Some(vec![glam::Vec3::ZERO; 3]),
            ..Default::default()
        };
        let e = registry.edit_objects(&entry, &[(1, moved), (1, wrong_count)]);
        assert!(e.is_err());
        assert_eq!(entry.read().acoustic.revision(), 0);
        let server = server.restart();
        let entry = server.state.registry().get("box").unwrap();
        let panel = &entry.read().scene.objects[1];
        assert_eq!(panel.transform.translation, glam::Vec3::ZERO);
    }
}
