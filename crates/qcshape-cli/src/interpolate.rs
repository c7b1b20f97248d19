//! `qcshape interpolate`: temporal interpolation of deformations (paper section 2.2.1).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use qcshape::dataset::{Dataset, MANIFEST_NAME};
use qcshape::geodesic::{
    normalization_factor, GeodesicOptions, Interpolated, InterpolationOptions, Interpolator, Normalization,
    OffPath,
};
use qcshape::io;
use qcshape::mesh::Topology;
use qcshape_studies::contribution::pose_speeds;

use crate::args::{flag_error, in_pool, MetricArgs};
use crate::mesh_format::MeshFormat;
use crate::template::Source;

/// Insert poses between consecutive poses of each deformation, along discrete geodesics.
///
/// Between two key poses, the midpoint is optimized first, then new poses are inserted by
/// averaging neighbours and all are re-optimized until --insert poses are in; this runs on the
/// coarsest of --levels mesh resolutions and is refined level by level. Key poses are written
/// unchanged. All poses of the data set are scaled by one common factor while solving (1 / mean
/// edge length of the first pose); segment lengths are reported in those units.
///
/// Writes DIR/<deformation>/pose000.ply ..., DIR/manifest.csv (readable as a data set; its
/// extra column `key` marks the key poses) and DIR/segments.csv (deformation, segment, from,
/// to, length). PLY, VTK, VTP and VTU poses carry per-vertex speed fields of the segment leaving
/// the pose (entering it, for the last pose): `speed` (the vertex's share of the segment's
/// metric length, in the metric's units; docs/maps.md), `euclidean_speed` and the vector
/// `velocity` (displacement to the next pose, input units). PLY's `quality` is `speed`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Insert interpolated poses between the poses of deformations",
    long_about
)]
pub struct Args {
    /// A data set (manifest CSV or folder), or the mesh files of one deformation in order.
    #[arg(required = true)]
    input: Vec<PathBuf>,
    /// Number of poses inserted between two consecutive poses.
    /// At most 1,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_INSERT as u64), allow_negative_numbers = true)]
    insert: usize,
    #[arg(long, help = qcshape::settings::LEVELS.help(), default_value = qcshape::settings::LEVELS.default_text(), value_parser = crate::args::count(&qcshape::settings::LEVELS), allow_negative_numbers = true)]
    levels: usize,
    /// Share of vertices kept by each coarsening step.
    #[arg(long, default_value_t = qcshape::multires::DEFAULT_RATIO, allow_negative_numbers = true)]
    ratio: f64,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    template: crate::template::TemplateArgs,
    #[command(flatten)]
    solve: crate::args::SolveArgs,
    /// Iteration limit of each geodesic solve (default: 1,000, or 60 sqrt(#V) on meshes above
    /// 278 vertices).
    /// At most 1,000,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    max_iterations: Option<usize>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Mesh format of the written poses (OBJ and OFF carry no speed fields).
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    format: MeshFormat,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let spec = args.metric.spec()?;
    if args.levels == 0 {
        bail!("--levels must be at least 1");
    }
    let source = if let [one] = args.input.as_slice() {
        if one.is_dir() || !has_mesh_extension(one) {
            Source::Dataset(one)
        } else {
            bail!("{} is a single mesh: give two or more poses", one.display());
        }
    } else {
        Source::Sequence(&args.input)
    };
    let quality = args.out.join("quality.csv");
    let (data, _) = args.template.load(source, &[], &quality, Some(&args.out), &[])?;
    crate::input::refuse_out_folder(&crate::input::all_inputs(&args.input, &data), &args.out, "--out")?;
    let Some(first) = data.deformations.first() else {
        bail!("the input has no deformations");
    };
    // One scale and one calibrated metric for the whole data set.
    let factor = normalization_factor(Normalization::MeanEdgeOfFirst, &first.topology, &first.poses[0]);
    let metric = spec.build_scaled(&first.topology, &first.poses[0], factor)?;
    let geodesic = args.solve.apply(GeodesicOptions {
        max_iterations: args.max_iterations,
        ..Default::default()
    });
    geodesic.validate().map_err(flag_error)?;
    let options = InterpolationOptions {
        insert: args.insert,
        levels: args.levels,
        ratio: args.ratio,
        geodesic,
        normalization: Normalization::Factor(factor),
    };
    let n_pairs: usize = data
        .deformations
        .iter()
        .map(|d| d.n_poses().saturating_sub(1))
        .sum();
    eprintln!(
        "interpolating {} deformation(s), {n_pairs} pose pair(s), {} per pair, with {} ...",
        data.deformations.len(),
        args.insert,
        spec.label()
    );
    let bar = crate::progress::new_bar(n_pairs);
    if let Some(style) = crate::progress::style("{bar:40} {pos}/{len} pairs, {elapsed} (eta {eta}{solver})") {
        bar.set_style(style);
    }
    crate::progress::start(&bar);
    // One interpolator (hierarchy and solvers) per distinct topology.
    let mut interpolators: Vec<(Arc<Topology>, Interpolator)> = Vec::new();
    let mut results: Vec<Interpolated> = Vec::with_capacity(data.deformations.len());
    for d in &data.deformations {
        let k = match interpolators
            .iter()
            .position(|(t, _)| Arc::ptr_eq(t, &d.topology))
        {
            Some(k) => k,
            None => {
                let ip = Interpolator::new(metric.as_ref(), &d.topology, &d.poses[0], options.clone())
                    .with_context(|| format!("deformation {:?}", d.name))?;
                if let Some(why) = ip.hierarchy().stopped() {
                    if args.insert > 0 {
                        bar.suspend(|| {
                            eprintln!(
                                "note: {} level(s) {:?} for {:?}: {why}",
                                ip.hierarchy().n_levels(),
                                ip.hierarchy().vertex_counts(),
                                d.name
                            )
                        });
                    }
                }
                interpolators.push((d.topology.clone(), ip));
                interpolators.len() - 1
            }
        };
        let out = interpolators[k]
            .1
            .interpolate_sequence(&d.poses, &|| bar.inc(1))
            .with_context(|| format!("deformation {:?}", d.name))?;
        results.push(out);
    }
    bar.finish_and_clear();
    for (d, r) in data.deformations.iter().zip(&results) {
        if let Some((from, to, o)) = OffPath::in_sequence(&d.topology, &r.poses, &r.is_key) {
            let w = o.warning(spec.bends());
            eprintln!("warning: deformation {:?}, poses {from} to {to}: {w}", d.name);
        }
    }
    write_outputs(args, &data, &results, metric.as_ref(), factor)?;
    outln!("deformation,key_poses,poses,length,energy,converged_pairs,seconds");
    for (d, r) in data.deformations.iter().zip(&results) {
        outln!(
            "{},{},{},{:.9e},{:.9e},{}/{},{:.3}",
            d.name,
            d.n_poses(),
            r.poses.len(),
            r.segment_lengths.iter().sum::<f64>(),
            r.pairs.iter().map(|p| p.energy).sum::<f64>(),
            r.pairs.iter().filter(|p| p.converged).count(),
            r.pairs.len(),
            r.pairs.iter().map(|p| p.seconds).sum::<f64>()
        );
    }
    Ok(())
}

