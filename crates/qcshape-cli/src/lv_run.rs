//! `qcshape lv run` and `qcshape lv cycle`: the left-ventricle analysis of section 4.3 from
//! one command (Tables 4 and 5, Fig. 9). Meshing of a cohort on one connectivity lives in
//! `lv_run/mesh.rs`, the report in `lv_run/report.rs`.

mod mesh;
mod report;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::cluster::{kmeans, ClusterOptions, Clustering};
use qcshape::dataset::{load_sequence, mesh_files, Dataset, Deformation};
use qcshape::embed::{smacof, MdsOptions};
use qcshape::lv::analysis::{
    close_cycle, drop_closing_pose, pose_distance_matrix, radial_features, Axis, Pose,
};
use qcshape::multires::Hierarchy;
use qcshape::path::{
    normalization_factor, GeodesicOptions, GeodesicSolver, InterpolationOptions, Interpolator, Normalization,
};
use qcshape::similarity::{assemble, similarities, DistanceMatrix, PipelineOptions, Prepared};
use qcshape::transport::Transport;

use crate::args::{in_pool, MetricArgs};
use crate::classify::score;
use crate::similarity::{bar, prepare_with_progress};
use mesh::{is_cohort, mesh_cohort, write_meshes, MeshSettings};
use report::{cycle_report, run_report, RunSummary};

/// Options of `qcshape lv run`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Classify left-ventricle motion (Tables 4 and 5, Fig. 9) from images or meshes",
    long_about = "Section 4.3 in one command. DIR is a cohort folder (labels.csv and per-subject images \
and landmarks.csv, as made by 'qcshape lv phantom'), a manifest CSV or folder of deformations already \
meshed on one connectivity, or a folder of one subject's mesh files (then only the cycle map, as \
'qcshape lv cycle').\n\nFor a cohort: per subject, landmark thin-plate splines frame 0 -> frame k \
(--landmarks); the first subject's frame-0 cavity surface (decimated to --vertices) is the template, \
carried to every other subject's frame 0 by the landmark spline between the subjects and projected on \
that subject's own surface, then to every frame through the subject's splines (one connectivity for \
the cohort); --region keeps the free wall or the whole surface. The cycle is closed (frame 0 is \
appended, so the gap last -> first is interpolated too: F (1 + --insert) poses, 8 x 4 = 32 as in the \
paper); interpolation, parallel transport to the first subject's frame 0, similarity (eq. 13), \
k-means with k = 2; sensitivity (hcm) and specificity (controls) after Hungarian matching, beside two \
baselines on the same meshes (mean systolic radial displacement, mean radial velocity) clustered the \
same way; Table 5 reruns everything for each --landmark-sweep count; Fig. 9 is the MDS of one subject's \
interpolated cycle. Writes OUT/report.md, CSVs, the similarity matrix, meshes and figures."
)]
pub struct RunArgs {
    /// Cohort folder, manifest CSV, folder of deformation folders, or folder of one sequence's meshes.
    dir: PathBuf,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// Landmarks of the registrations (the first N of each frame; paper: 16).
    #[arg(long, default_value_t = 16)]
    landmarks: usize,
    #[command(flatten)]
    common: CycleCommon,
    /// Region analysed: the free wall (paper) or the whole cavity surface.
    #[arg(long, default_value = "free-wall", value_parser = ["free-wall", "whole"])]
    region: String,
    /// Landmark counts of Table 5 (the whole pipeline once per count).
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32")]
    landmark_sweep: Vec<usize>,
    /// Skip Table 5.
    #[arg(long)]
    no_sweep: bool,
    /// Cavity threshold (default: upper two-level Otsu threshold of each frame 0).
    #[arg(long)]
    threshold: Option<f64>,
    /// Taubin smoothing iterations of the surfaces.
    #[arg(long, default_value_t = 10)]
    smooth: usize,
    /// Name of the subject whose cycle is mapped in Fig. 9 (default: the first).
    #[arg(long)]
    mds_subject: Option<String>,
    /// k-means restarts.
    #[arg(long, default_value_t = 20)]
    restarts: usize,
    /// Seed of k-means and MDS.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// With a folder of mesh files: only files whose name contains this text (e.g. LV_ENDO).
    #[arg(long)]
    pattern: Option<String>,
}

