use super::*;

fn still(p: DVec3) -> [DVec3; 2] {
    [p, p]
}

fn toi_vf(q: &VertexFace) -> Option<f64> {
    q.time_of_impact(&CcdOptions::default(), &mut CcdScratch::default())
}

fn toi_ee(q: &EdgeEdge) -> Option<f64> {
    q.time_of_impact(&CcdOptions::default(), &mut CcdScratch::default())
}

fn floor_face() -> [[DVec3; 2]; 3] {
    [
        still(DVec3::new(0.0, 0.0, 0.0)),
        still(DVec3::new(1.0, 0.0, 0.0)),
        still(DVec3::new(0.0, 1.0, 0.0)),
    ]
}

#[test]
fn a_falling_vertex_hits_the_face_when_it_reaches_it() {
    let q = VertexFace {
        vertex: [DVec3::new(0.25, 0.25, 1.0), DVec3::new(0.25, 0.25, -1.0)],
        face: floor_face(),
    };
    let t = toi_vf(&q).expect("crosses the face");
    assert!(t <= 0.5 && t > 0.5 - 1e-5, "{t}");
}

#[test]
fn a_vertex_passing_beside_the_face_misses_it() {
    let q = VertexFace {
        vertex: [DVec3::new(0.6, 0.6, 1.0), DVec3::new(0.6, 0.6, -1.0)],
        face: floor_face(),
    };
    assert_eq!(toi_vf(&q), None);
}

#[test]
fn a_vertex_passing_exactly_through_an_edge_hits() {
    // Through the hypotenuse's midpoint, where u + v = 1 exactly.
    let q = VertexFace {
        vertex: [DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, -1.0)],
        face: floor_face(),
    };
    assert!(toi_vf(&q).is_some());
}

/// The portable search's answer, checked equal to the bit to the AVX2
/// search's.
#[cfg(target_arch = "x86_64")]
fn both_searches<P: Primitives + std::fmt::Debug>(
    scratch: &mut [CcdScratch; 2],
    query: &P,
    options: &CcdOptions,
) -> Option<f64> {
    let portable = scratch[0].search_inlined(query, options);
    assert!(avx2_fma_available());
    // SAFETY: checked on the line above.
    let avx2 = unsafe { scratch[1].search_avx2(query, options) };
    assert_eq!(
        portable.map(f64::to_bits),
        avx2.map(f64::to_bits),
        "{query:?}"
    );
    portable
}

/// The AVX2 search and the portable one give the same answers to the
/// bit, near misses and touches decided in double-double included.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_search_answers_as_the_portable_one() {
    use rand::{Rng, SeedableRng};
    if !avx2_fma_available() {
        eprintln!("skipped: this CPU has no AVX2 and FMA");
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    // Coordinates on a grid of 1/8: crossings and touches are exact,
    // and moving one end by 2^-52 (a few ulps) leaves f64 in doubt.
    let grid = |rng: &mut rand_chacha::ChaCha8Rng| {
        DVec3::new(
            f64::from(rng.random_range(-8i8..=8)),
            f64::from(rng.random_range(-8i8..=8)),
            f64::from(rng.random_range(-8i8..=8)),
        ) / 8.0
    };
    let options = CcdOptions::default();
    let mut scratch = [CcdScratch::default(), CcdScratch::default()];
    let mut contacts = [0; 2];
    for n in 0..400 {
        let mut p = [[DVec3::ZERO; 2]; 4];
        for q in p.iter_mut().flatten() {
            *q = grid(&mut rng);
        }
        if n % 2 == 0 {
            p[0][1].z += f64::EPSILON;
        }
        let vf = VertexFace {
            vertex: p[0],
            face: [p[1], p[2], p[3]],
        };
        let ee = EdgeEdge {
            a: [p[0], p[1]],
            b: [p[2], p[3]],
        };
        let portable_vf = both_searches(&mut scratch, &vf, &options);
        let portable_ee = both_searches(&mut scratch, &ee, &options);
        contacts[0] += usize::from(portable_vf.is_some());
        contacts[1] += usize::from(portable_ee.is_some());
    }
    assert!(
        contacts.iter().all(|&c| c > 20),
        "{contacts:?} contacts: too few to compare"
    );
}

