//! Values known by name: the choice enums of the settings (`--metric`, `--form`, ...), parsed
//! from their names in one place for the command line, Python and data files. The settings
//! table (`crate::settings`) implements [`Named`] for each choice enum.

/// An enum whose values a setting names (`--metric isometric`): every value and its name, the
/// one spelling both front ends parse ([`parse_named`]; `FromStr` may accept aliases too).
pub trait Named: Copy + Sized + 'static {
    /// Every value, in `--help` order.
    const ALL: &'static [Self];
    /// The value's name.
    fn name(self) -> &'static str;
}

/// The value of `T` named `s` (`what`: the setting's key, for the error).
pub fn parse_named<T: Named>(s: &str, what: &str) -> Result<T, String> {
    T::ALL.iter().copied().find(|v| v.name() == s).ok_or_else(|| {
        let names: Vec<&str> = T::ALL.iter().map(|v| v.name()).collect();
        format!("unknown {what} '{s}' (expected {})", names.join(", "))
    })
}