/// Options shared by `lv run` and `lv cycle`.
#[derive(Debug, Clone, clap::Args)]
pub struct CycleCommon {
    #[command(flatten)]
    pub metric: MetricArgs,
    /// Poses inserted between consecutive frames (paper: 3).
    #[arg(long, default_value_t = 3)]
    pub insert: usize,
    /// Segments N of every geodesic.
    #[arg(long, default_value_t = 4)]
    pub steps: usize,
    /// Vertex budget: the cohort template's whole surface, or meshes given as input are coarsened
    /// (a vertex subset, multires hierarchy) when larger.
    #[arg(long, default_value_t = 600)]
    pub vertices: usize,
    /// Do not close the cycle (no gap last frame -> frame 0).
    #[arg(long)]
    pub open: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Options of `qcshape lv cycle`.
#[derive(Debug, clap::Args)]
#[command(
    about = "MDS path of one heart cycle with interpolated poses (Fig. 9) from mesh files",
    long_about = "Fig. 9 for one sequence of meshes with one connectivity (e.g. a fitted real cycle): \
the frames in natural name order (FILES: mesh files, or one folder filtered by --pattern), every \
--every-th frame kept, coarsened to about --vertices vertices (a subset of the vertices, so every frame \
keeps its correspondence), the cycle closed unless --open, --insert poses interpolated between \
consecutive frames, the geodesic distance dis(P_i, P_j) of every pair of poses (one solver) and its \
2-D SMACOF map: frames as filled dots, interpolated poses in a second colour. Writes OUT/report.md, \
OUT/fig9_mds.svg|png, OUT/fig9_mds.csv, OUT/fig9_distances.csv."
)]
pub struct CycleArgs {
    /// Mesh files in cycle order, or one folder of them.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// With a folder: only files whose name contains this text (e.g. LV_ENDO).
    #[arg(long)]
    pattern: Option<String>,
    /// Keep every K-th frame (1: all).
    #[arg(long, default_value_t = 1)]
    every: usize,
    #[command(flatten)]
    common: CycleCommon,
    /// Seed of the MDS.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn geodesic_options(c: &CycleCommon) -> Result<GeodesicOptions> {
    if c.steps == 0 {
        bail!("--steps must be at least 1");
    }
    Ok(GeodesicOptions {
        steps: c.steps,
        ..Default::default()
    })
}

/// Sensitivity and specificity of a two-class clustering (Table 4).
#[derive(Debug, Clone)]
pub(crate) struct Binary {
    pub(crate) positive: String,
    pub(crate) negative: String,
    /// TP / (TP + FN) of the positive class after Hungarian matching.
    pub(crate) sensitivity: f64,
    /// TN / (TN + FP): negatives predicted negative.
    pub(crate) specificity: f64,
    pub(crate) accuracy: f64,
    /// [TP, FN, FP, TN] (items in an unmatched cluster count as misses).
    pub(crate) counts: [f64; 4],
    /// Eq. 15 on the averaged one-vs-rest matrices (the `classify` reading).
    pub(crate) eq15: (f64, f64),
    /// Leave-one-out 1-nearest-neighbour accuracy on the distances (no clustering).
    pub(crate) nn_accuracy: f64,
}

/// Scores a 2-means clustering: `hcm` (else the second class in order of appearance) is the
/// positive class.
pub(crate) fn binary(d: &DistanceMatrix, c: &Clustering, labels: &[String]) -> Result<Binary> {
    let s = score(d, c, labels)?;
    if s.classes.len() != 2 {
        bail!(
            "two classes are needed for sensitivity and specificity, the labels name {}: {:?}",
            s.classes.len(),
            s.classes
        );
    }
    let pos = s.classes.iter().position(|c| c == "hcm").unwrap_or(1);
    let b = s.eq15.per_class[pos];
    Ok(Binary {
        positive: s.classes[pos].clone(),
        negative: s.classes[1 - pos].clone(),
        sensitivity: b.sensitivity(),
        specificity: b.specificity(),
        accuracy: s.confusion.accuracy(),
        counts: [b.tp, b.fn_, b.fp, b.tn],
        eq15: (s.eq15.sensitivity, s.eq15.specificity),
        nn_accuracy: s.nn_accuracy,
    })
}