/// Edge a's end passes edge b's end 2^-54 apart in z, at t = 0.5,
/// where f64 rounds the gap to zero (1 - 2^-54 rounds to 1): a near
/// miss, as in the benchmark's cliff edges. The same end kept at z = 1
/// touches.
#[test]
fn a_near_miss_below_f64_resolution_is_told_from_a_touch() {
    let b = [DVec3::new(1.0, 0.5, 1.0), DVec3::new(0.0, 0.5, 2.0)].map(still);
    let a_end = [DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, 0.0)];
    let miss = EdgeEdge {
        a: [
            [
                DVec3::new(1.0, 1.0, 1.0),
                DVec3::new(1.0, 0.0, 1.0 - f64::EPSILON / 2.0),
            ],
            a_end,
        ],
        b,
    };
    assert_eq!(toi_ee(&miss), None);
    let touch = EdgeEdge {
        a: [
            [DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, 0.0, 1.0)],
            a_end,
        ],
        b,
    };
    let t = toi_ee(&touch).expect("the ends meet");
    assert!(t <= 0.5 && t > 0.5 - 1e-5, "{t}");
}

#[test]
fn a_face_reaching_a_vertex_at_the_end_of_the_step_hits_at_one() {
    let face = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
        .map(|[x, y]| [DVec3::new(x, y, -1.0), DVec3::new(x, y, 0.0)]);
    let q = VertexFace {
        vertex: still(DVec3::new(0.2, 0.2, 0.0)),
        face,
    };
    let t = toi_vf(&q).expect("touches at t = 1");
    assert!(t > 1.0 - 1e-5 && t <= 1.0, "{t}");
    let short = VertexFace {
        vertex: still(DVec3::new(0.2, 0.2, 1e-3)),
        face,
    };
    assert_eq!(toi_vf(&short), None);
}

#[test]
fn motionless_primitives_touch_at_zero_or_never() {
    let touching = VertexFace {
        vertex: still(DVec3::new(0.3, 0.3, 0.0)),
        face: floor_face(),
    };
    assert_eq!(toi_vf(&touching), Some(0.0));
    let apart = VertexFace {
        vertex: still(DVec3::new(0.3, 0.3, 1e-3)),
        face: floor_face(),
    };
    assert_eq!(toi_vf(&apart), None);
}

#[test]
fn crossing_edges_meet_and_parallel_edges_meet_only_when_they_touch() {
    let a = [
        still(DVec3::new(-1.0, 0.0, 0.0)),
        still(DVec3::new(1.0, 0.0, 0.0)),
    ];
    let crossing = EdgeEdge {
        a,
        b: [
            [DVec3::new(0.0, -1.0, 1.0), DVec3::new(0.0, -1.0, -1.0)],
            [DVec3::new(0.0, 1.0, 1.0), DVec3::new(0.0, 1.0, -1.0)],
        ],
    };
    let t = toi_ee(&crossing).expect("crosses");
    assert!(t <= 0.5 && t > 0.5 - 1e-5, "{t}");
    // Parallel edges falling onto one another, overlapping over half
    // their length, and the same edges shifted sideways past the end.
    let parallel = |x: f64| EdgeEdge {
        a,
        b: [
            [DVec3::new(x, 0.0, 1.0), DVec3::new(x, 0.0, -1.0)],
            [
                DVec3::new(x + 2.0, 0.0, 1.0),
                DVec3::new(x + 2.0, 0.0, -1.0),
            ],
        ],
    };
    assert!(toi_ee(&parallel(0.0)).is_some());
    assert!(toi_ee(&parallel(1.0)).is_some(), "end touches end");
    assert_eq!(toi_ee(&parallel(1.001)), None);
}

#[test]
fn an_edge_end_sliding_along_another_edge_meets_it_first_at_its_end() {
    // b's lower end slides along a's line and reaches a's end at 0.5;
    // the two touch at every later time too.
    let e = EdgeEdge {
        a: [
            still(DVec3::new(1.0, 1.0, 1.0)),
            still(DVec3::new(2.0, 1.0, 1.0)),
        ],
        b: [
            [DVec3::new(2.5, 1.0, 1.0), DVec3::new(1.5, 1.0, 1.0)],
            [DVec3::new(2.5, 2.0, 2.0), DVec3::new(1.5, 2.0, 2.0)],
        ],
    };
    let t = toi_ee(&e).expect("touches");
    assert!(t <= 0.5 && t > 0.5 - 1e-5, "{t}");
}

