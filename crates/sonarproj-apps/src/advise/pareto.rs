//! The Pareto front of the feasible candidates over the three things a rig designer weighs: the
//! share of features both sonars see (more is better), the ambiguity of a shared feature's match
//! (its mean projection metric, less is better) and the recovery sigma (median, less is better).

use crate::advise::score::Score;

/// Returns the non-dominated candidates among `ranked` (indices into `scores`), in the order of
/// their shared share, most first. A candidate is dominated when another shares at least as
/// much, with no larger ambiguity and sigma, and is better in one of the three. A missing
/// ambiguity or sigma counts as the worst. Equal candidates are all kept.
#[must_use]
pub fn front(scores: &[Score], ranked: &[usize]) -> Vec<usize> {
    let key = |i: usize| {
        let s = &scores[i];
        let worst = |v: Option<f64>| v.filter(|v| !v.is_nan()).unwrap_or(f64::INFINITY);
        (-s.shared, worst(s.metric.mean), worst(s.sigma.median))
    };
    let mut order: Vec<usize> = ranked.to_vec();
    // In lexicographic order no candidate is dominated by a later one, so each is checked
    // against the front found so far alone.
    order.sort_by(|&a, &b| {
        let (x, y) = (key(a), key(b));
        x.0.total_cmp(&y.0)
            .then(x.1.total_cmp(&y.1))
            .then(x.2.total_cmp(&y.2))
            .then(a.cmp(&b))
    });
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        let k = key(i);
        let dominated = kept.iter().any(|&j| {
            let f = key(j);
            f.0 <= k.0 && f.1 <= k.1 && f.2 <= k.2 && (f.0 < k.0 || f.1 < k.1 || f.2 < k.2)
        });
        if !dominated {
            kept.push(i);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::front;
    use crate::advise::score::{Score, Stats};

    fn score(shared: f64, ambiguity: Option<f64>, sigma: Option<f64>) -> Score {
        Score {
            rotation: [0.0; 3],
            offset: [0.0; 3],
            translation: [0.0; 3],
            shared,
            shared_se: 0.0,
            examined: 100,
            features: 1,
            metric: Stats {
                mean: ambiguity,
                ..Stats::default()
            },
            sigma: Stats {
                median: sigma,
                ..Stats::default()
            },
            score: Some(0.0),
            score_se: None,
            tied: false,
        }
    }

    #[test]
    fn the_front_is_what_brute_force_finds() {
        // Random candidates on a coarse lattice (many ties), some without a sigma or ambiguity:
        // a candidate is on the front exactly when no other dominates it, checked pair by pair.
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..50 {
            let n = rng.random_range(1..60);
            let pick = |rng: &mut rand_chacha::ChaCha8Rng| {
                let v = f64::from(rng.random_range(0..5u8));
                (rng.random_range(0..8u8) > 0).then_some(v)
            };
            let scores: Vec<Score> = (0..n)
                .map(|_| {
                    let shared = f64::from(rng.random_range(1..5u8)) / 4.0;
                    score(shared, pick(&mut rng), pick(&mut rng))
                })
                .collect();
            let ranked: Vec<usize> = (0..n).collect();
            let mut got = front(&scores, &ranked);
            got.sort_unstable();
            let key = |s: &Score| {
                let w = |v: Option<f64>| v.unwrap_or(f64::INFINITY);
                (s.shared, w(s.metric.mean), w(s.sigma.median))
            };
            let dominates = |a: &Score, b: &Score| {
                let (x, y) = (key(a), key(b));
                x.0 >= y.0 && x.1 <= y.1 && x.2 <= y.2 && (x.0 > y.0 || x.1 < y.1 || x.2 < y.2)
            };
            let want: Vec<usize> = (0..n)
                .filter(|&i| !(0..n).any(|j| dominates(&scores[j], &scores[i])))
                .collect();
            assert_eq!(got, want);
        }
    }
}
