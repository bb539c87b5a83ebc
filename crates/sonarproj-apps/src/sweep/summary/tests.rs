//! The summaries against plain counts and sorts, any chunking, and forged parts.

use super::*;
use crate::sweep::config::Axis;

fn grid() -> Grid {
    Grid {
        axes: vec![
            Axis {
                column: "roll",
                values: vec![0.0, 10.0, 20.0],
            },
            Axis {
                column: "pitch",
                values: vec![0.0, 5.0, 10.0, 15.0],
            },
        ],
        placement: true,
    }
}

fn spec() -> SummarySpec {
    SummarySpec {
        by: "span".into(),
        top: 3,
        histogram: Some(HistogramSpec {
            min: 0.0,
            max: 1.0,
            bins: 4,
        }),
        marginals: vec![vec!["roll".into()], vec!["pitch".into(), "roll".into()]],
        rows: true,
    }
}

/// Values of 12 poses with ties, nulls and values off the histogram.
fn values() -> Vec<Option<f64>> {
    vec![
        Some(0.5),
        None,
        Some(0.25),
        Some(0.1),
        Some(0.25),
        Some(1.5),
        Some(-0.2),
        Some(0.75),
        Some(1.0),
        None,
        Some(0.1),
        Some(0.3),
    ]
}

#[test]
fn reductions_match_a_plain_count_and_sort() {
    let g = grid();
    let s = spec().summarise(Some(&g), 0, &values()).unwrap();
    assert_eq!((s.poses, s.with_value), (12, 10));
    assert_eq!(
        s.min,
        Some(Ranked {
            index: 6,
            value: -0.2
        })
    );
    assert_eq!(s.max, Some(Ranked { index: 5, value: 1.5 }));
    let idx = |r: &[Ranked]| r.iter().map(|x| x.index).collect::<Vec<_>>();
    // Ties broken by the lower index: 0.1 at poses 3 and 10, 0.25 at 2 and 4.
    assert_eq!(idx(&s.smallest), [6, 3, 10]);
    assert_eq!(idx(&s.largest), [5, 8, 7]);
    let h = s.histogram.as_ref().unwrap();
    // Bins [0, .25) [.25, .5) [.5, .75) [.75, 1]: 0.1 0.1 | 0.25 0.25 0.3 | 0.5 | 0.75 1.0.
    assert_eq!((h.counts.clone(), h.below, h.above), (vec![2, 3, 1, 2], 1, 1));
    // Roll is pose / 4, pitch pose % 4.
    let roll = &s.marginals[0];
    assert_eq!(roll.count, [3, 4, 3]);
    assert_eq!(roll.min, [Some(0.1), Some(-0.2), Some(0.1)]);
    assert_eq!(roll.max, [Some(0.5), Some(1.5), Some(1.0)]);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!((roll.mean[0].unwrap() - mean(&[0.5, 0.25, 0.1])).abs() < 1e-12);
    // Pitch × roll: the cell of pitch 5°, roll 20° (1 · 3 + 2) is pose 9 (no value).
    let pr = &s.marginals[1];
    assert_eq!(pr.values, vec![vec![0.0, 5.0, 10.0, 15.0], vec![0.0, 10.0, 20.0]]);
    assert_eq!(pr.count[5], 0);
    assert_eq!(pr.mean[5], None);
    // Pitch 15°, roll 10°: pose 1 · 4 + 3 = 7.
    assert_eq!((pr.min[3 * 3 + 1], pr.count[3 * 3 + 1]), (Some(0.75), 1));
}