#[test]
fn parallel_edges_meeting_along_a_segment_meet_when_they_reach_each_other() {
    let a = [
        still(DVec3::new(2.0, 1.0, 1.0)),
        still(DVec3::new(2.0, 2.0, 1.0)),
    ];
    let sliding = |p: DVec3| [p, p - DVec3::new(1.5, 0.0, 0.0)];
    let b = [
        sliding(DVec3::new(3.0, 1.0, 1.0)),
        sliding(DVec3::new(3.0, 2.0, 1.0)),
    ];
    let t = toi_ee(&EdgeEdge { a, b }).expect("meet");
    assert!(t <= 2.0 / 3.0 && t > 2.0 / 3.0 - 1e-5, "{t}");
}

#[test]
fn a_vertex_sliding_in_the_face_plane_meets_it_where_it_enters() {
    let q = VertexFace {
        vertex: [DVec3::new(2.5, 1.0, 1.0), DVec3::new(1.5, 1.0, 1.0)],
        face: [
            still(DVec3::new(1.0, 1.0, 1.0)),
            still(DVec3::new(2.0, 1.0, 1.0)),
            still(DVec3::new(2.0, 1.0, 2.0)),
        ],
    };
    let t = toi_vf(&q).expect("enters the face");
    assert!(t <= 0.5 && t > 0.5 - 1e-5, "{t}");
}

#[test]
fn large_and_small_scales_decide_alike() {
    for scale in [1e-3, 1e4] {
        let options = CcdOptions {
            tolerance: 1e-6 * scale,
            ..CcdOptions::default()
        };
        let at = |x: f64, z0: f64, z1: f64| VertexFace {
            vertex: [
                DVec3::new(x, 0.25, z0) * scale,
                DVec3::new(x, 0.25, z1) * scale,
            ],
            face: floor_face().map(|c| c.map(|p| p * scale)),
        };
        let mut scratch = CcdScratch::default();
        let t = at(0.25, 1.0, -1.0).time_of_impact(&options, &mut scratch);
        assert!(
            t.is_some_and(|t| t <= 0.5 && t > 0.5 - 1e-5),
            "{scale}: {t:?}"
        );
        let miss = at(0.76, 1.0, -1.0).time_of_impact(&options, &mut scratch);
        assert_eq!(miss, None, "{scale}");
    }
}

/// `at` repeats the operations of `coordinate` (the rounding bounds
/// count them), so the two agree to the bit at every corner, in f64
/// and in double-double, on random boxes of random queries.
#[test]
fn one_corner_is_computed_as_the_eight_are() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut point = || DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
    fn agree<P: Primitives>(p: &P, d: &Domain) {
        for axis in 0..3 {
            let (c64, cdd) = (
                p.coordinate::<f64>(d, axis),
                p.coordinate::<TwoFloat>(d, axis),
            );
            for i in 0..8 {
                let (t, u, v) = corner(d, i);
                assert_eq!(p.at::<f64>(axis, t, u, v).to_bits(), c64[i].to_bits());
                let dd: TwoFloat = p.at(axis, t, u, v);
                assert_eq!((dd.hi(), dd.lo()), (cdd[i].hi(), cdd[i].lo()));
            }
        }
    }
    for _ in 0..200 {
        let range = |a: f64, b: f64| [a.min(b), a.max(b)];
        let d: Domain = [0; 3].map(|_| {
            let (a, b) = (point().x.abs(), point().y.abs());
            range(a, b)
        });
        let vf = VertexFace {
            vertex: [point(), point()],
            face: [[point(), point()], [point(), point()], [point(), point()]],
        };
        agree(&vf, &d);
        let ee = EdgeEdge {
            a: [[point(), point()], [point(), point()]],
            b: [[point(), point()], [point(), point()]],
        };
        agree(&ee, &d);
    }
}
