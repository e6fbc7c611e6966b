//! `frusta ir --scene-id ID`: the impulse response computed by the server,
//! printed as the offline command prints it. With `--out` it is asked on
//! a stream, whose answer carries the samples with the paths: one
//! simulation, where the HTTP route would need a JSON and a WAV request.

use std::error::Error;

use frusta_client::api::impulse_responses::ImpulseResponseRequest;
use frusta_client::api::stream::StreamUpdate;
use frusta_client::Client;
use frusta_engine::acoustics::signal::write_wav;

use crate::ir::IrArgs;
use crate::report;

pub fn run(client: &Client, scene_id: &str, args: &IrArgs) -> Result<(), Box<dyn Error>> {
    let sim = &args.simulation;
    let request = ImpulseResponseRequest {
        lod_error_m: sim.lod_error,
        ..ImpulseResponseRequest::pair(sim.source, sim.listener, sim.options())
    };
    let Some(out) = &args.out else {
        let answer = client.impulse_responses(scene_id, &request)?;
        let response = answer
            .responses
            .first()
            .ok_or("the server sent no response")?;
        return report::print(response, args.json, None);
    };
    let mut stream = client.stream(scene_id)?;
    stream.send(&StreamUpdate {
        seq: Some(0),
        sources: Some(request.sources),
        listeners: Some(request.listeners),
        options: Some(request.options),
        lod_error_m: (request.lod_error_m > 0.0).then_some(request.lod_error_m),
        ..Default::default()
    })?;
    let (answer, samples) = stream.answer_to(0)?;
    stream.close()?;
    write_wav(out, &samples)?;
    report::print(&answer.pair, args.json, Some(out))
}
