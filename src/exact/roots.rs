//! Real roots on an interval, for the exact arc: of polynomials of degree at most 4, and of
//! first-degree trigonometric functions `a + b cos φ + c sin φ`.
//!
//! Polynomial roots are isolated by their derivatives. The roots of `p'` cut the interval into
//! pieces on which `p` is monotone. A piece holds a root exactly when `p` changes sign across it,
//! and bisection then finds that root to the last bit. The recursion ends at degree 1. Nothing
//! here divides by a leading coefficient, so a nearly degenerate polynomial is handled like any
//! other.
//!
//! A root where `p` touches zero without changing sign (a double root, a tangency) is reported
//! only when `p` evaluates to exactly 0 there. For the arc that is a single point, which no
//! length, extreme or cell depends on; a cut there only splits a piece in two alike.

/// Most coefficients of a polynomial here (degree 4).
pub(crate) const TERMS: usize = 5;

/// A polynomial `c[0] + c[1] x + … + c[4] x⁴`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Poly(pub [f64; TERMS]);

impl Poly {
    /// Returns the value at `x` (Horner).
    pub(crate) fn at(&self, x: f64) -> f64 {
        self.0.iter().rev().fold(0.0, |acc, &c| acc * x + c)
    }

    /// Returns the derivative.
    fn derivative(&self) -> Poly {
        let mut d = [0.0; TERMS];
        for k in 1..TERMS {
            d[k - 1] = self.0[k] * k as f64;
        }
        Poly(d)
    }

    /// Returns the degree: the index of the last non-zero coefficient (0 for a constant).
    fn degree(&self) -> usize {
        (0..TERMS).rev().find(|&k| self.0[k] != 0.0).unwrap_or(0)
    }

    /// Returns the product of two polynomials whose degrees sum to at most 4.
    pub(crate) fn times(&self, other: &Poly) -> Poly {
        let mut out = [0.0; TERMS];
        for (i, &a) in self.0.iter().enumerate() {
            for (j, &b) in other.0.iter().enumerate() {
                if a != 0.0 && b != 0.0 {
                    debug_assert!(i + j < TERMS, "product of degree {} > 4", i + j);
                    out[i + j] += a * b;
                }
            }
        }
        Poly(out)
    }

    /// Returns `self + k · other`.
    pub(crate) fn plus_scaled(&self, k: f64, other: &Poly) -> Poly {
        let mut out = self.0;
        for (o, b) in out.iter_mut().zip(other.0) {
            *o += k * b;
        }
        Poly(out)
    }
}

/// A short list of reals kept on the stack: the roots and cuts of one arc (at most a few
/// dozen), so solving a pose allocates nothing. `N` values at most (32 by default).
#[derive(Clone, Copy, Debug)]
pub(crate) struct List<const N: usize = 32> {
    values: [f64; N],
    len: usize,
}

impl<const N: usize> Default for List<N> {
    fn default() -> Self {
        List {
            values: [0.0; N],
            len: 0,
        }
    }
}

impl<const N: usize> List<N> {
    /// The most values the default list holds: an arc has at most 2 ends, 2 × 2 range roots,
    /// 2 × 2 azimuth roots, 2 × 2 axis-plane roots and 4 elevation roots (18), and a piece at
    /// most 2 ends and 4 stationary points.
    pub(crate) const CAPACITY: usize = N;

    /// Appends `x` unless it repeats the last value.
    pub(crate) fn push(&mut self, x: f64) {
        if self.len > 0 && self.values[self.len - 1] == x {
            return;
        }
        assert!(self.len < Self::CAPACITY, "more roots than an arc can have");
        self.values[self.len] = x;
        self.len += 1;
    }

    /// Returns the values.
    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.values[..self.len]
    }

    /// Sorts the values and drops repeats.
    pub(crate) fn sort(&mut self) {
        let v = &mut self.values[..self.len];
        v.sort_unstable_by(f64::total_cmp);
        let mut n = 0;
        for k in 0..self.len {
            if n == 0 || self.values[k] != self.values[n - 1] {
                self.values[n] = self.values[k];
                n += 1;
            }
        }
        self.len = n;
    }
}

/// Appends to `out` the roots of `p` in `[lo, hi]` where `p` changes sign, in increasing order.
pub(crate) fn poly_roots(p: &Poly, lo: f64, hi: f64, out: &mut List) {
    match p.degree() {
        0 => {}
        1 => {
            let x = -p.0[0] / p.0[1];
            if (lo..=hi).contains(&x) {
                out.push(x);
            }
        }
        _ => {
            let dp = p.derivative();
            let mut cuts = List::default();
            cuts.push(lo);
            poly_roots(&dp, lo, hi, &mut cuts);
            cuts.push(hi);
            for w in cuts.as_slice().windows(2) {
                if let Some(x) = newton_root(&|x| (p.at(x), dp.at(x)), w[0], w[1]) {
                    out.push(x);
                }
            }
        }
    }
}