fn has_mesh_extension(p: &Path) -> bool {
    io::Format::from_path(p).is_some()
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with('#') || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn write_outputs(
    args: &Args,
    data: &Dataset,
    results: &[Interpolated],
    metric: &dyn qcshape::metric::Metric,
    factor: f64,
) -> Result<()> {
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut manifest = String::from("deformation,label,pose,path,key\n");
    let mut segments = String::from("deformation,segment,from,to,length\n");
    let mut used: HashMap<String, usize> = HashMap::new();
    for (d, r) in data.deformations.iter().zip(results) {
        let mut folder = crate::input::folder_for(&d.name);
        let count = used.entry(folder.clone()).or_insert(0);
        *count += 1;
        if *count > 1 {
            folder = format!("{folder}-{count}");
        }
        let dir = args.out.join(&folder);
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let sp = if args.format.has_fields() {
            pose_speeds(metric, &d.topology, &r.poses, factor)
                .with_context(|| format!("deformation {:?}", d.name))?
        } else {
            None
        };
        for (i, (pose, key)) in r.poses.iter().zip(&r.is_key).enumerate() {
            let file = format!("pose{i:03}.{}", args.format.extension());
            match &sp {
                Some(sp) => {
                    let fields = [
                        io::Field::scalar("speed", &sp.speed[i]),
                        io::Field::scalar("euclidean_speed", &sp.euclidean[i]),
                        io::Field::vector("velocity", &sp.velocity[i]),
                    ];
                    io::write_mesh_fields(&dir.join(&file), pose, d.topology.faces(), &fields)?;
                }
                None => io::write_mesh(&dir.join(&file), pose, d.topology.faces(), &Default::default())?,
            }
            manifest.push_str(&format!(
                "{},{},{i},{},{key}\n",
                csv_field(&d.name),
                csv_field(d.label.as_deref().unwrap_or("")),
                csv_field(&format!("{folder}/{file}"))
            ));
        }
        for (s, len) in r.segment_lengths.iter().enumerate() {
            segments.push_str(&format!("{},{s},{s},{},{len:.12e}\n", csv_field(&d.name), s + 1));
        }
    }
    io::write_atomically(&args.out.join(MANIFEST_NAME), |w| {
        w.write_all(manifest.as_bytes())
    })?;
    io::write_atomically(&args.out.join("segments.csv"), |w| {
        w.write_all(segments.as_bytes())
    })?;
    Ok(())
}
