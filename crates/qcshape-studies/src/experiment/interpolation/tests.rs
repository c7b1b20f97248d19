use super::*;
use qcshape::synth::{genus0_benchmark, icosphere, SynthOptions};

fn deformation(name: &str, label: &str, topology: Arc<Topology>, poses: Vec<Vec<[f64; 3]>>) -> Deformation {
    Deformation {
        name: name.into(),
        label: Some(label.into()),
        topology,
        poses,
        paths: Vec::new(),
        warnings: Vec::new(),
    }
}

/// Poses `A`, `(A + B) / 2`, `B` of an icosphere: `B` stretched and shifted.
fn linear_deformation() -> Deformation {
    let s = icosphere(1);
    let a = s.positions.clone();
    let b: Vec<[f64; 3]> = a
        .iter()
        .map(|p| [1.3 * p[0] + 0.2, 0.8 * p[1], p[2] - 0.1])
        .collect();
    let mid = a
        .iter()
        .zip(&b)
        .map(|(p, q)| geometry::scale(geometry::add(*p, *q), 0.5))
        .collect();
    deformation("lin", "linear-motion", s.topology.clone(), vec![a, mid, b])
}

fn only(kinds: &[MetricKind]) -> InterpolationExperiment {
    InterpolationExperiment {
        metrics: kinds.iter().map(|k| MetricSpec::new(*k)).collect(),
        ..Default::default()
    }
}

#[test]
fn l2_and_baseline_recover_a_linear_middle_exactly() {
    let d = linear_deformation();
    let r = only(&[MetricKind::L2, MetricKind::Isometric])
        .run_synthetic(std::slice::from_ref(&d), &|| {})
        .unwrap();
    assert_eq!(r.methods, vec!["l2", "isometric", BASELINE]);
    let case = |m: &str| r.cases.iter().find(|c| c.method == m).unwrap();
    assert!(case("l2").max < 1e-9, "{:?}", case("l2"));
    assert!(case(BASELINE).max < 1e-9);
    // The isometric geodesic between a shape and its stretched copy is not the straight line.
    assert!(case("isometric").mean > 1e-4, "{:?}", case("isometric"));
    assert_eq!(r.summary.len(), 3);
    assert_eq!(r.get("linear-motion", "l2").unwrap().n, 1);
    // The only deformation is the showcase: one error map per method.
    assert_eq!(r.maps.len(), 3);
    assert_eq!(r.maps[0].errors.len(), d.topology.n_vertices());
}

