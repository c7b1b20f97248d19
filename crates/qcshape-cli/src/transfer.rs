//! `qcshape transfer`: carry deformations to a common base pose (paper section 2.2.2).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use qcshape::dataset::{self, Deformation, ManifestRow};
use qcshape::geodesic::{normalization_factor, Normalization};
use qcshape::io;
use qcshape::mesh::Shape;
use qcshape::transport::{TransferOptions, TransferSetup, Transport};

use crate::args::{in_pool, MetricArgs, SolverArgs};
use crate::mesh_format::MeshFormat;
use crate::template::{Extra, Source};

/// Transfer deformations to a new base pose (Euclidean by default, parallel transport along
/// geodesics with --transport parallel).
///
/// The default, `--transport euclidean` (the same default as `similarity`, `run`, `classify` and
/// `reproduce`), gives N_k = N_0 + M_k - M_0. With `--transport parallel` (the paper's), for
/// each deformation M_0 .. M_K and k = 0 .. K-1: the geodesic from M_k to N_k (N_0 = the
/// base), the segment M_{k+1} - M_k transported along it, N_{k+1} = N_k + the transported
/// segment. All shapes are scaled by one
/// common factor (1 / mean edge length of the base) for the geodesics; the poses are written
/// in the input's units as DIR/<deformation>/pose000.<format> ..., listed in DIR/manifest.csv.
/// PLY, VTK and VTP poses carry the transferred displacement N_k - N_0 as the vector field
/// `displacement` (PLY: `displacement_x/_y/_z`) and its length as the scalar `magnitude` (the
/// PLY's `quality`), in the input's units.
#[derive(Debug, clap::Args)]
#[command(about = "Transfer deformations to a common base pose", long_about)]
pub struct Args {
    /// A data set (manifest CSV, folder of deformation folders, folder of mesh files) or the
    /// mesh files of one deformation in pose order.
    #[arg(required = true, num_args = 1..)]
    input: Vec<PathBuf>,
    /// The base pose N_0 (a mesh with the deformations' connectivity; with --template, any
    /// mesh: fitted too unless it has the template's connectivity).
    #[arg(long)]
    to: PathBuf,
    #[command(flatten)]
    template: crate::template::TemplateArgs,
    /// Metric of the geodesics (the transport always uses the quadratic conformal form and the
    /// endpoint curvature weights of each geodesic).
    #[command(flatten)]
    metric: MetricArgs,
    #[arg(long, help = qcshape::settings::TRANSPORT.help(), default_value = qcshape::settings::TRANSPORT.default_text(), value_parser = crate::args::choice::<qcshape::transport::Transport>())]
    transport: Transport,
    /// Geodesics (N = number of transport steps).
    #[command(flatten)]
    solver: SolverArgs,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Mesh format of the written poses (OBJ and OFF carry no displacement fields).
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    format: MeshFormat,
    /// Print the per-deformation summary as JSON.
    #[arg(long)]
    json: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

/// The deformations of INPUT and the base `--to` (both fitted with `--template` when given).
fn load_input(args: &Args) -> Result<(Vec<Deformation>, Shape)> {
    let input = args.input.as_slice();
    let source = match input {
        [one] if one.is_dir() || one.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) => {
            Source::Dataset(one)
        }
        _ => Source::Sequence(input),
    };
    let base = Extra {
        name: "--to",
        path: &args.to,
    };
    let quality = args.out.join("quality.csv");
    let (data, mut extra) = args
        .template
        .load(source, &[base], &quality, Some(&args.out), &[])?;
    if data.deformations.is_empty() {
        bail!("{}: no deformations to transfer", input[0].display());
    }
    let base = extra.pop().context("the base pose --to")?;
    Ok((data.deformations, base))
}

/// A folder name for a deformation: letters, digits, `-`, `_`, `.` kept, the rest `_`.
fn folder_for(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        "deformation".into()
    } else {
        s
    }
}

