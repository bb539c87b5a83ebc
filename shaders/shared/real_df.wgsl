// Real arithmetic in double-f32 (hi + lo, about 44 significant bits), for adapters without
// SHADER_F64. Same functions as real_f64.wgsl. It relies on IEEE f32 addition without reassociation
// and on a fused fma. A driver that breaks either silently gives f32 precision instead (lavapipe
// does, but it has f64).

alias Real = vec2<f32>;

// Returns the value hi + lo stored as a pair (v.x = hi, v.y = lo).
fn real(v: vec2<f32>) -> Real {
    return v;
}

// Returns (s, e) with s + e = a + b exactly (Knuth's two-sum).
fn two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    let bb = s - a;
    return vec2<f32>(s, (a - (s - bb)) + (b - bb));
}

// Returns (s, e) with s + e = a + b exactly, given |a| >= |b|.
fn fast_two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    return vec2<f32>(s, b - (s - a));
}

fn r_add(a: Real, b: Real) -> Real {
    let s = two_sum(a.x, b.x);
    return fast_two_sum(s.x, s.y + (a.y + b.y));
}

// The error of the hi product comes exactly from fma.
fn r_mul(a: Real, b: Real) -> Real {
    let p = a.x * b.x;
    let e = fma(a.x, b.x, -p);
    return fast_two_sum(p, e + (a.x * b.y + a.y * b.x));
}

fn r_neg(a: Real) -> Real {
    return -a;
}

// Returns true when a >= b.
fn r_ge(a: Real, b: Real) -> bool {
    let d = r_add(a, -b);
    return d.x + d.y >= 0.0;
}

// Returns true when a > 0 (hi carries the sign of a normalised pair).
fn r_positive(a: Real) -> bool {
    return a.x > 0.0 || (a.x == 0.0 && a.y > 0.0);
}

// Returns true when a < 0.
fn r_negative(a: Real) -> bool {
    return a.x < 0.0 || (a.x == 0.0 && a.y < 0.0);
}

// Returns a rounded to f32.
fn r_f32(a: Real) -> f32 {
    return a.x + a.y;
}

// Returns a as the pair (hi, lo), normalised (hi is a rounded to f32).
fn r_pair(a: Real) -> vec2<f32> {
    return fast_two_sum(a.x, a.y);
}