#[test]
fn summary_is_mean_and_sd_of_cases_and_markdown_names_every_method() {
    let defs = genus0_benchmark(&SynthOptions {
        level: 0,
        ..Default::default()
    })
    .unwrap();
    // Two types, two shapes each.
    let defs: Vec<Deformation> = defs
        .into_iter()
        .filter(|d| {
            (d.name.starts_with("sphere-") || d.name.starts_with("pear-"))
                && matches!(d.label.as_deref(), Some("bend" | "twist"))
        })
        .collect();
    assert_eq!(defs.len(), 4);
    let exp = InterpolationExperiment::default();
    assert_eq!(exp.synthetic_cases(&defs), 16);
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let r = exp
        .run_synthetic(&defs, &|| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
    assert_eq!(calls.into_inner(), 16);
    assert_eq!(r.groups, vec!["twist", "bend"]);
    assert_eq!(r.cases.len(), 4 * 5);
    let row = r.get("bend", "isometric").unwrap();
    let x: Vec<f64> = r
        .cases
        .iter()
        .filter(|c| c.group == "bend" && c.method == "isometric")
        .map(|c| c.mean)
        .collect();
    assert_eq!(x.len(), 2);
    assert!((row.mean - (x[0] + x[1]) / 2.0).abs() < 1e-15);
    assert!((row.sd - (x[0] - x[1]).abs() / 2f64.sqrt()).abs() < 1e-12);
    // Showcase: the first "bend" deformation.
    assert!(r.maps.iter().all(|m| m.deformation == "sphere-bend"));
    let md = r.to_markdown();
    for m in super::FIG4_METRICS
        .map(|k| k.label())
        .into_iter()
        .chain([BASELINE])
    {
        assert!(md.contains(&format!(" {m} |")), "{m} missing from\n{md}");
    }
    assert!(
        md.contains("| bend | 2 |") && md.contains("of 2 deformation types"),
        "{md}"
    );
    let csv = r.to_csv();
    assert_eq!(csv.lines().count(), 1 + 2 * 5, "{csv}");
    assert!(csv.starts_with("type,method,n,mean,sd"));
}

#[test]
fn bad_settings_and_unusable_inputs_are_reported() {
    let d = linear_deformation();
    let defs = std::slice::from_ref(&d);
    let mut exp = only(&[MetricKind::L2]);
    exp.insert = 2;
    assert!(exp
        .run_synthetic(defs, &|| {})
        .unwrap_err()
        .to_string()
        .contains("odd"));
    exp.insert = 1;
    exp.showcase = Some("nope".into());
    assert!(exp
        .run_synthetic(defs, &|| {})
        .unwrap_err()
        .to_string()
        .contains("nope"));
    exp.showcase = None;
    let mut four = d.clone();
    four.name = "four".into();
    four.poses.push(four.poses[2].clone());
    let r = exp.run_synthetic(&[four.clone(), d.clone()], &|| {}).unwrap();
    assert_eq!(r.skipped.len(), 1);
    assert!(r.skipped[0].starts_with("four:"));
    assert!(exp.run_synthetic(&[four], &|| {}).is_err());
    assert!(only(&[]).run_synthetic(defs, &|| {}).is_err());
}

#[test]
fn leave_one_out_predicts_the_chosen_interior_frames() {
    // Five poses of a linear motion: l2 and the baseline are exact on every frame.
    let s = icosphere(1);
    let poses: Vec<Vec<[f64; 3]>> = (0..5)
        .map(|k| {
            let t = k as f64 / 4.0;
            s.positions
                .iter()
                .map(|p| [p[0] * (1.0 + 0.3 * t), p[1], p[2] + t])
                .collect()
        })
        .collect();
    let seq = deformation("seq", "x", s.topology.clone(), poses);
    let exp = only(&[MetricKind::L2, MetricKind::QuasiConformal]);
    let r = exp.run_leave_one_out(&seq, Some(&[1, 3]), &|| {}).unwrap();
    assert_eq!(r.frames, vec![1, 3]);
    assert_eq!(r.cases.len(), 2 * 3);
    assert_eq!(
        r.cases.iter().map(|c| c.pose).collect::<Vec<_>>(),
        vec![1, 1, 1, 3, 3, 3]
    );
    for c in r.cases.iter().filter(|c| c.method != "quasi-conformal") {
        assert!(c.max < 1e-9, "{c:?}");
    }
    assert_eq!(r.summary.len(), 3);
    assert!(r.summary.iter().all(|s| s.group == "seq" && s.n == 2));
    let md = r.to_markdown();
    assert!(
        md.contains("| quasi-conformal |") && md.contains("frames 1, 3"),
        "{md}"
    );
    assert!(exp.run_leave_one_out(&seq, Some(&[0]), &|| {}).is_err());
    assert!(exp.run_leave_one_out(&seq, Some(&[4]), &|| {}).is_err());
    assert_eq!(
        exp.run_leave_one_out(&seq, None, &|| {}).unwrap().frames,
        vec![1, 2, 3]
    );
}

#[test]
fn write_produces_tables_figure_and_error_maps() {
    let d = linear_deformation();
    let r = only(&[MetricKind::L2, MetricKind::Isometric])
        .run_synthetic(std::slice::from_ref(&d), &|| {})
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let files = r.write(dir.path()).unwrap();
    for name in [
        "interpolation.csv",
        "interpolation.md",
        "interpolation.svg",
        "interpolation.png",
        "interpolation_lin_isometric.ply",
        "interpolation_lin_truth.ply",
    ] {
        let p = dir.path().join(name);
        assert!(p.is_file() && files.contains(&p), "{name}");
    }
    let m = qcshape::io::read_mesh(&dir.path().join("interpolation_lin_isometric.ply")).unwrap();
    assert_eq!(m.positions.len(), d.topology.n_vertices());
}

#[test]
fn frames_are_interior_and_evenly_spaced() {
    assert_eq!(pick_frames(25, 0), (1..=23).collect::<Vec<_>>());
    assert_eq!(pick_frames(5, 8), vec![1, 2, 3]);
    assert_eq!(pick_frames(25, 3), vec![1, 12, 23]);
    let f = pick_frames(25, 8);
    assert_eq!(f.len(), 8);
    assert!(
        f[0] == 1 && f[7] == 23 && f.windows(2).all(|w| w[0] < w[1]),
        "{f:?}"
    );
    assert_eq!(pick_frames(25, 1), vec![12]);
}
