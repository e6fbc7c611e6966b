//! One soak client: a thread with its own keep-alive connection looping
//! over a seeded random mix of uploads, deletes, edits, impulse responses,
//! queries and streams until the deadline. Each client changes only the
//! scenes it uploaded (at most [`MAX_OWN`] at a time, the oldest deleted
//! first), so every request it sends is valid and any refusal other than
//! backpressure is the server's fault.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use frusta_client::api::impulse_responses::ImpulseResponseRequest;
use glam::Vec3;

use super::scenes::{self, Own};
use super::tally::{ms_since, Outcome, Progress, Tally};
use crate::rays::SplitMix64;
use crate::serve::{Options, Points};

/// Scenes one client holds at once: 64 clients keep at most 192 small
/// scenes (about 10k triangles) on the server.
const MAX_OWN: usize = 3;

/// A request's method and body.
#[derive(Clone, Copy)]
enum Req<'b> {
    Delete,
    Post(&'static str, &'b [u8]),
    Patch(&'static str, &'b [u8]),
}

pub struct Client<'a> {
    /// One keep-alive connection.
    pub(super) agent: frusta_client::Client,
    index: usize,
    pub(super) rng: SplitMix64,
    uploads: usize,
    pub(super) own: Vec<Own>,
    /// The bundled scene every client queries (never edits).
    pub(super) shoebox: Points,
    pub(super) end: Instant,
    stop: &'a AtomicBool,
    pub(super) progress: &'a Progress,
    pub(super) tally: Tally,
}

impl<'a> Client<'a> {
    pub fn new(
        agent: frusta_client::Client,
        index: usize,
        end: Instant,
        stop: &'a AtomicBool,
        progress: &'a Progress,
    ) -> Self {
        Self {
            agent,
            index,
            rng: SplitMix64::new(0x50AC_0000 ^ index as u64),
            uploads: 0,
            own: Vec::new(),
            shoebox: Points::of("shoebox"),
            end,
            stop,
            progress,
            tally: Tally::default(),
        }
    }

