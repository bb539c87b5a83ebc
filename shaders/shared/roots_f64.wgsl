// Root finding and atan in f64 for the exact stage (exact.wgsl), put before it. CPU twins:
// src/exact/fast_roots.rs (quadratic_roots, quartic_roots, closed_form_roots, horner) and
// src/exact/roots.rs (newton_root_between, List). Needs f64.

// A short list of elevations (as s): an arc's cuts, or its stationary points.
struct List {
    v: array<f64, 32>,
    n: u32,
}

// A root search's answer.
struct Found {
    ok: bool,
    x: f64,
}

// At most two roots, in increasing order.
struct Roots {
    n: u32,
    x0: f64,
    x1: f64,
}

// The closed form's two roots, each where it exists: guesses.
struct Guesses {
    ok0: bool,
    x0: f64,
    ok1: bool,
    x1: f64,
}

// Where the roots' Newton's method stops: a step of 1e-8 leaves an error of the order of 1e-16.
fn settle() -> f64 {
    return f64(1e-8);
}

// Returns the value and the derivative of c[0] + c[1] x + ... (degree n) at x.
fn horner(c: array<f64, 5>, n: i32, x: f64) -> vec2<f64> {
    var cc = c;
    var v = cc[n];
    var d = f64(0.0);
    for (var k = n - 1; k >= 0; k--) {
        d = d * x + v;
        v = v * x + cc[k];
    }
    return vec2<f64>(v, d);
}

// Returns the root in [a, b] of the polynomial c (degree n, monotone there) when it changes sign
// across it, given its end values; from start when has_start and it lies inside, else from the
// secant's point. Twin of roots.rs newton_root_between.
fn newton(c: array<f64, 5>, n: i32, a: f64, b: f64, fa: f64, fb: f64, has_start: bool, start: f64, stop: f64) -> Found {
    if fa == 0.0 {
        return Found(true, a);
    }
    if fb == 0.0 {
        return Found(true, b);
    }
    if (fa < 0.0) == (fb < 0.0) {
        return Found(false, a);
    }
    let lo_negative = fa < 0.0;
    var lo = a;
    var hi = b;
    var x = clamp(a - fa * (b - a) / (fb - fa), a, b);
    if has_start && start > a && start < b {
        x = start;
    }
    var last_step = b - a;
    for (var it = 0; it < 200; it++) {
        let f = horner(c, n, x);
        if f.x == 0.0 {
            return Found(true, x);
        }
        if (f.x < 0.0) == lo_negative {
            lo = x;
        } else {
            hi = x;
        }
        let moves = f.y != 0.0;
        var step = hi - lo;
        var nw = x;
        if moves {
            nw = x - f.x / f.y;
            step = abs(nw - x);
        }
        let within = moves && nw > lo && nw < hi;
        if within && step <= stop * max(abs(lo), abs(hi)) {
            return Found(true, nw);
        }
        var next = 0.5 * (lo + hi);
        if within && step < 0.5 * last_step {
            last_step = step;
            next = nw;
        } else {
            last_step = hi - lo;
        }
        if next <= lo || next >= hi {
            return Found(true, 0.5 * (lo + hi));
        }
        if next == x {
            return Found(true, next);
        }
        x = next;
    }
    return Found(true, x);
}

fn add_root(r: ptr<function, Roots>, f: Found) {
    if !f.ok || ((*r).n > 0u && (*r).x0 == f.x) || (*r).n == 2u {
        return;
    }
    if (*r).n == 0u {
        (*r).x0 = f.x;
    } else {
        (*r).x1 = f.x;
    }
    (*r).n += 1u;
}

// Returns the roots in [lo, hi] of c.x + c.y s + c.z s^2 where it changes sign, in increasing order.
fn quadratic_roots(c: vec3<f64>, lo: f64, hi: f64) -> Roots {
    var r = Roots(0u, f64(0.0), f64(0.0));
    if c.z == 0.0 {
        if c.y != 0.0 {
            let x = -c.x / c.y;
            if x >= lo && x <= hi {
                r.n = 1u;
                r.x0 = x;
            }
        }
        return r;
    }
    let p = array<f64, 5>(c.x, c.y, c.z, f64(0.0), f64(0.0));
    let vertex = -c.y / (2.0 * c.z);
    let d = c.y * c.y - 4.0 * c.z * c.x;
    var g0 = vertex;
    var g1 = vertex;
    if d > 0.0 {
        // The stable form: no cancellation in either root.
        let sq = sqrt(d);
        let q = -0.5 * (c.y + select(sq, -sq, c.y < 0.0));
        g0 = min(q / c.z, c.x / q);
        g1 = max(q / c.z, c.x / q);
    }
    let f_lo = horner(p, 2, lo).x;
    let f_hi = horner(p, 2, hi).x;
    if vertex > lo && vertex < hi {
        let f_vertex = horner(p, 2, vertex).x;
        add_root(&r, newton(p, 2, lo, vertex, f_lo, f_vertex, true, g0, settle()));
        add_root(&r, newton(p, 2, vertex, hi, f_vertex, f_hi, true, g1, settle()));
    } else {
        var g = g1;
        if g0 >= lo && g0 <= hi {
            g = g0;
        }
        add_root(&r, newton(p, 2, lo, hi, f_lo, f_hi, true, g, settle()));
    }
    return r;
}

