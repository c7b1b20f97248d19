//! The report of the cohort study and of a single cycle ([`super::study`],
//! [`super::cycle_map`]): Tables 4 and 5 beside the paper's, the clustering methods, times,
//! Fig. 9, and the CSVs behind them.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::cycle_map::{CycleMap, CycleSettings, CycleStudy};
use super::study::{Analysis, Baseline, BinaryScores as Binary, MethodRow, StudyError};
use qcshape::dataset::Deformation;

type Result<T> = std::result::Result<T, StudyError>;

/// The paper's Table 4 (sensitivity, specificity in %) by row.
const PAPER_TABLE4: [(&str, f64, f64); 3] = [
    ("Our method", 88.8, 85.7),
    ("Mean systolic radial", 79.4, 54.9),
    ("Mean radial displacement", 76.2, 70.9),
];

/// The paper's Table 5 (landmarks, sensitivity, specificity in %).
const PAPER_TABLE5: [(usize, f64, f64); 4] = [
    (8, 77.7, 71.4),
    (16, 88.8, 85.7),
    (24, 88.8, 92.8),
    (32, 88.8, 92.8),
];

/// What the report needs besides the analyses.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// The command line, as typed.
    pub args_line: String,
    /// A sentence on where the meshes came from.
    pub input_note: String,
    /// Registration landmarks.
    pub landmarks: usize,
    /// Whether the cohort was meshed from images here.
    pub from_images: bool,
    /// `free-wall` or `whole`.
    pub region: String,
    /// Frames per subject.
    pub frames: usize,
    /// Clustering restarts.
    pub restarts: usize,
    /// Seed of clustering and MDS.
    pub seed: u64,
    /// Seconds of registration and meshing per subject.
    pub mesh_seconds: Vec<f64>,
    /// End-diastolic and end-systolic frame per subject.
    pub ed_es: Vec<(usize, usize)>,
    /// Wall seconds of the whole run.
    pub total_seconds: f64,
    /// The subject of Fig. 9.
    pub mds_subject: String,
    /// How the subjects were split (a sentence).
    pub split: String,
    /// How the deformations were aligned before transfer (a sentence).
    pub align: String,
    /// How the landmarks were filtered and the splines regularized (a clause starting with
    /// "; " or empty: raw landmarks, exact splines).
    pub registration: String,
    /// The transport to the base (`parallel`, `schild` or `euclidean`).
    pub transport: String,
    /// The phantom's abnormal region on the base mesh (#V), when the cohort knows it
    /// ([`super::region::cohort_region`] weights >= 0.5).
    pub abnormal: Option<Vec<bool>>,
}

fn pct(x: f64) -> String {
    format!("{:.1}", 100.0 * x)
}

