//! Numbers for people: the formatting of every table of a report, of the terminal output and of
//! plot axes, in one plain format.
//!
//! Fixed-point for magnitudes in `[1e-4, 1e6)` (`3.657`, `0.01612`, `0.0004111`), the exponent
//! form Rust and Python print otherwise (`8.361e-17`, `2.500e7`: one digit before the point, no
//! `e0`, no engineering multiples of 3), zero as `0` (never `-0` or `-0.0`), and a value that is
//! zero up to rounding ([`relative`]: at most `1e-12` of the quantity's scale) as `0` too.

/// The unit of every distance, length and energy qcshape prints, as it names it (docs/method.md):
/// coordinates divided by a mean edge length (the base pose's, or for `geodesic` the mean of both
/// ends'), the common normalization factor every geodesic is solved in.
pub const UNITS: &str = "mean-edge units";

/// The magnitudes printed in fixed-point (the others in exponent form), by every function here.
const FIXED: std::ops::Range<f64> = 1e-4..1e6;

/// `x` with `sig` significant digits (at least 1): fixed-point for `|x|` in `[1e-4, 1e6)`,
/// exponent form otherwise (`4.111e-5`); `0` for zero (either sign); `NaN`, `inf` as Rust prints
/// them.
pub fn significant(x: f64, sig: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let sig = sig.max(1) as i32;
    let a = x.abs();
    if FIXED.contains(&a) {
        let decimals = (sig - 1 - a.log10().floor() as i32).max(0) as usize;
        return format!("{x:.decimals$}");
    }
    format!("{x:.prec$e}", prec = (sig - 1) as usize)
}

/// `x` with 4 significant digits ([`significant`]).
pub fn readable(x: f64) -> String {
    significant(x, 4)
}

/// [`readable`], but `0` when `|x| <= 1e-12 * scale` (rounding noise of a quantity of order
/// `scale`, e.g. an exact zero computed as `8e-17`).
pub fn relative(x: f64, scale: f64) -> String {
    if x.is_finite() && x.abs() <= 1e-12 * scale.abs() {
        "0".into()
    } else {
        readable(x)
    }
}

/// `n` and the noun, plural when `n != 1` (`1 pose`, `3 poses`); `plural` is the plural form.
pub fn count(n: usize, singular: &str, plural: &str) -> String {
    if n == 1 {
        format!("1 {singular}")
    } else {
        format!("{n} {plural}")
    }
}

/// A setting's value as the metric's description ([`crate::metric::MetricSpec::label`]) prints
/// it: Rust's shortest round-trip form (`0.01`, `0.5`, `12`) for magnitudes in `[1e-4, 1e6)`,
/// `1e-5`-style exponent form otherwise, `0` for zero (either sign).
pub fn plain(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if FIXED.contains(&a) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A plot axis's value `v` at ticks about `step` apart: rounded to a hundredth of `step` (so
/// `0.30000000000000004` is `0.3` and `-1e-17` is `0`), trailing zeros dropped, in the format of
/// [`plain`] (fixed-point in `[1e-4, 1e6)`, exponent form otherwise); never `-0`.
pub fn tick(v: f64, step: f64) -> String {
    let step = step.abs();
    if !v.is_finite() || !step.is_finite() || step == 0.0 {
        return plain(v);
    }
    let e = step.log10().floor() as i32 - 2;
    let unit = 10f64.powi(e);
    let r = (v / unit).round() * unit;
    if r == 0.0 {
        return "0".into();
    }
    let a = r.abs();
    let trim = |m: &str| -> String {
        if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            m.to_string()
        }
    };
    if FIXED.contains(&a) {
        trim(&format!("{r:.decimals$}", decimals = (-e).max(0) as usize))
    } else {
        let prec = (a.log10().floor() as i32 - e).max(0) as usize;
        let s = format!("{r:.prec$e}");
        match s.split_once('e') {
            Some((m, x)) => format!("{}e{x}", trim(m)),
            None => s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_well() {
        assert_eq!(readable(3.656566971), "3.657");
        assert_eq!(readable(0.016123), "0.01612");
        assert_eq!(readable(7.209e-3), "0.007209");
        assert_eq!(readable(1234.56), "1235");
        assert_eq!(readable(-0.5), "-0.5000");
        assert_eq!(readable(8.361e-17), "8.361e-17");
        assert_eq!(readable(2.5e7), "2.500e7");
        assert_eq!(readable(4.11077e-4), "0.0004111");
        assert_eq!(significant(4.11077123e-4, 6), "0.000411077");
        assert_eq!(significant(1.944768, 7), "1.944768");
        assert_eq!(significant(-3.2e-5, 3), "-3.20e-5");
        assert_eq!(readable(-0.0), "0");
        assert_eq!(readable(0.0), "0");
        assert_eq!(significant(3.656566971, 7), "3.656567");
        assert_eq!(relative(8.361e-17, 0.4), "0");
        assert_eq!(relative(0.0241, 0.4), "0.02410");
        assert_eq!(relative(f64::NAN, 1.0), "NaN");
        assert_eq!(count(1, "pose", "poses"), "1 pose");
        assert_eq!(count(3, "round", "rounds"), "3 rounds");
    }

    /// No engineering notation (`411.077e-6`), no `e0` (`1.944768e0`), no `-0.0` (issue 50,
    /// item 7).
    #[test]
    fn one_plain_format() {
        for x in [
            4.11077e-4, 1.944768, -1e-17, 0.25, 83.61e-18, 2.5e7, -0.0, 123456.7,
        ] {
            for s in [readable(x), significant(x, 6), plain(x), tick(x, 0.05)] {
                let v: f64 = s.parse().unwrap();
                assert!(!(v == 0.0 && s.starts_with('-')), "{x}: {s} (a negative zero)");
                if let Some((m, e)) = s.split_once('e') {
                    let m: f64 = m.parse().unwrap();
                    assert!((1.0..10.0).contains(&m.abs()), "{x}: {s} (mantissa)");
                    assert_ne!(e, "0", "{x}: {s}");
                }
            }
        }
        assert_eq!(tick(0.30000000000000004, 0.1), "0.3");
        assert_eq!(tick(-1.3877787807814457e-17, 0.2), "0");
        assert_eq!(tick(-0.0, 1.0), "0");
        assert_eq!(tick(-0.25, 0.05), "-0.25");
        assert_eq!(tick(1500.0, 500.0), "1500");
        assert_eq!(tick(2.5e7, 5e6), "2.5e7");
        assert_eq!(tick(3.0e-6, 1e-6), "3e-6");
        assert_eq!(plain(-0.0), "0");
    }
}
