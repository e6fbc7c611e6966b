//! Interleaved rounds: every implementation is measured once per round, the
//! order rotating from round to round, and each figure is the median over
//! rounds. This machine's speed drifts by up to 2x between runs (it is
//! shared), so a ratio is only taken between two measurements of the same
//! round; the reported ratio is the median of those per-round ratios.

use super::check::RefitCheck;
use super::measure::{median, Input, Structure};
use super::{mismatch, Impl};
use crate::report::{ImplResult, MraysPerS, Ratios, Round};

/// Measures `impls` (ours first: the reference) over `rounds` rounds on one
/// mesh.
pub fn run(impls: &[Impl], input: &Input, rounds: usize) -> Vec<ImplResult> {
    assert_eq!(impls.first().map(|i| i.name), Some("frusta"), "ours first");
    let rounds = rounds.max(1);
    let mut per: Vec<Vec<Round>> = vec![Vec::new(); impls.len()];
    let mut structures: Vec<Option<Structure>> = impls.iter().map(|_| None).collect();
    for r in 0..rounds {
        for k in 0..impls.len() {
            let i = (k + r) % impls.len();
            eprintln!(
                "[{}] round {}/{rounds} {}",
                input.mesh.name,
                r + 1,
                impls[i].name
            );
            let m = (impls[i].measure)(input, r == 0);
            structures[i] = structures[i].take().or(m.structure);
            per[i].push(m.round);
        }
    }
    let structures: Vec<Structure> = structures.into_iter().flatten().collect();
    let ours = per[0].clone();
    impls
        .iter()
        .zip(per)
        .zip(&structures)
        .enumerate()
        .map(|(i, ((imp, rounds), s))| {
            let vs_frusta = (i > 0).then(|| ratios(&ours, &rounds));
            let mismatch_fraction = mismatch(&structures[0].distances, &s.distances);
            aggregate(imp, rounds, s, mismatch_fraction, vs_frusta)
        })
        .collect()
}

fn med(rounds: &[Round], f: impl Fn(&Round) -> f64) -> f64 {
    median(rounds.iter().map(f).collect())
}

fn med_opt(rounds: &[Round], f: impl Fn(&Round) -> Option<f64>) -> Option<f64> {
    let v: Option<Vec<f64>> = rounds.iter().map(f).collect();
    v.map(median)
}

fn rates(rounds: &[Round], f: impl Fn(&MraysPerS) -> f64) -> f64 {
    med(rounds, |r| f(&r.mrays_per_s))
}

fn aggregate(
    imp: &Impl,
    rounds: Vec<Round>,
    s: &Structure,
    mismatch_fraction: f64,
    vs_frusta: Option<Ratios>,
) -> ImplResult {
    let r = &rounds;
    let refit_check = rounds.iter().try_fold(RefitCheck::default(), |mut sum, r| {
        sum += r.refit_check?;
        Some(sum)
    });
    ImplResult {
        name: imp.name,
        parallel_build: imp.parallel_build,
        build_ms: med(r, |r| r.build_ms),
        refit_ms: med_opt(r, |r| r.refit_ms),
        build_over_refit: med_opt(r, |r| r.refit_ms.map(|f| r.build_ms / f)),
        sah_cost: s.sah_cost,
        mrays_per_s: MraysPerS {
            coherent_closest: rates(r, |m| m.coherent_closest),
            incoherent_closest: rates(r, |m| m.incoherent_closest),
            coherent_any: rates(r, |m| m.coherent_any),
            incoherent_any: rates(r, |m| m.incoherent_any),
        },
        bytes_per_triangle: s.bytes_per_triangle,
        mismatch_fraction,
        refit_check,
        vs_frusta,
        rounds,
    }
}

/// Ours over the peer's, round by round, then the median: times (ours /
/// theirs below 1 means ours is faster) and rates (above 1 means ours is
/// faster) alike.
fn ratios(ours: &[Round], theirs: &[Round]) -> Ratios {
    let pairs: Vec<(&Round, &Round)> = ours.iter().zip(theirs).collect();
    let m = |f: &dyn Fn(&Round) -> f64| median(pairs.iter().map(|(o, t)| f(o) / f(t)).collect());
    let rate = |f: fn(&MraysPerS) -> f64| m(&|r: &Round| f(&r.mrays_per_s));
    Ratios {
        build: m(&|r| r.build_ms),
        refit: pairs
            .iter()
            .map(|(o, t)| Some(o.refit_ms? / t.refit_ms?))
            .collect::<Option<Vec<f64>>>()
            .map(median),
        mrays_per_s: MraysPerS {
            coherent_closest: rate(|m| m.coherent_closest),
            incoherent_closest: rate(|m| m.incoherent_closest),
            coherent_any: rate(|m| m.coherent_any),
            incoherent_any: rate(|m| m.incoherent_any),
        },
    }
}