fn counts(b: &Binary) -> String {
    let [tp, fn_, fp, tn] = b.counts;
    format!("{tp:.0} / {fn_:.0} / {fp:.0} / {tn:.0}")
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

fn write(path: &Path, text: &str) -> Result<()> {
    qcshape::io::write_atomically(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Per-subject seconds: meshing, interpolation, transfer, half of each of its pairs.
fn subject_seconds(s: &RunSummary, main: &Analysis) -> Vec<[f64; 4]> {
    let n = main.prepared.names.len();
    let mut pairs = vec![0.0; n];
    for &(i, j, t) in &main.pair_seconds {
        pairs[i] += t / 2.0;
        pairs[j] += t / 2.0;
    }
    (0..n)
        .map(|i| {
            [
                s.mesh_seconds[i],
                main.prepared.interpolation_seconds[i],
                main.prepared.transfer_seconds[i],
                pairs[i],
            ]
        })
        .collect()
}

/// Writes OUT/subjects.csv, table4.csv, table5.csv (with a sweep), similarity.svg and
/// subjects_mds.svg|png and returns OUT/report.md's text. `sweep` holds Table 5's rows
/// (landmarks, scores, seconds; 0 s for the main run).
#[allow(clippy::too_many_arguments)]
pub fn run_report(
    out: &Path,
    s: &RunSummary,
    common: &CycleSettings,
    defs: &[Deformation],
    main: &Analysis,
    base: &[Baseline],
    sweep: &[(usize, Binary, f64)],
    map: &CycleMap,
    methods: &[MethodRow],
) -> Result<String> {
    let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap_or_default()).collect();
    let secs = subject_seconds(s, main);
    // Per-subject CSV.
    let mut csv = String::from(
        "subject,label,cluster,baseline_systolic_mm,cluster_systolic,baseline_velocity_mm_per_frame,\
         cluster_velocity,ed_frame,es_frame,mesh_s,interpolation_s,transfer_s,similarity_share_s\n",
    );
    for (i, d) in defs.iter().enumerate() {
        writeln!(
            csv,
            "{},{},{},{:?},{},{:?},{},{},{},{:.3},{:.3},{:.3},{:.3}",
            d.name,
            labels[i],
            main.clustering.assignments[i],
            base[0].values[i],
            base[0].clustering.assignments[i],
            base[1].values[i],
            base[1].clustering.assignments[i],
            s.ed_es[i].0,
            s.ed_es[i].1,
            secs[i][0],
            secs[i][1],
            secs[i][2],
            secs[i][3]
        )?;
    }
    write(&out.join("subjects.csv"), &csv)?;
    let mut t4 =
        String::from("method,sensitivity,specificity,paper_sensitivity,paper_specificity,tp,fn,fp,tn\n");
    let main_name = format!("{} similarity (eq. 13)", common.metric.kind.label());
    let rows: Vec<(&str, &Binary)> = std::iter::once((main_name.as_str(), &main.scores))
        .chain(base.iter().map(|b| (b.name, &b.scores)))
        .collect();
    for (k, (name, b)) in rows.iter().enumerate() {
        let [tp, fn_, fp, tn] = b.counts;
        writeln!(
            t4,
            "{name},{:.4},{:.4},{},{},{tp},{fn_},{fp},{tn}",
            b.sensitivity, b.specificity, PAPER_TABLE4[k].1, PAPER_TABLE4[k].2
        )?;
    }
    write(&out.join("table4.csv"), &t4)?;
    if !sweep.is_empty() {
        let mut t5 = String::from("landmarks,sensitivity,specificity,paper_sensitivity,paper_specificity\n");
        for (n, b, _) in sweep {
            let p = PAPER_TABLE5.iter().find(|r| r.0 == *n);
            writeln!(
                t5,
                "{n},{:.4},{:.4},{},{}",
                b.sensitivity,
                b.specificity,
                p.map_or(String::new(), |p| p.1.to_string()),
                p.map_or(String::new(), |p| p.2.to_string())
            )?;
        }
        write(&out.join("table5.csv"), &t5)?;
    }
    let mut order: Vec<usize> = (0..defs.len()).collect();
    order.sort_by(|&a, &b| labels[a].cmp(&labels[b]).then(a.cmp(&b)));
    for ext in ["svg", "png"] {
        crate::plot::heatmap(
            &out.join(format!("similarity.{ext}")),
            &main.matrix,
            &order,
            Some(&labels),
            &format!(
                "Cycle distances (eq. 13) of {} subjects, by group",
                main.matrix.len()
            ),
            "distance (mean-edge units)",
        )?;
    }
    let e = qcshape::embed::smacof(
        &main.matrix,
        &qcshape::embed::MdsOptions {
            dims: 2,
            seed: s.seed,
            ..Default::default()
        },
    )?;
    for ext in ["svg", "png"] {
        crate::plot::scatter_map(
            &out.join(format!("subjects_mds.{ext}")),
            &e.coords,
            main.matrix.names(),
            Some(&labels),
            "Subjects by the similarity of their cycles (eq. 13)",
            Some(e.normalized_stress),
        )?;
    }

    let mut md = String::new();
    let n = defs.len();
    let npos = labels.iter().filter(|l| **l == main.scores.positive).count();
    writeln!(md, "# Left-ventricle motion classification (paper section 4.3)\n")?;
    writeln!(md, "Command: `{}`  ", s.args_line)?;
    writeln!(
        md,
        "qcshape {}, {} worker threads, total {:.1} s.\n",
        env!("CARGO_PKG_VERSION"),
        rayon::current_num_threads(),
        s.total_seconds
    )?;
    writeln!(md, "Input: {}\n", s.input_note)?;
    writeln!(
        md,
        "{n} subjects ({npos} {}, {} {}), {} frames each, region: {}, {} vertices, registration with {} \
         landmarks{}{}. Pipeline: the cycle {} ({} poses per subject: {} frames + {} interpolated), \
         {}transfer by {} transport to frame 0 of `{}`, similarity (eq. 13) with the {} metric, \
         geodesics with N = {} segments, {} with k = 2, {} restarts, seed {}.\n",
        main.scores.positive,
        n - npos,
        main.scores.negative,
        s.frames,
        s.region,
        main.prepared.topology.n_vertices(),
        s.landmarks,
        if s.from_images {
            ""
        } else {
            " (not applicable: meshes given)"
        },
        s.registration,
        if common.open {
            "is left open".to_string()
        } else {
            "is closed (frame 0 appended, the gap last -> frame 0 interpolated too, the repeated frame 0 \
             dropped afterwards)"
                .to_string()
        },
        main.prepared.is_key.len(),
        main.prepared.is_key.iter().filter(|&&k| k).count(),
        main.prepared.is_key.iter().filter(|&&k| !k).count(),
        s.align,
        s.transport,
        main.prepared.names[0],
        common.metric.label(),
        common.geodesic.steps,
        s.split,
        s.restarts,
        s.seed
    )?;

    writeln!(md, "## Table 4: sensitivity and specificity\n")?;
    writeln!(
        md,
        "| method | sensitivity (%) | specificity (%) | paper row | paper sens. | paper spec. | TP / FN / FP / TN | accuracy (%) | eq. 15 averaged sens. / spec. (%) | 1-NN (%) |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|---|---|---|---|")?;
    for (k, (name, b)) in rows.iter().enumerate() {
        writeln!(
            md,
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} / {} | {} |",
            pct(b.sensitivity),
            pct(b.specificity),
            PAPER_TABLE4[k].0,
            PAPER_TABLE4[k].1,
            PAPER_TABLE4[k].2,
            counts(b),
            pct(b.accuracy),
            pct(b.eq15.0),
            pct(b.eq15.1),
            pct(b.nn_accuracy)
        )?;
    }
    writeln!(
        md,
        "\nConvention: the two clusters are matched to the two classes by the Hungarian algorithm; \
         `{}` is the positive class: sensitivity = TP / (TP + FN) over the {} subjects, specificity = \
         TN / (TN + FP) over the {} subjects (the paper's 88.8 / 85.7 are 8/9 and 12/14 in this \
         reading). The last column is eq. 15 on the average of the two one-vs-rest matrices (as \
         `qcshape classify`), where both numbers equal the accuracy for two classes. 1-NN: \
         leave-one-out nearest-neighbour accuracy on the same distances (no clustering: how much \
         class information the distances hold, whatever 2-means does with it).\n",
        main.scores.positive, main.scores.positive, main.scores.negative
    )?;
    md.push_str(&main.shares.markdown(common.metric.kind.label()));
    md.push('\n');
    writeln!(
        md,
        "![Subjects by the similarity of their cycles: SMACOF MDS of the eq. 13 matrix, colour and \
         marker the group](subjects_mds.png)\n\n\
         ![Heat map of the eq. 13 matrix, subjects ordered by group (white lines between the \
         groups)](similarity.png)\n"
    )?;
    writeln!(
        md,
        "Baselines on the same meshes, each clustered by 2-means on its one feature: radius = \
         distance of each vertex to the long axis ({}); *mean systolic radial displacement* = mean \
         over vertices of r(ED) - r(ES), ED/ES the frames of largest/smallest mean radius; *mean \
         radial velocity* = mean over vertices and consecutive frames of |r(t+1) - r(t)| per frame \
         interval{} (mm/frame). The paper's baseline rows are printed as \"Mean systolic radial\" and \
         \"Mean radial displacement\" while its text names \"mean radial displacement and mean radial \
         velocity\" [41]; we place our systolic-displacement row beside the first and our velocity \
         row beside the second. Per-subject values: `subjects.csv`.\n",
        if s.from_images {
            "apex and base-centre landmarks of frame 0"
        } else {
            "principal axis of frame 0 through its fitted circle centre"
        },
        if common.open {
            ""
        } else {
            " (closing pair last -> frame 0 included)"
        }
    )?;
    md.push_str(&super::motion_report::motion_section(
        out,
        main,
        &labels,
        &main.scores.positive,
        s.abnormal.as_deref(),
        s.seed,
    )?);
    if !methods.is_empty() {
        methods_section(&mut md, methods)?;
        write(&out.join("clustering.csv"), &methods_csv(methods)?)?;
    }
    if main.unconverged > 0 {
        writeln!(
            md,
            "Warning: {} geodesic solve(s) stopped at the iteration limit.\n",
            main.unconverged
        )?;
    }

    if !sweep.is_empty() {
        writeln!(md, "## Table 5: number of registration landmarks\n")?;
        writeln!(
            md,
            "| landmarks | sensitivity (%) | specificity (%) | paper sens. | paper spec. | TP / FN / FP / TN | run (s) |"
        )?;
        writeln!(md, "|---|---|---|---|---|---|---|")?;
        for (nl, b, t) in sweep {
            let p = PAPER_TABLE5.iter().find(|r| r.0 == *nl);
            writeln!(
                md,
                "| {nl} | {} | {} | {} | {} | {} | {} |",
                pct(b.sensitivity),
                pct(b.specificity),
                p.map_or("-".into(), |p| p.1.to_string()),
                p.map_or("-".into(), |p| p.2.to_string()),
                counts(b),
                if *t > 0.0 {
                    format!("{t:.1}")
                } else {
                    "(main run)".into()
                }
            )?;
        }
        writeln!(
            md,
            "\nEach count reruns registration (intra- and inter-subject splines), meshing and the whole \
             pipeline with the first N landmarks of every frame.\n"
        )?;
    }

    writeln!(md, "## Times\n")?;
    let cols: Vec<Vec<f64>> = (0..4).map(|c| secs.iter().map(|r| r[c]).collect()).collect();
    let total: Vec<f64> = secs.iter().map(|r| r.iter().sum()).collect();
    writeln!(
        md,
        "| stage | wall clock (s) | per subject, mean ± sd (s) |\n|---|---|---|"
    )?;
    let stage = |md: &mut String, name: &str, wall: String, x: &[f64]| -> std::fmt::Result {
        let (m, sd) = mean_sd(x);
        writeln!(md, "| {name} | {wall} | {m:.3} ± {sd:.3} |")
    };
    stage(
        &mut md,
        "registration + meshing",
        format!("{:.1}", cols[0].iter().sum::<f64>()),
        &cols[0],
    )?;
    stage(
        &mut md,
        "interpolation + transfer",
        format!("{:.1}", main.wall[0]),
        &cols[1]
            .iter()
            .zip(&cols[2])
            .map(|(a, b)| a + b)
            .collect::<Vec<_>>(),
    )?;
    stage(
        &mut md,
        "similarity (its pairs, half each)",
        format!("{:.1}", main.wall[1]),
        &cols[3],
    )?;
    writeln!(md, "| k-means | {:.3} | - |", main.wall[2])?;
    writeln!(
        md,
        "| Fig. 9 (all pose pairs of one subject) | {:.1} | - |",
        map.seconds
    )?;
    stage(
        &mut md,
        "all (per subject: sum of its stages)",
        format!("{:.1}", s.total_seconds),
        &total,
    )?;
    writeln!(
        md,
        "\nPer-subject times are each item's own time inside parallel loops (summing them exceeds \
         the wall clock when threads run together); per subject and stage in `subjects.csv`.\n"
    )?;

    writeln!(md, "## Fig. 9: the cycle of `{}` in 2-D (MDS)\n", s.mds_subject)?;
    fig9_text(&mut md, map)?;
    writeln!(
        md,
        "\nFiles: `similarity.csv` (eq. 13 matrix), `similarity.svg|png` (heat map by class), \
         `subjects_mds.svg|png`, `motion_map.*`, `table4.csv`, \
         `table5.csv`, `subjects.csv`, `fig9_*`, `meshes/` (when meshed here)."
    )?;
    Ok(md)
}

fn fig9_text(md: &mut String, map: &CycleMap) -> std::fmt::Result {
    writeln!(
        md,
        "![Fig. 9: MDS of the poses of one cycle; frames (`key`, named by number) and \
         interpolated poses in two colours and markers](fig9_mds.png)\n"
    )?;
    writeln!(
        md,
        "{} poses ({} frames as `key`, {} interpolated), geodesic distance dis(P_i, P_j) of every \
         pair ({} geodesics, one solver{}), SMACOF in 2-D, normalized stress {:.4}. The frames are named \
         by number in the figure; `fig9_mds.csv` names every pose by its position in frames (`3` = \
         frame 3, `3.25` = a quarter of the way to frame 4). Length \
         of the path through the poses in order: {:.3}; largest distance {:.3} between `{}` and `{}` \
         (mean-edge units). Files: `fig9_mds.svg|png`, `fig9_mds.csv`, `fig9_distances.csv`.",
        map.n_poses,
        map.n_keys,
        map.n_poses - map.n_keys,
        map.n_poses * (map.n_poses - 1) / 2,
        if map.converged {
            ""
        } else {
            "; some did not converge"
        },
        map.stress,
        map.path_length,
        map.diameter.0,
        map.diameter.1,
        map.diameter.2
    )
}

/// OUT/report.md of one sequence's cycle map (`source` says where the frames came from,
/// `total_seconds` the wall time of the whole command).
pub fn cycle_report(
    args_line: &str,
    source: &str,
    c: &CycleStudy,
    common: &CycleSettings,
    total_seconds: f64,
) -> Result<String> {
    let (name, frames, raw_vertices, vertices) = (&c.name, c.frames, c.raw_vertices, c.vertices);
    let (note, map, interp_converged) = (c.note.as_deref(), &c.map, c.interpolation_converged);
    let seconds = [c.interpolation_seconds, map.seconds, total_seconds];
    let mut md = String::new();
    writeln!(md, "# Cycle map of `{name}` (Fig. 9)\n")?;
    writeln!(md, "Command: `{args_line}`  ")?;
    writeln!(
        md,
        "qcshape {}, {} worker threads, total {:.1} s.\n",
        env!("CARGO_PKG_VERSION"),
        rayon::current_num_threads(),
        seconds[2]
    )?;
    writeln!(
        md,
        "Input: {source}: {frames} frames, {raw_vertices} vertices{}. One subject: no classification, \
         only the cycle's map. The cycle is {}; {} poses interpolated between consecutive frames with \
         the {} metric (N = {} segments per geodesic){}.\n",
        note.map_or(String::new(), |n| format!(", {n}")),
        if common.open {
            "left open (no gap from the last frame back to frame 0)"
        } else {
            "closed (frame 0 appended so the gap last -> frame 0 is interpolated too)"
        },
        common.insert,
        common.metric.label(),
        common.geodesic.steps,
        if interp_converged {
            ""
        } else {
            "; some interpolation solves did not converge"
        }
    )?;
    writeln!(md, "Analysed mesh: {vertices} vertices.\n")?;
    writeln!(
        md,
        "| stage | wall clock (s) |\n|---|---|\n| interpolation | {:.1} |\n| pose-pair geodesics + MDS | {:.1} |\n| total | {:.1} |\n",
        seconds[0], seconds[1], seconds[2]
    )?;
    fig9_text(&mut md, map)?;
    writeln!(md)?;
    Ok(md)
}

/// `clustering.csv`: one row per (data, method).
pub fn methods_csv(rows: &[MethodRow]) -> Result<String> {
    let mut csv = String::from("data,method,sensitivity,specificity,accuracy,ari,tp,fn,fp,tn\n");
    for r in rows {
        let b = &r.scores;
        let [tp, fn_, fp, tn] = b.counts;
        writeln!(
            csv,
            "{},{},{:.4},{:.4},{:.4},{:.4},{tp},{fn_},{fp},{tn}",
            r.data, r.method, b.sensitivity, b.specificity, b.accuracy, b.ari
        )?;
    }
    Ok(csv)
}

/// The Markdown table of the clustering methods (data x method -> sensitivity / specificity
/// / ARI).
pub fn methods_section(md: &mut String, rows: &[MethodRow]) -> Result<()> {
    writeln!(md, "## Clustering methods (k = 2)\n")?;
    writeln!(
        md,
        "| data | method | sensitivity (%) | specificity (%) | accuracy (%) | ARI | TP / FN / FP / TN |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|---|")?;
    for r in rows {
        let b = &r.scores;
        writeln!(
            md,
            "| {} | `{}` | {} | {} | {} | {:.3} | {} |",
            r.data,
            r.method,
            pct(b.sensitivity),
            pct(b.specificity),
            pct(b.accuracy),
            b.ari,
            counts(b)
        )?;
    }
    writeln!(
        md,
        "\nEvery method on the same matrices, same restarts and seed (`--compare`); `clustering.csv`. \
         The baselines' matrices are `|x_i - x_j|` of their one feature.\n"
    )?;
    Ok(())
}
