//! The traced beam tree of one source: every frustum of order >= 1 with its
//! event sequence, so that any listener set can be answered without tracing
//! again. Frusta depend on the source, the scene and the trace options, not
//! on the listeners: a listener moving around a fixed source only needs the
//! containment test.
//!
//! Layout: beams are structure-of-arrays. The test record (apex, window
//! matrix, near plane: 152 bytes, against 216 for a whole frustum) is what
//! the scan over all beams streams through; the index of a beam's last
//! event is read only for the few beams that contain a listener. Event
//! sequences share prefixes in one `(parent, event)` arena (8 bytes per
//! beam), as during tracing, and are materialised only for proposals: no
//! allocation per beam.

use glam::DVec3;

use super::frustum::{Containment, Frustum};
use super::path::Event;
use super::surfaces::Surfaces;
use super::tracer::{events_of, TraceStats, Visit, LISTENER_MARGIN};

#[derive(Clone, Debug, Default)]
pub struct Beams {
    /// Per beam, in trace order.
    tests: Vec<Containment>,
    /// Per beam, its last event in `history`.
    last_event: Vec<u32>,
    history: Vec<(u32, Event)>,
    stats: TraceStats,
}

impl Visit for Beams {
    fn visit(&mut self, frustum: &Frustum, _history: &[(u32, Event)], at: u32) {
        self.tests.push(frustum.containment());
        self.last_event.push(at);
    }
}

/// Beams per parallel task of [`Beams::proposals`]: large enough to hide the
/// task's cost, small enough to spread a few thousand beams over the cores.
const CHUNK: usize = 1024;

impl Beams {
    /// One tracing task's beams, with its history arena and counters.
    pub(crate) fn part(mut beams: Beams, history: Vec<(u32, Event)>, stats: TraceStats) -> Self {
        beams.history = history;
        beams.stats = stats;
        beams
    }

    /// Joins the beams of the tracing tasks, in task order.
    pub(crate) fn concat(parts: Vec<Beams>) -> Self {
        let mut out = Beams::default();
        for part in parts {
            let offset = out.history.len() as u32;
            let shift = |i: u32| if i == u32::MAX { i } else { i + offset };
            out.tests.extend(part.tests);
            out.last_event
                .extend(part.last_event.into_iter().map(shift));
            out.history.extend(
                part.history
                    .into_iter()
                    .map(|(parent, e)| (shift(parent), e)),
            );
            out.stats = out.stats.add(part.stats);
        }
        out
    }

    /// Counters of the trace that produced these beams (`proposals` is 0:
    /// it depends on the listeners).
    pub fn stats(&self) -> TraceStats {
        self.stats
    }

    /// Beams kept (frusta of order >= 1).
    pub fn len(&self) -> usize {
        self.tests.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tests.is_empty()
    }

    /// Per listener, the event sequences of every beam containing it: the
    /// proposals tracing with these listeners gives, in the same order.
    pub fn proposals(&self, listeners: &[DVec3]) -> Vec<Vec<Vec<Event>>> {
        self.proposals_moved(listeners, &[])
    }

    /// How far each history entry's frustum apex moves when the source
    /// moves by `moved`: a beam's apex is its image source, the source
    /// mirrored in the planes of its reflections (a transmission keeps
    /// it), so it moves by `moved` mirrored the same way. Parents come
    /// before their children in the arena (they were pushed first).
    pub(crate) fn apex_moves(&self, moved: DVec3, surfaces: &Surfaces) -> Vec<DVec3> {
        let mut out: Vec<DVec3> = Vec::with_capacity(self.history.len());
        for &(parent, event) in &self.history {
            let from = if parent == u32::MAX {
                moved
            } else {
                out[parent as usize]
            };
            out.push(if event.is_transmission() {
                from
            } else {
                surfaces.group(event.group()).plane.mirror_vector(from)
            });
        }
        out
    }

