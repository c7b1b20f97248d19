//! The refusal table of issue 40: outputs that would overwrite inputs, option values without
//! bounds, reads that could not end, forged headers and unclear messages. Every case must end
//! with a non-zero exit status that is neither a panic (101) nor a signal, an error message
//! naming the problem, and every file of the case's folder byte-identical afterwards (the
//! inputs are never touched). Cases are data: a name, a command line (`{d}` is the case's
//! folder, which holds the small data set `S/`, a distance matrix `D.csv` and a label
//! manifest `M.csv`) and the substrings the message must hold.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use qcshape::synth::{genus0_benchmark, write_benchmark, SynthOptions};

/// One row of the table.
struct Case {
    name: &'static str,
    /// Command line; `{d}` is replaced by the case's folder.
    args: String,
    /// Substrings the error message must contain.
    expect: Vec<&'static str>,
    /// Extra files to make first (relative path, bytes).
    files: Vec<(String, Vec<u8>)>,
    /// How to prepare the folder beyond the common files (links, FIFOs, locks).
    setup: Option<fn(&Path)>,
}

fn case(name: &'static str, args: &str, expect: &[&'static str]) -> Case {
    Case {
        name,
        args: args.into(),
        expect: expect.to_vec(),
        files: Vec::new(),
        setup: None,
    }
}

impl Case {
    fn file(mut self, path: &str, bytes: impl Into<Vec<u8>>) -> Self {
        self.files.push((path.into(), bytes.into()));
        self
    }
    fn setup(mut self, f: fn(&Path)) -> Self {
        self.setup = Some(f);
        self
    }
}

/// A distance matrix of the three deformations a, b, c.
const MATRIX: &str = "name,a,b,c\na,0,1,2\nb,1,0,1.5\nc,2,1.5,0\n";

/// A label manifest of a, b, c.
const LABELS: &str = "name,label\na,x\nb,x\nc,y\n";

/// A similarity shard journal of `n` deformations with the settings string `settings`.
fn shard(n: usize, k: usize, s: usize, settings: &str) -> String {
    let names: Vec<String> = (0..n).map(|i| format!("\"d{i}\"")).collect();
    format!(
        "# qcshape similarity journal v3\nkey,0000000000000001\nn,{n}\nsettings,{settings}\nshard,{k}/{s}\nnames,[{}]\n",
        names.join(",")
    )
}

