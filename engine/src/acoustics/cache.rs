//! [`BeamCache`]: the beams traced from each source of the latest call, so
//! that listeners moving around fixed sources cost a containment test and
//! validation instead of a trace, and so do sources moving within a reach
//! of where their beams were traced (the beams re-mirrored).

use glam::DVec3;

use super::beams::Beams;
use super::tail::{record_tail, trace_tail, TailInput, TailOptions, TailRecord, TracedTail};
use super::tracer::{trace, trace_keeping, TraceInput, TraceOptions};
use super::{AcousticScene, FoundPaths};
use crate::deadline::Deadline;
use crate::Result;

/// Beams per source, valid for one scene state, trace options and
/// material table. Holds the beams traced near the sources of the latest
/// call, each trace of at most [`Self::max_beams`] beams (about 160 bytes
/// each): a trace with more keeps none and is done again next time,
/// unwidened, and after an unwidened one with more, as a one-off trace
/// (see `Keep`).
#[derive(Debug)]
pub struct BeamCache {
    key: Option<Key>,
    /// The beams, where they were traced from, and the last source that
    /// reused them from elsewhere.
    entries: Vec<Entry>,
    max_beams: usize,
    /// How much of a trace is kept, lowered by traces of more than
    /// `max_beams` frusta until the scene or the options change.
    keep: Keep,
    /// Tail walks: what a walk depends on besides the key and the source,
    /// the walk (whose chunks say where they were walked from), and the
    /// call that last took it. Sources whose walk would take the kept ones
    /// past [`Self::max_tail_events`] events in all keep none and are
    /// traced each time.
    tails: Vec<(TailKey, TailRecord, u64)>,
    max_tail_events: usize,
    /// The latest call: its number and its sources.
    call: u64,
    sources: Vec<[u64; 3]>,
}

/// What the cache traces to keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Keep {
    /// Frusta widened for a source moving within the reach.
    Widened,
    /// A widened trace had more than `max_beams` frusta and kept none:
    /// unwidened frusta (they would serve no moving source), which cost
    /// what a one-off trace's do and may fit, for moving listeners.
    Unwidened,
    /// An unwidened trace had too many frusta as well: nothing. Traces are
    /// one-off traces, their last order pruned to the call's listeners.
    Nothing,
}

#[derive(Debug)]
struct Entry {
    at: DVec3,
    /// The source that last reused these beams from another position:
    /// asked again from there, it has stopped, and is traced where it is.
    reused_by: Option<[u64; 3]>,
    beams: Beams,
    /// The reach they were traced for ([`TraceInput::apex_reach`]): they
    /// serve no source farther away.
    reach: f64,
}

/// What a tail's walk depends on beyond the scene state and the trace
/// options (its exact order and bands).
#[derive(Clone, Debug, PartialEq)]
struct TailKey {
    options: TailOptions,
    speed_of_sound: u64,
}

/// About 80 MB of beams per source.
pub const DEFAULT_MAX_BEAMS: usize = 500_000;

/// About 64 MiB of tail events over all sources of a call (hall-10k's
/// default tail walk has about 0.8 million): a stream of many sources
/// keeps the walks that fit and traces the others each time.
pub const DEFAULT_MAX_TAIL_EVENTS: usize = 1 << 20;

impl Default for BeamCache {
    fn default() -> Self {
        Self::with_max_beams(DEFAULT_MAX_BEAMS)
    }
}

/// Everything beams depend on besides the source: the scene's state
/// (geometry and materials, whose absorption decides where the energy
/// threshold stops tracing) and the options.
#[derive(Debug, PartialEq)]
struct Key {
    state: u64,
    options: TraceOptions,
}

fn bits(p: DVec3) -> [u64; 3] {
    p.to_array().map(f64::to_bits)
}

/// Whether `at` is `source`, or within `reach` of it.
fn near(at: DVec3, source: DVec3, reach: f64) -> bool {
    bits(at) == bits(source) || at.distance(source) <= reach
}

impl BeamCache {
    pub fn with_max_beams(max_beams: usize) -> Self {
        Self {
            key: None,
            entries: Vec::new(),
            max_beams,
            keep: Keep::Widened,
            tails: Vec::new(),
            max_tail_events: DEFAULT_MAX_TAIL_EVENTS,
            call: 0,
            sources: Vec::new(),
        }
    }

