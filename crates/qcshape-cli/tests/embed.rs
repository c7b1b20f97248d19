//! End-to-end tests of `qcshape embed`.

use std::path::Path;
use std::process::Command;

use qcshape::similarity::DistanceMatrix;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Eight points of a plane in two groups; their distance matrix and labels.
fn write_planar(dir: &Path) -> Vec<[f64; 2]> {
    let p: Vec<[f64; 2]> = (0..8)
        .map(|i| {
            let t = i as f64;
            if i < 4 {
                [t * 0.3, (t * 1.7).sin()]
            } else {
                [6.0 + (t * 0.9).cos(), 4.0 + t * 0.2]
            }
        })
        .collect();
    let names: Vec<String> = (0..8).map(|i| format!("d{i}")).collect();
    let d = DistanceMatrix::from_fn(names.clone(), |i, j| {
        ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2)).sqrt()
    })
    .unwrap();
    d.write_csv(&dir.join("D.csv")).unwrap();
    let mut labels = String::from("name,label\n");
    for (i, n) in names.iter().enumerate() {
        labels.push_str(&format!("{n},{}\n", if i < 4 { "near" } else { "far" }));
    }
    std::fs::write(dir.join("labels.csv"), labels).unwrap();
    p
}

#[test]
fn writes_coordinates_map_and_heatmap() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_planar(dir.path());
    let out = qcshape()
        .current_dir(dir.path())
        .args([
            "embed",
            "D.csv",
            "--labels",
            "labels.csv",
            "-o",
            "xy.csv",
            "--plot",
            "map.svg",
            "--heatmap",
            "h.svg",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("stress") && stdout.contains("normalized"),
        "{stdout}"
    );
    // Coordinates reproduce the planar distances (up to rigid motion).
    let text = std::fs::read_to_string(dir.path().join("xy.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("name,x,y,label"));
    let rows: Vec<(f64, f64, String)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].parse().unwrap(), f[2].parse().unwrap(), f[3].to_string())
        })
        .collect();
    assert_eq!(rows.len(), 8);
    for i in 0..8 {
        assert_eq!(rows[i].2, if i < 4 { "near" } else { "far" });
        for j in 0..8 {
            let want = ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2)).sqrt();
            let got = ((rows[i].0 - rows[j].0).powi(2) + (rows[i].1 - rows[j].1).powi(2)).sqrt();
            assert!((want - got).abs() < 1e-6, "{i} {j}: {want} vs {got}");
        }
    }
    let svg = std::fs::read_to_string(dir.path().join("map.svg")).unwrap();
    assert_eq!(
        svg.matches("<polygon").count(),
        8 + 2,
        "8 points and 2 legend markers"
    );
    // With classes the legend names them; the points are not named (they would overlap).
    assert!(!svg.contains("d7") && svg.contains("far"));
    let h = std::fs::read_to_string(dir.path().join("h.svg")).unwrap();
    assert!(h.starts_with("<svg") && h.matches("<rect").count() >= 64);
}

#[test]
fn three_dimensions_png_and_json() {
    let dir = tempfile::tempdir().unwrap();
    write_planar(dir.path());
    let out = qcshape()
        .current_dir(dir.path())
        .args([
            "embed", "D.csv", "--dims", "3", "-o", "xyz.csv", "--plot", "map.png", "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["dims"], 3);
    assert!(v["normalized_stress"].as_f64().unwrap() < 1e-6);
    let text = std::fs::read_to_string(dir.path().join("xyz.csv")).unwrap();
    assert!(
        text.starts_with("name,x,y,z\n") && text.lines().count() == 9,
        "{text}"
    );
    let png = std::fs::read(dir.path().join("map.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, at bytes 16..24.
    let w = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(png[20..24].try_into().unwrap());
    // No labels: no legend panel beside the square chart.
    assert_eq!((w, h), (760, 760));
    assert!(png.len() > 10_000);
}

#[test]
fn bad_inputs_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_planar(dir.path());
    std::fs::write(dir.path().join("bad.csv"), "name,a,b\na,0,1\nb,-1,0\n").unwrap();
    let out = qcshape()
        .current_dir(dir.path())
        .args(["embed", "bad.csv"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && e.contains("bad.csv: line 3") && !e.contains("panicked"),
        "{e}"
    );
    let out = qcshape()
        .current_dir(dir.path())
        .args(["embed", "D.csv", "--plot", "map.pdf"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && e.contains("map.pdf") && e.contains(".svg or .png"),
        "{e}"
    );
    let out = qcshape()
        .current_dir(dir.path())
        .args(["embed", "D.csv", "--dims", "4"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}