#[test]
fn any_chunking_combines_to_the_same_bits() {
    let g = grid();
    let spec = spec();
    let v = values();
    let whole = spec.summarise(Some(&g), 0, &v).unwrap();
    for cuts in [
        vec![0, 12],
        vec![0, 1, 12],
        vec![0, 5, 6, 11, 12],
        (0..=12).collect(),
    ] {
        // Each part through its file's form (sparse cells, JSON text) and back, as on disk.
        let parts: Vec<Summary> = cuts
            .windows(2)
            .map(|w| {
                let part = spec
                    .summarise(Some(&g), w[0] as u64, &v[w[0]..w[1]])
                    .unwrap()
                    .to_part();
                let text = serde_json::to_string(&part).unwrap();
                let s = serde_json::from_str::<PartSummary>(&text)
                    .unwrap()
                    .into_summary(&spec.empty(Some(&g)), "t")
                    .unwrap();
                spec.check(&s, w[0] as u64, (w[1] - w[0]) as u64, "t").unwrap();
                s
            })
            .collect();
        let forward = parts[1..]
            .iter()
            .fold(parts[0].clone(), |acc, p| spec.combine(&acc, p, "t").unwrap());
        let backward = parts[..parts.len() - 1]
            .iter()
            .rev()
            .fold(parts[parts.len() - 1].clone(), |acc, p| {
                spec.combine(p, &acc, "t").unwrap()
            });
        assert_eq!(forward, whole, "{cuts:?}");
        assert_eq!(backward, whole, "{cuts:?}");
        assert_eq!(
            serde_json::to_string(&forward).unwrap(),
            serde_json::to_string(&whole).unwrap()
        );
    }
}

#[test]
fn a_part_that_does_not_hold_together_is_refused() {
    let g = grid();
    let spec = spec();
    let good = spec.summarise(Some(&g), 4, &values()[4..8]).unwrap();
    spec.check(&good, 4, 4, "t").unwrap();
    let refused = |s: &Summary, words: &str| {
        let e = spec.check(s, 4, 4, "t").unwrap_err().to_string();
        assert!(e.contains(words), "{e}");
    };
    refused(
        &Summary {
            poses: 5,
            ..good.clone()
        },
        "5 poses",
    );
    refused(
        &Summary {
            smallest: good.smallest[..1].to_vec(),
            ..good.clone()
        },
        "1 smallest",
    );
    let mut moved = good.clone();
    moved.largest[0].index = 99;
    refused(&moved, "outside poses 4 to 7");
    let mut cut = good.clone();
    cut.histogram.as_mut().unwrap().counts.pop();
    refused(&cut, "histogram");
    let mut wrapped = good.clone();
    wrapped.marginals[0].count[0] = u64::MAX;
    refused(&wrapped, "marginal over [\"roll\"]");
    refused(
        &Summary {
            metric: "area".into(),
            ..good.clone()
        },
        "summarises \"area\"",
    );
    // Counts that overflow when combined are an error, not a wrap.
    let mut big = good.clone();
    big.with_value = u64::MAX;
    assert!(
        spec.combine(&big, &good, "t")
            .unwrap_err()
            .to_string()
            .contains("overflows")
    );
}

#[test]
fn bad_specs_name_the_key() {
    let g = grid();
    let e = |s: SummarySpec| s.checked("s.toml", Some(&g)).unwrap_err().to_string();
    assert!(
        e(SummarySpec {
            top: MAX_TOP + 1,
            ..spec()
        })
        .contains("summary.top")
    );
    let flat = SummarySpec {
        histogram: Some(HistogramSpec {
            min: 1.0,
            max: 1.0,
            bins: 4,
        }),
        ..spec()
    };
    assert!(e(flat).contains("min < max"));
    for (min, max, bins) in [
        (-1e308, 1e308, 2),
        (1.0, 1.000_000_000_000_000_2, 1000),
        (0.0, 5e-324, 100),
    ] {
        let h = SummarySpec {
            histogram: Some(HistogramSpec { min, max, bins }),
            ..spec()
        };
        assert!(e(h).contains("non-zero width"), "{min} {max} {bins}");
    }
    let yaw = SummarySpec {
        marginals: vec![vec!["yaw".into()]],
        ..spec()
    };
    assert!(e(yaw).contains("not a grid axis (the axes: roll, pitch)"));
    let list = spec().checked("s.toml", None).unwrap_err().to_string();
    assert!(list.contains("needs a grid"), "{list}");
}

