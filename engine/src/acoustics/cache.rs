//! [`BeamCache`]: the beams traced from each source of the latest call, so
//! that listeners moving around fixed sources cost a containment test and
//! validation instead of a trace.

use glam::DVec3;

use super::beams::Beams;
use super::tracer::{trace_keeping, TraceOptions};
use super::{AcousticScene, FoundPaths};
use crate::deadline::Deadline;
use crate::Result;

/// Beams per source, valid for one scene state, trace options and
/// material table. Holds only the sources of the latest call, and at most
/// [`Self::max_beams`] beams per source (about 160 bytes each): a trace
/// with more keeps none and is simply done again next time.
#[derive(Debug)]
pub struct BeamCache {
    key: Option<Key>,
    /// Source position (exact bits) and its beams.
    entries: Vec<([u64; 3], Beams)>,
    max_beams: usize,
}

/// About 80 MB of beams per source.
pub const DEFAULT_MAX_BEAMS: usize = 500_000;

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

impl BeamCache {
    pub fn with_max_beams(max_beams: usize) -> Self {
        Self {
            key: None,
            entries: Vec::new(),
            max_beams,
        }
    }

    pub fn max_beams(&self) -> usize {
        self.max_beams
    }

    /// Prepares a call from `sources`: forgets everything when the scene,
    /// the options or the materials changed, and the beams of any source
    /// not among `sources`.
    pub(crate) fn retain(
        &mut self,
        scene: &AcousticScene,
        options: &TraceOptions,
        sources: &[DVec3],
    ) {
        let stale = self
            .key
            .as_ref()
            .is_none_or(|k| k.state != scene.state() || k.options != *options);
        if stale {
            self.entries.clear();
            self.key = Some(Key {
                state: scene.state(),
                options: options.clone(),
            });
        }
        let wanted: Vec<[u64; 3]> = sources.iter().map(|&s| bits(s)).collect();
        self.entries.retain(|(key, _)| wanted.contains(key));
    }

    /// [`AcousticScene::find_paths`] from the kept beams of `source`, traced
    /// first when there are none; and whether they were kept. Call
    /// [`Self::retain`] first.
    pub(crate) fn find_paths(
        &mut self,
        scene: &AcousticScene,
        source: DVec3,
        listeners: &[DVec3],
        options: &TraceOptions,
        deadline: &Deadline,
    ) -> Result<(FoundPaths, bool)> {
        let key = bits(source);
        let kept = self.entries.iter().position(|(k, _)| *k == key);
        let (proposals, stats, reused) = match kept {
            Some(i) => {
                let beams = &self.entries[i].1;
                let proposals = beams.proposals(listeners);
                let mut stats = beams.stats();
                stats.proposals = proposals.iter().map(|p| p.len() as u64).sum();
                (proposals, stats, true)
            }
            None => {
                let input = scene.trace_input(source);
                let (proposals, stats, beams) =
                    trace_keeping(&input, listeners, options, deadline, self.max_beams)?;
                if let Some(beams) = beams {
                    self.entries.push((key, beams));
                }
                (proposals, stats, false)
            }
        };
        let paths = scene.validate_proposals(source, listeners, proposals, deadline)?;
        Ok((FoundPaths { paths, stats }, reused))
    }
}
