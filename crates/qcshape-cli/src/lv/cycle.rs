//! `qcshape lv cycle` (and the single-sequence path of `lv run`): the Fig. 9 map of one
//! cycle ([`qcshape_studies::lv::cycle_map::study_cycle`], [`qcshape_studies::lv::study_report::cycle_report`]);
//! this module parses the arguments, shows progress and writes the files.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::dataset::{load_sequence, Deformation};
use qcshape_studies::lv::cycle_map::{cycle_title, study_cycle, CycleSettings};
use qcshape_studies::lv::pipeline::pattern_files;
use qcshape_studies::lv::study_report::cycle_report;

use super::bars::Bars;
use crate::args::{in_pool, MetricArgs, SolverArgs};

/// `--steps`' default in `lv run` and `lv cycle`: [`qcshape_studies::study_defaults::PAPER_STEPS`] (a named
/// exception, checked by tests/defaults.rs).
const PAPER_STEPS: &str = "4";

/// Options shared by `lv run` and `lv cycle`.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("steps", |a| a
    .default_value(PAPER_STEPS)
    .long_help("Segments N of every geodesic (default 4, the setting the README's LV tables were \
measured with, not the other commands' 8).\nAt most 10,000.")))]
pub struct CycleCommon {
    #[command(flatten)]
    pub metric: MetricArgs,
    /// Poses inserted between consecutive frames (default 3, the paper's section 4 setting, not
    /// the other commands' 0).
    /// At most 1,000.
    #[arg(long, default_value_t = qcshape::defaults::PAPER_INSERT, value_parser = crate::args::count(&qcshape::settings::INSERT), allow_negative_numbers = true)]
    pub insert: usize,
    /// The geodesic solver (`--steps` defaults to 4 here, the setting the README's LV tables
    /// were measured with, not the other commands' 8).
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Vertex budget: the cohort template's whole surface, or meshes given as input are coarsened
    /// (a vertex subset, multires hierarchy) when larger.
    /// At most 100,000,000.
    #[arg(long, default_value_t = 600, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_VERTICES as u64), allow_negative_numbers = true)]
    pub vertices: usize,
    /// Do not close the cycle (no gap last frame -> frame 0).
    #[arg(long)]
    pub open: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
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
    /// At most 10,000.
    #[arg(long, default_value_t = 1, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_EVERY as u64), allow_negative_numbers = true)]
    every: usize,
    #[command(flatten)]
    common: CycleCommon,
    /// Seed of the MDS.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// The library's cycle settings of the command line.
pub(super) fn cycle_settings(c: &CycleCommon, frame_stride: usize) -> Result<CycleSettings> {
    Ok(CycleSettings {
        metric: c.metric.spec()?,
        geodesic: c.solver.options()?,
        insert: c.insert,
        vertices: c.vertices,
        open: c.open,
        frame_stride,
    })
}

/// The command line, as typed (for reports).
pub(super) fn args_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// Interpolates one sequence and maps it (the single-subject path of `lv run`, and `lv cycle`).
pub(super) fn run_cycle(
    def: Deformation,
    out: &Path,
    common: &CycleCommon,
    frame_stride: usize,
    seed: u64,
    source: &str,
) -> Result<()> {
    let t_all = Instant::now();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let settings = cycle_settings(common, frame_stride)?;
    let nv = def.topology.n_vertices();
    eprintln!(
        "{}: {} frames of {nv} vertices{}",
        def.name,
        def.poses.len(),
        if common.vertices > 0 && nv > common.vertices {
            format!(
                "; coarsened to about {} vertices first (--vertices; 0 keeps every vertex)",
                common.vertices
            )
        } else {
            String::new()
        }
    );
    let bars = Bars::default();
    let c = study_cycle(def, &settings, seed, &|t| bars.tick(t)).with_context(|| source.to_string())?;
    c.map.write_files(out, &cycle_title(&c.name, c.frames))?;
    eprintln!(
        "{}: {} frames -> {} poses, {} vertices; interpolation {:.1} s, {} pose pairs {:.1} s",
        c.name,
        c.frames,
        c.map.n_poses,
        c.vertices,
        c.interpolation_seconds,
        c.map.n_poses * (c.map.n_poses - 1) / 2,
        c.map.seconds
    );
    let md = cycle_report(&args_line(), source, &c, &settings, t_all.elapsed().as_secs_f64())?;
    let path = out.join("report.md");
    qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
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
        let given: Vec<&Path> = a.files.iter().chain(&files).map(PathBuf::as_path).collect();
        crate::input::refuse_out_folder(&given, &a.out, "--out")?;
        let files: Vec<PathBuf> = files.into_iter().step_by(a.every).collect();
        let def = load_sequence(&files)?;
        let source = format!(
            "{} files from {}{}",
            files.len(),
            files[0].parent().unwrap_or(Path::new(".")).display(),
            if a.every > 1 {
                format!(
                    ", one frame in {} (frames 0, {}, {}, ...)",
                    a.every,
                    a.every,
                    2 * a.every
                )
            } else {
                String::new()
            }
        );
        run_cycle(def, &a.out, &a.common, a.every, a.seed, &source)
    })
}