    pub fn max_beams(&self) -> usize {
        self.max_beams
    }

    /// Prepares a call from `sources`: forgets everything when the scene,
    /// the options or the materials changed, and the beams traced farther
    /// than `reach` from every source (beams at a source's very position
    /// are kept whatever the reach).
    pub(crate) fn retain(
        &mut self,
        scene: &AcousticScene,
        options: &TraceOptions,
        sources: &[DVec3],
        reach: f64,
    ) {
        let stale = self
            .key
            .as_ref()
            .is_none_or(|k| k.state != scene.state() || k.options != *options);
        if stale {
            self.entries.clear();
            self.keep = Keep::Widened;
            self.tails.clear();
            self.key = Some(Key {
                state: scene.state(),
                options: options.clone(),
            });
        }
        self.call += 1;
        self.sources = sources.iter().map(|&s| bits(s)).collect();
        self.entries.retain(|e| {
            let reach = e.reach.min(reach);
            sources.iter().any(|&s| near(e.at, s, reach))
        });
        self.tails.retain(|(_, record, _)| {
            record
                .sources()
                .iter()
                .any(|&at| sources.iter().any(|&s| near(at, s, reach)))
        });
    }

    /// The most events the kept tail walks may hold together.
    pub fn max_tail_events(&self) -> usize {
        self.max_tail_events
    }

    /// This cache, keeping tail walks of at most `max_events` events in all.
    pub fn with_max_tail_events(mut self, max_events: usize) -> Self {
        self.max_tail_events = max_events;
        self
    }

    /// The late reverberation of `source` at `listeners` from a kept walk
    /// with chunks that started within `reach` of it, walked and kept
    /// first when there is none. A kept walk's chunks from elsewhere (a
    /// source that moved) are walked again from `source` first: every
    /// one that started beyond the reach, and else the one that started
    /// farthest. A source moving steadily renews a few eighths of its
    /// rays per call and never all at once; once it stops, its tail is
    /// the one a walk from there gives, to the bit. Call
    /// [`Self::retain`] first.
    pub(crate) fn tail(
        &mut self,
        scene: &AcousticScene,
        source: DVec3,
        listeners: &[DVec3],
        input: &TailInput,
        reach: f64,
        deadline: &Deadline,
    ) -> Result<TracedTail> {
        let start = std::time::Instant::now();
        let key = TailKey {
            options: input.options.clone(),
            speed_of_sound: input.speed_of_sound.to_bits(),
        };
        // One call has one set of tail options: walks made with others
        // only take room.
        self.tails.retain(|t| t.0 == key);
        let offset = |record: &TailRecord| {
            record
                .sources()
                .iter()
                .map(|at| at.distance(source))
                .fold(0.0, f64::max)
        };
        let kept = self
            .tails
            .iter()
            .enumerate()
            // A walk another source of this call took is not shared: the
            // two would walk its chunks back and forth for ever.
            .filter(|(_, (_, record, call))| {
                *call != self.call && record.sources().iter().any(|&at| near(at, source, reach))
            })
            .min_by(|a, b| offset(&a.1 .1).total_cmp(&offset(&b.1 .1)))
            .map(|(i, _)| i);
        let held = |tails: &[(TailKey, TailRecord, u64)], except: Option<usize>| -> usize {
            tails
                .iter()
                .enumerate()
                .filter(|&(i, _)| Some(i) != except)
                .map(|(_, t)| t.1.events())
                .sum()
        };
        let i = match kept {
            Some(i) => {
                let room = self
                    .max_tail_events
                    .saturating_sub(held(&self.tails, Some(i)));
                self.tails[i].2 = self.call;
                let record = &mut self.tails[i].1;
                let starts = record.sources();
                let mut renew: Vec<usize> = (0..starts.len())
                    .filter(|&c| !near(starts[c], source, reach))
                    .collect();
                if renew.is_empty() {
                    renew.extend(
                        (0..starts.len())
                            .filter(|&c| bits(starts[c]) != bits(source))
                            .max_by(|&a, &b| {
                                starts[a]
                                    .distance(source)
                                    .total_cmp(&starts[b].distance(source))
                            }),
                    );
                }
                let mut renewed = true;
                for chunk in renew {
                    renewed &= record.rewalk(chunk, scene, source, input, room, deadline)?;
                    if !renewed {
                        break;
                    }
                }
                if renewed {
                    Some(i)
                } else {
                    self.tails.remove(i);
                    None
                }
            }
            None => {
                let room = self.max_tail_events.saturating_sub(held(&self.tails, None));
                record_tail(scene, source, input, room, deadline)?.map(|record| {
                    self.tails.push((key, record, self.call));
                    self.tails.len() - 1
                })
            }
        };
        let mut traced = match i {
            Some(i) => {
                let record = &self.tails[i].1;
                let mut traced = record.replay(scene, listeners, input, deadline)?;
                traced.stats.walk_reused = kept.is_some();
                traced.stats.walk_offset_m = offset(record);
                traced
            }
            None => trace_tail(scene, source, listeners, input, deadline)?,
        };
        // The walk's time too, when this call walked.
        traced.stats.trace_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(traced)
    }