/// Summarising a long chunk in pieces on all cores gives the same bytes as one pass.
/// Ties across pieces go to the lower index. Pieces added one by one to a summary agree too.
#[test]
fn pieces_on_all_cores_make_the_summary_of_one_pass() {
    let g = grid();
    let spec = spec();
    // 100 003 values cycling through the 12 with ties, nulls and out-of-range values, offset so
    // the grid's cells are visited in every phase.
    let base = values();
    let v: Vec<Option<f64>> = (0..100_003)
        .map(|i| base[(i * 7 + i / 13) % base.len()])
        .collect();
    let nan: Vec<f64> = v.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    let mut whole = spec.empty(Some(&g));
    spec.add(&mut whole, Some(&g), 5, &nan).unwrap();
    super::fill_means(&mut whole);
    let pieces = spec.summarise(Some(&g), 5, &v).unwrap();
    assert_eq!(
        serde_json::to_string(&pieces).unwrap(),
        serde_json::to_string(&whole).unwrap()
    );
    let mut running = spec.empty(Some(&g));
    for (k, piece) in nan.chunks(9_999).enumerate().rev() {
        spec.add(&mut running, Some(&g), 5 + (k * 9_999) as u64, piece)
            .unwrap();
    }
    super::fill_means(&mut running);
    assert_eq!(
        serde_json::to_string(&running).unwrap(),
        serde_json::to_string(&whole).unwrap()
    );
}

/// The marginals' min and max of +0 and -0 do not depend on which comes first (`f64::min` may
/// return either), so pieces grouped differently by the thread pool print the same zero.
#[test]
fn signed_zeros_pick_the_same_whichever_comes_first() {
    use super::{greatest, least};
    for (a, b) in [(0.0, -0.0), (-0.0, 0.0)] {
        assert_eq!(least(a, b).to_bits(), (-0.0f64).to_bits());
        assert_eq!(greatest(a, b).to_bits(), 0.0f64.to_bits());
    }
    assert_eq!(least(1.0, 2.0), 1.0);
    assert_eq!(greatest(1.0, 2.0), 2.0);
}

/// Fixed point rounds as `f64::round` does (halves away from zero) on both of its paths: the
/// 64-bit one and the 128-bit one above 2^62 units; means divide in 64 bits as in 128.
#[test]
fn fixed_point_rounds_as_round_does() {
    use super::{FIXED_BITS, fixed, mean_of};
    let unit = f64::from(FIXED_BITS).exp2();
    let mut cases = vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        1e-13,
        -1e-13,
        0.1,
        -0.7,
        123.456,
        -98_765.432,
    ];
    for k in [0.5, 1.5, 2.5, 1e6 + 0.5, 0.499_999_999_999_999_94] {
        cases.push(k / unit);
        cases.push(-k / unit);
    }
    for p in [61, 62, 63, 70, 79] {
        for x in [2f64.powi(p) / unit, (2f64.powi(p) + 2048.0) / unit] {
            cases.push(x);
            cases.push(-x);
        }
    }
    for x in cases {
        let want = (x * unit).round();
        #[expect(clippy::cast_possible_truncation, reason = "below 2^80 here")]
        let want = want as i128;
        assert_eq!(fixed(x), Some(want), "{x:e}");
    }
    assert_eq!(fixed(2f64.powi(41)), None);
    assert_eq!(fixed(f64::INFINITY), None);
    // 2^70 / 3 in 128 bits, -7 / 2 and 7 / 2 in 64: quotient and remainder taken the same way.
    let big = 1i128 << 70;
    assert_eq!(
        mean_of(big, 3),
        Some((big / 3) as f64 / unit + (big % 3) as f64 / 3.0 / unit)
    );
    assert_eq!(mean_of(-7, 2), Some(-3.5 / unit));
    assert_eq!(mean_of(7, 2), Some(3.5 / unit));
    assert_eq!(mean_of(5, 0), None);
}

