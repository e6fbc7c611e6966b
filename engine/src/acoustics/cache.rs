//! [`BeamCache`]: the beams traced from each source of the latest call, so
//! that listeners moving around fixed sources cost a containment test and
//! validation instead of a trace.

use glam::DVec3;

use super::beams::Beams;
use super::deadline::Deadline;
use super::tracer::{trace_beams, TraceOptions};
use super::{AcousticScene, FoundPaths};
use crate::scene::Material;
use crate::Result;

/// Beams per source, valid for one scene revision, trace options and
/// material table. Holds only the sources of the latest call, so memory is
/// bounded by what one call needs (about 160 bytes per traced frustum).
#[derive(Debug, Default)]
pub struct BeamCache {
    key: Option<Key>,
    /// Source position (exact bits) and its beams.
    entries: Vec<([u64; 3], Beams)>,
}

/// Everything beams depend on besides the source. Materials are compared
/// too: they are a public field, changed without a revision, and their
/// absorption decides where the energy threshold stops tracing.
#[derive(Debug, PartialEq)]
struct Key {
    revision: u64,
    options: TraceOptions,
    materials: Vec<Material>,
}

fn bits(p: DVec3) -> [u64; 3] {
    p.to_array().map(f64::to_bits)
}

impl BeamCache {
    /// Prepares a call from `sources`: forgets everything when the scene,
    /// the options or the materials changed, and the beams of any source
    /// not among `sources`.
    pub(crate) fn retain(
        &mut self,
        scene: &AcousticScene,
        options: &TraceOptions,
        sources: &[DVec3],
    ) {
        let stale = self.key.as_ref().is_none_or(|k| {
            k.revision != scene.revision()
                || k.options != *options
                || k.materials != scene.materials
        });
        if stale {
            self.entries.clear();
            self.key = Some(Key {
                revision: scene.revision(),
                options: options.clone(),
                materials: scene.materials.clone(),
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
        let (index, reused) = match kept {
            Some(i) => (i, true),
            None => {
                let beams = trace_beams(&scene.trace_input(source), options, deadline)?;
                self.entries.push((key, beams));
                (self.entries.len() - 1, false)
            }
        };
        let beams = &self.entries[index].1;
        let proposals = beams.proposals(listeners);
        let mut stats = beams.stats();
        stats.proposals = proposals.iter().map(|p| p.len() as u64).sum();
        let paths = scene.validate_proposals(source, listeners, proposals, deadline)?;
        Ok((FoundPaths { paths, stats }, reused))
    }
}