fn progress(n: usize) -> indicatif::ProgressBar {
    let pb = crate::progress::new_bar(n);
    if let Some(style) = crate::progress::style("{bar:40} {pos}/{len} {msg} [{elapsed}, ETA {eta}{solver}]") {
        pb.set_style(style);
    }
    crate::progress::start(&pb);
    pb
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let spec = args.metric.spec()?;
    let geodesic = args.solver.options()?;
    let (deformations, base) = load_input(args)?;
    let mut inputs: Vec<&std::path::Path> = args.input.iter().map(PathBuf::as_path).collect();
    inputs.push(&args.to);
    inputs.extend(
        deformations
            .iter()
            .flat_map(|d| d.paths.iter().map(PathBuf::as_path)),
    );
    crate::input::refuse_out_folder(&inputs, &args.out, "--out")?;
    let mut names = std::collections::HashSet::new();
    for d in &deformations {
        let probe = d.shape(0);
        if let Err(e) = base.check_same_topology(&probe) {
            return Err(crate::template::hint(anyhow::Error::new(e).context(format!(
                "deformation {:?} ({}) cannot be transferred to {}",
                d.name,
                d.paths[0].display(),
                args.to.display()
            ))));
        }
        if !names.insert(folder_for(&d.name)) {
            bail!(
                "two deformations map to the output folder {:?}; rename one",
                folder_for(&d.name)
            );
        }
    }
    let options = TransferOptions {
        geodesic,
        normalization: Normalization::MeanEdgeOfFirst,
        ..Default::default()
    };
    // The metric calibrated on the base, in the base's mean-edge units.
    let factor = normalization_factor(Normalization::MeanEdgeOfFirst, &base.topology, &base.positions);
    let scaled: Vec<[f64; 3]> = base.positions.iter().map(|p| p.map(|c| c * factor)).collect();
    let calibration = spec.calibrate(&base.topology, &[&scaled])?;
    let options = TransferOptions {
        normalization: Normalization::Factor(factor),
        ..options
    };
    let setup = TransferSetup::new(&spec, &calibration, base.topology.clone(), options)?;
    let transfer = setup.solver()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    // Euclidean transport translates: it uses neither the metric nor geodesics.
    let translate = args.transport == qcshape::transport::Transport::Translate;
    let how = match translate {
        true => "N_k = N_0 + M_k - M_0, no metric and no geodesic".to_string(),
        false => format!("{}, N = {}", spec.label(), args.solver.steps),
    };
    eprintln!(
        "transferring {} deformation(s) to {} ({} vertices) with {} transport, {how} ...",
        deformations.len(),
        args.to.display(),
        base.n_vertices(),
        args.transport.label(),
    );
    if !translate && !args.json {
        eprintln!("per deformation: the longest geodesic the transport solved (mean-edge units), the largest relative change of a displacement's norm |out/in - 1|, the largest inner-product / norm residuals of the transport, and whether every geodesic converged");
    }
    let pb = progress(deformations.len());
    let mut rows = Vec::new();
    let mut summaries = Vec::new();
    for d in &deformations {
        pb.set_message(d.name.clone());
        let out = transfer
            .run(&d.poses, &base.positions, args.transport)
            .with_context(|| format!("transferring deformation {:?}", d.name))?;
        let folder = folder_for(&d.name);
        let dir = args.out.join(&folder);
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for (k, p) in out.poses.iter().enumerate() {
            let file = format!("pose{k:03}.{}", args.format.extension());
            let path = dir.join(&file);
            if !args.format.has_fields() {
                io::write_mesh(&path, p, base.topology.faces(), &Default::default())?;
            } else {
                let n0 = &out.poses[0];
                let disp: Vec<[f64; 3]> = n0
                    .iter()
                    .zip(p)
                    .map(|(a, b)| [b[0] - a[0], b[1] - a[1], b[2] - a[2]])
                    .collect();
                let mag: Vec<f64> = disp
                    .iter()
                    .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                    .collect();
                let fields = [
                    io::Field::vector("displacement", &disp),
                    io::Field::scalar("magnitude", &mag),
                ];
                io::write_mesh_fields(&path, p, base.topology.faces(), &fields)?;
            }
            rows.push(ManifestRow {
                deformation: d.name.clone(),
                label: d.label.clone(),
                pose: k as i64,
                path: Path::new(&folder).join(file),
            });
        }
        let segs = &out.segments;
        let max =
            |f: &dyn Fn(&qcshape::transport::SegmentReport) -> f64| segs.iter().map(f).fold(0.0, f64::max);
        let ratio = max(&|s| {
            if s.input_norm > 0.0 {
                (s.output_norm / s.input_norm - 1.0).abs()
            } else {
                0.0
            }
        });
        let summary = serde_json::json!({
            "deformation": d.name,
            "poses": out.poses.len(),
            "max_geodesic_length": max(&|s| s.geodesic_length),
            "geodesics_converged": segs.iter().all(|s| s.geodesic_converged),
            "max_inner_residual": max(&|s| s.max_inner_residual),
            "max_norm_residual": max(&|s| s.max_norm_residual),
            "max_norm_change": ratio,
            "scale": out.scale,
            "seconds": out.seconds,
        });
        if !args.json && translate {
            let line = format!(
                "{:<20} poses {:>3}  translated  {:.2}s",
                d.name,
                out.poses.len(),
                out.seconds
            );
            pb.suspend(|| -> anyhow::Result<()> {
                outln!("{line}");
                Ok(())
            })?;
        } else if !args.json {
            pb.suspend(|| -> anyhow::Result<()> {
                let num = |x: f64| qcshape::numfmt::significant(x, 3);
                outln!(
                    "{:<20} poses {:>3}  max geodesic {}  norm change {}  residuals {}/{}  {}  {:.2}s",
                    d.name,
                    out.poses.len(),
                    qcshape::numfmt::readable(summary["max_geodesic_length"].as_f64().unwrap_or(0.0)),
                    num(ratio),
                    num(summary["max_inner_residual"].as_f64().unwrap_or(0.0)),
                    num(summary["max_norm_residual"].as_f64().unwrap_or(0.0)),
                    if summary["geodesics_converged"] == true {
                        "converged"
                    } else {
                        "NOT converged"
                    },
                    out.seconds
                );
                Ok(())
            })?;
        }
        summaries.push(summary);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let manifest = args.out.join(dataset::MANIFEST_NAME);
    dataset::write_manifest(&manifest, &rows)?;
    if args.json {
        let v = serde_json::json!({
            "metric": spec.label(),
            "transport": args.transport,
            "steps": args.solver.steps,
            "base": args.to,
            "manifest": manifest,
            "deformations": summaries,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        outln!("wrote {} pose(s) and {}", rows.len(), manifest.display());
    }
    Ok(())
}
