//! Numbers as text: the shortest form that reads back to the same `f64`, written exactly as
//! Rust's `Display` writes it (`1`, `0.1`, `-0`, `0.0000001`, `1000000000000000000000`, `NaN`,
//! `inf`), faster. Tables of millions of rows (the paper's CSVs, sweep CSVs) spend most of their
//! formatting time on these numbers.
//!
//! The digits come from Ryū (the `ryu` crate). Like the standard library's Grisu with its Dragon
//! fallback, it finds the fewest digits that read back to the number and, of those, the nearest.
//! The two differ only on a tie, a number exactly halfway between its two nearest candidates
//! (`758641930659884.25` between `…884.2` and `…884.3`): Ryū rounds half to even, the standard
//! library half up. A tie needs the number's exact decimal expansion to end one place after the
//! digits found, with a 5; such numbers are written by `Display` itself. Only the layout of the
//! digits is redone here.

/// Appends `v` to `out` as `format!("{v}")` would.
pub fn push_f64(out: &mut String, v: f64) {
    use std::fmt::Write;
    if !v.is_finite() {
        out.push_str(if v.is_nan() {
            "NaN"
        } else if v > 0.0 {
            "inf"
        } else {
            "-inf"
        });
        return;
    }
    let mut buffer = ryu::Buffer::new();
    let text = buffer.format_finite(v);
    // Ryū writes `[-]digits[.digits][e[-]exponent]`: split it into the significant digits and
    // the place of the decimal point among them.
    let (negative, text) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text),
    };
    let (mantissa, exponent) = match text.split_once('e') {
        Some((m, e)) => (m, e.parse::<i32>().expect("Ryū writes a decimal exponent")),
        None => (text, 0),
    };
    let (whole, fraction) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    // Ryū writes at most 17 significant digits and a few zeros around them.
    let mut all = [0; 40];
    let mut len = 0;
    for d in whole.bytes().chain(fraction.bytes()) {
        all[len] = d;
        len += 1;
    }
    let all = &all[..len];
    let Some(first) = all.iter().position(|&d| d != b'0') else {
        out.push_str(if negative { "-0" } else { "0" });
        return;
    };
    let last = all.iter().rposition(|&d| d != b'0').unwrap_or(first);
    let digits = std::str::from_utf8(&all[first..=last]).expect("ASCII digits");
    // The decimal point sits after `point` of the digits (before them when not positive).
    let count = |k: usize| i32::try_from(k).expect("a short number");
    let point = count(whole.len()) + exponent - count(first);
    let n = count(digits.len());
    if last_place(v).is_none_or(|t| t == point - n - 1) {
        // The last digit found is at 10^(point − n); an exact expansion ending one place
        // further may be a tie.
        write!(out, "{v}").expect("a String takes every write");
        return;
    }
    if negative {
        out.push('-');
    }
    let zeros =
        |out: &mut String, k: i32| out.extend(std::iter::repeat_n('0', usize::try_from(k).unwrap_or(0)));
    if point <= 0 {
        out.push_str("0.");
        zeros(out, -point);
        out.push_str(digits);
    } else if point >= n {
        out.push_str(digits);
        zeros(out, point - n);
    } else {
        let (a, b) = digits.split_at(usize::try_from(point).expect("positive"));
        out.push_str(a);
        out.push('.');
        out.push_str(b);
    }
}

/// Returns the place `t` of the last nonzero digit of finite, nonzero `v`'s exact decimal
/// expansion (its digit at 10^t): `−q` when `v` is an odd multiple of 2^−q (the digit is a 5),
/// and for an integer below 2^64 the count of its trailing decimal zeros. `None` for larger
/// integers, which are left to `Display`.
fn last_place(v: f64) -> Option<i32> {
    let bits = v.to_bits();
    let field = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (m, e) = if field == 0 {
        (fraction, -1074)
    } else {
        (fraction | 1 << 52, field - 1075)
    };
    #[expect(clippy::cast_possible_wrap, reason = "at most 63")]
    let low = e + m.trailing_zeros() as i32;
    if low < 0 {
        return Some(low);
    }
    // The integer `odd · 2^low`, when it fits in 64 bits.
    let odd = m >> m.trailing_zeros();
    let low = u32::try_from(low).expect("not negative");
    if 64 - odd.leading_zeros() + low > 64 {
        return None;
    }
    let mut n = odd << low;
    let mut t = 0;
    while n.is_multiple_of(10) {
        n /= 10;
        t += 1;
    }
    Some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn check(v: f64) {
        let mut out = String::new();
        push_f64(&mut out, v);
        assert_eq!(out, format!("{v}"), "bits {:#018x}", v.to_bits());
    }

    #[test]
    fn special_values_zeros_and_powers_of_ten_are_written_as_display_does() {
        for v in [
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1.0,
            -1.0,
            0.1,
            0.5,
        ] {
            check(v);
        }
        // Ties, where Ryū alone would write 758641930659884.2 and 654077115020823.2.
        for bits in [0x4305_8fd8_b64f_4162_u64, 0x4302_9709_90c5_b0ba] {
            check(f64::from_bits(bits));
            check(-f64::from_bits(bits));
        }
        for v in [
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::EPSILON,
            5e-324,
            1e16,
            1e15,
            123.0,
        ] {
            check(v);
            check(-v);
        }
        for e in -324..=308 {
            let v: f64 = format!("1e{e}").parse().unwrap();
            check(v);
            check(v * 1.5);
            check(v * 9.999_999_999_999_999);
        }
    }

    #[test]
    fn random_numbers_are_written_as_display_does() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..200_000 {
            // Any bit pattern (every exponent, subnormals, NaNs), and numbers like results.
            check(f64::from_bits(rng.random()));
            check(rng.random_range(-100.0..100.0));
            check(f64::from(rng.random_range(-100_000..100_000)) / 1000.0);
        }
    }
}