fn two_means(d: &DistanceMatrix, restarts: usize, seed: u64) -> Result<Clustering> {
    Ok(kmeans(
        d,
        &ClusterOptions {
            k: 2,
            restarts,
            seed,
            max_iterations: 100,
        },
    )?)
}

/// One run of the classification pipeline on deformations of one connectivity.
pub(crate) struct Analysis {
    pub(crate) prepared: Prepared,
    pub(crate) matrix: DistanceMatrix,
    pub(crate) clustering: Clustering,
    pub(crate) scores: Binary,
    pub(crate) pair_seconds: Vec<(usize, usize, f64)>,
    /// Wall seconds: interpolation + transfer, similarity, clustering.
    pub(crate) wall: [f64; 3],
    pub(crate) unconverged: usize,
}

/// Interpolation (closed cycle unless `open`), transfer to the first deformation's frame 0,
/// similarity (eq. 13), 2-means and scores.
fn analyse(
    defs: &[Deformation],
    opts: &PipelineOptions,
    open: bool,
    restarts: usize,
    seed: u64,
) -> Result<Analysis> {
    let labels = labels_of(defs)?;
    let data = Dataset {
        deformations: defs
            .iter()
            .map(|d| Deformation {
                poses: if open {
                    d.poses.clone()
                } else {
                    close_cycle(&d.poses)
                },
                ..d.clone()
            })
            .collect(),
    };
    let t0 = Instant::now();
    let mut prepared = prepare_with_progress(&data, opts)?;
    if !open {
        prepared.interpolated.iter_mut().for_each(drop_closing_pose);
        prepared.transferred.iter_mut().for_each(drop_closing_pose);
        drop_closing_pose(&mut prepared.is_key);
    }
    let t_prep = t0.elapsed().as_secs_f64();
    let n = defs.len();
    let pb = bar(n * (n - 1) / 2, "pairs");
    let t1 = Instant::now();
    let pairs = similarities(&prepared, opts, &Default::default(), None, |_| {
        pb.inc(1);
        Ok(())
    })?;
    pb.finish_and_clear();
    let t_sim = t1.elapsed().as_secs_f64();
    let matrix = DistanceMatrix::new(prepared.names.clone(), assemble(n, &pairs))?;
    let t2 = Instant::now();
    let clustering = two_means(&matrix, restarts, seed)?;
    let scores = binary(&matrix, &clustering, &labels)?;
    Ok(Analysis {
        unconverged: pairs.iter().filter(|p| !p.converged).count() + usize::from(!prepared.converged),
        pair_seconds: pairs.iter().map(|p| (p.i, p.j, p.seconds)).collect(),
        wall: [t_prep, t_sim, t2.elapsed().as_secs_f64()],
        prepared,
        matrix,
        clustering,
        scores,
    })
}

fn labels_of(defs: &[Deformation]) -> Result<Vec<String>> {
    defs.iter()
        .map(|d| {
            d.label
                .clone()
                .with_context(|| format!("deformation '{}' has no class label", d.name))
        })
        .collect()
}

/// A baseline of Table 4: one feature per subject, 2-means on it.
pub(crate) struct Baseline {
    pub(crate) name: &'static str,
    pub(crate) values: Vec<f64>,
    pub(crate) clustering: Clustering,
    pub(crate) scores: Binary,
}

/// End-diastolic and end-systolic frame of a subject.
type EdEs = (usize, usize);

