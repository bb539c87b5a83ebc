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
        let worst = |v: Option<f64>| v.unwrap_or(f64::INFINITY);
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
