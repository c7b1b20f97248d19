//! The `qcshape` command-line tool.
//!
//! This file only parses arguments and dispatches: each subcommand lives in its own module
//! (`info.rs`, ...; nested subcommands in `experiment/` and `lv/`) with a clap `Args` struct and
//! a `run(&Args) -> anyhow::Result<()>`. The analysis itself is in the library (`qcshape::
//! experiment`, `qcshape::similarity`, ...); the modules here parse arguments, show progress,
//! name the output files and print. Helpers shared by several commands: `args.rs`, `input.rs`,
//! `pipeline.rs`, `progress.rs`, `template.rs` (`--template`: fitting the input meshes first).
//! Errors are printed to stderr as `error: ...` with exit status 1; clap's usage errors exit
//! with status 2.

use std::process::ExitCode;

/// `println!` that returns the write error (`?` into `anyhow`) instead of panicking, so that a
/// closed pipe (`qcshape ... | head`) ends the command quietly (see `main`).
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($t)*)?
    }};
}

/// `print!` that returns the write error instead of panicking (see [`outln!`]).
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($t)*)?
    }};
}

use clap::{Parser, Subcommand};

mod args;
mod bounds;
mod classify;
mod embed;
mod experiment;
mod fit;
mod geodesic;
mod info;
mod input;
mod interpolate;
mod localize;
mod lv;
mod matrix_out;
mod mesh_format;
mod pipeline;
mod progress;
mod reproduce;
mod run;
mod similarity;
mod synth;
mod template;
mod transfer;

/// Deformation similarity in quasi-conformal shape space.
///
/// Meshes are read from OBJ, PLY (ASCII or binary), OFF, STL (ASCII or binary), legacy VTK
/// (.vtk), VTK XML PolyData (.vtp) and VTK XML UnstructuredGrid (.vtu) files; polygons are
/// triangulated. Run `qcshape help <command>` for a command's options.
#[derive(Debug, Parser)]
#[command(name = "qcshape", version, propagate_version = true)]
struct Cli {
    /// No progress bars or progress lines on stderr (errors and results are still printed).
    /// Without it, progress is a bar on a terminal and a plain line at least every 10 s otherwise.
    #[arg(long, short = 'q', global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    // Help text comes from each `Args` struct's `#[command(about, long_about)]` (a doc comment
    // here would replace the long help).
    Info(info::Args),
    Geodesic(geodesic::Args),
    Reproduce(reproduce::Args),
    Run(run::Args),
    Similarity(similarity::Args),
    SimilarityMerge(similarity::MergeArgs),
    Synth(synth::Args),
    Transfer(transfer::Args),
    Interpolate(interpolate::Args),
    Classify(classify::Args),
    Embed(embed::Args),
    Experiment(experiment::Args),
    Fit(fit::Args),
    Lv(lv::Args),
    Localize(localize::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    progress::set_quiet(cli.quiet);
    let result = match &cli.command {
        Command::Info(args) => info::run(args),
        Command::Geodesic(args) => geodesic::run(args),
        Command::Reproduce(args) => reproduce::run(args),
        Command::Run(args) => run::run(args),
        Command::Similarity(args) => similarity::run(args),
        Command::SimilarityMerge(args) => similarity::run_merge(args),
        Command::Synth(args) => synth::run(args),
        Command::Transfer(args) => transfer::run(args),
        Command::Interpolate(args) => interpolate::run(args),
        Command::Classify(args) => classify::run(args),
        Command::Embed(args) => embed::run(args),
        Command::Experiment(args) => experiment::run(args),
        Command::Fit(args) => fit::run(args),
        Command::Lv(args) => lv::run(args),
        Command::Localize(args) => localize::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`qcshape info x.ply | head -1`) is not an error worth reporting.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
