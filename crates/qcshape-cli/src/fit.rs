//! `qcshape fit`: one template mesh fitted to targets of any triangulation (issue 49), written
//! as a data set with the template's connectivity that `similarity` and `run` read.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::dataset::{mesh_files, write_manifest, Dataset, DeformationFiles, ManifestRow, MANIFEST_NAME};
use qcshape::fit::data::{fit_dataset, write_quality};
use qcshape::fit::FitOptions;
use qcshape::io::{self, VertexAttributes};
use qcshape::limits::{MAX_POSES, MAX_SUBJECTS};

use crate::mesh_format::MeshFormat;

/// Arguments of `qcshape fit`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Fit one template mesh to meshes of any triangulation (or point clouds); write a data set",
    long_about = "Fit one template mesh to target meshes of any triangulation, so that data whose \
poses do not share one connectivity (segmentations, scans, meshes from other tools) can be \
compared: each target gets the template's connectivity at positions on its surface.\n\n\
Each fit: a similarity alignment (centroid, scale, principal axes with their sign choices, \
refined by ICP; --alignment), then a non-rigid fit under a deformation prior (--prior) whose \
stiffness is annealed from stiff to soft (point-to-surface and surface-to-point terms, outliers, \
boundaries and opposed normals rejected). Targets without faces are point clouds. docs/fit.md \
describes the method and its measured accuracy.\n\n\
TARGETS are mesh files (one deformation, poses in the given order), a folder of mesh files, or \
a manifest CSV (deformation,label,pose,path; a folder holding manifest.csv counts as one): every \
deformation's poses are fitted. With --sequence, each deformation's first pose is fitted from \
the template and each next pose from the previous fit (tracking); without, every pose from the \
template.\n\n\
Writes OUT/<deformation>/pose<k>.<ext> (the fitted template; PLY and VTK files carry the \
per-vertex distance to the target as `residual`), OUT/manifest.csv for `qcshape similarity` \
and `run`, and OUT/quality.csv: per pose the symmetric surface distance (mean, 95th \
percentile, Hausdorff, in template mean edge lengths), the smallest angle, flipped triangles, \
edge strain, and whether the fit is poor (a warning line on stderr names each poor fit).",
    after_help = "Examples:\n  qcshape fit --template base.ply --out fitted scans/\n  qcshape fit --template base.ply --out fitted --sequence frame*.stl\n  qcshape fit --template base.ply --out fitted cohort/manifest.csv --sequence"
)]
pub struct Args {
    /// The template mesh (a manifold triangle mesh; its connectivity is written).
    #[arg(long)]
    pub template: PathBuf,
    /// Target mesh files, a folder of them, or a manifest CSV.
    #[arg(required = true)]
    pub targets: Vec<PathBuf>,
    /// Output folder (created if missing; must not hold an input).
    #[arg(long)]
    pub out: PathBuf,
    /// Track each deformation: pose k + 1 is fitted from the fit of pose k.
    #[arg(long)]
    pub sequence: bool,
    /// Initial alignment: similarity (rotation, translation, scale), rigid, or none (the
    /// template is already placed on the targets).
    #[arg(long, default_value = FitOptions::default().alignment.label())]
    pub alignment: Alignment,
    /// Deformation prior: smooth (local affine maps near similarities that vary smoothly; the
    /// default), affine (one affine map per vertex, stiffness annealed from one map for the
    /// whole template to edge-scale detail, as Amberg et al.'s NICP: better on stretches and
    /// shears), arap (as-rigid-as-possible: every edge strain costs) or asap (local scaling is
    /// free).
    #[arg(long, default_value = FitOptions::default().prior.label())]
    pub prior: qcshape::fit::Prior,
    /// Deformation name when TARGETS are mesh files or a folder.
    #[arg(long, default_value = "fit")]
    pub name: String,
    /// Stiffness stages (annealed from stiff to soft). At most 1,000.
    #[arg(long, default_value_t = FitOptions::default().stages, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    pub stages: usize,
    /// Degree of a polynomial warp of space fitted before the non-rigid stages (0 = none, the
    /// default). Degree 2 follows global motions of closed surfaces (taper, bend, stretch)
    /// without sliding the template along the surface, but spreads a local motion (dent,
    /// bulge, ripple) over the whole shape, and it made the tracked LV phantom cohort worse
    /// (docs/fit.md "Global polynomial warp"). At most 5.
    #[arg(long, default_value_t = FitOptions::default().global_degree, value_parser = crate::bounds::count::<usize>(0, qcshape::fit::MAX_GLOBAL_DEGREE as u64), allow_negative_numbers = true)]
    pub global_degree: usize,
    /// Mesh file format of the fitted poses.
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    pub format: MeshFormat,
}

