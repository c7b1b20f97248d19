//! End-to-end test of `qcshape fit` (issue 49): a 42-vertex template fitted to synthetic
//! deformations meshed with 162 vertices, tracked, written as a data set that `similarity`
//! reads; refusals.

use std::path::Path;
use std::process::{Command, Output};

use qcshape::dataset::Dataset;
use qcshape::io::{write_mesh, VertexAttributes};
use qcshape::synth::{genus0_benchmark, icosphere, write_benchmark, SynthOptions};

fn qcshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .output()
        .expect("the qcshape binary runs")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fits_tracks_and_writes_a_data_set_that_similarity_reads() {
    let dir = tempfile::tempdir().unwrap();
    let defs = genus0_benchmark(&SynthOptions {
        level: 2,
        ..Default::default()
    })
    .unwrap();
    // ellipsoid-bend, ellipsoid-taper, pear-bend (the benchmark is shape-major, 8 per shape).
    let subset = vec![defs[8 + 1].clone(), defs[8 + 2].clone(), defs[32 + 1].clone()];
    let data = dir.path().join("data");
    let manifest = write_benchmark(&data, &subset, qcshape::io::Format::Ply).unwrap();
    let template = dir.path().join("template.obj");
    let t = icosphere(1);
    write_mesh(
        &template,
        &t.positions,
        t.topology.faces(),
        &VertexAttributes::default(),
    )
    .unwrap();
    let out = dir.path().join("fitted");
    let r = qcshape(&[
        "fit",
        "--template",
        s(&template),
        "--out",
        s(&out),
        "--sequence",
        s(&manifest),
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(
        stdout.contains("to 9 poses of 3 deformations (tracked)"),
        "{stdout}"
    );
    let ds = Dataset::load(&out.join("manifest.csv")).unwrap();
    assert_eq!(ds.deformations.len(), 3);
    assert!(ds.shares_topology());
    assert_eq!(ds.deformations[0].topology.faces(), t.topology.faces());
    assert_eq!(ds.labels(), Dataset::load(&manifest).unwrap().labels());
    let quality = std::fs::read_to_string(out.join("quality.csv")).unwrap();
    assert_eq!(quality.lines().count(), 10, "{quality}");
    // No poor fit (column 13, `poor`; the template's own angle, new slivers and the slide
    // follow it).
    assert!(
        quality
            .lines()
            .skip(1)
            .all(|l| l.split(',').nth(13) == Some("false")),
        "{quality}"
    );

    // The fitted set is an ordinary data set.
    let d = dir.path().join("D.csv");
    let r = qcshape(&[
        "similarity",
        s(&out.join("manifest.csv")),
        "--metric",
        "isometric",
        "--steps",
        "4",
        "--threads",
        "1",
        "-o",
        s(&d),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));

    // Same input, same bytes.
    let again = dir.path().join("again");
    let r = qcshape(&[
        "fit",
        "--template",
        s(&template),
        "--out",
        s(&again),
        "--sequence",
        s(&manifest),
    ]);
    assert!(r.status.success());
    let pose = ds.deformations[1].paths[2]
        .strip_prefix(&out)
        .unwrap()
        .to_path_buf();
    for rel in [Path::new("manifest.csv"), Path::new("quality.csv"), &pose] {
        assert_eq!(
            std::fs::read(out.join(rel)).unwrap(),
            std::fs::read(again.join(rel)).unwrap(),
            "{}",
            rel.display()
        );
    }
}

#[test]
fn refuses_to_write_over_its_inputs_and_bad_targets() {
    let dir = tempfile::tempdir().unwrap();
    let t = icosphere(1);
    let template = dir.path().join("template.ply");
    write_mesh(
        &template,
        &t.positions,
        t.topology.faces(),
        &VertexAttributes::default(),
    )
    .unwrap();
    let target = dir.path().join("target.off");
    let big = icosphere(2);
    write_mesh(
        &target,
        &big.positions,
        big.topology.faces(),
        &VertexAttributes::default(),
    )
    .unwrap();
    // The output folder holds the inputs.
    let r = qcshape(&[
        "fit",
        "--template",
        s(&template),
        "--out",
        s(dir.path()),
        s(&target),
    ]);
    assert!(!r.status.success());
    let e = String::from_utf8_lossy(&r.stderr);
    assert!(e.contains("--out") && e.lines().count() == 1, "{e}");
    // An empty target.
    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let r = qcshape(&[
        "fit",
        "--template",
        s(&template),
        "--out",
        s(&dir.path().join("o")),
        s(&empty),
    ]);
    assert!(!r.status.success());
    let e = String::from_utf8_lossy(&r.stderr);
    assert!(e.contains("empty.obj") && e.lines().count() == 1, "{e}");
    // A good run on plain files names the deformation.
    let out = dir.path().join("ok");
    let r = qcshape(&[
        "fit",
        "--template",
        s(&template),
        "--out",
        s(&out),
        "--name",
        "blob",
        s(&target),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // Named as every other command names poses (issue 60: it wrote pose0.ply).
    assert!(out.join("blob/pose000.ply").is_file());
    assert!(!out.join("blob/pose0.ply").exists());
}
