//! `qcshape synth --out DIR`: the synthetic benchmark of the paper (section 3, Fig. 3) as mesh
//! files and a manifest.

use std::path::{Path, PathBuf};

use anyhow::Result;
use qcshape::dataset::Deformation;
use qcshape::io::Format;
use qcshape::synth::{genus0_benchmark, genus1_benchmark, write_benchmark, SynthOptions};

use crate::mesh_format::MeshFormat;

/// Arguments of `qcshape synth`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Write the synthetic benchmark: 6 initial shapes x 8 deformations, with a manifest",
    long_about = "Write the synthetic benchmark of the paper (section 3, Fig. 3): six genus-0 \
initial shapes (sphere, ellipsoid, oblate-ellipsoid, rounded-box, pear, peanut), all made from one \
icosphere so they share one connectivity, each deformed by eight analytic deformations (twist, \
bend, taper, stretch, bulge, shear, dent, ripple) that are neither rigid, isometric nor \
conformal: 48 deformations labelled by deformation type.\n\n\
Pose k of P is the deformation at time k / (P - 1) (pose 0 is the initial shape). Each \
deformation instance's amplitude is scaled by 1 + jitter * u, u uniform in [-1, 1] drawn from \
the seed; the same options always write the same bytes.\n\n\
Layout: DIR/<shape>-<deformation>/pose<k>.<ext> and DIR/manifest.csv \
(deformation,label,pose,path), which every command that takes a data set reads. With --genus 1 \
or all, the same eight deformations on three tori (round, thin, elliptic) go to DIR/genus1/.",
    after_help = "Examples:\n  qcshape synth --out bench\n  qcshape synth --out bench --level 2 --poses 5 --genus all --format obj"
)]
pub struct Args {
    /// Output folder (created if missing; existing files of the same names are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Template resolution: icosphere level (10 * 4^L + 2 vertices: 1: 42, 2: 162, 3: 642,
    /// 4: 2,562); the torus has 6 * 2^L x 3 * 2^L vertices.
    /// At most 8.
    #[arg(long, default_value_t = 3, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    pub level: u32,
    /// Seed of the amplitude jitter.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Poses per deformation (at least 2).
    /// At most 10,000.
    #[arg(long, default_value_t = 3, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_POSES as u64), allow_negative_numbers = true)]
    pub poses: usize,
    /// Relative amplitude variation per deformation instance, 0 to 0.5 (0: exact nominal motions).
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub jitter: f64,
    /// Which set: 0 (the 48 genus-0 deformations), 1 (24 on tori, in DIR/genus1), or all.
    #[arg(long, default_value = "0", value_parser = ["0", "1", "all"])]
    pub genus: String,
    /// Mesh file format.
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    pub format: MeshFormat,
}

/// Writes one set and prints its one-line summary.
fn write_set(dir: &Path, defs: &[Deformation], format: Format, genus: u32) -> Result<()> {
    let manifest = write_benchmark(dir, defs, format)?;
    let labels: std::collections::BTreeSet<_> = defs.iter().filter_map(|d| d.label.as_deref()).collect();
    outln!(
        "wrote {} genus-{genus} deformations ({} classes) x {} poses, {} vertices each, to {}; manifest {}",
        defs.len(),
        labels.len(),
        defs.first().map_or(0, |d| d.n_poses()),
        defs.first().map_or(0, |d| d.topology.n_vertices()),
        dir.display(),
        manifest.display()
    );
    Ok(())
}

/// Runs `qcshape synth`.
pub fn run(args: &Args) -> Result<()> {
    let opts = SynthOptions {
        level: args.level,
        seed: args.seed,
        poses: args.poses,
        jitter: args.jitter,
    };
    opts.validate()?;
    let format = args.format.format();
    if args.genus != "1" {
        write_set(&args.out, &genus0_benchmark(&opts)?, format, 0)?;
    }
    if args.genus != "0" {
        write_set(&args.out.join("genus1"), &genus1_benchmark(&opts)?, format, 1)?;
    }
    Ok(())
}
