//! One option schema: every command that computes a similarity matrix from a data set takes
//! every setting of the library's table (`qcshape::settings::SETTINGS`), with the library's
//! default in its `--help`; every command that solves geodesics takes the metric and solver
//! settings.

use std::process::Command;

use qcshape::settings::{of_groups, Group, Setting};

fn help(command: &str) -> String {
    let mut args: Vec<&str> = command.split_whitespace().collect();
    args.push("--help");
    let out = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(&args)
        .output()
        .unwrap();
    assert!(out.status.success(), "{command} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

/// The text of `--key` in `help`, up to the next option.
fn entry(help: &str, key: &str) -> Option<String> {
    let flag = format!("--{key} ");
    let mut lines = help.lines().skip_while(|l| !l.trim_start().starts_with(&flag));
    let first = lines.next()?;
    let rest = lines.take_while(|l| !l.trim_start().starts_with('-'));
    Some(std::iter::once(first).chain(rest).collect::<Vec<_>>().join("\n"))
}

fn check(command: &str, settings: &[&Setting]) {
    let text = help(command);
    for s in settings {
        let e = entry(&text, s.key).unwrap_or_else(|| panic!("`qcshape {command}` has no --{}", s.key));
        // Named exceptions keep their own default (tests/defaults.rs checks those).
        let exception = matches!(command, "experiment noise" | "lv run" | "lv cycle") && s.key == "steps";
        if let Some(d) = (s.default)().filter(|_| !exception) {
            let shown = e.contains(&format!("[default: {d}]"));
            assert!(
                shown,
                "`qcshape {command}` --{}: expected [default: {d}] in\n{e}",
                s.key
            );
        }
    }
}

#[test]
fn matrix_commands_take_every_setting_with_the_librarys_default() {
    // Every setting of the table, whatever its group (a new group is taken too).
    let all: Vec<&Setting> = qcshape::settings::SETTINGS.iter().collect();
    for command in ["similarity", "run", "classify"] {
        check(command, &all);
    }
}

#[test]
fn geodesic_commands_take_every_metric_and_solver_setting() {
    let ms: Vec<&Setting> = of_groups(&[Group::Metric, Group::Solver]).collect();
    for command in [
        "geodesic",
        "transfer",
        "localize",
        "experiment noise",
        "lv run",
        "lv cycle",
    ] {
        check(command, &ms);
    }
}

#[test]
fn a_value_out_of_range_is_named_by_its_flag() {
    let out = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(["geodesic", "--demo", "--qc-floor", "-1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("--qc-floor"), "{err}");
}

mod settings_gen;

/// (source file under crates/qcshape-cli/src, flag): options that keep a help and default of
/// their own, each for its reason: a documented exception of `qcshape::defaults` (the paper's
/// settings), or another option that shares the name.
const OWN: &[(&str, &str)] = &[
    ("reproduce.rs", "insert"),                // default 3 (1 with --quick), section 3.3
    ("reproduce.rs", "steps"),                 // default 4 (2 with --quick), Table 1
    ("experiment/interpolation.rs", "insert"), // 1: the middle pose of Fig. 4
    ("experiment/noise.rs", "steps"),          // NOISE_STEPS, Table 3 (mut_arg)
    ("experiment/noise.rs", "levels"),         // noise variances, not spatial levels
    ("experiment/geometry.rs", "levels"),      // icosphere levels
    ("experiment/robustness.rs", "smooth"),    // lists of values compared
    ("experiment/robustness.rs", "smooth-length"),
    ("experiment/robustness.rs", "bending"), // a list of weights compared
    ("interpolate.rs", "insert"),            // required: no default
    ("lv/cycle.rs", "insert"),               // PAPER_INSERT, the LV tables
    ("lv/cycle.rs", "steps"),                // PAPER_STEPS (mut_arg)
    ("lv/run.rs", "smooth"),                 // the meshing's Taubin iterations
    ("lv/run.rs", "transport"),              // LV_TRANSPORT, the LV tables
    ("lv/mesh.rs", "smooth"),                // the meshing's Taubin iterations
    ("lv/mesh.rs", "lambda"),                // the landmark spline's smoothing
    ("lv/mod.rs", "lambda"),                 // the landmark spline's smoothing
    ("embed.rs", "tolerance"),               // the MDS stress tolerance
];

/// Every `#[arg(...)]` of the CLI's sources whose flag is a setting's key: (file, flag, the
/// attribute, whether a doc comment stands above it); and every `mut_arg("flag"` as
/// (file, flag, "mut_arg", false).
fn setting_args() -> Vec<(String, String, String, bool)> {
    let src = settings_gen::root().join("crates/qcshape-cli/src");
    let mut files = vec![src.clone()];
    let mut out = Vec::new();
    while let Some(p) = files.pop() {
        if p.is_dir() {
            files.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            continue;
        }
        let rel = p.strip_prefix(&src).unwrap().to_string_lossy().replace('\\', "/");
        let text = std::fs::read_to_string(&p).unwrap();
        for (i, _) in text.match_indices("mut_arg(\"") {
            let flag: String = text[i + 9..].chars().take_while(|&c| c != '"').collect();
            out.push((rel.clone(), flag, "mut_arg".to_string(), false));
        }
        let lines: Vec<&str> = text.lines().collect();
        let mut i = 0;
        while i < lines.len() {
            if !lines[i].trim_start().starts_with("#[arg(") {
                i += 1;
                continue;
            }
            let mut doc = i > 0 && lines[i - 1].trim_start().starts_with("///");
            let mut attr = lines[i].trim().to_string();
            while !lines[i].trim_end().ends_with(")]") {
                i += 1;
                attr.push_str(lines[i].trim());
            }
            let mut k = i + 1;
            // Attributes and doc comments (a doc comment is clap's help) up to the field.
            while lines[k].trim_start().starts_with("#[") || lines[k].trim_start().starts_with("///") {
                doc |= lines[k].trim_start().starts_with("///");
                k += 1;
            }
            let field = lines[k]
                .trim_start()
                .trim_start_matches("pub(crate) ")
                .trim_start_matches("pub ");
            let mut flag: String = field
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            flag = flag.replace('_', "-");
            if let Some(j) = attr.find("long = \"") {
                flag = attr[j + 8..].chars().take_while(|&c| c != '"').collect();
            }
            if qcshape::settings::by_key(&flag).is_some() {
                out.push((rel.clone(), flag, attr, doc));
            }
            i += 1;
        }
    }
    out
}

/// The acceptance test of issue 48 item 2: every setting is declared once, in
/// `qcshape::settings`. It fails when
/// - a CLI flag of a setting declares its own help (a doc comment or `help = "..."`) or default
///   instead of the declaration's (`help = S::X.help()`, `default_value = S::X.default_text()`),
///   outside the named exceptions `OWN`;
/// - a Python source names a setting's keyword in code (the keywords come from the table;
///   `ShapeSpace`'s parameters must be the table's metric and solver keywords);
/// - a generated text (the `.pyi` option lists, docs/defaults.md's table, the text signatures)
///   differs from what the declaration renders (refresh: `settings_gen::REFRESH`);
/// - a command's `--help` shows another help or default for a setting than the declaration.
#[test]
fn each_setting_is_declared_once() {
    let mut problems = Vec::new();
    let mut seen = 0;
    for (file, flag, attr, doc) in setting_args() {
        if OWN.contains(&(file.as_str(), flag.as_str())) {
            continue;
        }
        seen += 1;
        let c = format!("::{}.", flag.to_uppercase().replace('-', "_"));
        let own_default = attr.contains("default_value_t")
            || (attr.contains("default_value") && !attr.contains(&format!("{c}default_text()")));
        if doc || attr == "mut_arg" || !attr.contains(&format!("{c}help()")) || own_default {
            problems.push(format!(
                "crates/qcshape-cli/src/{file}: --{flag} declares its own help or default; take them from \
                 qcshape::settings (help = S{c}help(), default_value = S{c}default_text()) or name the \
                 exception in OWN"
            ));
        }
    }
    assert!(seen >= 40, "only {seen} setting flags found: the scan is broken");
    // Python: no setting keyword spelled in code (comments and the generated text signatures aside).
    let py = settings_gen::root().join("crates/qcshape-py/src");
    for entry in std::fs::read_dir(&py).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            // `points(x, "base")` names a method's shape argument, not the setting.
            if code.contains("text_signature")
                || code.contains("points(")
                || line.trim_start().starts_with("//")
            {
                continue;
            }
            for s in qcshape::settings::SETTINGS {
                for kw in std::iter::once(s.python).chain(s.python_alias) {
                    // `prior="smooth"` is a value that happens to spell a keyword.
                    let spelled = code.matches(&format!("\"{kw}\"")).count();
                    let as_value = code.matches(&format!("=\"{kw}\"")).count();
                    if spelled > as_value {
                        problems.push(format!(
                            "{}:{}: the Python keyword \"{kw}\" is spelled again; read it from qcshape::settings",
                            path.display(),
                            n + 1
                        ));
                    }
                }
            }
        }
    }
    // ShapeSpace's keyword parameters are exactly the table's metric and solver keywords.
    let space = std::fs::read_to_string(py.join("space.rs")).unwrap();
    let sig = space
        .split("#[pyo3(signature = (faces, ")
        .nth(1)
        .expect("ShapeSpace's signature");
    let sig = &sig[..sig.find("))]").unwrap()];
    let mut given: Vec<String> = sig
        .split(',')
        .map(|p| p.trim().split('=').next().unwrap().to_string())
        .filter(|p| !["*", "reference", "scale", "n_vertices", ""].contains(&p.as_str()))
        .collect();
    let mut table: Vec<String> = of_groups(&[Group::Metric, Group::Solver])
        .map(|s| s.python.to_string())
        .collect();
    given.sort();
    table.sort();
    if given != table {
        problems.push(format!(
            "ShapeSpace's keywords {given:?} differ from the table's {table:?}"
        ));
    }
    // The generated front ends.
    for (path, expected) in settings_gen::expected() {
        let actual = std::fs::read_to_string(settings_gen::root().join(&path)).unwrap();
        if actual != expected {
            let diff: Vec<String> = actual
                .lines()
                .zip(expected.lines())
                .filter(|(a, e)| a != e)
                .take(5)
                .map(|(a, e)| format!("  is:        {a}\n  generated: {e}"))
                .collect();
            problems.push(format!(
                "{} differs from the declaration (refresh: {}):\n{}",
                path.display(),
                settings_gen::REFRESH,
                diff.join("\n")
            ));
        }
    }
    // The CLI's help shows the declaration's help and default.
    let squash = |t: &str| t.split_whitespace().collect::<Vec<_>>().join(" ");
    for command in [
        "similarity",
        "geodesic",
        "reproduce",
        "experiment noise",
        "transfer",
        "interpolate",
    ] {
        let text = help(command);
        for s in qcshape::settings::SETTINGS {
            let Some(e) = entry(&text, s.key) else { continue };
            if command == "reproduce" && ["insert", "steps"].contains(&s.key)
                || command == "experiment noise" && ["steps", "levels"].contains(&s.key)
                || command == "interpolate" && s.key == "insert"
            {
                continue;
            }
            if !squash(&e).contains(&squash(s.help())) {
                problems.push(format!(
                    "`qcshape {command}` --{}: help differs from the declaration:\n{e}",
                    s.key
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The fit's options (`qcshape::fit::FitOptions`, not in the settings table): the CLI takes its
/// defaults from `FitOptions::default()` in code; pyo3 shows a default in `help(qs.fit)` only
/// when it is a literal, so the Python signature and the `.pyi` stub spell them, and this test
/// fails when either differs from the library's.
#[test]
fn the_fit_defaults_of_python_and_the_stub_are_the_librarys() {
    let d = qcshape::fit::FitOptions::default();
    let expected = [
        ("alignment", format!("\"{}\"", d.alignment.label())),
        ("prior", format!("\"{}\"", d.prior.label())),
        ("stages", d.stages.to_string()),
        ("max_samples", d.max_samples.to_string()),
    ];
    let root = settings_gen::root();
    let binding = std::fs::read_to_string(root.join("crates/qcshape-py/src/fit.rs")).unwrap();
    let sig = binding
        .lines()
        .find(|l| l.contains("#[pyo3(signature = (template_vertices"))
        .expect("qs.fit's signature line");
    let stub = std::fs::read_to_string(root.join("crates/qcshape-py/python/qcshape/__init__.pyi")).unwrap();
    let stub = &stub[stub.find("def fit(").expect("def fit( in the stub")..];
    let stub = &stub[..stub.find(") ->").unwrap()];
    for (key, value) in &expected {
        let in_sig = sig
            .split(',')
            .map(str::trim)
            .find_map(|p| p.strip_prefix(&format!("{key}=")))
            .unwrap_or_else(|| panic!("{key} is not in qs.fit's signature: {sig}"));
        let in_sig = in_sig
            .strip_prefix("AnyInt::new(")
            .map_or(in_sig, |n| n.trim_end_matches([')', ']']));
        assert_eq!(in_sig, value, "qs.fit's default for {key}");
        let line = stub
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{key}:")))
            .unwrap_or_else(|| panic!("{key} is not in the stub's fit"));
        let in_stub = line.rsplit('=').next().unwrap().trim().trim_end_matches(',');
        assert_eq!(in_stub, value, "the stub's default for {key}");
    }
}
