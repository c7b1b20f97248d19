//! Numbers for people: the formatting of every table of a report and of the terminal output.
//!
//! Fixed-point where it reads well (`3.657`, `0.01612`), engineering notation (exponent a
//! multiple of 3: `83.61e-18`) outside `[1e-3, 1e6)`, and a value that is zero up to rounding
//! ([`relative`]: at most `1e-12` of the quantity's scale) as plain `0`.

/// `x` with `sig` significant digits (at least 1): fixed-point for `|x|` in `[1e-3, 1e6)`,
/// engineering notation otherwise; `0` for zero; `NaN`, `inf` as Rust prints them.
pub fn significant(x: f64, sig: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let sig = sig.max(1) as i32;
    let a = x.abs();
    if (1e-3..1e6).contains(&a) {
        let decimals = (sig - 1 - a.log10().floor() as i32).max(0) as usize;
        return format!("{x:.decimals$}");
    }
    let mut e = (a.log10() / 3.0).floor() as i32 * 3;
    let mut m = x / 10f64.powi(e);
    let digits = |m: f64| (sig - 1 - m.abs().log10().floor() as i32).max(0) as usize;
    let mut s = format!("{m:.prec$}", prec = digits(m));
    // Rounding can carry the mantissa to 1000: move to the next exponent.
    if s.trim_start_matches('-').starts_with("1000") {
        e += 3;
        m = x / 10f64.powi(e);
        s = format!("{m:.prec$}", prec = (sig - 1) as usize);
    }
    format!("{s}e{e}")
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

/// A setting's value as the metric's description ([`crate::metric::MetricSpec::label`]) prints it: Rust's shortest round-trip form (`0.01`,
/// `0.5`, `12`) for magnitudes in `[1e-4, 1e6)` and zero, `1e-5`-style exponent form otherwise.
pub fn plain(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if (1e-4..1e6).contains(&a) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
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
        assert_eq!(readable(8.361e-17), "83.61e-18");
        assert_eq!(readable(2.5e7), "25.00e6");
        assert_eq!(readable(9.99999e-4), "1.000e-3");
        assert_eq!(readable(0.0), "0");
        assert_eq!(significant(3.656566971, 7), "3.656567");
        assert_eq!(relative(8.361e-17, 0.4), "0");
        assert_eq!(relative(0.0241, 0.4), "0.02410");
        assert_eq!(relative(f64::NAN, 1.0), "NaN");
        assert_eq!(count(1, "pose", "poses"), "1 pose");
        assert_eq!(count(3, "round", "rounds"), "3 rounds");
    }
}