/// The extremes and rankings order -0 below +0 (IEEE total order), whichever comes first, and
/// ties of equal values go to the lower index: what a sort by (total order, index) gives.
#[test]
fn extremes_and_rankings_follow_the_total_order_on_ties() {
    let spec = SummarySpec {
        top: 2,
        histogram: None,
        marginals: Vec::new(),
        ..spec()
    };
    for v in [
        vec![Some(0.0), Some(-0.0), Some(0.0), Some(-0.0)],
        vec![Some(-0.0), Some(0.0), Some(-0.0), Some(0.0)],
        vec![Some(1.0), Some(0.5), Some(1.0), Some(0.5), Some(0.75)],
    ] {
        let s = spec.summarise(None, 0, &v).unwrap();
        let mut sorted: Vec<Ranked> = v
            .iter()
            .enumerate()
            .map(|(k, x)| Ranked {
                index: k as u64,
                value: x.unwrap(),
            })
            .collect();
        sorted.sort_by(|a, b| a.value.total_cmp(&b.value).then(a.index.cmp(&b.index)));
        let first = |s: &[Ranked]| s.iter().map(|r| (r.index, r.value.to_bits())).collect::<Vec<_>>();
        assert_eq!(first(&s.smallest), first(&sorted[..2]), "{v:?}");
        assert_eq!(first(&s.min.into_iter().collect::<Vec<_>>()), first(&sorted[..1]));
        sorted.sort_by(|a, b| b.value.total_cmp(&a.value).then(a.index.cmp(&b.index)));
        assert_eq!(first(&s.largest), first(&sorted[..2]), "{v:?}");
        assert_eq!(first(&s.max.into_iter().collect::<Vec<_>>()), first(&sorted[..1]));
    }
}

/// Marginals taken segment by segment agree with each pose put in its cell by division.
/// Covers axes of one or many values, one or two per-pose axes, both orders within a pair,
/// and pieces starting anywhere.
#[test]
fn marginals_match_each_pose_put_in_its_cell() {
    let axis = |column, n: usize| Axis {
        column,
        values: (0..n).map(|i| i as f64).collect(),
    };
    let g = Grid {
        // A one-value axis last: two axes (yaw2, last) change their digit every pose.
        axes: vec![
            axis("roll", 3),
            axis("pitch", 1),
            axis("yaw", 5),
            axis("yaw2", 4),
            axis("last", 1),
        ],
        placement: true,
    };
    let sizes: Vec<u64> = g.axes.iter().map(|a| a.values.len() as u64).collect();
    let poses: u64 = sizes.iter().product();
    let marginals: Vec<Vec<String>> = [
        &["roll"][..],
        &["pitch"],
        &["yaw2"],
        &["yaw", "roll"],
        &["roll", "yaw"],
        &["yaw2", "yaw"],
        &["yaw", "yaw2"],
        &["pitch", "yaw2"],
        &["last"],
        &["yaw2", "last"],
        &["last", "roll"],
    ]
    .iter()
    .map(|m| m.iter().map(|a| (*a).to_string()).collect())
    .collect();
    let spec = SummarySpec {
        by: "span".into(),
        top: 0,
        histogram: None,
        marginals: marginals.clone(),
        rows: false,
    };
    // Two laps of the grid, with gaps and repeated values.
    let value = |i: u64| (i % 7 != 3).then(|| ((i * 37) % 11) as f64 * 0.125 - 0.5);
    let total = 2 * poses;
    for (first, piece) in [(0, total), (5, 1), (7, 13), (59, 61), (1, total - 1)] {
        let v: Vec<f64> = (first..first + piece)
            .map(|i| value(i).unwrap_or(f64::NAN))
            .collect();
        let mut s = spec.empty(Some(&g));
        spec.add(&mut s, Some(&g), first, &v).unwrap();
        for (axes, m) in marginals.iter().zip(&s.marginals) {
            let cells: usize = axes
                .iter()
                .map(|a| g.axes.iter().find(|x| x.column == a).unwrap().values.len())
                .product();
            let (mut count, mut sum) = (vec![0u64; cells], vec![0i128; cells]);
            let (mut min, mut max) = (vec![None::<f64>; cells], vec![None::<f64>; cells]);
            for i in first..first + piece {
                let Some(x) = value(i) else { continue };
                // The value of each axis at pose i (the last axis fastest), then the cell.
                let mut rest = i % poses;
                let mut at = vec![0; sizes.len()];
                for k in (0..sizes.len()).rev() {
                    at[k] = rest % sizes[k];
                    rest /= sizes[k];
                }
                let mut c = 0;
                for a in axes {
                    let k = g.axes.iter().position(|x| x.column == a).unwrap();
                    c = c * sizes[k] + at[k];
                }
                let c = usize::try_from(c).unwrap();
                count[c] += 1;
                sum[c] += fixed(x).unwrap();
                min[c] = Some(min[c].map_or(x, |y: f64| y.min(x)));
                max[c] = Some(max[c].map_or(x, |y: f64| y.max(x)));
            }
            let case = format!("{axes:?} from {first}, {piece} poses");
            assert_eq!(m.count, count, "{case}");
            assert_eq!(m.sum, sum, "{case}");
            assert_eq!(m.min, min, "{case}");
            assert_eq!(m.max, max, "{case}");
        }
    }
}