fn cases() -> Vec<Case> {
    let metric = |lambda: &str| {
        format!("MetricSpec {{ kind: Isometric, scale: Calibrated, lambda: {lambda} }}|steps=8|insert=0")
    };
    vec![
        // ---- outputs never overwrite inputs ----
        case("classify -o is the matrix", "classify {d}/D.csv --k 2 -o {d}/D.csv", &["-o", "would overwrite the input file", "D.csv"]),
        case("embed -o is the matrix", "embed {d}/D.csv -o {d}/D.csv", &["-o", "would overwrite the input file"]),
        case("classify -o is the label manifest", "classify {d}/D.csv --k 2 --labels {d}/M.csv -o {d}/M.csv", &["would overwrite the input file", "M.csv"]),
        case("classify -o is the matrix by another spelling", "classify {d}/D.csv --k 2 -o {d}/S/../D.csv", &["would overwrite the input file"]),
        case("classify --confusion is the labels", "classify {d}/D.csv --k 2 --labels {d}/M.csv --confusion {d}/M.csv", &["--confusion", "would overwrite"]),
        case("embed --plot is the matrix", "embed {d}/D.csv --plot {d}/D.csv", &["--plot", "would overwrite"]),
        case("classify -o an existing folder", "classify {d}/D.csv --k 2 -o {d}/S", &["-o", "is a folder"]),
        case("similarity -o an existing folder", "similarity {d}/S/manifest.csv -o {d}/S", &["-o", "is a folder"]),
        case("similarity -o .npy whose names file is an input", "similarity {d}/S/x.names.txt -o {d}/S/x.npy", &["names file of -o", "would overwrite the input file"])
            .setup(|d| std::fs::copy(d.join("S/manifest.csv"), d.join("S/x.names.txt")).map(|_| ()).unwrap()),
        case("similarity -o is the manifest", "similarity {d}/S/manifest.csv -o {d}/S/manifest.csv", &["would overwrite the input file"]),
        case("interpolate --out holds the manifest", "interpolate {d}/S/manifest.csv --insert 1 --out {d}/S", &["--out", "holds the input file"]),
        case("interpolate --out holds the key poses", "interpolate {d}/S/sphere-twist/pose000.ply {d}/S/sphere-twist/pose001.ply --insert 1 --out {d}/S", &["--out", "holds the input file", "pose000.ply"]),
        case("interpolate --out is the poses' folder", "interpolate {d}/S/sphere-twist/pose000.ply {d}/S/sphere-twist/pose001.ply --insert 1 --out {d}/S/sphere-twist", &["holds the input file"]),
        case("interpolate --out is an input file", "interpolate {d}/S/sphere-twist/pose000.ply {d}/S/sphere-twist/pose001.ply --insert 1 --out {d}/S/sphere-twist/pose001.ply", &["--out", "would overwrite the input file"]),
        case("transfer --out holds the manifest", "transfer {d}/S/manifest.csv --to {d}/S/sphere-twist/pose000.ply --out {d}/S", &["--out", "holds the input file"]),
        case("geodesic --out holds an input pose", "geodesic {d}/S/sphere-twist/pose000.ply {d}/S/sphere-twist/pose002.ply --out {d}/S/sphere-twist", &["--out", "holds the input file"]),
        case("run --out holds the data set", "run {d}/S/manifest.csv --out {d}/S --k 2", &["--out", "holds the input file"]),
        case("localize --out holds the data set", "localize {d}/S/manifest.csv --out {d}/S", &["--out", "holds the input file"]),
        case("lv mesh --out is the cohort", "lv mesh {d}/S --out {d}/S", &["--out", "holds the input file"]),
        case("experiment noise --out holds the input", "experiment noise {d}/S/manifest.csv --insert 1 --out {d}/S", &["--out", "holds the input file"]),
        case("similarity-merge -o is a shard", "similarity-merge {d}/a.shard-1-of-2 -o {d}/a.shard-1-of-2", &["-o", "would overwrite the input file"])
            .file("a.shard-1-of-2", shard(2, 1, 2, "m=a")),
        case("a second similarity run on a live journal", "similarity {d}/S/manifest.csv -o {d}/out.csv", &["another run holds", "out.csv.journal.lock"])
            .setup(|d| std::fs::write(d.join("out.csv.journal.lock"), format!("{}\n", std::process::id())).unwrap()),
        case("a second similarity run on a live shard", "similarity {d}/S/manifest.csv -o {d}/out.csv --shard 1/2", &["another run holds", "out.csv.shard-1-of-2.lock"])
            .setup(|d| std::fs::write(d.join("out.csv.shard-1-of-2.lock"), format!("{}\n", std::process::id())).unwrap()),
        // ---- bounded options ----
        case("steps u64::MAX", "geodesic --demo --steps 18446744073709551615", &["--steps must be at most 10000"]),
        case("steps 2^32", "geodesic --demo --steps 4294967296", &["--steps must be at most 10000"]),
        case("steps 0", "geodesic --demo --steps 0", &["--steps must be at least 1"]),
        case("insert u64::MAX", "interpolate {d}/S/manifest.csv --insert 18446744073709551615 --out {d}/o", &["--insert must be at most 1000"]),
        case("insert u64::MAX - 1", "interpolate {d}/S/manifest.csv --insert 18446744073709551614 --out {d}/o", &["--insert must be at most 1000"]),
        case("insert above u64", "similarity {d}/S/manifest.csv -o {d}/o.csv --insert 99999999999999999999999", &["--insert must be at most 1000"]),
        case("threads huge", "similarity {d}/S/manifest.csv -o {d}/o.csv --threads 100000", &["--threads must be at most 1024"]),
        case("threads 0", "similarity {d}/S/manifest.csv -o {d}/o.csv --threads 0", &["--threads must be at least 1"]),
        case("k huge", "classify {d}/D.csv --k 99999999", &["--k must be at most 10000"]),
        case("restarts huge", "classify {d}/D.csv --k 2 --restarts 99999999", &["--restarts must be at most 10000"]),
        case("levels huge", "interpolate {d}/S/manifest.csv --insert 1 --levels 1000 --out {d}/o", &["--levels must be at most 16"]),
        case("synth level huge", "synth --out {d}/o --level 40", &["--level must be at most 8"]),
        case("lv cycle every huge", "lv cycle {d}/S --out {d}/o --every 99999999", &["--every must be at most 10000"]),
        case("max iterations huge", "embed {d}/D.csv --max-iterations 99999999999", &["--max-iterations must be at most 1000000"]),
        case("lambda 1e308", "geodesic --demo --lambda 1e308", &["--lambda must be at most 1e6"]),
        case("lambda inf", "geodesic --demo --lambda inf", &["--lambda must be at most"]),
        case("lambda nan", "geodesic --demo --lambda NaN", &["--lambda must be at most"]),
        // ---- negative values ----
        case("steps -1", "geodesic --demo --steps -1", &["--steps must be >= 0"]),
        case("insert -1", "interpolate {d}/S/manifest.csv --insert -1 --out {d}/o", &["--insert must be >= 0"]),
        case("lambda -1", "geodesic --demo --lambda -1", &["--lambda must be >= 0"]),
        case("tolerance -1", "geodesic --demo --tolerance -1", &["--tolerance must be >= 0"]),
        case("length tolerance -0.5", "similarity {d}/S/manifest.csv -o {d}/o.csv --length-tolerance -0.5", &["--length-tolerance must be >= 0"]),
        case("smooth -1", "similarity {d}/S/manifest.csv -o {d}/o.csv --smooth -1", &["--smooth must be >= 0"]),
        case("smooth length -0.1", "similarity {d}/S/manifest.csv -o {d}/o.csv --smooth-length -0.1", &["--smooth-length must be >= 0"]),
        case("smooth length nan", "similarity {d}/S/manifest.csv -o {d}/o.csv --smooth-length NaN", &["--smooth-length must be at most"]),
        case("smooth length 11", "experiment robustness --out {d}/o --smooth-length 0.18,11", &["--smooth-length must be at most"]),
        case("robustness level 9", "experiment robustness --out {d}/o --level 2,9", &["--level must be at most 8"]),
        case("robustness level twice", "experiment robustness --out {d}/o --level 2,2 --shapes sphere --scenarios clean --metrics l2", &["a level is given twice"]),
        case("robustness max restarts below restarts", "experiment robustness --out {d}/o --restarts 30 --max-restarts 20", &["--max-restarts (20) must be at least --restarts (30)"]),
        case("smooth and smooth length", "similarity {d}/S/manifest.csv -o {d}/o.csv --smooth 10 --smooth-length 0.2", &["--smooth", "cannot be used with", "--smooth-length"]),
        case("threads -2", "similarity {d}/S/manifest.csv -o {d}/o.csv --threads -2", &["--threads must be >= 0"]),
        case("k -3", "classify {d}/D.csv --k -3", &["--k must be >= 0"]),
        case("jitter -0.1", "synth --out {d}/o --jitter -0.1", &["jitter must be between 0 and 0.5"]),
        // ---- messages ----
        case("a PLY face index 2.5", "info {d}/f.ply", &["f.ply", "line 14", "vertex index 2.5, not an integer"])
            .file("f.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2.5 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n"),
        // ---- bounded reads ----
        case("a mesh that is a link to /dev/zero", "info {d}/zero.ply", &["zero.ply", "not a regular file"])
            .setup(|d| std::os::unix::fs::symlink("/dev/zero", d.join("zero.ply")).unwrap()),
        case("a mesh that is a FIFO", "info {d}/fifo.ply", &["fifo.ply", "not a regular file"]).setup(mkfifo),
        case("a matrix that is a FIFO", "classify {d}/fifo.ply --k 2", &["fifo.ply", "not a regular file"]).setup(mkfifo),
        case("a manifest that is a link to /dev/zero", "similarity {d}/zero.csv -o {d}/o.csv", &["zero.csv", "not a regular file"])
            .setup(|d| std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap()),
        case("a forged shard header of 70,000 names", "similarity-merge {d}/f.shard-1-of-2 -o {d}/f.csv", &["f.shard-1-of-2", "incomplete"])
            .file("f.shard-1-of-2", shard(70_000, 1, 2, "m=a")),
        case("shards with another lambda", "similarity-merge {d}/h.shard-2-of-2 {d}/g.shard-1-of-2 -o {d}/g.csv", &["other settings", "lambda 0.01 (not 0.1)"])
            .file("g.shard-1-of-2", shard(2, 1, 2, &metric("0.01")))
            .file("h.shard-2-of-2", shard(2, 2, 2, &metric("0.1"))),
    ]
}