/// Radial baselines of the key frames (frame interval 1).
fn baselines(
    defs: &[Deformation],
    axes: &[Axis],
    open: bool,
    restarts: usize,
    seed: u64,
) -> Result<(Vec<Baseline>, Vec<EdEs>)> {
    let labels = labels_of(defs)?;
    let mut sys = Vec::new();
    let mut vel = Vec::new();
    let mut frames = Vec::new();
    for (d, a) in defs.iter().zip(axes) {
        let f = radial_features(&d.poses, a, 1.0, !open).with_context(|| format!("subject '{}'", d.name))?;
        sys.push(f.systolic_displacement);
        vel.push(f.mean_velocity);
        frames.push((f.ed_frame, f.es_frame));
    }
    let names: Vec<String> = defs.iter().map(|d| d.name.clone()).collect();
    let mut out = Vec::new();
    for (name, values) in [
        ("mean systolic radial displacement", sys),
        ("mean radial velocity", vel),
    ] {
        let d = DistanceMatrix::from_fn(names.clone(), |i, j| (values[i] - values[j]).abs())?;
        let clustering = two_means(&d, restarts, seed)?;
        let scores = binary(&d, &clustering, &labels)?;
        out.push(Baseline {
            name,
            values,
            clustering,
            scores,
        });
    }
    Ok((out, frames))
}

/// Fig. 9 of one interpolated sequence.
pub(crate) struct CycleMap {
    pub(crate) n_poses: usize,
    pub(crate) n_keys: usize,
    pub(crate) stress: f64,
    pub(crate) converged: bool,
    pub(crate) seconds: f64,
    /// Length of the closed (or open) path through the poses in order (normalized units).
    pub(crate) path_length: f64,
    /// Largest pose-to-pose distance and its pair of pose names.
    pub(crate) diameter: (f64, String, String),
}

/// The MDS map of an interpolated sequence (poses in input units, `factor` the normalization):
/// writes OUT/fig9_distances.csv, fig9_mds.csv and fig9_mds.svg|png.
#[allow(clippy::too_many_arguments)]
fn cycle_map(
    out: &Path,
    poses: &[Pose],
    is_key: &[bool],
    per_gap: usize,
    topo: &std::sync::Arc<qcshape::mesh::Topology>,
    factor: f64,
    common: &CycleCommon,
    seed: u64,
    title: &str,
) -> Result<CycleMap> {
    let t0 = Instant::now();
    let metric = common.metric.spec()?.build();
    let solver = GeodesicSolver::new(metric.as_ref(), topo.clone(), geodesic_options(common)?)?;
    let scaled: Vec<Pose> = poses
        .iter()
        .map(|p| p.iter().map(|v| v.map(|c| c * factor)).collect())
        .collect();
    let n = poses.len();
    let pb = bar(n * (n - 1) / 2, "pose pairs");
    let (values, converged) = pose_distance_matrix(&solver, &scaled, None, &|| pb.inc(1))?;
    pb.finish_and_clear();
    let names: Vec<String> = (0..n)
        .map(|k| {
            let t = k as f64 / per_gap as f64;
            if is_key[k] {
                format!("{t:.0}")
            } else {
                format!("{t:.2}").trim_end_matches('0').to_string()
            }
        })
        .collect();
    let d = DistanceMatrix::new(names.clone(), values)?;
    d.write_csv(&out.join("fig9_distances.csv"))?;
    let e = smacof(
        &d,
        &MdsOptions {
            dims: 2,
            seed,
            ..Default::default()
        },
    )?;
    let kinds: Vec<String> = is_key
        .iter()
        .map(|&k| if k { "key" } else { "interpolated" }.to_string())
        .collect();
    for ext in ["svg", "png"] {
        qcshape::plot::scatter_map(
            &out.join(format!("fig9_mds.{ext}")),
            &e.coords,
            &names,
            Some(&kinds),
            title,
            Some(e.normalized_stress),
        )?;
    }
    let mut csv = String::from("pose,frame_position,kind,x,y\n");
    for k in 0..n {
        csv.push_str(&format!(
            "{k},{},{},{:?},{:?}\n",
            names[k], kinds[k], e.coords[k][0], e.coords[k][1]
        ));
    }
    qcshape::io::write_atomically(&out.join("fig9_mds.csv"), |w| w.write_all(csv.as_bytes()))?;
    let mut path_length: f64 = (0..n - 1).map(|k| d.get(k, k + 1)).sum();
    if !common.open {
        path_length += d.get(n - 1, 0);
    }
    let mut diameter = (0.0, String::new(), String::new());
    for i in 0..n {
        for j in i + 1..n {
            if d.get(i, j) > diameter.0 {
                diameter = (d.get(i, j), names[i].clone(), names[j].clone());
            }
        }
    }
    Ok(CycleMap {
        n_poses: n,
        n_keys: is_key.iter().filter(|&&k| k).count(),
        stress: e.normalized_stress,
        converged,
        seconds: t0.elapsed().as_secs_f64(),
        path_length,
        diameter,
    })
}

