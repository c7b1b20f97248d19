//! `qcshape localize`: where labelled groups of deformations differ, per vertex.

use std::path::PathBuf;

use anyhow::{Context, Result};
use qcshape::dataset::Dataset;
use qcshape::io::{self, Field};
use qcshape::similarity::PipelineOptions;
use qcshape_studies::localize::{
    file_part, group_labels, localize, motion_title, push_region_row, read_vertex_mask, region_share,
    write_map, LocalizeOptions, MotionMeasure, MotionScale, VertexMap, REGION_SUMMARY_HEADER,
};
use qcshape_studies::render::RenderOptions;

use crate::args::{in_pool, MetricArgs, SolverArgs};

/// Per-vertex contrasts between the labels of a data set (docs/maps.md).
///
/// The data set is prepared as for `qcshape similarity` (smoothing, rigid alignment,
/// interpolation, transfer to the first deformation's first pose). For every pair of
/// deformations the similarity sum_k dis(M_k, N_k) (eq. 13) is split per vertex (face and edge
/// terms shared equally among their vertices, each segment's length in proportion to its
/// energy split). For every pair of labels A, B the score of a vertex is the mean split over
/// pairs across A and B minus the mean over pairs within A or within B (normalized length
/// units), its p-value comes from --permutations random relabellings (seeded), and vertices
/// passing the Benjamini-Hochberg procedure at --alpha are significant.
///
/// The similarity split is unsigned: it shows where two groups move differently, not which
/// moves more. So every deformation also gets its own motion map (--motion normal: how far
/// each vertex moves along the surface normal over the poses, times its area; --motion
/// metric: the metric's per-vertex length of each step; --motion-scale share divides by the
/// deformation's total) and, for every pair of labels A, B, DIR/motion_<A>_minus_<B>.* holds
/// the signed difference of the group means (positive where A moves more) with two-sided
/// permutation p-values and the same FDR procedure.
///
/// With --region FILE (a vertex mask), DIR/region_summary.csv gives per map the region's
/// share of the area and of the positive mass (for a motion map, one row per direction: the
/// row `motion,A,B` is where A moves more).
///
/// Writes DIR/contrast_<A>_vs_<B>.csv (vertex,score,p_value,significant), and .vtk and .ply
/// files of the same name on the common base mesh with the point data score, p_value,
/// significant (0/1), between and within (the PLY's quality is the score), and a PNG picture
/// of the score on the base mesh (six views, non-significant vertices grey when any vertex
/// is significant, the --region outlined); DIR/motion_<A>_minus_<B>.csv
/// (vertex,difference,p_value,significant) with .vtk, .ply (difference, p_value,
/// significant, mean_a, mean_b) and .png alike.
#[derive(Debug, clap::Args)]
#[command(
    about = "Per-vertex maps of where labelled groups of deformations differ",
    long_about
)]
pub struct Args {
    /// A labelled data set (manifest CSV or folder of labelled deformation folders).
    input: PathBuf,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    #[arg(long, help = qcshape::settings::INSERT.help(), default_value = qcshape::settings::INSERT.default_text(), value_parser = crate::args::count(&qcshape::settings::INSERT), allow_negative_numbers = true)]
    insert: usize,
    #[command(flatten)]
    smooth: crate::args::SmoothArgs,
    /// Random relabellings per contrast.
    /// At most 1,000,000.
    #[arg(long, default_value_t = 999, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_PERMUTATIONS as u64), allow_negative_numbers = true)]
    permutations: usize,
    /// Seed of the relabellings.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// False discovery rate (Benjamini-Hochberg).
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true)]
    alpha: f64,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
    /// A vertex mask on the base mesh (CSV with `vertex` and `region` columns, e.g. the LV
    /// phantom's meshes/abnormal_region.csv): reports each contrast's positive mass share in
    /// the region against its area share (DIR/region_summary.csv) and outlines it in the
    /// pictures.
    #[arg(long)]
    region: Option<PathBuf>,
    /// How the signed motion maps measure each deformation's motion per vertex: `normal`
    /// (motion along the surface normal, times the vertex area; tangential sliding does not
    /// count) or `metric` (the metric's per-vertex length split of each step).
    #[arg(long, default_value = "normal", value_parser = MotionMeasure::NAMES)]
    motion: String,
    /// Divide each deformation's motion map by its total (`share`): where a deformation moves,
    /// whatever its overall amount of motion.
    #[arg(long, default_value = "absolute", value_parser = MotionScale::NAMES)]
    motion_scale: String,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    let data = Dataset::load(&args.input)?;
    let mut inputs = data.input_paths(&args.input);
    inputs.extend(args.region.as_deref());
    crate::input::refuse_out_folder(&inputs, &args.out, "--out")?;
    let defs = data.deformations;
    let labels = group_labels(&defs)?;
    let opts = PipelineOptions {
        metric: args.metric.spec()?,
        geodesic: args.solver.options()?,
        insert: args.insert,
        smoothing: args.smooth.smoothing(),
        ..Default::default()
    };
    let lopts = LocalizeOptions {
        permutations: args.permutations,
        seed: args.seed,
        alpha: args.alpha,
    };
    eprintln!(
        "localizing {} deformation(s) with {} labels, {} ...",
        defs.len(),
        {
            let mut u = labels.clone();
            u.sort();
            u.dedup();
            u.len()
        },
        opts.metric.label()
    );
    let scale: MotionScale = args.motion_scale.parse()?;
    let l = in_pool(args.threads, || {
        Ok(localize(&defs, &labels, &opts, &lopts, &args.motion, scale)?)
    })?;
    let (prepared, metric_name) = (&l.prepared, &l.metric_name);
    if !l.maps.converged {
        eprintln!("warning: not every geodesic converged");
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let base = &prepared.transferred[0][0];
    let region = match &args.region {
        Some(p) => Some(read_vertex_mask(p, base.len())?),
        None => None,
    };
    let out = Output {
        dir: &args.out,
        base,
        topology: &prepared.topology,
        region: region.as_ref(),
        alpha: args.alpha,
    };
    let mut summary = String::from(REGION_SUMMARY_HEADER);
    for c in &l.contrasts {
        let stem = format!("contrast_{}_vs_{}", file_part(&c.a), file_part(&c.b));
        out.write_map(
            &stem,
            VertexMap {
                name: "score",
                values: &c.score,
                p_value: &c.p_value,
                significant: &c.significant,
            },
            &[
                Field::scalar("between", &c.between),
                Field::scalar("within", &c.within),
            ],
            &format!("{} vs {}: {}", c.a, c.b, metric_name),
            "score = mean between - mean within similarity split",
        )?;
        out.summarize(&mut summary, "contrast", &c.a, &c.b, &c.score, &c.significant)?;
    }
    let motion_name = motion_title(&args.motion, scale, metric_name);
    for c in &l.motion {
        let stem = format!("motion_{}_minus_{}", file_part(&c.a), file_part(&c.b));
        out.write_map(
            &stem,
            VertexMap {
                name: "difference",
                values: &c.difference,
                p_value: &c.p_value,
                significant: &c.significant,
            },
            &[
                Field::scalar("mean_a", &c.mean_a),
                Field::scalar("mean_b", &c.mean_b),
            ],
            &format!("motion {} minus {}: {motion_name}", c.a, c.b),
            &format!("red: {} moves more, blue: {} moves more", c.a, c.b),
        )?;
        out.summarize(&mut summary, "motion", &c.a, &c.b, &c.difference, &c.significant)?;
        let flipped: Vec<f64> = c.difference.iter().map(|d| -d).collect();
        out.summarize(&mut summary, "motion", &c.b, &c.a, &flipped, &c.significant)?;
    }
    if region.is_some() {
        io::write_atomically(&args.out.join("region_summary.csv"), |w| {
            w.write_all(summary.as_bytes())
        })?;
    }
    Ok(())
}

