//! Frustum tracing (Lauterbach's dissertation, section 6.1): frusta leave
//! the source tiling the sphere; each is split into `N x N` sub-frusta
//! (cells), the triangles it meets are classified per cell, and the cells
//! that meet one plane group are merged into secondary frusta, mirrored in
//! that plane (reflection) or continued through it (transmission).
//!
//! Cells are handed to triangles in one of two ways. Conservative cells
//! ([`classify`](super::classify)) go to every triangle that touches them
//! in the frustum's window space, except those wholly behind a triangle
//! that covers the cell, so that every image source is proposed; sampled
//! cells go to what their corner and centre rays meet first, found by
//! classifying the frustum's triangles against the sample points while
//! they are few and by casting the rays ([`sample_rays`]) when they are
//! many. Either way exact validation ([`validate`](super::path::validate))
//! rejects what is not a path.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;

use super::beams::Beams;
use super::classify::{classify, Contacts, LastOrder, NearestDepths, Target};
use super::cull::{box_cull, for_each_leaf};
use super::frustum::Frustum;
use super::merge::{merge_cells, CellSets, GroupWindows};
use super::path::Event;
use super::sample_rays;
use super::surfaces::{Surfaces, NO_GROUP};
use crate::deadline::{Deadline, CLOCK_PERIOD};
use crate::query::SceneBvh;
use crate::scene::{Bands, Material, BAND_COUNT};
use crate::Result;

/// How far to trace.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceOptions {
    /// Highest number of surface events on a path.
    pub max_order: u32,
    /// Cells per frustum side (`N`); 1..=64. Default: 2, the default
    /// cells' [`CellAssignment::default_sampling`] (sampled cells want 8).
    pub sampling: u32,
    /// Frusta per cube-face side for the frusta leaving the source.
    pub primary_split: u32,
    /// A frustum whose energy, relative to the source, has fallen below this
    /// in every active band spawns no more frusta.
    pub energy_threshold: f32,
    /// Bands that count for the energy threshold.
    pub active_bands: [bool; BAND_COUNT],
    /// How cells are handed to triangles.
    pub cells: CellAssignment,
}

/// How a frustum's cells (sub-frusta) are handed to the triangles they meet.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CellAssignment {
    /// To every triangle the cell touches that no covering triangle hides:
    /// every image source is proposed (complete recall), at the cost of
    /// many frusta where triangles are small next to cells.
    #[default]
    Conservative,
    /// To the triangles hit first by the cell's sample rays (its four
    /// corners and its centre), as in the dissertation: bounded work per
    /// frustum, and paths through features smaller than a cell may be
    /// missed (never invented: validation stays exact).
    Sampled,
}

impl CellAssignment {
    /// The sampling `N` a trace takes unless asked for another. Conservative
    /// cells are complete at any `N`, and coarse cells cost least: a finer
    /// grid hides little more behind small triangles and splits every
    /// frustum into more children. Kept traces (streams) of hall-10k at
    /// order 4 took 0.6 of the time at N = 2 as at N = 8, the shoebox and
    /// the L-room half; one-off traces, whose last order is pruned to the
    /// listeners, differ less (0.41 against 0.44 s in hall-10k, half in the
    /// shoebox; `frusta-bench propagation`). Sampled cells find most paths
    /// only with enough sample rays.
    pub fn default_sampling(self) -> u32 {
        match self {
            CellAssignment::Conservative => 2,
            CellAssignment::Sampled => 8,
        }
    }
}

impl Default for TraceOptions {
    fn default() -> Self {
        let cells = CellAssignment::default();
        Self {
            max_order: 4,
            sampling: cells.default_sampling(),
            primary_split: 2,
            energy_threshold: 1e-6,
            active_bands: [true; BAND_COUNT],
            cells,
        }
    }
}

/// Counters of one trace.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TraceStats {
    /// Frusta traced, primary and secondary.
    pub frusta: u64,
    /// Triangle-against-frustum classifications (conservative cells, and
    /// sampled cells in frusta holding few triangles).
    pub triangle_tests: u64,
    /// Rays cast through the scene (sampled cells).
    pub sample_rays: u64,
    /// Event sequences proposed for validation (before de-duplication).
    pub proposals: u64,
}

impl TraceStats {
    pub(crate) fn add(mut self, o: Self) -> Self {
        self.frusta += o.frusta;
        self.triangle_tests += o.triangle_tests;
        self.sample_rays += o.sample_rays;
        self.proposals += o.proposals;
        self
    }
}