// Returns the closed form's roots of c.x + c.y s + c.z s^2, unpolished: guesses.
fn closed_form(c: vec3<f64>) -> Guesses {
    let d = c.y * c.y - 4.0 * c.z * c.x;
    if !(d >= 0.0) {
        return Guesses(false, f64(0.0), false, f64(0.0));
    }
    let sq = sqrt(d);
    let q = -0.5 * (c.y + select(sq, -sq, c.y < 0.0));
    var g = Guesses(c.z != 0.0, f64(0.0), q != 0.0, f64(0.0));
    if g.ok0 {
        g.x0 = q / c.z;
    }
    if g.ok1 {
        g.x1 = c.x / q;
    }
    return g;
}

// Appends x to the list unless it repeats the last value.
fn push(list: ptr<function, List>, x: f64) {
    let n = (*list).n;
    if n < 32u && (n == 0u || (*list).v[n - 1u] != x) {
        (*list).v[n] = x;
        (*list).n = n + 1u;
    }
}

fn push_found(list: ptr<function, List>, f: Found) {
    if f.ok {
        push(list, f.x);
    }
}

fn push_roots(list: ptr<function, List>, c: vec3<f64>, lo: f64, hi: f64) {
    let r = quadratic_roots(c, lo, hi);
    if r.n > 0u {
        push(list, r.x0);
    }
    if r.n > 1u {
        push(list, r.x1);
    }
}

// Sorts the list and drops repeats.
fn sort(list: ptr<function, List>) {
    let count = (*list).n;
    for (var i = 1u; i < count; i++) {
        let x = (*list).v[i];
        var j = i;
        while j > 0u && (*list).v[j - 1u] > x {
            (*list).v[j] = (*list).v[j - 1u];
            j -= 1u;
        }
        (*list).v[j] = x;
    }
    var n = 0u;
    for (var i = 0u; i < count; i++) {
        if n == 0u || (*list).v[i] != (*list).v[n - 1u] {
            (*list).v[n] = (*list).v[i];
            n += 1u;
        }
    }
    (*list).n = n;
}

// Pushes the roots in [lo, hi] of the quartic g where it changes sign, in increasing order: the
// roots of g'' cut the interval where g' is monotone, and a piece where g turns is split at its
// turning point (or at a hint beyond which g turns back). Twin of fast.rs quartic_roots.
fn quartic_roots(list: ptr<function, List>, g: array<f64, 5>, lo: f64, hi: f64, hints: Guesses) {
    let d1 = array<f64, 5>(g[1], 2.0 * g[2], 3.0 * g[3], 4.0 * g[4], f64(0.0));
    let d2 = vec3<f64>(d1[1], 2.0 * d1[2], 3.0 * d1[3]);
    var cut = array<f64, 4>(lo, lo, lo, lo);
    var n = 1u;
    let inner = quadratic_roots(d2, lo, hi);
    if inner.n > 0u && inner.x0 != cut[n - 1u] {
        cut[n] = inner.x0;
        n += 1u;
    }
    if inner.n > 1u && inner.x1 != cut[n - 1u] {
        cut[n] = inner.x1;
        n += 1u;
    }
    if hi != cut[n - 1u] {
        cut[n] = hi;
        n += 1u;
    }
    var a = cut[0];
    var va = horner(g, 4, a);
    for (var k = 1u; k < n; k++) {
        let b = cut[k];
        let vb = horner(g, 4, b);
        let a0 = a;
        let ga = va.x;
        let da = va.y;
        let gb = vb.x;
        let db = vb.y;
        a = b;
        va = vb;
        if b <= a0 {
            // An empty piece.
        } else if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            let peak = da > 0.0;
            // The first hint inside the piece, when g lies beyond 0 there.
            var split = false;
            var m = a0;
            var gm = ga;
            var h = hints.x0;
            var has_h = hints.ok0 && hints.x0 > a0 && hints.x0 < b;
            if !has_h {
                h = hints.x1;
                has_h = hints.ok1 && hints.x1 > a0 && hints.x1 < b;
            }
            if has_h {
                let gh = horner(g, 4, h).x;
                if (peak && gh > 0.0) || (!peak && gh < 0.0) {
                    split = true;
                    m = h;
                    gm = gh;
                }
            }
            if !split {
                let t = newton(d1, 3, a0, b, da, db, false, a0, f64(1e-6));
                split = t.ok;
                m = t.x;
                gm = horner(g, 4, m).x;
            }
            // Near m, g ~ g(m) + g'(m) d + g''(m) d^2 / 2: its roots start the searches.
            let sl = horner(d1, 3, m);
            let c = closed_form(vec3<f64>(gm, sl.x, 0.5 * sl.y));
            var l = m + c.x0;
            var r = m + c.x1;
            var has_l = c.ok0;
            var has_r = c.ok1;
            if has_l && has_r {
                let x = min(l, r);
                r = max(l, r);
                l = x;
            } else if has_l {
                r = l;
                has_r = true;
            } else if has_r {
                l = r;
                has_l = true;
            }
            // Without a split (the turning point's search found none), no root: as the CPU.
            if split {
                push_found(list, newton(g, 4, a0, m, ga, gm, has_l, l, settle()));
                push_found(list, newton(g, 4, m, b, gm, gb, has_r, r, settle()));
            }
        } else {
            push_found(list, newton(g, 4, a0, b, ga, gb, false, a0, settle()));
        }
    }
}

