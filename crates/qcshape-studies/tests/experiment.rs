//! The analysis steps as library calls: the reproduction's Table 1 and the one-data-set
//! analysis, checked on their result structs (the CLI's end-to-end tests read the Markdown).

use qcshape::dataset::Deformation;
use qcshape::geodesic::GeodesicOptions;
use qcshape::metric::{MetricKind, MetricSpec};
use qcshape::similarity::PipelineOptions;
use qcshape::synth::{genus0_benchmark, SynthOptions};
use qcshape_studies::experiment::analysis::{analyse, class_count, dataset_labels, AnalysisReport};
use qcshape_studies::experiment::classification::classify_set;
use qcshape_studies::experiment::provenance::Provenance;
use qcshape_studies::experiment::reproduce::{paper_table3, ReproduceReport, Reproduction, Table3Row};

#[test]
fn reproduction_table1_is_far_above_chance() {
    let s = Reproduction {
        level: 1,
        metrics: vec![MetricKind::Isometric],
        ..Reproduction::quick()
    };
    s.validate().unwrap();
    let defs = s.benchmark().unwrap();
    assert_eq!(defs.len(), 48);
    let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap()).collect();
    let run = s
        .run_metric(&defs, &labels, MetricKind::Isometric, &|_| {})
        .unwrap();
    assert_eq!(run.classified.matrix.len(), 48);
    assert_eq!(run.classified.pair_seconds.len(), 48 * 47 / 2);
    let runs = [run];
    let report = ReproduceReport::new(
        &s,
        &defs,
        &runs,
        &[Table3Row {
            metric: "isometric".into(),
            level: 1.0,
            uniform: 0.9,
            gaussian: 0.8,
            paper: paper_table3(1.0),
            accuracy: (1.0, 0.75),
            reference_accuracy: 0.9,
        }],
        ["", ""],
        Provenance::current("test".into(), 1.0),
    )
    .unwrap();
    assert_eq!(report.table1.len(), 1);
    let row = &report.table1[0];
    assert_eq!(row.metric, "isometric");
    assert_eq!(row.paper, Some((71.3, 69.2)));
    // The README's Table 1 reports 100 / 100 % for the default (isometric) at 162 vertices; at
    // level 1 (42 vertices, 2 steps, one inserted pose) measured 100 / 100 %, 1-NN 100 %, ARI 1.0
    // (level 0 gave 92.9 / 50 %). Chance level for 8 classes is 12.5 % sensitivity.
    assert!(row.sensitivity >= 0.95 && row.specificity >= 0.99, "{row:?}");
    assert!(row.nn_accuracy >= 0.95 && row.ari >= 0.9, "{row:?}");
    assert_eq!(report.table2.len(), 1);
    assert_eq!(report.table3[0].paper, Some((97.9, 97.9)));
    assert_eq!(report.noise_metrics, ["isometric"]);
    assert_eq!(report.poses, 5, "3 key poses, one inserted between each");
    let md = report.to_markdown();
    assert!(
        md.contains("## Table 1") && md.contains("## Table 3") && md.contains("](fig6_mds_isometric.png)")
    );
    let shares = &row.shares;
    assert_eq!((shares.pairs, shares.unknown), (48 * 47 / 2, 0));
    // The metric measures isometric, not L2 (README: a share above one half would): measured
    // median 0.24 %, one pair of 1,128 above one half.
    assert!(
        shares.median < 0.02 && shares.above_half * 100 < shares.pairs,
        "{shares:?}"
    );
    assert!(md.contains("Energy share of the L2 regularizer"), "{md}");
    // Table 3: one column per metric (uniform / Gaussian), the paper's beside.
    assert!(
        md.contains("| noise variance (%) | isometric | paper (quasi-conformal) |")
            && md.contains("| 1 | 90.0 / 80.0 | 97.9 / 97.9 |")
            && md.contains("Below the paper's tau: isometric at 1 %.")
            && md.contains("| 0 (reference) | 90.0 |")
            && md.contains("| 1 | 100.0 / 75.0 |"),
        "{md}"
    );
}