/// Coarsens deformations of one connectivity to about `vertices` vertices (a subset of the
/// vertices chosen on the first deformation's frame 0); returns a note.
fn coarsen(defs: &mut [Deformation], vertices: usize) -> Result<Option<String>> {
    let Some(first) = defs.first() else {
        return Ok(None);
    };
    let nv = first.topology.n_vertices();
    if vertices == 0 || nv <= vertices {
        return Ok(None);
    }
    if defs.iter().any(|d| d.topology.faces() != first.topology.faces()) {
        bail!("the deformations do not share one connectivity: they cannot be compared pose by pose");
    }
    let ratio = (vertices as f64 / nv as f64).clamp(0.01, 0.99);
    let h = Hierarchy::new(&first.topology, &first.poses[0], 2, ratio)?;
    if h.n_levels() < 2 {
        return Ok(Some(format!(
            "not coarsened ({})",
            h.stopped().unwrap_or("no coarse level")
        )));
    }
    let level = h.level(1);
    for d in defs.iter_mut() {
        d.poses = d.poses.iter().map(|p| level.restrict(p)).collect();
        d.topology = level.topology.clone();
    }
    Ok(Some(format!(
        "coarsened from {nv} to {} vertices (a vertex subset)",
        level.n_vertices()
    )))
}

