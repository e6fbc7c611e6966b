//! `GET /v1/scenes/{id}/stream`: one WebSocket, [`StreamUpdate`]s out,
//! typed frames in, each impulse response read together with the binary
//! frame of samples that follows it.

use std::net::TcpStream;

use frusta_api::stream::{
    ObjectsUpdated, StreamAnswer, StreamCollisions, StreamFrame, StreamUpdate,
};
use frusta_api::Problem;
use frusta_engine::acoustics::signal::ImpulseResponse;
use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

use crate::http::{encode, Answer};
use crate::{Client, Error};

/// An open stream on one scene.
pub struct Stream {
    socket: WebSocket<MaybeTlsStream<TcpStream>>,
}

/// What the server sent.
#[derive(Debug)]
pub enum Received {
    /// One source-listener pair and its samples.
    ImpulseResponse {
        answer: Box<StreamAnswer>,
        samples: ImpulseResponse,
    },
    ObjectsUpdated(ObjectsUpdated),
    /// The collision subscription's answer.
    Collisions(Box<StreamCollisions>),
    /// A refused update; the stream stays open.
    Error(Problem),
    /// The server's Close frame: 1000 when the scene was deleted, 1001 when
    /// the server shuts down.
    Closed {
        code: Option<u16>,
        reason: String,
    },
}

impl Client {
    /// Opens the scene's stream: `ws://` for `http://`, `wss://` for
    /// `https://`. A refused upgrade is an [`Error::Status`], as an HTTP
    /// error is.
    pub fn stream(&self, id: &str) -> Result<Stream, Error> {
        let url = format!(
            "ws{}/v1/scenes/{}/stream",
            self.base().trim_start_matches("http"),
            encode(id)
        );
        let mut request = url.as_str().into_client_request()?;
        if let Some(bearer) = self.bearer() {
            let value = bearer.parse().map_err(|_| Error::Url(url.clone()))?;
            request.headers_mut().insert("authorization", value);
        }
        let socket = match tungstenite::connect(request) {
            Ok((socket, _)) => socket,
            Err(tungstenite::Error::Http(response)) => {
                let header = |name: &str| {
                    let value = response.headers().get(name)?.to_str().ok();
                    value.map(str::to_owned)
                };
                return Err(Error::Status(Box::new(Answer {
                    status: response.status().as_u16(),
                    content_type: header("content-type").unwrap_or_default(),
                    retry_after: header("retry-after"),
                    body: response.body().clone().unwrap_or_default(),
                })));
            }
            Err(e) => {
                return Err(Error::Transport {
                    url,
                    message: e.to_string(),
                })
            }
        };
        if let MaybeTlsStream::Plain(tcp) = socket.get_ref() {
            // Updates are small frames: send each at once.
            tcp.set_nodelay(true).map_err(tungstenite::Error::Io)?;
            tcp.set_read_timeout(self.config().timeout)
                .map_err(tungstenite::Error::Io)?;
        }
        Ok(Stream { socket })
    }
}

impl Stream {
    pub fn send(&mut self, update: &StreamUpdate) -> Result<(), Error> {
        let text = serde_json::to_string(update)?;
        self.socket.send(Message::text(text))?;
        Ok(())
    }

    /// The next frame, an impulse response with its samples.
    pub fn read(&mut self) -> Result<Received, Error> {
        loop {
            let text = match self.socket.read()? {
                Message::Text(text) => text,
                Message::Close(frame) => {
                    return Ok(Received::Closed {
                        code: frame.as_ref().map(|f| u16::from(f.code)),
                        reason: frame.map(|f| f.reason.to_string()).unwrap_or_default(),
                    })
                }
                Message::Binary(_) => {
                    return Err(Error::Protocol("samples without their answer".into()))
                }
                _ => continue,
            };
            return Ok(match serde_json::from_str(&text)? {
                StreamFrame::ImpulseResponse(answer) => {
                    let samples = self.samples(&answer)?;
                    Received::ImpulseResponse { answer, samples }
                }
                StreamFrame::ObjectsUpdated(updated) => Received::ObjectsUpdated(updated),
                StreamFrame::Collisions(found) => Received::Collisions(Box::new(found)),
                StreamFrame::Error { problem } => Received::Error(problem),
            });
        }
    }

    /// Reads until the answer to update `seq`, skipping answers to older
    /// updates (and to others' edits of the scene). An error frame is
    /// [`Error::Frame`]; a Close ends it too.
    pub fn answer_to(&mut self, seq: u64) -> Result<(StreamAnswer, ImpulseResponse), Error> {
        loop {
            match self.read()? {
                Received::ImpulseResponse { answer, samples } if answer.seq == Some(seq) => {
                    return Ok((*answer, samples))
                }
                Received::ImpulseResponse { .. }
                | Received::ObjectsUpdated(_)
                | Received::Collisions(_) => {}
                Received::Error(problem) => return Err(Error::Frame(problem)),
                Received::Closed { reason, .. } => {
                    return Err(Error::Protocol(format!(
                        "the server closed the stream: {reason}"
                    )))
                }
            }
        }
    }

    /// Reads until the collisions answering update `seq`, skipping other
    /// frames, as [`answer_to`](Self::answer_to) does.
    pub fn collisions_for(&mut self, seq: u64) -> Result<StreamCollisions, Error> {
        loop {
            match self.read()? {
                Received::Collisions(found) if found.seq == Some(seq) => return Ok(*found),
                Received::Error(problem) => return Err(Error::Frame(problem)),
                Received::Closed { reason, .. } => {
                    return Err(Error::Protocol(format!(
                        "the server closed the stream: {reason}"
                    )))
                }
                _ => {}
            }
        }
    }

    /// Closes with the handshake: sends Close, then reads what is still in
    /// flight until the server's Close ends the connection.
    pub fn close(mut self) -> Result<(), Error> {
        self.socket.close(None)?;
        loop {
            match self.socket.read() {
                Ok(_) => {}
                Err(tungstenite::Error::ConnectionClosed) => return Ok(()),
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// The binary frame after `answer`: interleaved little-endian f32.
    fn samples(&mut self, answer: &StreamAnswer) -> Result<ImpulseResponse, Error> {
        let Message::Binary(bytes) = self.socket.read()? else {
            return Err(Error::Protocol(
                "the answer's samples did not follow it".into(),
            ));
        };
        let pair = &answer.pair;
        let expected = pair.frames * pair.channels * 4;
        if bytes.len() != expected {
            return Err(Error::Protocol(format!(
                "expected {expected} bytes of samples, got {}",
                bytes.len()
            )));
        }
        let mut channels = vec![Vec::with_capacity(pair.frames); pair.channels];
        for (i, c) in bytes.chunks_exact(4).enumerate() {
            let sample = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            channels[i % pair.channels].push(sample);
        }
        Ok(ImpulseResponse {
            sample_rate: pair.sample_rate,
            channels,
        })
    }
}