/// Starts a search for a root of `f` in `[a, b]` from its end values `fa`, `fb`: `Ok` with
/// whether `f(a) < 0` when a root lies inside, `Err` with the answer when the ends settle it
/// (an end where `f` is 0 is the root; no sign change, or a NaN end, has none).
fn bracket(a: f64, b: f64, fa: f64, fb: f64) -> Result<bool, Option<f64>> {
    if fa == 0.0 {
        return Err(Some(a));
    }
    if fb == 0.0 {
        return Err(Some(b));
    }
    if (fa < 0.0) == (fb < 0.0) || a.is_nan() || b.is_nan() {
        return Err(None);
    }
    Ok(fa < 0.0)
}

/// Returns the root of `f` in `[a, b]` when `f` changes sign across it (an end where `f` is 0
/// counts); `f` gives its value and derivative and is taken as monotone there.
///
/// Newton's method kept inside the bracket: a step that would leave it, or that does not
/// shrink, is replaced by a bisection, so it converges as bisection does at worst and in a few
/// steps near a simple root.
pub(crate) fn newton_root(f: &impl Fn(f64) -> (f64, f64), a: f64, b: f64) -> Option<f64> {
    newton_root_between(f, [a, b], [f(a).0, f(b).0], None, SETTLED)
}

/// The step, relative to the bracket's ends, at which [`newton_root`] stops: a few
/// roundings, so its roots are exact to the last bits.
pub(crate) const SETTLED: f64 = 4.0 * f64::EPSILON;