/// Makes the FIFO `fifo.ply` (through `mkfifo`).
fn mkfifo(d: &Path) {
    let ok = Command::new("mkfifo").arg(d.join("fifo.ply")).status().unwrap();
    assert!(ok.success());
}

fn walk(d: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![d.to_path_buf()];
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).unwrap() {
            let e = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&e).unwrap();
            if meta.is_dir() {
                stack.push(e);
            } else if meta.is_file() {
                out.push(e);
            }
        }
    }
    out.sort();
    out
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let t = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &t);
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

/// Runs `qcshape args` with a time limit (a read that blocks fails the case instead of the
/// suite); returns the exit status and stderr.
fn run_limited(args: &[String], limit: Duration) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .arg("--quiet")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
            return (status, err);
        }
        if t0.elapsed() > limit {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{args:?} did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn run(c: &Case, data: &Path) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_dir(data, &d.join("S"));
    std::fs::write(d.join("D.csv"), MATRIX).unwrap();
    std::fs::write(d.join("M.csv"), LABELS).unwrap();
    for (path, bytes) in &c.files {
        std::fs::write(d.join(path), bytes).unwrap();
    }
    if let Some(f) = c.setup {
        f(d);
    }
    let before: Vec<(PathBuf, Vec<u8>)> = walk(d)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    let args: Vec<String> = c
        .args
        .split_whitespace()
        .map(|a| a.replace("{d}", d.to_str().unwrap()))
        .collect();
    let (status, stderr) = run_limited(&args, Duration::from_secs(60));
    assert!(
        status.code().is_some_and(|c| c != 0 && c != 101),
        "{}: exit status {status:?}\n{stderr}",
        c.name
    );
    assert!(!stderr.contains("panicked"), "{}: {stderr}", c.name);
    let err: String = stderr
        .lines()
        .filter(|l| l.starts_with("error"))
        .collect::<Vec<_>>()
        .join("\n");
    for e in &c.expect {
        assert!(err.contains(e), "{}: the message lacks {e:?}:\n{stderr}", c.name);
    }
    for (p, b) in &before {
        assert_eq!(
            std::fs::read(p).ok().as_ref(),
            Some(b),
            "{}: {} changed",
            c.name,
            p.display()
        );
    }
}

