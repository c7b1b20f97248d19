//! `qcshape localize`: where labelled groups of deformations differ, per vertex.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::dataset::Dataset;
use qcshape::io::{self, Field};
use qcshape::localize::{contrasts, pair_maps, read_vertex_mask, region_share, LocalizeOptions};
use qcshape::path::GeodesicSolver;
use qcshape::render::{render_png, RenderOptions};
use qcshape::similarity::{prepare, PipelineOptions};

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
/// With --region FILE (a vertex mask), DIR/region_summary.csv gives per contrast the region's
/// share of the area and of the positive score mass.
///
/// Writes DIR/contrast_<A>_vs_<B>.csv (vertex,score,p_value,significant), and .vtk and .ply
/// files of the same name on the common base mesh with the point data score, p_value,
/// significant (0/1), between and within (the PLY's quality is the score), and a PNG picture
/// of the score on the base mesh (six views, non-significant vertices grey when any vertex
/// is significant, the --region outlined).
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
    /// Poses inserted between consecutive key poses before transfer.
    #[arg(long, default_value_t = 0)]
    insert: usize,
    /// Taubin smoothing iterations applied to every pose first (0 = none).
    #[arg(long, default_value_t = 10)]
    smoothing: usize,
    /// Random relabellings per contrast.
    #[arg(long, default_value_t = 999)]
    permutations: usize,
    /// Seed of the relabellings.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// False discovery rate (Benjamini-Hochberg).
    #[arg(long, default_value_t = 0.05)]
    alpha: f64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// A vertex mask on the base mesh (CSV with `vertex` and `region` columns, e.g. the LV
    /// phantom's meshes/abnormal_region.csv): reports each contrast's positive mass share in
    /// the region against its area share (DIR/region_summary.csv) and outlines it in the
    /// pictures.
    #[arg(long)]
    region: Option<PathBuf>,
}

/// A file name part for a label: letters, digits, `-`, `_` kept, the rest `_`.
fn file_part(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        "_".into()
    } else {
        t
    }
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    let data = Dataset::load(&args.input)?;
    let defs = data.deformations;
    let mut labels = Vec::with_capacity(defs.len());
    for d in &defs {
        match &d.label {
            Some(l) if !l.is_empty() => labels.push(l.clone()),
            _ => bail!(
                "deformation {:?} has no label: localize needs a labelled data set",
                d.name
            ),
        }
    }
    let opts = PipelineOptions {
        metric: args.metric.spec()?,
        geodesic: args.solver.options()?,
        insert: args.insert,
        smoothing: args.smoothing,
        ..Default::default()
    };
    let lopts = LocalizeOptions {
        permutations: args.permutations,
        seed: args.seed,
        alpha: args.alpha,
    };
    let metric = opts.metric.build();
    eprintln!(
        "localizing {} deformation(s) with {} labels, {} ...",
        defs.len(),
        {
            let mut u = labels.clone();
            u.sort();
            u.dedup();
            u.len()
        },
        metric.name()
    );
    let (prepared, maps, result) = in_pool(args.threads, || {
        let prepared = prepare(&defs, &opts, &|_, _| {})?;
        let solver = GeodesicSolver::new(metric.as_ref(), prepared.topology.clone(), opts.geodesic.clone())?;
        let maps = pair_maps(&solver, &prepared.scaled())?;
        let result = contrasts(&maps, &labels, &lopts)?;
        Ok((prepared, maps, result))
    })?;
    if !maps.converged {
        eprintln!("warning: not every geodesic converged");
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let base = &prepared.transferred[0][0];
    let faces = prepared.topology.faces();
    let region = match &args.region {
        Some(p) => Some(read_vertex_mask(p, base.len())?),
        None => None,
    };
    let mut summary = String::from(
        "a,b,region_vertices,vertices,area_share,positive_mass_share,ratio,significant_in_region,significant\n",
    );
    for c in &result {
        let stem = format!("contrast_{}_vs_{}", file_part(&c.a), file_part(&c.b));
        let mut csv = String::from("vertex,score,p_value,significant\n");
        for v in 0..c.score.len() {
            writeln!(
                csv,
                "{v},{:.12e},{:.6},{}",
                c.score[v], c.p_value[v], c.significant[v]
            )?;
        }
        io::write_atomically(&args.out.join(format!("{stem}.csv")), |w| {
            w.write_all(csv.as_bytes())
        })?;
        let sig: Vec<f64> = c.significant.iter().map(|&s| f64::from(u8::from(s))).collect();
        let fields = [
            Field::scalar("score", &c.score),
            Field::scalar("p_value", &c.p_value),
            Field::scalar("significant", &sig),
            Field::scalar("between", &c.between),
            Field::scalar("within", &c.within),
        ];
        for ext in ["vtk", "ply"] {
            io::write_mesh_fields(&args.out.join(format!("{stem}.{ext}")), base, faces, &fields)?;
        }
        let n_sig = c.significant.iter().filter(|&&s| s).count();
        let picture = RenderOptions {
            title: format!(
                "{} vs {}: {}; {n_sig} of {} vertices significant (FDR {})",
                c.a,
                c.b,
                metric.name(),
                c.score.len(),
                args.alpha
            ),
            label: format!(
                "score = mean between - mean within similarity split{}{}",
                if n_sig > 0 { "; grey: not significant" } else { "" },
                if region.is_some() {
                    "; black line: --region"
                } else {
                    ""
                }
            ),
            grey: (n_sig > 0).then(|| c.significant.iter().map(|&s| !s).collect()),
            outline: region.clone(),
            ..Default::default()
        };
        render_png(
            &args.out.join(format!("{stem}.png")),
            base,
            faces,
            &c.score,
            &picture,
        )?;
        if let Some(r) = &region {
            let share = region_share(&prepared.topology, base, &c.score, &c.significant, r);
            writeln!(
                summary,
                "{},{},{},{},{:.6},{:.6},{:.4},{},{}",
                c.a,
                c.b,
                share.vertices,
                c.score.len(),
                share.area_share,
                share.positive_mass_share,
                share.ratio,
                share.significant_in_region,
                share.significant
            )?;
            println!(
                "{} vs {}: region of {} vertices: {:.1} % of the area, {:.1} % of the positive score mass (ratio {:.2}); {} of {} significant vertices in it",
                c.a,
                c.b,
                share.vertices,
                100.0 * share.area_share,
                100.0 * share.positive_mass_share,
                share.ratio,
                share.significant_in_region,
                share.significant
            );
        }
        println!(
            "{} vs {}: {} of {} vertices significant (FDR {}), max score {:.4e}, min p {:.4}",
            c.a,
            c.b,
            c.significant.iter().filter(|&&s| s).count(),
            c.score.len(),
            args.alpha,
            c.score.iter().copied().fold(f64::MIN, f64::max),
            c.p_value.iter().copied().fold(1.0, f64::min)
        );
    }
    if region.is_some() {
        io::write_atomically(&args.out.join("region_summary.csv"), |w| {
            w.write_all(summary.as_bytes())
        })?;
    }
    Ok(())
}