/// The deformations of TARGETS, and every input file (for the overlap check).
fn groups(args: &Args) -> Result<(Vec<DeformationFiles>, Vec<PathBuf>)> {
    let mut inputs = vec![args.template.clone()];
    let manifest = match args.targets.as_slice() {
        [one] if one.is_dir() && one.join(MANIFEST_NAME).is_file() => Some(one.join(MANIFEST_NAME)),
        [one] if one.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) => Some(one.clone()),
        _ => None,
    };
    let Some(manifest) = manifest else {
        let mut files = Vec::new();
        for t in &args.targets {
            if t.is_dir() {
                files.extend(mesh_files(t)?);
            } else {
                files.push(t.clone());
            }
            if files.len() > MAX_POSES {
                bail!("more than {MAX_POSES} target files");
            }
        }
        if files.is_empty() {
            bail!("no mesh files among the targets");
        }
        inputs.extend(files.iter().cloned());
        let g = DeformationFiles {
            name: args.name.clone(),
            label: None,
            files,
        };
        return Ok((vec![g], inputs));
    };
    inputs.push(manifest.clone());
    // The manifest's deformations in the order of their first line, poses checked 0..K-1.
    let out = Dataset::files(&manifest)?;
    if out.iter().map(|g| g.files.len()).sum::<usize>() > MAX_POSES.saturating_mul(MAX_SUBJECTS) {
        bail!("{}: too many rows", manifest.display());
    }
    inputs.extend(out.iter().flat_map(|g| g.files.iter().cloned()));
    Ok((out, inputs))
}

/// Runs `qcshape fit`.
pub fn run(args: &Args) -> Result<()> {
    let (groups, inputs) = groups(args)?;
    let input_refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::input::refuse_out_folder(&input_refs, &args.out, "--out")?;
    let template = io::load_shape(&args.template)?;
    let opts = FitOptions {
        alignment: args.alignment,
        prior: args.prior,
        stages: args.stages,
        global_degree: args.global_degree,
        ..FitOptions::default()
    };
    opts.check()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create", args.out.display()))?;
    let total: usize = groups.iter().map(|g| g.files.len()).sum();
    let pb = crate::progress::bar(total, "fitting");
    let mut manifest = Vec::new();
    let mut tally = crate::template::FitTally::default();
    let mut used = std::collections::BTreeSet::new();
    // The deformations (and untracked poses) in parallel, results in order.
    let (data, fits) = fit_dataset(&template, &groups, &opts, args.sequence, |_, _| pb.inc(1))?;
    for (g, fitted) in groups.iter().zip(&fits) {
        let mut folder = crate::input::folder_for(&g.name);
        while !used.insert(folder.clone()) {
            folder.push('_');
        }
        std::fs::create_dir_all(args.out.join(&folder))?;
        for (k, f) in fitted.iter().enumerate() {
            let rel = PathBuf::from(&folder).join(format!("pose{k:03}.{}", args.format.extension()));
            let attrs = VertexAttributes {
                scalar: args
                    .format
                    .has_fields()
                    .then_some(("residual", f.residual.as_slice())),
                colors: None,
            };
            io::write_mesh(
                &args.out.join(&rel),
                &f.positions,
                template.topology.faces(),
                &attrs,
            )?;
            manifest.push(ManifestRow {
                deformation: g.name.clone(),
                label: g.label.clone(),
                pose: k as i64,
                path: rel,
            });
            tally.record(&pb, g, k, f);
        }
    }
    pb.finish_and_clear();
    write_quality(&args.out.join("quality.csv"), &data, &fits)?;
    let manifest_path = args.out.join(MANIFEST_NAME);
    write_manifest(&manifest_path, &manifest)?;
    outln!(
        "fitted {} ({} vertices) to {total} pose{} of {} deformation{}{}; worst mean distance {:.3} edge lengths, {} poor; wrote {} and {}",
        args.template.display(),
        template.n_vertices(),
        if total == 1 { "" } else { "s" },
        groups.len(),
        if groups.len() == 1 { "" } else { "s" },
        if args.sequence { " (tracked)" } else { "" },
        tally.worst,
        tally.poor,
        manifest_path.display(),
        args.out.join("quality.csv").display()
    );
    Ok(())
}
