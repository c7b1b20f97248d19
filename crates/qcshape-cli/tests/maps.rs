//! End-to-end tests of the per-vertex maps: `geodesic --out`, `transfer` and `interpolate`
//! fields, and `qcshape localize`.

use std::path::{Path, PathBuf};
use std::process::Command;

use qcshape::dataset::{write_manifest, ManifestRow};

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

#[test]
fn geodesic_out_writes_segment_and_contribution_maps_that_sum_to_the_distance() {
    let dir = tempfile::tempdir().unwrap();
    let out = qcshape()
        .args([
            "geodesic",
            "--demo",
            "--demo-level",
            "1",
            "--steps",
            "3",
            "--json",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let distance = v["distance"].as_f64().unwrap();
    let energy = v["energy"].as_f64().unwrap();
    let c = qcshape::io::read_mesh(&dir.path().join("contribution.vtk")).unwrap();
    let length: f64 = c.point_array("length").unwrap().values.iter().sum();
    let e: f64 = c.point_array("energy").unwrap().values.iter().sum();
    assert!(
        (length - distance).abs() <= 1e-9 * distance,
        "{length} vs {distance}"
    );
    assert!((e - energy).abs() <= 1e-8 * energy, "{e} vs {energy}");
    assert_eq!(c.point_array("displacement").unwrap().components, 3);
    let mut seg_sum = 0.0;
    for i in 0..3 {
        let s = qcshape::io::read_mesh(&dir.path().join(format!("segment_{i:03}.vtk"))).unwrap();
        seg_sum += s.point_array("length").unwrap().values.iter().sum::<f64>();
    }
    assert!((seg_sum - distance).abs() <= 1e-9 * distance);
    let ply = std::fs::read(dir.path().join("contribution.ply")).unwrap();
    assert!(String::from_utf8_lossy(&ply).contains("property double quality\nproperty double length\n"));
}

/// `base` with a radial bump of height `h` on the cap z > 0.6.
fn bumped(base: &[[f64; 3]], h: f64) -> Vec<[f64; 3]> {
    base.iter()
        .map(|p| {
            let t = ((p[2] - 0.6) / 0.4).max(0.0);
            p.map(|c| c * (1.0 + h * t * t))
        })
        .collect()
}

/// 5 + 5 deformations of two poses on a 162-vertex sphere: all stretch along x by slightly
/// different amounts; group "bump" also grows a bump on the cap z > 0.6.
fn labelled_set(dir: &Path) -> PathBuf {
    let s = qcshape::synth::icosphere(2);
    let faces = s.topology.faces();
    let mut rows = Vec::new();
    for k in 0..10 {
        let (label, h) = if k < 5 { ("plain", 0.0) } else { ("bump", 0.25) };
        let a = 0.1 + 0.02 * (k % 5) as f64;
        let name = format!("d{k}");
        std::fs::create_dir_all(dir.join(&name)).unwrap();
        let end: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [p[0] * (1.0 + a), p[1], p[2]])
            .collect();
        for (pose, pos) in [s.positions.clone(), bumped(&end, h)].iter().enumerate() {
            let rel = PathBuf::from(&name).join(format!("p{pose}.ply"));
            qcshape::io::write_mesh(&dir.join(&rel), pos, faces, &Default::default()).unwrap();
            rows.push(ManifestRow {
                deformation: name.clone(),
                label: Some(label.into()),
                pose: pose as i64,
                path: rel,
            });
        }
    }
    let m = dir.join("manifest.csv");
    write_manifest(&m, &rows).unwrap();
    m
}

#[test]
fn localize_finds_the_bumped_cap() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = labelled_set(dir.path());
    let out_dir = dir.path().join("maps");
    // The cap as a --region mask.
    let sphere = qcshape::synth::icosphere(2);
    let mut region = String::from("vertex,region\n");
    for (v, p) in sphere.positions.iter().enumerate() {
        region.push_str(&format!("{v},{}\n", u8::from(p[2] > 0.5)));
    }
    let region_file = dir.path().join("cap.csv");
    std::fs::write(&region_file, region).unwrap();
    let out = qcshape()
        .args([
            "localize",
            "--region",
            region_file.to_str().unwrap(),
            manifest.to_str().unwrap(),
            "--steps",
            "3",
            "--smoothing",
            "0",
        ])
        .args([
            "--permutations",
            "199",
            "--seed",
            "3",
            "--threads",
            "1",
            "--alpha",
            "0.1",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(out_dir.join("contrast_plain_vs_bump.csv")).unwrap();
    let s = qcshape::synth::icosphere(2);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("vertex,score,p_value,significant"));
    // The ring of vertices just outside the cap: the bump's rim bends the hinges that straddle
    // the cap's edge, and the bending term shares each hinge among its four vertices.
    let on_cap = |v: usize| s.positions[v][2] > 0.5;
    let rim = |v: usize| !on_cap(v) && s.topology.neighbors(v).iter().any(|&u| on_cap(u as usize));
    let (mut sig_cap, mut sig_off, mut sig_far, mut n_cap) = (0, 0, 0, 0);
    let (mut score_cap, mut score_all) = (0.0, 0.0);
    for (v, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let score: f64 = f[1].parse().unwrap();
        let significant = f[3] == "true";
        let on_cap = s.positions[v][2] > 0.5;
        n_cap += usize::from(on_cap);
        score_all += score.max(0.0);
        if on_cap {
            score_cap += score.max(0.0);
            sig_cap += usize::from(significant);
        } else {
            sig_off += usize::from(significant);
            sig_far += usize::from(significant && !rim(v));
        }
    }
    eprintln!(
        "cap: {sig_cap} of {n_cap} significant, elsewhere {sig_off} ({sig_far} beyond the cap's rim); cap share of positive score {:.4}",
        score_cap / score_all
    );
    assert!(score_cap / score_all > 0.9, "{}", score_cap / score_all);
    assert!(sig_cap >= n_cap / 2, "{sig_cap} of {n_cap}");
    assert!(
        sig_far <= 3,
        "{sig_far} significant beyond the rim ({sig_off} off the cap)"
    );
    let m = qcshape::io::read_mesh(&out_dir.join("contrast_plain_vs_bump.vtk")).unwrap();
    for name in ["score", "p_value", "significant", "between", "within"] {
        assert!(m.point_array(name).is_some(), "{name}");
    }
    assert!(out_dir.join("contrast_plain_vs_bump.ply").exists());
    let png = std::fs::read(out_dir.join("contrast_plain_vs_bump.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The region summary: the cap holds most of the positive mass, a small share of the area.
    let summary = std::fs::read_to_string(out_dir.join("region_summary.csv")).unwrap();
    let mut lines = summary.lines();
    assert_eq!(
        lines.next(),
        Some("map,a,b,region_vertices,vertices,area_share,positive_mass_share,ratio,significant_in_region,significant")
    );
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert_eq!(rows.len(), 3, "{summary}");
    let f = &rows[0];
    assert_eq!(
        (f[0].as_str(), f[1].as_str(), f[2].as_str(), f[4].as_str()),
        ("contrast", "plain", "bump", "162")
    );
    assert_eq!(f[3].parse::<usize>().unwrap(), n_cap);
    let (area, mass, ratio): (f64, f64, f64) = (
        f[5].parse().unwrap(),
        f[6].parse().unwrap(),
        f[7].parse().unwrap(),
    );
    assert!(area > 0.1 && area < 0.4, "{area}");
    assert!((mass - score_cap / score_all).abs() < 1e-4, "{mass}");
    assert!((ratio - mass / area).abs() < 1e-3 * ratio);
    // The signed motion map: the bump group moves more, on the cap (the bump grows along the
    // normal); where the plain group moves more there is little mass, and not on the cap.
    let (plain_more, bump_more) = (&rows[1], &rows[2]);
    assert_eq!(
        (
            plain_more[0].as_str(),
            plain_more[1].as_str(),
            plain_more[2].as_str()
        ),
        ("motion", "plain", "bump")
    );
    assert_eq!((bump_more[1].as_str(), bump_more[2].as_str()), ("bump", "plain"));
    let bump_mass: f64 = bump_more[6].parse().unwrap();
    assert!(bump_mass > 0.9, "{summary}");
    let csv = std::fs::read_to_string(out_dir.join("motion_plain_minus_bump.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("vertex,difference,p_value,significant"));
    let (mut neg_cap, mut pos_cap) = (0, 0);
    for (v, line) in lines.enumerate() {
        let d: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
        if s.positions[v][2] > 0.6 {
            neg_cap += usize::from(d < 0.0);
            pos_cap += usize::from(d > 0.0);
        }
    }
    assert!(neg_cap > 0 && pos_cap == 0, "{neg_cap} {pos_cap}");
    let m = qcshape::io::read_mesh(&out_dir.join("motion_plain_minus_bump.vtk")).unwrap();
    for name in ["difference", "p_value", "significant", "mean_a", "mean_b"] {
        assert!(m.point_array(name).is_some(), "{name}");
    }
    let png = std::fs::read(out_dir.join("motion_plain_minus_bump.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn localize_needs_labels() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = labelled_set(dir.path());
    let text = std::fs::read_to_string(&manifest).unwrap();
    let unlabelled: String = text.replace(",bump,", ",,").replace(",plain,", ",,");
    std::fs::write(&manifest, unlabelled).unwrap();
    let out = qcshape()
        .args(["localize", manifest.to_str().unwrap(), "--out"])
        .arg(dir.path().join("m"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no label"), "{err}");
}