/// Interpolates one sequence and maps it (the single-subject path of `lv run`, and `lv cycle`).
fn run_cycle(def: Deformation, out: &Path, common: &CycleCommon, seed: u64, source: &str) -> Result<()> {
    let t_all = Instant::now();
    if def.poses.len() < 2 {
        bail!(
            "{source}: a cycle needs at least two frames, got {}",
            def.poses.len()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let frames = def.poses.len();
    let raw_vertices = def.topology.n_vertices();
    let mut defs = vec![def];
    let note = coarsen(&mut defs, common.vertices)?;
    let def = defs.pop().expect("one deformation");
    let metric = common.metric.spec()?.build();
    let topo = def.topology.clone();
    let factor = normalization_factor(Normalization::MeanEdgeOfFirst, &topo, &def.poses[0]);
    let keys = if common.open {
        def.poses.clone()
    } else {
        close_cycle(&def.poses)
    };
    let t0 = Instant::now();
    let interp = Interpolator::new(
        metric.as_ref(),
        &topo,
        &def.poses[0],
        InterpolationOptions {
            insert: common.insert,
            levels: 1,
            geodesic: geodesic_options(common)?,
            normalization: Normalization::Factor(factor),
            ..Default::default()
        },
    )?;
    let pb = bar(keys.len() - 1, "interpolating");
    let mut r = interp.interpolate_sequence(&keys, &|| pb.inc(1))?;
    pb.finish_and_clear();
    let t_interp = t0.elapsed().as_secs_f64();
    let interp_converged = r.pairs.iter().all(|p| p.converged);
    if !common.open {
        drop_closing_pose(&mut r.poses);
        drop_closing_pose(&mut r.is_key);
    }
    let map = cycle_map(
        out,
        &r.poses,
        &r.is_key,
        common.insert + 1,
        &topo,
        factor,
        common,
        seed,
        &format!("{}: cycle of {} frames + interpolated poses", def.name, frames),
    )?;
    eprintln!(
        "{}: {frames} frames -> {} poses, {} vertices; interpolation {t_interp:.1} s, {} pose pairs {:.1} s",
        def.name,
        map.n_poses,
        topo.n_vertices(),
        map.n_poses * (map.n_poses - 1) / 2,
        map.seconds
    );
    let md = cycle_report(
        source,
        &def.name,
        frames,
        raw_vertices,
        topo.n_vertices(),
        note.as_deref(),
        common,
        &map,
        [t_interp, map.seconds, t_all.elapsed().as_secs_f64()],
        interp_converged,
    )?;
    let path = out.join("report.md");
    qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The mesh files of `dir` whose names contain `pattern`.
fn pattern_files(dir: &Path, pattern: Option<&str>) -> Result<Vec<PathBuf>> {
    let files: Vec<PathBuf> = mesh_files(dir)?
        .into_iter()
        .filter(|f| pattern.is_none_or(|p| f.file_name().is_some_and(|n| n.to_string_lossy().contains(p))))
        .collect();
    Ok(files)
}

/// `qcshape lv cycle`.
pub fn cycle(a: &CycleArgs) -> Result<()> {
    if a.every == 0 {
        bail!("--every must be at least 1");
    }
    in_pool(a.common.threads, || {
        let files = match a.files.as_slice() {
            [dir] if dir.is_dir() => {
                let f = pattern_files(dir, a.pattern.as_deref())?;
                if f.is_empty() {
                    bail!(
                        "{}: no mesh files{}",
                        dir.display(),
                        a.pattern
                            .as_ref()
                            .map_or(String::new(), |p| format!(" containing {p:?}"))
                    );
                }
                f
            }
            files => files.to_vec(),
        };
        let files: Vec<PathBuf> = files.into_iter().step_by(a.every).collect();
        let def = load_sequence(&files)?;
        let source = format!(
            "{} files from {}{}",
            files.len(),
            files[0].parent().unwrap_or(Path::new(".")).display(),
            if a.every > 1 {
                format!(", every {}th", a.every)
            } else {
                String::new()
            }
        );
        run_cycle(def, &a.out, &a.common, a.seed, &source)
    })
}

/// `qcshape lv run`.
pub fn run(a: &RunArgs) -> Result<()> {
    in_pool(a.common.threads, || run_in_pool(a))
}

fn run_in_pool(a: &RunArgs) -> Result<()> {
    let t_all = Instant::now();
    if a.restarts == 0 {
        bail!("--restarts must be at least 1");
    }
    let opts = PipelineOptions {
        metric: a.common.metric.spec()?,
        geodesic: geodesic_options(&a.common)?,
        insert: a.common.insert,
        levels: 1,
        transport: Transport::Parallel,
        align: Default::default(),
        smoothing: PipelineOptions::default().smoothing,
        base: 0,
    };
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let settings = MeshSettings {
        threshold: a.threshold,
        smooth: a.smooth,
        vertices: a.common.vertices,
        free_wall: a.region == "free-wall",
    };
    // The deformations, their long axes and per-subject meshing seconds.
    let (defs, axes, mesh_seconds, input_note, from_images) =
        if is_cohort(&a.dir) {
            let t0 = Instant::now();
            let c = mesh_cohort(&a.dir, a.landmarks, &settings)?;
            write_meshes(&a.out.join("meshes"), &c.defs)?;
            eprintln!(
                "meshed {} subjects ({} vertices each, {} of {} projected on their own surface) in {:.1} s",
                c.defs.len(),
                c.defs[0].topology.n_vertices(),
                c.snapped,
                c.defs.len() - 1,
                t0.elapsed().as_secs_f64()
            );
            let note =
                format!(
            "cohort `{}`: template = frame 0 of `{}` ({} vertices on the whole surface, {} in the {}), \
             carried to the other subjects by the landmark spline between frame-0 landmarks and projected \
             on each subject's own frame-0 surface ({} of {} projected; the rest kept the spline result, \
             which would otherwise fold a triangle); meshes in `meshes/manifest.csv`.",
            a.dir.display(),
            c.defs[0].name,
            c.whole_vertices,
            c.defs[0].topology.n_vertices(),
            if settings.free_wall { "free wall" } else { "whole surface" },
            c.snapped,
            c.defs.len() - 1
        );
            (c.defs, c.axes, c.seconds, note, true)
        } else {
            let seq = if a.dir.is_dir() {
                let f = pattern_files(&a.dir, a.pattern.as_deref())?;
                (!f.is_empty()).then_some(f)
            } else {
                None
            };
            if let Some(files) = seq {
                let def = load_sequence(&files)?;
                eprintln!(
                    "{}: one sequence of {} frames: cycle map only",
                    a.dir.display(),
                    files.len()
                );
                let source = format!("{} files from {}", files.len(), a.dir.display());
                return run_cycle(def, &a.out, &a.common, a.seed, &source);
            }
            let t0 = Instant::now();
            let mut data = Dataset::load(&a.dir)?;
            if data.deformations.len() == 1 {
                let def = data.deformations.pop().expect("one");
                return run_cycle(def, &a.out, &a.common, a.seed, &a.dir.display().to_string());
            }
            let note = coarsen(&mut data.deformations, a.common.vertices)?;
            let axes = data
                .deformations
                .iter()
                .map(|d| Axis::fit(&d.poses[0]).with_context(|| format!("deformation '{}'", d.name)))
                .collect::<Result<Vec<_>>>()?;
            let per = t0.elapsed().as_secs_f64() / data.deformations.len() as f64;
            let n = data.deformations.len();
            (
                data.deformations,
                axes,
                vec![per; n],
                format!(
                    "meshes from `{}` (no images: registration and meshing skipped, long axes fitted to \
                 frame 0{}).",
                    a.dir.display(),
                    note.map_or(String::new(), |n| format!("; {n}"))
                ),
                false,
            )
        };
    let frames = defs[0].poses.len();

    let main = analyse(&defs, &opts, a.common.open, a.restarts, a.seed)?;
    eprintln!(
        "{} landmarks: our method sensitivity {:.1} %, specificity {:.1} % ({:.1} s)",
        a.landmarks,
        100.0 * main.scores.sensitivity,
        100.0 * main.scores.specificity,
        main.wall.iter().sum::<f64>()
    );
    let (base, ed_es) = baselines(&defs, &axes, a.common.open, a.restarts, a.seed)?;
    for b in &base {
        eprintln!(
            "{}: sensitivity {:.1} %, specificity {:.1} %",
            b.name,
            100.0 * b.scores.sensitivity,
            100.0 * b.scores.specificity
        );
    }
    main.matrix.write_csv(&a.out.join("similarity.csv"))?;

    // Table 5.
    let mut sweep = Vec::new();
    if from_images && !a.no_sweep {
        for &n in &a.landmark_sweep {
            if n == a.landmarks {
                sweep.push((n, main.scores.clone(), 0.0));
                continue;
            }
            let t0 = Instant::now();
            let c = mesh_cohort(&a.dir, n, &settings)?;
            let r = analyse(&c.defs, &opts, a.common.open, a.restarts, a.seed)?;
            let secs = t0.elapsed().as_secs_f64();
            eprintln!(
                "{n} landmarks: sensitivity {:.1} %, specificity {:.1} % ({secs:.1} s)",
                100.0 * r.scores.sensitivity,
                100.0 * r.scores.specificity
            );
            sweep.push((n, r.scores, secs));
        }
    }

    // Fig. 9.
    let idx = match &a.mds_subject {
        Some(name) => defs
            .iter()
            .position(|d| &d.name == name)
            .with_context(|| format!("--mds-subject {name:?} is not a subject"))?,
        None => 0,
    };
    let map = cycle_map(
        &a.out,
        &main.prepared.interpolated[idx],
        &main.prepared.is_key,
        a.common.insert + 1,
        &main.prepared.topology,
        main.prepared.factor,
        &a.common,
        a.seed,
        &format!("{}: {} frames + interpolated poses", defs[idx].name, frames),
    )?;

    let summary = RunSummary {
        args_line: std::env::args().collect::<Vec<_>>().join(" "),
        input_note,
        landmarks: a.landmarks,
        from_images,
        region: a.region.clone(),
        frames,
        restarts: a.restarts,
        seed: a.seed,
        mesh_seconds,
        ed_es,
        total_seconds: t_all.elapsed().as_secs_f64(),
        mds_subject: defs[idx].name.clone(),
    };
    let md = run_report(&a.out, &summary, &a.common, &defs, &main, &base, &sweep, &map)?;
    let path = a.out.join("report.md");
    qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}