/// Returns [`newton_root`]'s root of `f` in `[a, b]`, from `start` when it lies inside (a
/// closed form's guess) else from the secant's point, given `f`'s values `[fa, fb]` at the
/// ends (a caller that has them saves two evaluations), stopping at a step of `settle` relative
/// to the bracket's ends. Newton's error squares at each step near a simple root, so a step of
/// `1e-8` leaves an error of the order of `1e-16`: a looser `settle` saves the last evaluation.
#[inline]
pub(crate) fn newton_root_between(
    f: &impl Fn(f64) -> (f64, f64),
    [a, b]: [f64; 2],
    [fa, fb]: [f64; 2],
    start: Option<f64>,
    settle: f64,
) -> Option<f64> {
    let lo_negative = match bracket(a, b, fa, fb) {
        Ok(negative) => negative,
        Err(settled) => return settled,
    };
    let (mut lo, mut hi) = (a, b);
    let mut x = match start {
        Some(s) if s > a && s < b => s,
        _ => (a - fa * (b - a) / (fb - fa)).clamp(a, b),
    };
    let mut last_step = b - a;
    for _ in 0..200 {
        let (fx, dx) = f(x);
        if fx == 0.0 {
            return Some(x);
        }
        if (fx < 0.0) == lo_negative {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - fx / dx;
        let step = (newton - x).abs();
        // A step of `settle` of the bracket's size: converged (by default Newton now only jitters).
        if newton > lo && newton < hi && step <= settle * lo.abs().max(hi.abs()) {
            return Some(newton);
        }
        let next = if dx != 0.0 && newton > lo && newton < hi && step < 0.5 * last_step {
            last_step = step;
            newton
        } else {
            last_step = hi - lo;
            0.5 * (lo + hi)
        };
        if next == x || next <= lo || next >= hi {
            // Converged: the bracket is a float or two wide, or Newton stopped moving.
            return Some(if next <= lo || next >= hi {
                0.5 * (lo + hi)
            } else {
                next
            });
        }
        x = next;
    }
    Some(x)
}

/// Returns the root of `f` in `[a, b]` when `f` changes sign across it (an end where `f` is 0
/// counts), found by bisection to the last bit; `f` is taken as monotone there.
pub(crate) fn monotone_root(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
    let (fa, fb) = (f(a), f(b));
    let lo_negative = match bracket(a, b, fa, fb) {
        Ok(negative) => negative,
        Err(settled) => return settled,
    };
    let (mut lo, mut hi) = (a, b);
    // Each step halves the bracket; 200 steps reach adjacent floats from any start.
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        let fm = f(mid);
        if fm == 0.0 {
            return Some(mid);
        }
        if (fm < 0.0) == lo_negative {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Appends to `out` the roots in `[lo, hi]` (within `(−π, π]`) of `a + b cos φ + c sin φ`
/// where it changes sign, in increasing order.
///
/// Closed form: `b cos φ + c sin φ = m cos(φ − α)` with `m = √(b² + c²)`, `α = atan2(c, b)`,
/// so the roots are `α ± acos(−a / m)`. Each is polished by Newton's method on the function
/// itself, kept within a bracket around the guess: `acos` near ±1 loses half the digits. A
/// function that does not change sign (`|a| ≥ m`) has none.
pub(crate) fn trig_roots(a: f64, b: f64, c: f64, lo: f64, hi: f64, out: &mut List) {
    use std::f64::consts::PI;
    let m = b.hypot(c);
    if m == 0.0 || a.abs() >= m {
        return;
    }
    let f = |phi: f64| {
        let (s, co) = phi.sin_cos();
        (a + b * co + c * s, c * co - b * s)
    };
    let alpha = c.atan2(b);
    let delta = (-a / m).acos();
    let mut found = [f64::NAN; 2];
    for (k, guess) in [alpha - delta, alpha + delta].into_iter().enumerate() {
        // Into (−π, π]: α and δ lie in [−π, π] and [0, π], so one turn at most.
        let g = if guess <= -PI {
            guess + 2.0 * PI
        } else if guess > PI {
            guess - 2.0 * PI
        } else {
            guess
        };
        // A guess far outside the interval needs no polish (its error is below 1e-7).
        if g < lo - 1e-6 || g > hi + 1e-6 {
            continue;
        }
        // The root lies within a few 1e-8 of the guess (acos's error near ±1 is √ε), and the
        // two roots are 2δ apart: the bracket is widened until f changes sign across it, and
        // kept below δ so that it holds one root.
        let mut h = 1e-9_f64.max(1e-3 * delta).min(0.5 * delta);
        let mut root = None;
        while h <= delta.max(1e-300) {
            root = newton_root(&f, g - h, g + h);
            if root.is_some() {
                break;
            }
            h *= 16.0;
        }
        if let Some(x) = root
            && (lo..=hi).contains(&x)
        {
            found[k] = x;
        }
    }
    if found[0] > found[1] {
        found.swap(0, 1);
    }
    for x in found {
        if !x.is_nan() {
            out.push(x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartic_roots_are_found_to_the_last_bits() {
        // (1 − 0.1x)(x + 0.3)(x − 0.7)(x − 0.75): the first factor's root, 10, is outside.
        let p = Poly([1.0, -0.1, 0.0, 0.0, 0.0])
            .times(&Poly([0.3, 1.0, 0.0, 0.0, 0.0]))
            .times(&Poly([-0.7, 1.0, 0.0, 0.0, 0.0]))
            .times(&Poly([-0.75, 1.0, 0.0, 0.0, 0.0]));
        let mut out = List::default();
        poly_roots(&p, -1.0, 1.0, &mut out);
        let found = out.as_slice().to_vec();
        let want = [-0.3, 0.7, 0.75];
        assert_eq!(found.len(), want.len(), "{found:?}");
        for (x, w) in found.iter().zip(want) {
            assert!((x - w).abs() < 1e-14, "{x} vs {w}");
        }
        // A double root (touching zero) is no sign change: reported only where p is exactly 0.
        let touch = Poly([0.25, -1.0, 1.0, 0.0, 0.0]); // (x − 0.5)², exactly 0 at 0.5
        out = List::default();
        poly_roots(&touch, -1.0, 1.0, &mut out);
        assert_eq!(out.as_slice(), [0.5]);
        let above = Poly([0.2501, -1.0, 1.0, 0.0, 0.0]); // positive everywhere
        out = List::default();
        poly_roots(&above, -1.0, 1.0, &mut out);
        assert!(out.as_slice().is_empty(), "{out:?}");
    }

    #[test]
    fn trig_roots_match_the_closed_form_and_stay_in_the_interval() {
        // 0.2 + cos φ: roots at ±acos(−0.2).
        let mut out = List::default();
        trig_roots(0.2, 1.0, 0.0, -3.0, 3.0, &mut out);
        let r = (-0.2f64).acos();
        let v = out.as_slice();
        assert_eq!(v.len(), 2);
        assert!((v[0] + r).abs() < 1e-15 && (v[1] - r).abs() < 1e-15, "{out:?}");
        out = List::default();
        trig_roots(0.2, 1.0, 0.0, 0.0, 1.0, &mut out);
        assert!(out.as_slice().is_empty());
        // Near tangency the roots are still roots of the function to rounding.
        out = List::default();
        trig_roots(-(1.0 - 1e-12), 0.6, 0.8, -3.0, 3.0, &mut out);
        assert_eq!(out.as_slice().len(), 2, "{out:?}");
        for &x in out.as_slice() {
            let f = -(1.0 - 1e-12) + 0.6 * x.cos() + 0.8 * x.sin();
            assert!(f.abs() < 1e-15, "f({x}) = {f}");
        }
    }
}
