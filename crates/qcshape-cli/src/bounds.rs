//! Value parsers of the bounded options: every integer option and the non-negative real ones
//! take one of these (`value_parser = bounds::count::<usize>(MIN, MAX)`,
//! `value_parser = bounds::real(MAX)`) together with `allow_negative_numbers = true`, so that
//! `--steps -1` says "--steps must be >= 0" (not clap's "unexpected argument '-1'"),
//! `--insert 18446744073709551615` says "--insert must be at most 1000", and `--lambda 1e308`
//! names its bound. The maxima are the library's [`qcshape::limits`]; each option's `--help`
//! states its own.

use std::marker::PhantomData;

use clap::builder::TypedValueParser;
use clap::error::ErrorKind;

/// The option's name as the user sees it (`--steps`), for messages.
fn option_name(arg: Option<&clap::Arg>) -> String {
    match arg {
        Some(a) => match a.get_long() {
            Some(l) => format!("--{l}"),
            None => a.get_id().to_string().to_uppercase(),
        },
        None => "the value".into(),
    }
}

/// A clap error with `message`, formatted with the command's usage.
fn error(cmd: &clap::Command, message: String) -> clap::Error {
    clap::Error::raw(ErrorKind::ValueValidation, message).format(&mut cmd.clone())
}

/// An integer option of type `T` in `min..=max`.
#[derive(Clone, Debug)]
pub(crate) struct Count<T> {
    min: u64,
    max: u64,
    ty: PhantomData<fn() -> T>,
}

/// The parser of an integer option in `min..=max` (both must fit `T`).
pub(crate) fn count<T>(min: u64, max: u64) -> Count<T> {
    Count {
        min,
        max,
        ty: PhantomData,
    }
}

impl<T> TypedValueParser for Count<T>
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        let name = option_name(arg);
        let text = value.to_string_lossy();
        let text = text.trim();
        if let Some(rest) = text.strip_prefix('-') {
            if rest.parse::<f64>().is_ok() {
                return Err(error(cmd, format!("{name} must be >= 0 (got {text})")));
            }
        }
        let v: u128 = text.parse().map_err(|_| {
            error(
                cmd,
                format!(
                    "{name} must be a whole number from {} to {} (got {text:?})",
                    self.min, self.max
                ),
            )
        })?;
        if v > self.max as u128 {
            return Err(error(
                cmd,
                format!("{name} must be at most {} (got {text})", self.max),
            ));
        }
        if v < self.min as u128 {
            return Err(error(
                cmd,
                format!("{name} must be at least {} (got {text})", self.min),
            ));
        }
        T::try_from(v as u64).map_err(|_| error(cmd, format!("{name}: {text} is out of range")))
    }
}

/// A real option: finite, `>= 0` and at most `max`.
#[derive(Clone, Debug)]
pub(crate) struct Real {
    max: f64,
}

/// The parser of a finite non-negative real option of at most `max`.
pub(crate) fn real(max: f64) -> Real {
    Real { max }
}

impl TypedValueParser for Real {
    type Value = f64;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<f64, clap::Error> {
        let name = option_name(arg);
        let text = value.to_string_lossy();
        let text = text.trim();
        let v: f64 = text
            .parse()
            .map_err(|_| error(cmd, format!("{name} must be a number >= 0 (got {text:?})")))?;
        if v < 0.0 {
            return Err(error(cmd, format!("{name} must be >= 0 (got {text})")));
        }
        if !v.is_finite() || v > self.max {
            return Err(error(
                cmd,
                format!("{name} must be at most {:e} (got {text})", self.max),
            ));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use std::any::TypeId;

    use clap::CommandFactory;

    /// Every integer or real option (except seeds and the options that are free by nature)
    /// has a bounded parser that accepts negative numbers (to refuse them with a message) and
    /// states its maximum in its help.
    #[test]
    fn every_numeric_option_is_bounded_and_documented() {
        fn walk(cmd: &clap::Command, path: &str, bad: &mut Vec<String>) {
            for a in cmd.get_arguments() {
                let t = a.get_value_parser().type_id();
                let integer = [
                    TypeId::of::<usize>(),
                    TypeId::of::<u64>(),
                    TypeId::of::<u32>(),
                    TypeId::of::<u8>(),
                ]
                .into_iter()
                .any(|id| t == id);
                let id = a.get_id().as_str();
                if !integer || id.contains("seed") {
                    continue;
                }
                let help = format!(
                    "{} {}",
                    a.get_help().map(|h| h.to_string()).unwrap_or_default(),
                    a.get_long_help().map(|h| h.to_string()).unwrap_or_default()
                );
                if !a.is_allow_negative_numbers_set() || !help.contains("At most") {
                    bad.push(format!("{path} --{id}"));
                }
            }
            for sub in cmd.get_subcommands() {
                walk(sub, &format!("{path} {}", sub.get_name()), bad);
            }
        }
        let mut bad = Vec::new();
        walk(&crate::Cli::command(), "qcshape", &mut bad);
        assert!(
            bad.is_empty(),
            "unbounded or undocumented integer options: {bad:#?}"
        );
    }
}