/// A frustum waiting to be traced, with the events that led to it.
struct Pending {
    frustum: Frustum,
    /// Index of its last event in the history arena (`u32::MAX`: none).
    history: u32,
    order: u32,
    energy: Bands,
}

/// Reusable buffers of one worker.
#[derive(Default)]
struct Scratch {
    /// Per cell, the nearest depth at which a triangle covers it wholly.
    cover: NearestDepths,
    /// Every cell-triangle contact, and the triangles' window bounds.
    contacts: Contacts,
    /// The window bounds of each group's triangles that are seen.
    windows: GroupWindows,
    /// `(group, cell)` pairs that survive occlusion.
    touched: Vec<(u32, u32)>,
    cell_sets: CellSets,
    rects: Vec<[u32; 4]>,
    /// The nearest hit of each sample ray ([`CellAssignment::Sampled`];
    /// empty otherwise).
    samples: NearestDepths,
    history: Vec<(u32, Event)>,
    pending: Vec<Pending>,
}

/// Everything the tracer reads.
pub(crate) struct TraceInput<'a> {
    pub bvh: &'a SceneBvh,
    pub surfaces: &'a Surfaces,
    pub materials: &'a [Material],
    pub source: DVec3,
    /// How far the source may move while these frusta serve it (a kept
    /// trace's `source_reuse_m`; 0 for a one-off trace). Conservative
    /// secondary frusta are cut to the window bounds of the triangles they
    /// leave from ([`GroupWindows`]), widened by as much as those bounds
    /// can shift seen from an apex moved that far (the apex of every
    /// frustum moves by the source's move, mirrored): a path from the
    /// moved source through those triangles and the cells they were seen
    /// in stays inside. Paths through other cells, or through triangles
    /// not seen from the old apex, wait for the next trace, as they would
    /// in uncut frusta.
    pub apex_reach: f64,
    /// The listeners, when the trace only proposes to them and keeps no
    /// frusta ([`trace`]): a frustum's children of the last order are then
    /// handed only triangles through which one of them can be reached
    /// (see [`LastOrder`]). `None` hands them every triangle, for
    /// frusta kept to test other listeners against later.
    pub last_order_listeners: Option<&'a [DVec3]>,
}

/// What the tracer does with each frustum of order >= 1, the frusta that
/// propose their events to the listeners they contain.
pub(crate) trait Visit {
    /// `at` indexes the frustum's last event in `history`.
    fn visit(&mut self, frustum: &Frustum, history: &[(u32, Event)], at: u32);
}

/// Proposals per listener, tested while tracing: nothing else is kept.
struct Proposals<'a> {
    listeners: &'a [DVec3],
    found: Vec<Vec<Vec<Event>>>,
}

impl Visit for Proposals<'_> {
    fn visit(&mut self, frustum: &Frustum, history: &[(u32, Event)], at: u32) {
        for (l, &listener) in self.listeners.iter().enumerate() {
            if frustum.contains(listener, LISTENER_MARGIN) {
                self.found[l].push(events_of(history, at));
            }
        }
    }
}

/// Per listener, the event sequences of the frusta that contain it.
pub(crate) type Proposed = Vec<Vec<Vec<Event>>>;

/// Traces frusta from the source and proposes, per listener, the event
/// sequences of every frustum that contains it.
pub(crate) fn trace(
    input: &TraceInput,
    listeners: &[DVec3],
    options: &TraceOptions,
    deadline: &Deadline,
) -> Result<(Proposed, TraceStats)> {
    let input = TraceInput {
        last_order_listeners: Some(listeners),
        ..*input
    };
    let (proposals, stats, _) = trace_keeping(&input, listeners, options, deadline, 0)?;
    Ok((proposals, stats))
}

/// Traces frusta from the source and keeps every one of order >= 1, to
/// test any listeners against later.
pub(crate) fn trace_beams(
    input: &TraceInput,
    options: &TraceOptions,
    deadline: &Deadline,
) -> Result<Beams> {
    let (_, _, beams) = trace_keeping(input, &[], options, deadline, usize::MAX)?;
    Ok(beams.unwrap_or_default())
}

