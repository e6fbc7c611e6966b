//! The two references each traced case is compared with, run once per
//! scene and order and timed like the tracer:
//! - the independent reference (`acoustics::brute_force`): `f64`, every
//!   leg against every triangle, closed-form gains; it shares no code
//!   with the tracer's validation, so the accuracy columns come from it
//!   wherever it is feasible;
//! - the exhaustive image-source solver (`acoustics::reference`): every
//!   event sequence validated by the tracer's own `path::validate`, so it
//!   is fast but agrees with the tracer by construction on every path
//!   both find. It stands in for recall (not for errors) where the
//!   independent reference is infeasible, and its time is shown beside.

use std::time::{Duration, Instant};

use frusta_engine::acoustics::brute_force::{BruteForce, ReferencePath};
use frusta_engine::acoustics::path::ValidPath;
use frusta_engine::acoustics::reference::image_sources;
use frusta_engine::acoustics::AcousticScene;
use frusta_engine::scene::Material;
use glam::DVec3;

/// The independent reference is not run above this many event sequences.
const INDEPENDENT_SEQUENCES: f64 = 2e7;
/// The exhaustive solver is not run above this many: hall-200k at order 3
/// (5.7e8) and hall-10k at order 4 (1.8e9) take about four minutes each on
/// two threads, and give those cases a recall.
const EXHAUSTIVE_SEQUENCES: f64 = 2e9;
/// Nor is either reference where its time, extrapolated from the order
/// below by the ratio of sequence counts, would exceed this. The
/// extrapolation overestimates about 3x in the halls (longer sequences
/// fail sooner), and the shared machine's load moves it by 2x: this
/// admits hall-200k at order 3 (extrapolated 250-500 s, measured 100-200 s).
const BUDGET: Duration = Duration::from_secs(900);
/// Timed repeats (median) for runs under a second.
pub const REPEATS: usize = 3;

/// Runs `f` once, and `REPEATS` times in all if that took under a second:
/// the last result, the median time in ms and the first run's duration.
pub fn timed<T>(mut f: impl FnMut() -> T) -> (T, f64, Duration) {
    let t = Instant::now();
    let mut out = f();
    let first = t.elapsed();
    let mut times = vec![first.as_secs_f64() * 1e3];
    if first < Duration::from_secs(1) {
        for _ in 1..REPEATS {
            let t = Instant::now();
            out = f();
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    (out, times[times.len() / 2], first)
}

pub struct Independent {
    pub ms: f64,
    pub paths: Vec<ReferencePath>,
}

pub struct Exhaustive {
    pub ms: f64,
    pub paths: Vec<ValidPath>,
}

/// Both references at one order (`None`: infeasible).
#[derive(Default)]
pub struct AtOrder {
    pub independent: Option<Independent>,
    pub exhaustive: Option<Exhaustive>,
}

/// Event sequences of the exhaustive solver up to `order`: every event
/// (a reflection per plane group, a transmission per transmitting one),
/// then every event but the last group's.
fn exhaustive_sequences(events: usize, order: u32) -> f64 {
    let e = events as f64;
    (0..order)
        .map(|k| e * (e - 1.0).max(0.0).powi(k as i32))
        .sum::<f64>()
        + 1.0
}

/// Whether a run of `count` sequences is feasible: under `limit`, and
/// (given the last run's sequences and time) expected within the budget.
fn feasible(count: f64, limit: f64, last: Option<(f64, f64)>) -> bool {
    count <= limit
        && last.is_none_or(|(c, ms)| ms * count / c.max(1.0) <= BUDGET.as_secs_f64() * 1e3)
}

/// Runs both references at every order of `orders` (ascending) where
/// they are feasible, with progress on stderr.
pub fn run(
    name: &str,
    scene: &AcousticScene,
    independent: &BruteForce,
    source: DVec3,
    listener: DVec3,
    orders: &[u32],
) -> Vec<(u32, AtOrder)> {
    let events: usize = scene
        .surfaces()
        .groups()
        .map(|(_, g)| {
            1 + scene
                .materials()
                .get(usize::from(g.material))
                .is_some_and(Material::transmits) as usize
        })
        .sum();
    eprintln!(
        "[{name}] references: {} faces (independent), {events} events per step (exhaustive)",
        independent.face_count()
    );
    let (mut last_independent, mut last_exhaustive) = (None, None);
    let mut out = Vec::new();
    for &order in orders {
        let mut at = AtOrder::default();
        let count = independent.sequence_count(order as usize);
        if feasible(count, INDEPENDENT_SEQUENCES, last_independent) {
            let (paths, ms, _) =
                timed(|| independent.paths(source, listener, order as usize, None));
            eprintln!(
                "[{name}] independent reference, order {order}: {count:.2e} sequences, {} paths in {ms:.1} ms",
                paths.len()
            );
            last_independent = Some((count, ms));
            at.independent = Some(Independent { ms, paths });
        } else {
            eprintln!(
                "[{name}] independent reference, order {order}: {count:.2e} sequences, infeasible"
            );
        }
        let count = exhaustive_sequences(events, order);
        if feasible(count, EXHAUSTIVE_SEQUENCES, last_exhaustive) {
            let (paths, ms, _) = timed(|| {
                image_sources(
                    scene.bvh(),
                    scene.surfaces(),
                    scene.materials(),
                    source,
                    listener,
                    order as usize,
                )
            });
            eprintln!(
                "[{name}] exhaustive solver, order {order}: {count:.2e} sequences, {} paths in {ms:.1} ms",
                paths.len()
            );
            last_exhaustive = Some((count, ms));
            at.exhaustive = Some(Exhaustive { ms, paths });
        } else {
            eprintln!(
                "[{name}] exhaustive solver, order {order}: {count:.2e} sequences, infeasible"
            );
        }
        out.push((order, at));
    }
    out
}