// Returns atan(x) in f64, to within an ulp or two: WGSL has no f64 trigonometry. fdlibm's s_atan.c
// (Sun Microsystems, freely redistributable): reduce |x| to [0, 7/16] against atan(1/2), atan(1),
// atan(3/2) or pi/2, then an odd polynomial of degree 23.
fn atan_f64(v: f64) -> f64 {
    let ax = abs(v);
    let negative = v < 0.0;
    // atan of the reduction's point, as hi + lo (none below 7/16).
    var hi = f64(1.57079632679489655800e+00);
    var lo = f64(6.12323399573676603587e-17);
    if ax >= f64(7.378697629483821e19) {
        // |v| >= 2^66: pi/2 to the last bit.
        return select(hi + lo, -(hi + lo), negative);
    }
    var x = v;
    var reduced = true;
    if ax < 0.4375 {
        reduced = false;
    } else if ax < 0.6875 {
        hi = f64(4.63647609000806093515e-01);
        lo = f64(2.26987774529616870924e-17);
        x = (2.0 * ax - 1.0) / (2.0 + ax);
    } else if ax < 1.1875 {
        hi = f64(7.85398163397448278999e-01);
        lo = f64(3.06161699786838301793e-17);
        x = (ax - 1.0) / (ax + 1.0);
    } else if ax < 2.4375 {
        hi = f64(9.82793723247329054082e-01);
        lo = f64(1.39033110312309984516e-17);
        x = (ax - 1.5) / (1.0 + 1.5 * ax);
    } else {
        x = -1.0 / ax;
    }
    // No constant arrays: naga's pipeline-constant pass rejected them here.
    let z = x * x;
    let w = z * z;
    let s1 = z * (f64(3.33333333333329318027e-01) + w * (f64(1.42857142725034663711e-01)
        + w * (f64(9.09088713343650656196e-02) + w * (f64(6.66107313738753120669e-02)
        + w * (f64(4.97687799461593236017e-02) + w * f64(1.62858201153657823623e-02))))));
    let s2 = w * (f64(-1.99999999998764832476e-01) + w * (f64(-1.11111104054623557880e-01)
        + w * (f64(-7.69187620504482999495e-02) + w * (f64(-5.83357013379057348645e-02)
        + w * f64(-3.65315727442169155270e-02)))));
    if !reduced {
        return x - x * (s1 + s2);
    }
    let r = hi - ((x * (s1 + s2) - lo) - x);
    return select(r, -r, negative);
}

// pi as hi + lo.
fn pi_hi() -> f64 {
    return f64(3.141592653589793116);
}

fn pi_lo() -> f64 {
    return f64(1.2246467991473532e-16);
}

// Returns atan2(y, x) in f64 (0 at the origin), from atan_f64.
fn atan2_f64(y: f64, x: f64) -> f64 {
    if x == 0.0 {
        if y == 0.0 {
            return f64(0.0);
        }
        let half_pi = 0.5 * pi_hi();
        return select(-half_pi, half_pi, y > 0.0);
    }
    let a = atan_f64(y / x);
    if x > 0.0 {
        return a;
    }
    if y >= 0.0 {
        return (a + pi_lo()) + pi_hi();
    }
    return (a - pi_lo()) - pi_hi();
}
