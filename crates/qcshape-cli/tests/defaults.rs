//! One set of defaults (issue 21): every command's `--help` shows the same default for the same
//! option, and that default is the library's constant in `qcshape::defaults`, except for the
//! documented exceptions listed (with their reasons) in `EXCEPTIONS`.

use std::collections::BTreeMap;
use std::process::Command;

use qcshape::defaults;

/// The commands compared, as argument lists before `--help`.
const COMMANDS: &[&[&str]] = &[
    &["transfer"],
    &["similarity"],
    &["run"],
    &["interpolate"],
    &["classify"],
    &["experiment", "noise"],
    &["experiment", "robustness"],
    &["experiment", "interpolation"],
    &["experiment", "transfer"],
    &["reproduce"],
    &["lv", "run"],
];

/// (command, option, default): the documented exceptions. Each is a named constant of
/// `qcshape::defaults` or `qcshape_studies::study_defaults` whose doc comment gives the reason, and the option's `--help` says so.
fn exceptions() -> Vec<(&'static str, &'static str, String)> {
    vec![
        // The README's Table 3 was measured with N = 4 and 10 restarts.
        (
            "experiment noise",
            "steps",
            qcshape_studies::study_defaults::NOISE_STEPS.to_string(),
        ),
        (
            "experiment noise",
            "restarts",
            qcshape_studies::study_defaults::NOISE_RESTARTS.to_string(),
        ),
        // Paper section 4 settings, with which the README's LV tables were measured.
        ("lv run", "insert", defaults::PAPER_INSERT.to_string()),
        (
            "lv run",
            "steps",
            qcshape_studies::study_defaults::PAPER_STEPS.to_string(),
        ),
        // Paper section 4's parallel transport, with which the README's LV tables were measured.
        (
            "lv run",
            "transport",
            qcshape_studies::study_defaults::LV_TRANSPORT.label().to_string(),
        ),
        // `experiment noise --levels` are the noise variances of Table 3, not spatial levels.
        ("experiment noise", "levels", "1,2.5,5,10,20".to_string()),
        // The middle pose of Fig. 4 is the one inserted pose.
        ("experiment interpolation", "insert", "1".to_string()),
    ]
}

/// The library's defaults by option name.
fn library() -> BTreeMap<&'static str, String> {
    BTreeMap::from([
        ("metric", defaults::METRIC.label().to_string()),
        ("lambda", defaults::LAMBDA.to_string()),
        ("steps", defaults::STEPS.to_string()),
        ("solver", defaults::SOLVER.label().to_string()),
        ("tolerance", defaults::TOLERANCE.to_string()),
        ("energy-tolerance", defaults::ENERGY_TOLERANCE.to_string()),
        ("length-tolerance", defaults::LENGTH_TOLERANCE.to_string()),
        ("insert", defaults::INSERT.to_string()),
        ("levels", defaults::LEVELS.to_string()),
        ("transport", defaults::TRANSPORT.label().to_string()),
        ("align", defaults::ALIGN.label().to_string()),
        // `--smooth N` (Taubin iterations) overrides the length filter and has no default (`lv
        // run --smooth`, the meshing's iterations, is another option under the same name).
        ("smooth-length", defaults::SMOOTH_LENGTH.to_string()),
        ("restarts", defaults::RESTARTS.to_string()),
        ("seed", defaults::SEED.to_string()),
    ])
}

/// The `[default: X]` of every long option in `help` (clap's long help: the option line, then
/// its description, which ends with the default).
fn parse_defaults(help: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in help.lines() {
        let t = line.trim_start();
        let flag = t.strip_prefix("--").or_else(|| {
            t.split_once(", --")
                .filter(|(s, _)| s.starts_with('-'))
                .map(|(_, r)| r)
        });
        if let Some(rest) = flag {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                .collect();
            current = Some(name);
        }
        if let (Some(name), Some(i)) = (&current, line.find("[default: ")) {
            let v = &line[i + "[default: ".len()..];
            let v = v.split(']').next().unwrap_or("").to_string();
            out.insert(name.clone(), v);
        }
    }
    out
}

fn help_of(cmd: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(cmd)
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success(), "{cmd:?} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_command_shows_the_library_defaults() {
    let lib = library();
    let exceptions = exceptions();
    let mut seen: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    let mut problems = Vec::new();
    for cmd in COMMANDS {
        let name = cmd.join(" ");
        let found = parse_defaults(&help_of(cmd));
        for (option, expected) in &lib {
            let Some(shown) = found.get(*option) else {
                continue;
            };
            seen.entry(option).or_default().push(name.clone());
            let allowed = exceptions
                .iter()
                .find(|(c, o, _)| *c == name && o == option)
                .map(|(_, _, v)| v);
            match allowed {
                Some(v) if shown == v => {}
                Some(v) => problems.push(format!(
                    "{name} --{option}: shows {shown}, the documented exception is {v}"
                )),
                None if shown != expected => problems.push(format!(
                    "{name} --{option}: shows {shown}, the library default is {expected}"
                )),
                None => {}
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The comparison is not vacuous: the shared options appear in the commands that have them.
    for (option, at_least) in [
        ("transport", 6),
        ("steps", 5),
        ("lambda", 8),
        ("insert", 5),
        ("restarts", 5),
        ("align", 6),
        ("smooth-length", 5),
        ("levels", 3),
    ] {
        let n = seen.get(option).map_or(0, Vec::len);
        assert!(n >= at_least, "--{option} seen in only {n} commands: {seen:?}");
    }
    // Every exception is still an exception (else it should be removed from the list).
    for (c, o, v) in &exceptions {
        if lib.get(o) == Some(v) {
            panic!("{c} --{o}: the exception {v} equals the library default; drop it");
        }
    }
}

#[test]
fn transfer_and_similarity_use_one_transport() {
    let t = parse_defaults(&help_of(&["transfer"]));
    let s = parse_defaults(&help_of(&["similarity"]));
    assert_eq!(t.get("transport"), s.get("transport"));
    assert_eq!(t.get("transport").map(String::as_str), Some("euclidean"));
}