#[test]
fn every_issue_40_defect_is_refused_before_harm() {
    let data = tempfile::tempdir().unwrap();
    let defs = genus0_benchmark(&SynthOptions {
        level: 0,
        ..Default::default()
    })
    .unwrap();
    write_benchmark(data.path(), &defs[..2], qcshape::io::Format::Ply).unwrap();
    let cases = cases();
    let mut names = std::collections::HashSet::new();
    let mut failed = Vec::new();
    for c in &cases {
        assert!(names.insert(c.name), "two cases named {}", c.name);
        if std::panic::catch_unwind(|| run(c, data.path())).is_err() {
            failed.push(c.name);
        }
    }
    assert!(
        failed.is_empty(),
        "{} of {} cases failed: {failed:?}",
        failed.len(),
        cases.len()
    );
    println!("{} refusal cases", cases.len());
}

/// `qcshape ... | head`: a closed pipe ends the command quietly (exit 0, nothing on stderr
/// about a panic).
#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("D.csv"), MATRIX).unwrap();
    for args in [
        vec![
            "embed".to_string(),
            dir.path().join("D.csv").to_str().unwrap().to_string(),
        ],
        vec![
            "geodesic".into(),
            "--demo".into(),
            "--demo-level".into(),
            "1".into(),
        ],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_qcshape"))
            .args(&args)
            .arg("--quiet")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end at once, as `head -0` would.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {:?}\n{stderr}", out.status);
    }
}
