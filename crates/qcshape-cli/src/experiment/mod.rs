//! `qcshape experiment`: the paper's experiments (section 3), one subcommand each.

use anyhow::Result;
use clap::Subcommand;

mod approx;
mod geometry;
mod interpolation;
mod noise;
mod robustness;
mod transfer;

/// Run one of the paper's experiments and write its tables and figures.
#[derive(Debug, clap::Args)]
#[command(about = "Run one of the paper's experiments (tables and figures)", long_about)]
pub struct Args {
    #[command(subcommand)]
    command: Experiment,
}

#[derive(Debug, Subcommand)]
enum Experiment {
    Interpolation(interpolation::Args),
    Transfer(transfer::Args),
    Noise(noise::Args),
    Robustness(robustness::Args),
    Approx(approx::Args),
    Geometry(geometry::Args),
}

/// Runs the chosen experiment.
pub fn run(args: &Args) -> Result<()> {
    match &args.command {
        Experiment::Interpolation(a) => interpolation::run(a),
        Experiment::Transfer(a) => transfer::run(a),
        Experiment::Noise(a) => noise::run(a),
        Experiment::Robustness(a) => robustness::run_command(a),
        Experiment::Approx(a) => approx::run(a),
        Experiment::Geometry(a) => geometry::run(a),
    }
}
