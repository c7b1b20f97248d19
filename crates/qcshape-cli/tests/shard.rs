//! End-to-end tests of sharded similarity runs: `similarity --shard K/S` and
//! `similarity-merge` give the bytes of a single run; incomplete, repeated or foreign shards are
//! refused.

use std::path::{Path, PathBuf};
use std::process::Command;

use qcshape::synth::{genus0_benchmark, write_benchmark, SynthOptions};

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Seven deformations of the 42-vertex benchmark, several classes.
fn dataset(dir: &Path) -> PathBuf {
    let defs = genus0_benchmark(&SynthOptions {
        level: 1,
        ..Default::default()
    })
    .unwrap();
    let subset: Vec<_> = (0..7).map(|c| defs[c * 6 % defs.len()].clone()).collect();
    write_benchmark(dir, &subset, qcshape::io::Format::Ply).unwrap()
}

fn similarity(manifest: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    qcshape()
        .args([
            "similarity",
            manifest.to_str().unwrap(),
            "--metric",
            "isometric",
            "--steps",
            "3",
        ])
        .args(["-o", out.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap()
}

fn ok(r: &std::process::Output) {
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

fn fails_with(r: &std::process::Output, words: &[&str]) {
    let e = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "expected a failure");
    for w in words {
        assert!(e.contains(w), "expected {w:?} in: {e}");
    }
}

fn merge(shards: &[PathBuf], out: &Path, extra: &[&str]) -> std::process::Output {
    qcshape()
        .arg("similarity-merge")
        .args(shards)
        .args(["-o", out.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn merged_shards_are_byte_identical_to_a_single_run() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path());
    let single = dir.path().join("single.csv");
    let single_details = dir.path().join("single-poses.csv");
    ok(&similarity(
        &manifest,
        &single,
        &["--details", single_details.to_str().unwrap()],
    ));

    let out = dir.path().join("D.csv");
    let shards: Vec<PathBuf> = (1..=3)
        .map(|k| {
            // Different thread counts per shard: the values do not depend on them.
            let threads = if k == 2 { "1" } else { "2" };
            ok(&similarity(
                &manifest,
                &out,
                &["--shard", &format!("{k}/3"), "--threads", threads],
            ));
            let f = dir.path().join(format!("D.csv.shard-{k}-of-3"));
            assert!(f.exists(), "{}", f.display());
            f
        })
        .collect();
    assert!(!out.exists(), "a shard must not write the matrix");
    let details = dir.path().join("poses.csv");
    ok(&merge(&shards, &out, &["--details", details.to_str().unwrap()]));
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&single).unwrap());
    assert_eq!(
        std::fs::read(&details).unwrap(),
        std::fs::read(&single_details).unwrap()
    );
    // .npy output too.
    let npy = dir.path().join("D.npy");
    ok(&merge(&shards, &npy, &[]));
    let single_npy = dir.path().join("single.npy");
    ok(&similarity(&manifest, &single_npy, &[]));
    assert_eq!(std::fs::read(&npy).unwrap(), std::fs::read(&single_npy).unwrap());

    // A missing or repeated shard is refused.
    fails_with(
        &merge(&shards[..2], &dir.path().join("x.csv"), &[]),
        &["3/3", "missing"],
    );
    let twice = [
        shards[0].clone(),
        shards[0].clone(),
        shards[1].clone(),
        shards[2].clone(),
    ];
    fails_with(&merge(&twice, &dir.path().join("x.csv"), &[]), &["also given"]);
    // A shard of another run (other settings) is refused, naming the setting.
    let other = dir.path().join("other.csv");
    ok(&similarity(
        &manifest,
        &other,
        &["--shard", "3/3", "--lambda", "0.2"],
    ));
    let mixed = [
        shards[0].clone(),
        shards[1].clone(),
        dir.path().join("other.csv.shard-3-of-3"),
    ];
    fails_with(
        &merge(&mixed, &dir.path().join("x.csv"), &[]),
        &["another run", "lambda"],
    );
    // An interrupted shard (its last record lost) is refused, and --resume completes it.
    let text = std::fs::read_to_string(&shards[1]).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    std::fs::write(&shards[1], lines[..lines.len() - 1].join("\n") + "\n").unwrap();
    fails_with(
        &merge(&shards, &dir.path().join("x.csv"), &[]),
        &["incomplete", "--resume"],
    );
    let r = similarity(&manifest, &out, &["--shard", "2/3", "--resume"]);
    ok(&r);
    assert!(String::from_utf8_lossy(&r.stderr).contains("already done"));
    let again = dir.path().join("again.csv");
    ok(&merge(&shards, &again, &[]));
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&single).unwrap());
    // Bad shard specifications.
    fails_with(
        &similarity(&manifest, &out, &["--shard", "4/3"]),
        &["1 <= K <= S"],
    );
    fails_with(
        &similarity(&manifest, &out, &["--shard", "1/3", "--details", "p.csv"]),
        &["similarity-merge"],
    );
}
