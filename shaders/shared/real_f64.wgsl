// Real arithmetic in f64, for adapters with SHADER_F64 (lavapipe, most desktop GPUs). Same
// functions as real_df.wgsl; the stages use only these.

alias Real = f64;

// Returns the value hi + lo stored as a pair (v.x = hi, v.y = lo).
fn real(v: vec2<f32>) -> Real {
    return f64(v.x) + f64(v.y);
}

fn r_add(a: Real, b: Real) -> Real {
    return a + b;
}

fn r_mul(a: Real, b: Real) -> Real {
    return a * b;
}

fn r_neg(a: Real) -> Real {
    return -a;
}

// Returns true when a >= b.
fn r_ge(a: Real, b: Real) -> bool {
    return a >= b;
}

// Returns true when a > 0.
fn r_positive(a: Real) -> bool {
    return a > f64(0.0);
}

// Returns true when a < 0.
fn r_negative(a: Real) -> bool {
    return a < f64(0.0);
}

// Returns a rounded to f32.
fn r_f32(a: Real) -> f32 {
    return f32(a);
}

// Returns a as the pair (hi, lo): hi = a rounded to f32, lo = the rest rounded to f32. This is the
// host's split of an f64.
fn r_pair(a: Real) -> vec2<f32> {
    let hi = f32(a);
    return vec2<f32>(hi, f32(a - f64(hi)));
}
