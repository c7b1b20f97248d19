//! End-to-end tests of `qcshape transfer`.

use std::path::Path;
use std::process::Command;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Writes an icosphere(level) deformed by `f` to `path`.
fn write(path: &Path, level: u32, f: impl Fn([f64; 3]) -> [f64; 3]) {
    let s = qcshape::synth::icosphere(level);
    let pos: Vec<[f64; 3]> = s.positions.iter().map(|&p| f(p)).collect();
    qcshape::io::write_mesh(path, &pos, s.topology.faces(), &Default::default()).unwrap();
}

fn twist(p: [f64; 3], t: f64) -> [f64; 3] {
    let a = 0.4 * t * p[2];
    [
        a.cos() * p[0] - a.sin() * p[1],
        a.sin() * p[0] + a.cos() * p[1],
        (1.0 + 0.2 * t) * p[2],
    ]
}

#[test]
fn data_set_in_transferred_poses_and_manifest_out() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    for (name, sign) in [("up", 1.0), ("down", -1.0)] {
        std::fs::create_dir_all(data.join(name)).unwrap();
        for k in 0..3 {
            write(&data.join(name).join(format!("p{k}.obj")), 1, |p| {
                twist(p, sign * k as f64 / 2.0)
            });
        }
    }
    let base = dir.path().join("base.ply");
    write(&base, 1, |p| [1.3 * p[0], p[1], 0.8 * p[2]]);
    let out_dir = dir.path().join("out");
    let run = |transport: &str, out: &Path| {
        qcshape()
            .args(["transfer", data.to_str().unwrap(), "--to", base.to_str().unwrap()])
            .args([
                "--metric",
                "isometric",
                "--steps",
                "3",
                "--transport",
                transport,
                "--json",
            ])
            .arg("--out")
            .arg(out)
            .output()
            .unwrap()
    };
    let out = run("parallel", &out_dir);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let defs = v["deformations"].as_array().unwrap();
    assert_eq!(defs.len(), 2);
    for d in defs {
        assert_eq!(d["poses"], 3);
        assert_eq!(d["geodesics_converged"], true);
        assert!(d["max_norm_residual"].as_f64().unwrap() < 1e-9, "{d}");
        assert!(d["max_geodesic_length"].as_f64().unwrap() > 0.0);
    }
    // The written data set loads back, starts at the base and differs from Euclidean transfer.
    let set = qcshape::dataset::Dataset::load(&out_dir).unwrap();
    assert_eq!(set.deformations.len(), 2);
    let b = qcshape::io::load_shape(&base).unwrap();
    let eu_dir = dir.path().join("eu");
    assert!(run("euclidean", &eu_dir).status.success());
    let eu = qcshape::dataset::Dataset::load(&eu_dir).unwrap();
    for (d, e) in set.deformations.iter().zip(&eu.deformations) {
        assert_eq!(d.n_poses(), 3);
        assert_eq!(d.poses[0], b.positions);
        assert_eq!(d.name, e.name);
        let diff = d.poses[2]
            .iter()
            .zip(&e.poses[2])
            .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(diff > 1e-6, "parallel transfer equals Euclidean: {diff:e}");
    }
}

#[test]
fn list_of_files_in_obj_out_with_text_summary() {
    let dir = tempfile::tempdir().unwrap();
    let files: Vec<_> = (0..3)
        .map(|k| {
            let p = dir.path().join("seq").join(format!("pose{k}.ply"));
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            write(&p, 1, |x| twist(x, k as f64 / 2.0));
            p
        })
        .collect();
    let base = dir.path().join("base.obj");
    write(&base, 1, |p| [p[0], 1.2 * p[1], p[2]]);
    let out_dir = dir.path().join("out");
    let out = qcshape()
        .arg("transfer")
        .args(&files)
        .args([
            "--to",
            base.to_str().unwrap(),
            "--metric",
            "quasi-conformal",
            "--steps",
            "2",
        ])
        .args(["--transport", "schild", "--format", "obj", "--out"])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("seq") && stdout.contains("converged"), "{stdout}");
    for k in 0..3 {
        let s = qcshape::io::load_shape(&out_dir.join("seq").join(format!("pose{k:03}.obj"))).unwrap();
        assert_eq!(s.n_vertices(), 42);
    }
    let manifest = std::fs::read_to_string(out_dir.join("manifest.csv")).unwrap();
    assert!(manifest.starts_with("deformation,label,pose,path"), "{manifest}");
    assert_eq!(manifest.lines().count(), 4);
}

#[test]
fn a_base_of_another_connectivity_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let files: Vec<_> = (0..2)
        .map(|k| {
            let p = dir.path().join(format!("m{k}.ply"));
            write(&p, 1, |x| twist(x, k as f64));
            p
        })
        .collect();
    let base = dir.path().join("base.ply");
    write(&base, 2, |p| p);
    let out = qcshape()
        .arg("transfer")
        .args(&files)
        .args(["--to", base.to_str().unwrap(), "--out"])
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot be transferred")
            && err.contains("base.ply")
            && err.contains("42")
            && !err.contains("panicked"),
        "{err}"
    );
}

/// Issue 60: Euclidean transfer printed "max geodesic 0  norm change ...  residuals 0/0" and
/// a metric and N it does not use; it now says it translates, and parallel transport explains
/// its columns.
#[test]
fn euclidean_transfer_says_it_translates() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(data.join("up")).unwrap();
    for k in 0..2 {
        write(&data.join("up").join(format!("p{k}.obj")), 1, |p| {
            twist(p, k as f64 / 2.0)
        });
    }
    let base = dir.path().join("base.ply");
    write(&base, 1, |p| [1.3 * p[0], p[1], 0.8 * p[2]]);
    let run = |transport: &str, out: &str| {
        qcshape()
            .args(["transfer", data.to_str().unwrap(), "--to", base.to_str().unwrap()])
            .args(["--steps", "2", "--transport", transport, "--out"])
            .arg(dir.path().join(out))
            .output()
            .unwrap()
    };
    let out = run("euclidean", "eu");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (text, err) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        text.contains("translated") && !text.contains("max geodesic"),
        "{text}"
    );
    assert!(
        err.contains("no metric and no geodesic") && !err.contains("N = 2"),
        "{err}"
    );
    let out = run("parallel", "par");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (text, err) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(text.contains("max geodesic"), "{text}");
    assert!(err.contains("per deformation: the longest geodesic"), "{err}");
}
