// f32 bits widened to f64 exactly, with integer operations. The summary stage derives its values
// with them; the host's twin is f64::from(f32::from_bits(b)).

// Returns the f32 of bits b as an f64, exactly, with integer operations: a device may flush a
// subnormal f32 to zero when it converts one (Vulkan allows it), where the host never does.
fn widen(b: u32) -> f64 {
    let sign = u64(b >> 31u) << 63u;
    let exponent = (b >> 23u) & 0xffu;
    let mantissa = b & 0x7fffffu;
    if exponent == 0u {
        // zero or subnormal: mantissa × 2^-149, exact (a normal f64 times a power of two)
        let magnitude = f64(mantissa) * power_of_two(-149);
        return bitcast<f64>(bitcast<u64>(magnitude) | sign);
    }
    // infinity and NaN keep their all-ones exponent; a normal f32 its exponent, rebased
    let e = select(u64(exponent) + 896lu, 2047lu, exponent == 0xffu);
    return bitcast<f64>(sign | e << 52u | u64(mantissa) << 29u);
}

// Returns 2^e for -1022 <= e <= 1023, exactly.
fn power_of_two(e: i32) -> f64 {
    return bitcast<f64>(u64(e + 1023) << 52u);
}