/// A value too large for the marginals' exact sums is refused, naming the first pose that has
/// one, whichever marginal's task finds it and however the rest is cut into pieces.
#[test]
fn a_value_too_large_for_exact_sums_names_its_first_pose() {
    let g = grid();
    let spec = spec();
    let mut v = vec![0.5; 100_000];
    v[90_000] = 2f64.powi(41);
    v[70_000] = -2f64.powi(45);
    for _ in 0..3 {
        let e = spec.partial(Some(&g), 11, &v).unwrap_err().to_string();
        assert!(e.contains("summary of span at pose 70011"), "{e}");
        assert!(e.contains("too large for the marginals' exact sums"), "{e}");
    }
    // Below 2^40 the sums stay exact, and nothing is refused.
    v[90_000] = 2f64.powi(39);
    v[70_000] = -2f64.powi(39);
    assert!(spec.partial(Some(&g), 11, &v).is_ok());
    // Without marginals no sum is kept, and no value is too large.
    let bare = SummarySpec {
        marginals: Vec::new(),
        ..spec
    };
    v[70_000] = 2f64.powi(100);
    assert!(bare.partial(Some(&g), 11, &v).is_ok());
}

/// Values too large for the quick exact term (2^22 and more) but within 2^40 take the checked
/// way, in both kinds of segment, to the sums, counts and extremes a pose-by-pose count gives.
#[test]
fn large_values_take_the_checked_way_to_the_same_cells() {
    let g = grid();
    let spec = spec();
    let first = 7u64;
    let v: Vec<f64> = (0..50_000u32)
        .map(|i| match i % 11 {
            0 => 2f64.powi(39) - f64::from(i),
            3 => -(2f64.powi(30)) + 0.3,
            5 => f64::NAN,
            7 => -0.0,
            _ => f64::from(i % 97) * 0.013,
        })
        .collect();
    let s = spec.partial(Some(&g), first, &v).unwrap();
    // Pose p: roll (3 values) is p / 4 % 3, pitch (4 values) p % 4. The marginals are roll,
    // and pitch × roll (roll fastest).
    let cell = |p: u64| usize::try_from(p % 4 * 3 + p / 4 % 3).unwrap();
    for (j, m) in s.marginals.iter().enumerate() {
        let cell_of = |p: u64| if j == 0 { cell(p) % 3 } else { cell(p) };
        let n = m.count.len();
        let (mut count, mut sum) = (vec![0u64; n], vec![0i128; n]);
        let (mut min, mut max) = (vec![None::<f64>; n], vec![None::<f64>; n]);
        for (k, &x) in v.iter().enumerate() {
            if x.is_nan() {
                continue;
            }
            let c = cell_of(first + k as u64);
            count[c] += 1;
            sum[c] += fixed(x).unwrap();
            min[c] = Some(min[c].map_or(x, |y: f64| if x.total_cmp(&y).is_lt() { x } else { y }));
            max[c] = Some(max[c].map_or(x, |y: f64| if x.total_cmp(&y).is_gt() { x } else { y }));
        }
        assert_eq!(m.count, count, "{:?}", m.axes);
        assert_eq!(m.sum, sum, "{:?}", m.axes);
        let bits = |v: &[Option<f64>]| v.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&m.min), bits(&min), "{:?}", m.axes);
        assert_eq!(bits(&m.max), bits(&max), "{:?}", m.axes);
    }
}
