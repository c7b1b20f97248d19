//! `--format` of the mesh-writing commands: each writes `.vtu` poses that read back with the
//! positions (and fields) of the same command's `.ply` poses, and `--help` lists every format.

use std::path::{Path, PathBuf};
use std::process::Command;

use qcshape::io::{read_mesh, MeshData};

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Runs `qcshape ARGS`, failing the test with its stderr on an error.
fn ok(args: &[&std::ffi::OsStr]) {
    let out = qcshape().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{:?}: {}",
        args,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Three poses of a stretching icosphere (level 1) as `dir/p_k.ply`.
fn sequence(dir: &Path) -> Vec<PathBuf> {
    let s = qcshape::synth::icosphere(1);
    (0..3)
        .map(|k| {
            let a = 1.0 + 0.2 * k as f64;
            let pos: Vec<[f64; 3]> = s.positions.iter().map(|p| [a * p[0], p[1], p[2] / a]).collect();
            let path = dir.join(format!("p_{k}.ply"));
            qcshape::io::write_mesh(&path, &pos, s.topology.faces(), &Default::default()).unwrap();
            path
        })
        .collect()
}

/// The meshes `dir/**/pose*.EXT`, in name order.
fn poses(dir: &Path, ext: &str) -> Vec<MeshData> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == ext)
                && p.file_name().unwrap().to_string_lossy().starts_with("pose")
            {
                files.push(p);
            }
        }
    }
    files.sort();
    assert!(!files.is_empty(), "no {ext} poses in {}", dir.display());
    files.iter().map(|f| read_mesh(f).unwrap()).collect()
}

/// Same positions, faces and point arrays.
fn same(a: &[MeshData], b: &[MeshData]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.positions, y.positions);
        assert_eq!(x.faces, y.faces);
        for f in &x.point_data {
            if f.name == "quality" {
                continue;
            }
            // PLY spells a vector field as NAME_x, NAME_y, NAME_z: compare the fields both have.
            if let Some(g) = y.point_array(&f.name) {
                assert_eq!(f.values, g.values, "field {}", f.name);
            }
        }
    }
}

/// Runs `args ... --format F --out dir/F` for ply and vtu and compares the poses.
fn ply_and_vtu_agree(dir: &Path, args: &[&std::ffi::OsStr]) -> Vec<MeshData> {
    let mut got = Vec::new();
    for ext in ["ply", "vtu"] {
        let out = dir.join(ext);
        let mut a = args.to_vec();
        a.extend([
            "--format".as_ref(),
            ext.as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        ok(&a);
        got.push(poses(&out, ext));
    }
    same(&got[0], &got[1]);
    got.pop().unwrap()
}

#[test]
fn interpolate_transfer_geodesic_write_vtu() {
    let dir = tempfile::tempdir().unwrap();
    let files = sequence(dir.path());
    let f: Vec<&std::ffi::OsStr> = files.iter().map(|p| p.as_os_str()).collect();

    let d = dir.path().join("interp");
    let mut args: Vec<&std::ffi::OsStr> = vec!["interpolate".as_ref()];
    args.extend(&f);
    args.extend(["--insert", "1", "--levels", "1", "--metric", "isometric"].map(std::ffi::OsStr::new));
    let vtu = ply_and_vtu_agree(&d, &args);
    assert_eq!(vtu.len(), 5);
    // Key poses come back as given; the speeds are there.
    let key = read_mesh(&files[1]).unwrap();
    assert_eq!(vtu[2].positions, key.positions);
    assert!(vtu[0].point_array("speed").is_some() && vtu[0].point_array("velocity").is_some());

    let d = dir.path().join("transfer");
    let mut args: Vec<&std::ffi::OsStr> = vec!["transfer".as_ref()];
    args.extend(&f);
    args.extend(["--to".as_ref(), f[1]]);
    let vtu = ply_and_vtu_agree(&d, &args);
    assert_eq!(vtu.len(), 3);
    assert_eq!(vtu[0].positions, key.positions);

    let d = dir.path().join("geodesic");
    let args: Vec<&std::ffi::OsStr> = vec!["geodesic".as_ref(), f[0], f[2], "--steps".as_ref(), "2".as_ref()];
    let vtu = ply_and_vtu_agree(&d, &args);
    assert_eq!(vtu.len(), 3);
    assert_eq!(vtu[0].positions, read_mesh(&files[0]).unwrap().positions);
    assert_eq!(vtu[2].positions, read_mesh(&files[2]).unwrap().positions);
}

#[test]
fn synth_writes_vtu() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["synth", "--level", "0"].map(std::ffi::OsStr::new);
    let vtu = ply_and_vtu_agree(dir.path(), &args);
    assert_eq!(vtu.len(), 48 * 3);
}

#[test]
fn help_lists_every_format() {
    for cmd in [
        &["interpolate"][..],
        &["transfer"],
        &["geodesic"],
        &["synth"],
        &["lv", "mesh"],
    ] {
        let out = qcshape().args(cmd).arg("--help").output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        let line = help
            .lines()
            .skip_while(|l| !l.trim_start().starts_with("--format"))
            .take(12)
            .collect::<Vec<_>>()
            .join("\n");
        for f in ["ply", "obj", "off", "vtk", "vtp", "vtu"] {
            assert!(line.contains(f), "{cmd:?} --help: --format lacks {f}:\n{line}");
        }
    }
}
