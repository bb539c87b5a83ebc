//! The fast twin's root finding (`fast.rs`): the roots of polynomials of degree 2 and 4 in
//! `s = tan(φ/2)` on an interval, each bracketed and polished by Newton's method, and the closed
//! form's unpolished roots of a quadratic. The GPU's twin is `shaders/shared/roots_f64.wgsl`.

use super::roots::{List, newton_root_between};

/// Where the roots' Newton's method stops ([`newton_root_between`]): a step of 1e-8 leaves an
/// error of the order of 1e-16 near a simple root, without the reference's last evaluation.
const SETTLE: f64 = 1e-8;

/// Returns the value and the derivative of `c[0] + c[1] x + … ` (degree `n`) at `x`.
#[inline]
pub(super) fn horner(c: &[f64; 5], n: usize, x: f64) -> (f64, f64) {
    let (mut v, mut d) = (c[n], 0.0);
    for k in (0..n).rev() {
        d = d * x + v;
        v = v * x + c[k];
    }
    (v, d)
}

/// Appends the roots in `[lo, hi]` of `c[0] + c[1] s + c[2] s²` where it changes sign, in
/// increasing order. The closed form's roots start a bracketed Newton's method on each monotone
/// side of the vertex, which takes them to within a rounding or two.
pub(super) fn quadratic_roots<const N: usize>(c: [f64; 3], lo: f64, hi: f64, out: &mut List<N>) {
    let [c0, c1, c2] = c;
    if c2 == 0.0 {
        if c1 != 0.0 {
            let x = -c0 / c1;
            if (lo..=hi).contains(&x) {
                out.push(x);
            }
        }
        return;
    }
    let f = |x: f64| ((c2 * x + c1) * x + c0, 2.0 * c2 * x + c1);
    let vertex = -c1 / (2.0 * c2);
    let d = c1 * c1 - 4.0 * c2 * c0;
    let (g0, g1) = if d > 0.0 {
        // The stable form: no cancellation in either root.
        let q = -0.5 * (c1 + d.sqrt().copysign(c1));
        let (x, y) = (q / c2, c0 / q);
        (x.min(y), x.max(y))
    } else {
        (vertex, vertex)
    };
    let mut push = |r: Option<f64>| {
        if let Some(x) = r {
            out.push(x);
        }
    };
    let (f_lo, f_hi) = (f(lo).0, f(hi).0);
    if vertex > lo && vertex < hi {
        let f_vertex = f(vertex).0;
        push(newton_root_between(
            &f,
            [lo, vertex],
            [f_lo, f_vertex],
            Some(g0),
            SETTLE,
        ));
        push(newton_root_between(
            &f,
            [vertex, hi],
            [f_vertex, f_hi],
            Some(g1),
            SETTLE,
        ));
    } else {
        let g = if (lo..=hi).contains(&g0) { g0 } else { g1 };
        push(newton_root_between(&f, [lo, hi], [f_lo, f_hi], Some(g), SETTLE));
    }
}

/// Appends the roots in `[lo, hi]` of the polynomial `g` of degree at most 4 where it changes
/// sign, in increasing order.
///
/// The roots of `g''` (a quadratic, closed form) cut the interval into pieces where `g'` is
/// monotone, so `g` turns at most once in each. Where `g'` has the same sign at a piece's ends,
/// `g` is monotone there and a sign change brackets its one root. Otherwise the turning point
/// (the root of `g'`) splits the piece into two monotone halves. Every root is then found by a
/// bracketed Newton's method, to the last bits; only the pieces that turn need `g'`'s root.
/// `hints` are guesses of turning points (NaN for none): only starts, never trusted.
pub(super) fn quartic_roots(g: &[f64; 5], lo: f64, hi: f64, hints: [f64; 2], out: &mut List) {
    let mut d1 = [0.0; 5];
    for k in 1..5 {
        d1[k - 1] = g[k] * k as f64;
    }
    let d2 = [d1[1], 2.0 * d1[2], 3.0 * d1[3]];
    // The ends, and the second derivative's two roots at most.
    let mut cuts = List::<4>::default();
    cuts.push(lo);
    quadratic_roots(d2, lo, hi, &mut cuts);
    cuts.push(hi);
    let value = |x: f64| horner(g, 4, x);
    let slope = |x: f64| {
        let (v, _) = horner(&d1, 3, x);
        (v, (d2[2] * x + d2[1]) * x + d2[0])
    };
    let mut push = |r: Option<f64>| {
        if let Some(x) = r {
            out.push(x);
        }
    };
    let cut = cuts.as_slice();
    let mut left = (cut[0], value(cut[0]));
    for &b in &cut[1..] {
        let right = (b, value(b));
        let ((a, (ga, da)), (_, (gb, db))) = (left, right);
        left = right;
        if b <= a {
            continue;
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            // g turns once inside, at a maximum when it rises first (else a minimum): split the
            // piece there into two halves, each with at most one root.
            let peak = da > 0.0;
            // A point beyond which g turns back serves as well as the turning point: where g is
            // above 0 at a maximum (below at a minimum), each half's ends differ in sign exactly
            // when the half holds a root, and holds one. A thin fan's bound has its maximum near
            // the height's zero, where g = sin² e ρ² > 0: so the hint spares the turning point.
            let hinted = hints.into_iter().find(|&h| h > a && h < b).and_then(|h| {
                let gh = value(h).0;
                (if peak { gh > 0.0 } else { gh < 0.0 }).then_some((h, gh))
            });
            let split = hinted.or_else(|| {
                // The turning point itself; it only splits the piece: 1e-6 leaves it within ~1e-12.
                let m = newton_root_between(&slope, [a, b], [da, db], None, 1e-6)?;
                Some((m, value(m).0))
            });
            let Some((m, gm)) = split else {
                continue;
            };
            // Near m, g ≈ g(m) + g'(m) d + g''(m) d²/2: its roots start the searches.
            let (d1m, d2m) = slope(m);
            let [l, r] = closed_form_roots([gm, d1m, 0.5 * d2m]).map(|d| m + d);
            let start = |x: f64| x.is_finite().then_some(x);
            let (l, r) = (l.min(r), l.max(r));
            push(newton_root_between(&value, [a, m], [ga, gm], start(l), SETTLE));
            push(newton_root_between(&value, [m, b], [gm, gb], start(r), SETTLE));
        } else {
            push(newton_root_between(&value, [a, b], [ga, gb], None, SETTLE));
        }
    }
}

/// Returns the closed form's roots of `c[0] + c[1] s + c[2] s²` (NaN where there are none),
/// unpolished: guesses.
pub(super) fn closed_form_roots([c0, c1, c2]: [f64; 3]) -> [f64; 2] {
    let d = c1 * c1 - 4.0 * c2 * c0;
    if d.is_nan() || d < 0.0 {
        return [f64::NAN; 2];
    }
    let q = -0.5 * (c1 + d.sqrt().copysign(c1));
    [q / c2, c0 / q]
}