/// Proposes for `listeners` as [`trace`] does and also keeps the beams for
/// later listeners, unless more than `max_beams` are traced: then none are
/// kept (`None`), so memory stays bounded whatever the scene.
pub(crate) fn trace_keeping(
    input: &TraceInput,
    listeners: &[DVec3],
    options: &TraceOptions,
    deadline: &Deadline,
    max_beams: usize,
) -> Result<(Proposed, TraceStats, Option<Beams>)> {
    use rayon::prelude::*;
    let kept = AtomicUsize::new(0);
    let over = |n: usize| n > max_beams;
    let (roots, root_stats) = expand_primaries(input, options, deadline)?;
    let parts = roots
        .into_par_iter()
        .map_init(Scratch::default, |scratch, root| {
            let mut visitor = Keeping {
                proposals: Proposals {
                    listeners,
                    found: vec![Vec::new(); listeners.len()],
                },
                beams: Beams::default(),
                kept: &kept,
                max_beams,
            };
            let stats = trace_subtree(input, options, root, scratch, &mut visitor, deadline)?;
            // The arena's parents index this subtree's arena: it moves
            // along with its beams, unless they are dropped anyway.
            let beams = (!over(kept.load(Ordering::Relaxed))).then(|| {
                let history = std::mem::take(&mut scratch.history);
                Beams::part(visitor.beams, history, stats)
            });
            Ok((visitor.proposals.found, stats, beams))
        })
        .collect::<Result<Vec<_>>>()?;
    let keep = !over(kept.load(Ordering::Relaxed));
    let mut proposals = vec![Vec::new(); listeners.len()];
    let mut stats = root_stats;
    let mut beams = Vec::with_capacity(if keep { parts.len() + 1 } else { 0 });
    if keep {
        beams.push(Beams::part(Beams::default(), Vec::new(), root_stats));
    }
    for (found, s, b) in parts {
        for (all, mut f) in proposals.iter_mut().zip(found) {
            stats.proposals += f.len() as u64;
            all.append(&mut f);
        }
        stats = stats.add(s);
        beams.extend(b.filter(|_| keep));
    }
    let beams = keep.then(|| Beams::concat(beams));
    Ok((proposals, stats, beams))
}

/// Proposals and beams at once; stops keeping beams past the shared cap.
struct Keeping<'a> {
    proposals: Proposals<'a>,
    beams: Beams,
    kept: &'a AtomicUsize,
    max_beams: usize,
}

impl Visit for Keeping<'_> {
    fn visit(&mut self, frustum: &Frustum, history: &[(u32, Event)], at: u32) {
        self.proposals.visit(frustum, history, at);
        if self.kept.load(Ordering::Relaxed) > self.max_beams {
            return;
        }
        if self.kept.fetch_add(1, Ordering::Relaxed) < self.max_beams {
            self.beams.visit(frustum, history, at);
        } else {
            self.beams = Beams::default();
        }
    }
}

/// A frustum of order 1 and the event that made it: the root of one
/// tracing task.
struct Root {
    pending: Pending,
    event: Event,
}

