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
    let all: Vec<&Setting> = of_groups(&[Group::Metric, Group::Solver, Group::Pipeline]).collect();
    assert_eq!(all.len(), qcshape::settings::SETTINGS.len());
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