    /// [`proposals`](Self::proposals) of the beams with their apexes moved
    /// by `apex_moves` (per history entry, from [`Self::apex_moves`]; empty
    /// for none): the beams of a source that moved, re-mirrored instead of
    /// traced again. Each beam keeps its window's directions, so a path
    /// that opened only after the move is missed, and every proposal is
    /// still validated exactly.
    pub(crate) fn proposals_moved(
        &self,
        listeners: &[DVec3],
        apex_moves: &[DVec3],
    ) -> Vec<Vec<Vec<Event>>> {
        use rayon::prelude::*;
        let parts: Vec<Vec<Vec<Vec<Event>>>> = self
            .tests
            .par_chunks(CHUNK)
            .zip(self.last_event.par_chunks(CHUNK))
            .map(|(tests, last)| {
                let mut found = vec![Vec::new(); listeners.len()];
                for (test, &at) in tests.iter().zip(last) {
                    let test = match apex_moves.get(at as usize) {
                        Some(&by) => test.shifted(by),
                        None => *test,
                    };
                    for (l, &listener) in listeners.iter().enumerate() {
                        if test.contains(listener, LISTENER_MARGIN) {
                            found[l].push(events_of(&self.history, at));
                        }
                    }
                }
                found
            })
            .collect();
        let mut out = vec![Vec::new(); listeners.len()];
        for part in parts {
            for (all, mut found) in out.iter_mut().zip(part) {
                all.append(&mut found);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acoustics::tracer::{events_of, trace, trace_beams, trace_keeping};
    use crate::acoustics::{test_shoebox, AcousticScene, CellAssignment, TraceOptions};
    use crate::deadline::Deadline;

    #[test]
    fn beams_propose_what_tracing_proposes() {
        let scene = AcousticScene::new(&test_shoebox(2, 0.3));
        let input = scene.trace_input(DVec3::new(2.0, 3.5, 1.2));
        let listeners: Vec<DVec3> = (0..7)
            .map(|i| DVec3::new(1.0 + 1.2 * i as f64, 1.0 + 0.6 * i as f64, 1.5))
            // On a wall's plane and on the source's cube-face border.
            .chain([DVec3::new(10.0, 3.0, 1.5), DVec3::new(5.0, 3.5, 1.2)])
            .collect();
        for cells in [CellAssignment::Conservative, CellAssignment::Sampled] {
            let options = TraceOptions {
                max_order: 4,
                sampling: 4,
                cells,
                ..TraceOptions::default()
            };
            let none = Deadline::none();
            // Every triangle handed to the last order, as kept beams are.
            let (traced, stats, _) = trace_keeping(&input, &listeners, &options, &none, 0).unwrap();
            let beams = trace_beams(&input, &options, &none).unwrap();
            assert_eq!(beams.proposals(&listeners), traced);
            // A one-off conservative trace proposes some of those in this
            // convex box (elsewhere the cover it drops may let it propose
            // others; sampled cells hand its last order exactly, which
            // proposes others here too).
            let (one_off, _) = trace(&input, &listeners, &options, &none).unwrap();
            if cells == CellAssignment::Conservative {
                for (some, all) in one_off.iter().zip(&traced) {
                    assert!(some.iter().all(|p| all.contains(p)));
                }
            }
            assert_eq!(
                beams.stats(),
                TraceStats {
                    proposals: 0,
                    ..stats
                }
            );
            // Every traced frustum but the 24 primaries is a beam, and
            // more than one task's worth, so chunks are joined in order.
            assert_eq!(beams.len() as u64, stats.frusta - 24);
            assert!(beams.len() > CHUNK, "{}", beams.len());
        }
    }

    #[test]
    fn moved_beams_have_the_moved_source_s_image_sources() {
        // The 10 x 6 x 3 m box: an image source is the source with the
        // coordinate of each wall's axis reflected, x -> 2c - x, written
        // here without the planes' mirroring.
        let scene = AcousticScene::new(&test_shoebox(1, 0.1));
        let size = DVec3::new(10.0, 6.0, 3.0);
        let image = |mut p: DVec3, events: &[Event]| {
            for e in events {
                let plane = scene.surfaces().group(e.group()).plane;
                let axis = plane.normal.abs().max_position();
                let wall = if plane.distance(DVec3::ZERO).abs() < 1e-9 {
                    0.0
                } else {
                    size[axis]
                };
                p[axis] = 2.0 * wall - p[axis];
            }
            p
        };
        let source = DVec3::new(2.0, 3.5, 1.2);
        let moved = DVec3::new(0.07, -0.05, 0.03);
        let input = scene.trace_input(source);
        let options = TraceOptions {
            max_order: 3,
            sampling: 2,
            cells: CellAssignment::Sampled,
            ..TraceOptions::default()
        };
        let beams = trace_beams(&input, &options, &Deadline::none()).unwrap();
        let moves = beams.apex_moves(moved, scene.surfaces());
        assert!(beams.len() > 100, "{}", beams.len());
        for (test, &at) in beams.tests.iter().zip(&beams.last_event) {
            let events = events_of(&beams.history, at);
            let traced = test.apex();
            assert!((traced - image(source, &events)).length() < 1e-9);
            let apex = test.shifted(moves[at as usize]).apex();
            let expected = image(source + moved, &events);
            assert!(
                (apex - expected).length() < 1e-9,
                "{events:?}: {apex} {expected}"
            );
        }
        // Not moved: the very proposals of the traced beams.
        let listeners = [DVec3::new(7.0, 2.0, 1.5), DVec3::new(4.0, 4.0, 2.0)];
        let still = beams.apex_moves(DVec3::ZERO, scene.surfaces());
        assert_eq!(
            beams.proposals_moved(&listeners, &still),
            beams.proposals(&listeners)
        );
    }
}
