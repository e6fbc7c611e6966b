//! `frusta ir --scene-id ID`: the impulse response computed by the server,
//! printed as the offline command prints it.

use std::error::Error;

use serde_json::Value;

use super::{points, segment, Server};
use crate::ir::IrArgs;
use crate::report;

pub fn run(server: &Server, scene_id: &str, args: &IrArgs) -> Result<(), Box<dyn Error>> {
    let sim = &args.simulation;
    let mut body = serde_json::to_value(sim.options())?;
    body["sources"] = points(sim.source);
    body["listeners"] = points(sim.listener);
    let path = format!("/v1/scenes/{}/impulse-responses", segment(scene_id));
    let answer: Value =
        serde_json::from_slice(&server.post_json(&path, &body, "application/json")?)?;
    let response = answer["responses"]
        .get(0)
        .ok_or("the server sent no response")?;
    // The route sends samples only as WAV, in an answer of their own; the
    // simulation is deterministic, so they belong to the paths above unless
    // the scene was edited in between.
    if let Some(out) = &args.out {
        std::fs::write(out, server.post_json(&path, &body, "audio/wav")?)
            .map_err(|e| format!("{}: {e}", out.display()))?;
    }
    report::print(response, args.json, args.out.as_deref())
}