/// Where and how the maps are written.
struct Output<'a> {
    dir: &'a std::path::Path,
    base: &'a [[f64; 3]],
    topology: &'a qcshape::mesh::Topology,
    region: Option<&'a Vec<bool>>,
    alpha: f64,
}

impl Output<'_> {
    /// Writes `STEM.csv` (`vertex,NAME,p_value,significant`), `STEM.vtk`, `STEM.ply` (the
    /// fields) and `STEM.png` (the map, non-significant vertices grey when any is
    /// significant, the region outlined).
    fn write_map(&self, stem: &str, map: VertexMap, extra: &[Field], title: &str, label: &str) -> Result<()> {
        let n_sig = map.n_significant();
        let picture = RenderOptions {
            title: format!(
                "{title}; {n_sig} of {} vertices significant (FDR {})",
                map.values.len(),
                self.alpha
            ),
            label: format!(
                "{label}{}{}",
                if n_sig > 0 { "; grey: not significant" } else { "" },
                if self.region.is_some() {
                    "; black line: --region"
                } else {
                    ""
                }
            ),
            outline: self.region.cloned(),
            ..Default::default()
        };
        write_map(
            self.dir,
            stem,
            self.base,
            self.topology.faces(),
            &map,
            extra,
            &["vtk", "ply"],
            picture,
        )?;
        outln!(
            "{title}: {n_sig} of {} vertices significant (FDR {}), max {}, min p {}",
            map.values.len(),
            qcshape::numfmt::plain(self.alpha),
            qcshape::numfmt::significant(map.values.iter().copied().fold(f64::MIN, f64::max), 5),
            qcshape::numfmt::significant(map.p_value.iter().copied().fold(1.0, f64::min), 4)
        );
        Ok(())
    }

    /// Appends the region summary row of `values` (its positive part) to `summary` and
    /// prints it, when there is a region.
    fn summarize(
        &self,
        summary: &mut String,
        map: &str,
        a: &str,
        b: &str,
        values: &[f64],
        significant: &[bool],
    ) -> Result<()> {
        let Some(r) = self.region else { return Ok(()) };
        let share = region_share(self.topology, self.base, values, significant, r);
        push_region_row(summary, map, a, b, values.len(), &share);
        outln!("{map} {a} over {b}: {share}");
        Ok(())
    }
}