    /// [`AcousticScene::find_paths`] from the kept beams traced at
    /// `source`, or else the nearest within `reach` of it (re-mirrored for
    /// the move: [`Beams::proposals_moved`]), traced and kept first when
    /// there are none or when the source asks again from where it last
    /// reused them (it has stopped: traced there, it misses nothing); and,
    /// when kept beams answered, how far from `source` they were traced.
    /// Call [`Self::retain`] first.
    pub(crate) fn find_paths(
        &mut self,
        scene: &AcousticScene,
        source: DVec3,
        listeners: &[DVec3],
        options: &TraceOptions,
        reach: f64,
        deadline: &Deadline,
    ) -> Result<(FoundPaths, Option<f64>)> {
        let key = bits(source);
        let kept = match self.entries.iter().position(|e| bits(e.at) == key) {
            Some(i) => Some(i),
            None => {
                let nearest = self
                    .entries
                    .iter()
                    .enumerate()
                    .map(|(i, e)| (i, e.at.distance(source), e.reach))
                    .filter(|&(_, d, traced)| d <= reach.min(traced))
                    .map(|(i, d, _)| (i, d))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|(i, _)| i);
                match nearest {
                    Some(i) if self.entries[i].reused_by == Some(key) => {
                        // Stopped: the old beams go unless another source
                        // of this call stands on them.
                        if !self.sources.contains(&bits(self.entries[i].at)) {
                            self.entries.remove(i);
                        }
                        None
                    }
                    Some(i) => {
                        self.entries[i].reused_by = Some(key);
                        Some(i)
                    }
                    None => None,
                }
            }
        };
        let (proposals, stats, offset) = match kept {
            Some(i) => {
                let Entry { at, beams, .. } = &self.entries[i];
                let moved = source - *at;
                let moves = if moved == DVec3::ZERO {
                    Vec::new()
                } else {
                    beams.apex_moves(moved, scene.surfaces())
                };
                let proposals = beams.proposals_moved(listeners, &moves);
                let mut stats = beams.stats();
                stats.proposals = proposals.iter().map(|p| p.len() as u64).sum();
                (proposals, stats, Some(moved.length()))
            }
            None if self.keep == Keep::Nothing => {
                let input = scene.trace_input(source);
                let (proposals, stats) = trace(&input, listeners, options, deadline)?;
                (proposals, stats, None)
            }
            None => {
                let reach = if self.keep == Keep::Widened {
                    reach
                } else {
                    0.0
                };
                let input = TraceInput {
                    apex_reach: reach,
                    ..scene.trace_input(source)
                };
                let (proposals, stats, beams) =
                    trace_keeping(&input, listeners, options, deadline, self.max_beams)?;
                if beams.is_none() {
                    self.keep = if reach > 0.0 {
                        Keep::Unwidened
                    } else {
                        Keep::Nothing
                    };
                }
                if let Some(beams) = beams {
                    self.entries.push(Entry {
                        at: source,
                        reused_by: None,
                        beams,
                        reach,
                    });
                }
                (proposals, stats, None)
            }
        };
        let paths = scene.validate_proposals(source, listeners, proposals, deadline)?;
        Ok((FoundPaths { paths, stats }, offset))
    }
}