    /// Loops until the deadline (or until the server is gone), then
    /// deletes what it still holds, so the scene count at the end shows
    /// whether every delete freed its scene.
    pub fn run(mut self) -> Tally {
        while Instant::now() < self.end && !self.stopped() {
            self.step();
        }
        while let Some(scene) = self.own.pop() {
            if self.stopped() {
                break;
            }
            self.delete(scene);
        }
        self.tally
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// One action, drawn by weight (per cent); queries and impulse
    /// responses dominate, as they would in use.
    fn step(&mut self) {
        if self.own.is_empty() {
            return self.upload();
        }
        match self.below(100) {
            0..8 => {
                if self.own.len() >= MAX_OWN {
                    let oldest = self.own.remove(0);
                    self.delete(oldest);
                }
                self.upload();
            }
            8..11 => {
                let i = self.below(self.own.len());
                let scene = self.own.swap_remove(i);
                self.delete(scene);
            }
            11..23 => self.move_object(),
            23..35 => self.vertices(),
            35..41 => self.materials(),
            41..61 => self.impulse_response(),
            61..74 => self.rays(),
            74..87 => self.occlusion(),
            _ => self.stream(),
        }
    }

    pub(super) fn below(&mut self, n: usize) -> usize {
        (self.rng.next_u64() % n as u64) as usize
    }

    /// Uniform in `[-1, 1)`.
    pub(super) fn signed(&mut self) -> f32 {
        2.0 * self.rng.next_f32() - 1.0
    }

    /// Simulation options small enough to keep the soak about the service.
    pub(super) fn options(&mut self) -> Options {
        let cells = ["conservative", "sampled"][self.below(2)];
        Options {
            max_order: 2,
            sampling: 4,
            cells: cells.into(),
            sample_rate: 16_000,
            // One request in four with the late reverberation.
            tail: self.below(4) == 0,
        }
    }

    /// A scene to query: one of this client's own (its index), or one
    /// time in four the shared shoebox (`None`).
    pub(super) fn pick(&mut self) -> Option<usize> {
        let i = self.below(self.own.len() + self.own.len().div_ceil(3));
        (i < self.own.len()).then_some(i)
    }

    pub(super) fn id(&self, at: Option<usize>) -> String {
        at.map_or_else(|| "shoebox".into(), |i| self.own[i].id.clone())
    }

    /// Within half a metre of the scene's source.
    pub(super) fn source(&mut self, at: Option<usize>) -> Vec3 {
        let t = Vec3::new(
            self.rng.next_f32(),
            self.rng.next_f32(),
            self.rng.next_f32(),
        );
        let points = at.map_or(&self.shoebox, |i| &self.own[i].points);
        points.source + 0.5 * (t - 0.5)
    }

    pub(super) fn listener(&mut self, at: Option<usize>) -> Vec3 {
        let points = at.map_or(&self.shoebox, |i| &self.own[i].points);
        points.random_listener(&mut self.rng)
    }

    /// Sends one request and counts its answer under `kind`; whether it
    /// succeeded. Backpressure waits as long as the server asked.
    fn request(&mut self, kind: &'static str, path: &str, req: Req<'_>) -> bool {
        let t = Instant::now();
        let (method, answer) = match req {
            Req::Delete => ("DELETE", self.agent.delete(path)),
            Req::Post(media, body) => ("POST", self.agent.post(path, media, body)),
            Req::Patch(media, body) => ("PATCH", self.agent.patch(path, media, body)),
        };
        let ms = ms_since(t);
        let outcome = match answer {
            Ok(a) => Outcome::of(a.status, a.retry_after.as_deref(), &a.body),
            Err(e) => Outcome::Unexpected(format!("transport: {e}")),
        };
        let what = || format!("{method} {path} {}", describe(req));
        self.record(kind, what, ms, &outcome);
        matches!(outcome, Outcome::Ok)
    }

    /// Counts an answer; after backpressure, sleeps the `Retry-After` (at
    /// most until the deadline).
    pub(super) fn record(
        &mut self,
        kind: &'static str,
        what: impl FnOnce() -> String,
        ms: f64,
        outcome: &Outcome,
    ) {
        let what = match outcome {
            Outcome::Unexpected(_) => what(),
            _ => String::new(),
        };
        self.tally.record(self.progress, kind, &what, ms, outcome);
        if let Outcome::Backpressure(after) = outcome {
            let left = self.end.saturating_duration_since(Instant::now());
            std::thread::sleep((*after).min(left));
        }
    }

    fn upload(&mut self) {
        self.uploads += 1;
        let id = format!("soak-{}-{}", self.index, self.uploads);
        // One upload in four is an OBJ mesh, the rest scene documents.
        let json = self.below(4) != 0;
        let (kind, path, media, body, points) = if json {
            let (doc, points) = scenes::json_room(&mut self.rng);
            let path = format!("/v1/scenes?id={id}");
            ("upload_json", path, "application/json", doc, points)
        } else {
            let path = format!("/v1/scenes?id={id}&object=room");
            let body = scenes::OBJ_ROOM.to_string();
            ("upload_obj", path, "model/obj", body, Points::of("shoebox"))
        };
        if self.request(kind, &path, Req::Post(media, body.as_bytes())) {
            self.own.push(Own { id, json, points });
        }
    }

    fn delete(&mut self, scene: Own) {
        let path = format!("/v1/scenes/{}", scene.id);
        self.request("delete", &path, Req::Delete);
    }

    /// A small translation and/or rotation about z of the door (or the
    /// OBJ room): a transform update, no refit.
    fn move_object(&mut self) {
        let i = self.below(self.own.len());
        let path = format!(
            "/v1/scenes/{}/objects/{}",
            self.own[i].id,
            self.own[i].object()
        );
        let half = (2.0 * self.signed()).to_radians() / 2.0;
        let mut edit = serde_json::json!({});
        match self.below(3) {
            0 => edit["translation"] = serde_json::json!([0.0, 0.3 * self.signed(), 0.0]),
            1 => edit["rotation"] = serde_json::json!([0.0, 0.0, half.sin(), half.cos()]),
            _ => {
                edit["translation"] = serde_json::json!([0.1 * self.signed(), 0.0, 0.0]);
                edit["rotation"] = serde_json::json!([0.0, 0.0, half.sin(), half.cos()]);
            }
        }
        let body = edit.to_string();
        self.request(
            "object_transform",
            &path,
            Req::Patch("application/json", body.as_bytes()),
        );
    }

    /// New door vertices (a refit), as JSON or as binary f32; on a
    /// client holding only OBJ rooms, a transform instead.
    fn vertices(&mut self) {
        let doors: Vec<usize> = (0..self.own.len()).filter(|&i| self.own[i].json).collect();
        if doors.is_empty() {
            return self.move_object();
        }
        let i = doors[self.below(doors.len())];
        let path = format!("/v1/scenes/{}/objects/door", self.own[i].id);
        let door = scenes::door_edit(&mut self.rng);
        if self.below(2) == 0 {
            let body = serde_json::json!({ "vertices": door }).to_string();
            let req = Req::Patch("application/json", body.as_bytes());
            self.request("vertices_json", &path, req);
        } else {
            let body = scenes::le_bytes(&door);
            let req = Req::Patch("application/octet-stream", &body);
            self.request("vertices_binary", &path, req);
        }
    }

    fn materials(&mut self) {
        let i = self.below(self.own.len());
        let path = format!("/v1/scenes/{}/materials", self.own[i].id);
        let absorption = 0.1 + 0.5 * self.rng.next_f32();
        let body = serde_json::json!({ "materials": { "walls": { "absorption": absorption } } });
        let body = body.to_string();
        self.request(
            "materials",
            &path,
            Req::Patch("application/json", body.as_bytes()),
        );
    }

    fn impulse_response(&mut self) {
        let at = self.pick();
        let (id, source, listener) = (self.id(at), self.source(at), self.listener(at));
        let request = ImpulseResponseRequest::pair(source, listener, self.options().simulation());
        let body = serde_json::to_string(&request).expect("a request serializes");
        let path = format!("/v1/scenes/{id}/impulse-responses");
        let kind = if id == "shoebox" {
            "ir_shoebox"
        } else {
            "ir_own"
        };
        self.request(kind, &path, Req::Post("application/json", body.as_bytes()));
    }

    /// 1-32 rays from about the source in random directions.
    fn rays(&mut self) {
        let at = self.pick();
        let (id, source) = (self.id(at), self.source(at));
        let rays: Vec<_> = (0..1 + self.below(32))
            .map(|_| {
                let direction = self.direction();
                serde_json::json!({ "origin": source.to_array(), "direction": direction.to_array() })
            })
            .collect();
        let mode = ["closest", "any"][self.below(2)];
        let body = serde_json::json!({ "rays": rays, "mode": mode }).to_string();
        let path = format!("/v1/scenes/{id}/rays");
        self.request(
            "rays",
            &path,
            Req::Post("application/json", body.as_bytes()),
        );
    }

    /// A direction in the unit cube, never near zero (which is invalid).
    fn direction(&mut self) -> Vec3 {
        loop {
            let d = Vec3::new(self.signed(), self.signed(), self.signed());
            if d.length() > 0.1 {
                return d;
            }
        }
    }

    /// 1-16 source-listener pairs.
    fn occlusion(&mut self) {
        let at = self.pick();
        let (id, source) = (self.id(at), self.source(at));
        let pairs: Vec<_> = (0..1 + self.below(16))
            .map(|_| {
                let to = self.listener(at);
                serde_json::json!({ "from": source.to_array(), "to": to.to_array() })
            })
            .collect();
        let body = serde_json::json!({ "pairs": pairs }).to_string();
        let path = format!("/v1/scenes/{id}/occlusion");
        self.request(
            "occlusion",
            &path,
            Req::Post("application/json", body.as_bytes()),
        );
    }
}

/// A request body for an error report: text as sent (cut at 300
/// characters), binary by its length.
fn describe(req: Req<'_>) -> String {
    match req {
        Req::Delete => String::new(),
        Req::Post(media, body) | Req::Patch(media, body) => match std::str::from_utf8(body) {
            Ok(text) if media != "application/octet-stream" => text.chars().take(300).collect(),
            _ => format!("<{} bytes of {media}>", body.len()),
        },
    }
}