/// Expands the frusta leaving the source into their children, each the
/// root of its own task. A primary facing the far end of a hall spawns
/// most of the work: traced as one task per primary, it would leave a core
/// idle for a fifth of the trace.
fn expand_primaries(
    input: &TraceInput,
    options: &TraceOptions,
    deadline: &Deadline,
) -> Result<(Vec<Root>, TraceStats)> {
    use rayon::prelude::*;
    let parts = Frustum::sphere(input.source, options.primary_split)
        .into_par_iter()
        .map_init(Scratch::default, |scratch, frustum| {
            deadline.check()?;
            let mut stats = TraceStats {
                frusta: 1,
                ..TraceStats::default()
            };
            scratch.history.clear();
            scratch.pending.clear();
            if options.max_order > 0 {
                let primary = Pending {
                    frustum,
                    history: u32::MAX,
                    order: 0,
                    energy: [1.0; BAND_COUNT],
                };
                expand(input, options, &primary, scratch, &mut stats);
            }
            let history = &scratch.history;
            let roots: Vec<Root> = scratch
                .pending
                .drain(..)
                .map(|pending| Root {
                    event: history[pending.history as usize].1,
                    pending,
                })
                .collect();
            Ok((roots, stats))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut roots = Vec::new();
    let mut stats = TraceStats::default();
    for (r, s) in parts {
        roots.extend(r);
        stats = stats.add(s);
    }
    Ok((roots, stats))
}

/// Depth-first tracing of one root frustum and everything it spawns.
fn trace_subtree(
    input: &TraceInput,
    options: &TraceOptions,
    root: Root,
    scratch: &mut Scratch,
    visitor: &mut impl Visit,
    deadline: &Deadline,
) -> Result<TraceStats> {
    let mut stats = TraceStats::default();
    scratch.history.clear();
    scratch.history.push((u32::MAX, root.event));
    scratch.pending.clear();
    scratch.pending.push(Pending {
        history: 0,
        ..root.pending
    });
    while let Some(p) = scratch.pending.pop() {
        if stats.frusta % CLOCK_PERIOD == 0 {
            deadline.check()?;
        } else {
            deadline.expired()?;
        }
        stats.frusta += 1;
        visitor.visit(&p.frustum, &scratch.history, p.history);
        if p.order < options.max_order {
            expand(input, options, &p, scratch, &mut stats);
        }
    }
    Ok(stats)
}

/// Frusta are widened by this much (in window units) when testing whether
/// they contain a listener, so a listener on the border of two frusta is
/// proposed by both and then counted once.
pub(crate) const LISTENER_MARGIN: f64 = 1e-7;

/// The events ending at `at` in a `(parent, event)` arena, first first.
pub(crate) fn events_of(history: &[(u32, Event)], mut at: u32) -> Vec<Event> {
    let mut out = Vec::new();
    while at != u32::MAX {
        let (parent, e) = history[at as usize];
        out.push(e);
        at = parent;
    }
    out.reverse();
    out
}

/// Hands `p`'s cells to the plane groups they meet and pushes its
/// secondary frusta.
fn expand(
    input: &TraceInput,
    options: &TraceOptions,
    p: &Pending,
    scratch: &mut Scratch,
    stats: &mut TraceStats,
) {
    let n = options.sampling.clamp(1, 64) as usize;
    let last_group = (p.history != u32::MAX).then(|| scratch.history[p.history as usize].1.group());
    scratch.touched.clear();
    scratch.windows.clear();
    let f = &p.frustum;
    let last_order = input
        .last_order_listeners
        .filter(|_| p.order + 1 == options.max_order);
    touch_cells(
        input,
        f,
        last_group,
        n,
        options.cells,
        last_order,
        scratch,
        stats,
    );
    scratch.cell_sets.sort_dedup(&mut scratch.touched, n * n);
    let touched = std::mem::take(&mut scratch.touched);
    for cells in touched.chunk_by(|a, b| a.0 == b.0) {
        spawn(input, options, p, cells, n, last_order, scratch);
    }
    scratch.touched = touched;
}

/// Above this many triangles in one frustum, sample rays cost less than
/// classifying the triangles against the samples: a ray through the hall's
/// 8-wide tree costs about as much as a classified triangle, and a
/// frustum has `(N+1)^2 + N^2` rays (145 at N = 8). Below it, in rooms
/// of large walls, classification is several times cheaper. A frustum
/// over the budget throws away what it classified, so at most this many
/// classifications are wasted per frustum. (96, chosen when rays walked
/// the 4-wide tree, took 1.05x the time of 48 at order 4 in hall-10k and
/// 1.08x at order 3 in hall-200k, for the same paths.)
const SAMPLE_CLASSIFY_BUDGET: u64 = 48;

/// Frusta of a one-off trace's last expansion in sampled cells hand their
/// cells exactly, as conservative cells do, while they hold at most this
/// many triangles: only the triangles that a segment to a listener's image
/// crosses are classified ([`LastOrder`]), so a triangle costs a few
/// dozen multiply-adds, against 145 sample rays (N = 8) of a few hundred
/// nanoseconds each. Past it (counted first), the frustum casts its rays.
const LAST_ORDER_BUDGET: u64 = 512;

/// Pushes to `scratch.touched` a `(group, cell)` pair for every plane group
/// a cell of `f` is handed to. Conservative: every triangle touching the
/// cell that no covering triangle hides. Sampled: the groups the cell's
/// five sample rays meet first, found by classifying the triangles the
/// cull reaches while they are few, else by casting the rays.
///
/// Given `last_order` listeners (the children are of the last order and
/// only propose to them), cells are handed only triangles through which
/// one of them can be reached, conservatively, also in sampled cells while
/// the frustum holds few triangles ([`LAST_ORDER_BUDGET`]).
#[allow(clippy::too_many_arguments)]
fn touch_cells(
    input: &TraceInput,
    f: &Frustum,
    skip: Option<u32>,
    n: usize,
    cells: CellAssignment,
    last_order: Option<&[DVec3]>,
    scratch: &mut Scratch,
    stats: &mut TraceStats,
) {
    let exact = |scratch: &mut Scratch, stats: &mut TraceStats| {
        conservative_cells(input, f, skip, n, last_order, scratch, stats)
    };
    match cells {
        CellAssignment::Sampled => {
            if last_order.is_some() && culled_at_most(input, f, LAST_ORDER_BUDGET) {
                exact(scratch, stats);
                return;
            }
            scratch.samples.reset((n + 1) * (n + 1) + n * n);
            let budget = SAMPLE_CLASSIFY_BUDGET;
            if !classify_culled(input, f, skip, n, Record::Samples, budget, scratch, stats) {
                let hit = &mut scratch.samples.group;
                sample_rays::cast(input.bvh, input.surfaces, f, skip, n, hit);
                stats.sample_rays += hit.len() as u64;
            }
            sampled_cells(&scratch.samples.group, n, &mut scratch.touched);
        }
        CellAssignment::Conservative => {
            exact(scratch, stats);
        }
    }
}

/// Conservative cells: pushes to `scratch.touched` every `(group, cell)`
/// of a triangle touching the cell that no covering triangle hides, and
/// widens the group's window to the triangle's footprint.
fn conservative_cells(
    input: &TraceInput,
    f: &Frustum,
    skip: Option<u32>,
    n: usize,
    last_order: Option<&[DVec3]>,
    scratch: &mut Scratch,
    stats: &mut TraceStats,
) {
    scratch.cover.reset(n * n);
    scratch.contacts.reset(f, input.apex_reach);
    let cells = Record::Cells(last_order);
    classify_culled(input, f, skip, n, cells, u64::MAX, scratch, stats);
    // A contact counts unless a covering triangle lies wholly in front of
    // it over the whole cell.
    let cover = &scratch.cover.depth;
    let Contacts {
        touches,
        footprints,
        ..
    } = &scratch.contacts;
    // A triangle's contacts are side by side: its footprint is taken once.
    let mut taken = u32::MAX;
    for &(cell, group, depth, footprint) in touches {
        if depth <= cover[cell as usize] * (1.0 + 1e-9) {
            scratch.touched.push((group, cell));
            if footprint != taken {
                scratch.windows.widen(group, footprints[footprint as usize]);
                taken = footprint;
            }
        }
    }
}

/// Whether the cull of `f` reaches at most `most` triangles: counted leaf
/// by leaf, without a look at any, which costs a fraction of classifying
/// them, so a frustum that holds more wastes little on finding out.
fn culled_at_most(input: &TraceInput, f: &Frustum, most: u64) -> bool {
    let cull = box_cull(f, (input.surfaces.scale() * 1e-6) as f32);
    let mut count = 0u64;
    for_each_leaf(input.bvh, input.surfaces, &cull, |_, n| {
        count += n as u64;
        if count > most {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        }
    });
    count <= most
}

/// What [`classify_culled`] classifies triangles into.
#[derive(Clone, Copy)]
enum Record<'a> {
    /// The sample hits.
    Samples,
    /// The cover depths and contacts, of only the triangles through which
    /// one of the listeners can be reached, if given.
    Cells(Option<&'a [DVec3]>),
}

/// Classifies the triangles the cull of `f` reaches, nearest leaves first,
/// `into` the sample hits or the cells, until nothing nearer can remain.
/// Gives up, returning false, once more than `budget` triangles were
/// classified.
#[allow(clippy::too_many_arguments)]
fn classify_culled(
    input: &TraceInput,
    f: &Frustum,
    skip: Option<u32>,
    n: usize,
    into: Record,
    budget: u64,
    scratch: &mut Scratch,
    stats: &mut TraceStats,
) -> bool {
    let scale = input.surfaces.scale();
    let cull = box_cull(f, (scale * 1e-6) as f32);
    let Scratch {
        cover,
        contacts,
        samples,
        ..
    } = scratch;
    let mut tested = 0u64;
    for_each_leaf(input.bvh, input.surfaces, &cull, |first, count| {
        for i in first..first + count {
            let (corners, group) = input.surfaces.slot(i);
            if group == NO_GROUP || Some(group) == skip {
                continue;
            }
            tested += 1;
            let target = match into {
                Record::Samples => Target::Samples(samples),
                Record::Cells(last_order) => {
                    let last_order = last_order.map(|listeners| LastOrder {
                        listeners,
                        transmits: input
                            .materials
                            .get(input.surfaces.group(group).material as usize)
                            .is_some_and(Material::transmits),
                    });
                    Target::Cells(cover, contacts, last_order)
                }
            };
            classify(f, input.surfaces, corners, group, n, scale, target);
        }
        if tested > budget {
            return f64::NEG_INFINITY;
        }
        // Nothing beyond the farthest covered cell (or sample hit) can be
        // handed a cell.
        match into {
            Record::Samples => samples.farthest(),
            Record::Cells(_) => cover.farthest(),
        }
    });
    stats.triangle_tests += tested;
    tested <= budget
}

/// Pushes to `touched` a `(group, cell)` pair for every group that one of
/// the cell's five sample rays meets first (`hit`, in the order of
/// [`sample_rays::cast`]).
fn sampled_cells(hit: &[u32], n: usize, touched: &mut Vec<(u32, u32)>) {
    for i in 0..n {
        for j in 0..n {
            let cell = (i * n + j) as u32;
            let corner = |a: usize, b: usize| hit[a * (n + 1) + b];
            let centre = hit[(n + 1) * (n + 1) + i * n + j];
            let groups = [
                corner(i, j),
                corner(i + 1, j),
                corner(i, j + 1),
                corner(i + 1, j + 1),
                centre,
            ];
            // Mostly all five rays meet one group: push each group once.
            for (k, &g) in groups.iter().enumerate() {
                if g != NO_GROUP && !groups[..k].contains(&g) {
                    touched.push((g, cell));
                }
            }
        }
    }
}

/// Pushes the secondary frusta over `cells`, `(group, cell)` pairs of one
/// group; of the last order, only those that may contain one of the
/// `last_order` listeners, if given (the others would propose nothing).
fn spawn(
    input: &TraceInput,
    options: &TraceOptions,
    p: &Pending,
    cells: &[(u32, u32)],
    n: usize,
    last_order: Option<&[DVec3]>,
    scratch: &mut Scratch,
) {
    let group = cells[0].0;
    let g = input.surfaces.group(group);
    let Some(material) = input.materials.get(g.material as usize) else {
        return;
    };
    let step = 1.0 / n as f64;
    let mut rects = std::mem::take(&mut scratch.rects);
    rects.clear();
    merge_cells(cells, n, &mut rects);
    for &[i0, i1, j0, j1] in &rects {
        let rect = [
            i0 as f64 * step,
            (i1 + 1) as f64 * step,
            j0 as f64 * step,
            (j1 + 1) as f64 * step,
        ];
        let [x0, x1, y0, y1] = scratch.windows.cut(group, rect);
        if let Some(listeners) = last_order {
            // A child contains a listener within `LISTENER_MARGIN` of its
            // own window, this rectangle of the parent's mirrored: twice
            // that, and a billionth of the window for the rounding, keeps
            // every child that may.
            let (mx, my) = (
                2.0 * LISTENER_MARGIN * (x1 - x0) + 1e-9,
                2.0 * LISTENER_MARGIN * (y1 - y0) + 1e-9,
            );
            let in_rect = |q: DVec3| {
                let w = p.frustum.window_coords(q);
                // As `!(s <= 0)`, so that NaN is kept.
                if w.z <= 0.0 {
                    return false;
                }
                let (u, v) = (w.x / w.z, w.y / w.z);
                !(u < x0 - mx || u > x1 + mx || v < y0 - my || v > y1 + my)
            };
            let transmits = material.transmits();
            let shown = |&l: &DVec3| in_rect(g.plane.mirror(l)) || (transmits && in_rect(l));
            if !listeners.iter().any(shown) {
                continue;
            }
        }
        let Some(sub) = p.frustum.sub(x0, x1, y0, y1) else {
            continue;
        };
        let reflect = std::array::from_fn(|b| p.energy[b] * (1.0 - material.absorption[b]));
        let through = std::array::from_fn(|b| p.energy[b] * material.transmission[b]);
        let children = [
            (sub.reflected(&g.plane), reflect, Event::reflection(group)),
            (
                if material.transmits() {
                    sub.transmitted(&g.plane)
                } else {
                    None
                },
                through,
                Event::transmission(group),
            ),
        ];
        for (frustum, energy, event) in children {
            let Some(frustum) = frustum else { continue };
            let loud = energy
                .iter()
                .zip(&options.active_bands)
                .any(|(&e, &on)| on && e >= options.energy_threshold);
            if !loud {
                continue;
            }
            scratch.history.push((p.history, event));
            scratch.pending.push(Pending {
                frustum,
                history: scratch.history.len() as u32 - 1,
                order: p.order + 1,
                energy,
            });
        }
    }
    scratch.rects = rects;
}