#[test]
fn analysis_of_two_motions_recovers_the_classes() {
    let defs: Vec<Deformation> = genus0_benchmark(&SynthOptions {
        level: 1,
        ..Default::default()
    })
    .unwrap()
    .into_iter()
    .filter(|d| {
        matches!(d.label.as_deref(), Some("twist") | Some("stretch"))
            && !d.name.starts_with("pear-")
            && !d.name.starts_with("peanut-")
    })
    .collect();
    assert_eq!(defs.len(), 8);
    let labels = dataset_labels(&defs);
    assert_eq!(class_count(labels.as_deref()), 2);
    let opts = PipelineOptions {
        metric: MetricSpec::new(MetricKind::Isometric),
        geodesic: GeodesicOptions {
            steps: 2,
            ..Default::default()
        },
        insert: 1,
        ..Default::default()
    };
    let c = classify_set(&defs, &opts, 2, 20, 0, &|_| {}).unwrap();
    let a = analyse(&c.matrix, &c.prepared, &opts, 2, 20, 0, labels.as_deref()).unwrap();
    let s = a.scores.as_ref().expect("scores with labels");
    assert_eq!(s.eq15.sensitivity, 1.0);
    assert_eq!(a.coords.len(), 8);
    assert_eq!(a.plot_labels, labels.clone().unwrap());
    let dir = tempfile::tempdir().unwrap();
    let files = a.write(dir.path(), &c.matrix, "isometric").unwrap();
    for f in [
        "assignments.csv",
        "confusion.csv",
        "coordinates.csv",
        "map.svg",
        "map.png",
        "heatmap.svg",
    ] {
        assert!(files.contains(&dir.path().join(f)), "{f}");
    }
    let report = AnalysisReport {
        provenance: Provenance::current("test".into(), 1.0),
        input: "data".into(),
        deformations: 8,
        key_poses: 3,
        vertices: c.prepared.topology.n_vertices(),
        metric: "isometric".into(),
        insert: 1,
        transport: "euclidean".into(),
        base: c.prepared.names[0].clone(),
        steps: 2,
        prepare_seconds: 0.0,
        similarity_seconds: 0.0,
        shares: c.shares,
        k: 2,
        analysis: a,
    };
    let md = report.to_markdown();
    assert!(md.contains("| sensitivity (eq. 15) | 100.0 % |"));
    assert_eq!(c.shares.pairs, 28);
    assert!(md.contains("Energy share of the L2 regularizer"), "{md}");
}

/// `experiment robustness` at two resolutions in one run (issue 51): two shapes x two kinds, the
/// clean scenario, the three baselines and the default (isometric) pipeline at levels 1 and 2.
#[test]
fn robustness_at_two_levels_has_a_column_group_per_level() {
    use qcshape::synth::{DeformationKind, InitialShape};
    use qcshape_studies::experiment::robustness::{run, Baseline, Method, RobustnessOptions, Scenario};
    let clean = Scenario::defaults()
        .into_iter()
        .find(|s| s.name == "clean")
        .unwrap();
    let mut methods: Vec<Method> = Baseline::all().into_iter().map(Method::Baseline).collect();
    methods.push(Method::Pipeline {
        name: "isometric".into(),
        options: Box::new(PipelineOptions {
            geodesic: GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
            ..Default::default()
        }),
    });
    let opts = RobustnessOptions {
        levels: vec![1, 2],
        shapes: vec![InitialShape::Sphere, InitialShape::Ellipsoid],
        kinds: vec![DeformationKind::Twist, DeformationKind::Bulge],
        poses: 3,
        scenarios: vec![clean],
        methods,
        seed: 0,
        restarts: 4,
        max_restarts: 64,
    };
    let r = run(&opts, &|_, _, _| {}).unwrap();
    assert_eq!(r.levels, vec![(1, 42), (2, 162)]);
    assert_eq!(r.rows.len(), 2 * 4);
    for level in [1, 2] {
        for m in ["displacement", "aligned-displacement", "edge-strain", "isometric"] {
            let row = r.row(level, "clean", m).unwrap_or_else(|| panic!("{level} {m}"));
            assert_eq!(row.vertices, if level == 1 { 42 } else { 162 });
            for v in [row.nn, row.kmeans, row.kmedoids, row.sensitivity, row.specificity] {
                assert!((0.0..=1.0).contains(&v), "{row:?}");
            }
            assert!((-1.0..=1.0).contains(&row.ari), "{row:?}");
            assert!(row.kmeans_restarts >= 4 && row.kmeans_restarts <= 64, "{row:?}");
            assert!(
                row.kmedoids_restarts >= 4 && row.kmedoids_restarts <= 64,
                "{row:?}"
            );
        }
        // A twist and a bulge on two shapes, clean: every method separates the two motions.
        let iso = r.row(level, "clean", "isometric").unwrap();
        assert_eq!((iso.nn, iso.kmeans, iso.kmedoids), (1.0, 1.0, 1.0), "{iso:?}");
        assert!(
            iso.converged && iso.kmeans_agreed && iso.kmedoids_agreed,
            "{iso:?}"
        );
    }
    let md = r.to_markdown();
    assert!(
        md.contains("level 1 (42 vertices), level 2 (162 vertices)"),
        "{md}"
    );
    for v in [42, 162] {
        for m in ["best baseline", "displacement", "edge-strain", "isometric"] {
            assert!(md.contains(&format!("| {m} @ {v} v |")), "{m} @ {v}: {md}");
        }
    }
    let csv = r.to_csv();
    assert_eq!(csv.lines().count(), 1 + 8);
    assert!(
        csv.lines()
            .skip(1)
            .any(|l| l.starts_with("1,42,clean,isometric,")),
        "{csv}"
    );
    assert!(
        csv.lines()
            .skip(1)
            .any(|l| l.starts_with("2,162,clean,isometric,")),
        "{csv}"
    );
}
