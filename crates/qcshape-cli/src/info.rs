//! `qcshape info FILE [--json]`: what a mesh file holds and whether qcshape can use it.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::io::inspect::{inspect, write_text, PointDataSummary};
use qcshape::io::{self, Format, IoError, DEGENERATE_REL_TOL};
use qcshape::mesh::{Shape, Topology};

/// Arguments of `qcshape info`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Summarize a mesh: counts, boundary, components, genus, size and quality warnings",
    long_about = "Summarize a mesh file: vertex, face and edge counts, boundary loops (count and \
lengths), connected components, Euler characteristic and genus, bounding box, mean edge length, \
total area and smallest angle, the file's named per-vertex arrays (point data: PLY extra vertex \
properties, VTK POINT_DATA, VTP/VTU PointData; name, components and range), with quality warnings (near-zero-area faces, isolated vertices, \
sliver triangles, fan-triangulated polygons and other reader remarks).\n\n\
The file is checked exactly as every other command loads it: it must parse, its faces must form \
a consistently oriented manifold, and no face may have zero area. If a face has zero area the \
report is still printed, and the command then fails. Exit status: 0 if the mesh is usable, 1 if \
not (with the reason on stderr), 2 for bad arguments.",
    after_help = "Examples:\n  qcshape info horse-01.ply\n  qcshape info --json scan.obj | jq .genus"
)]
pub struct Args {
    /// Mesh file: .obj, .ply (ASCII or binary), .off, .stl (ASCII or binary), .vtk (legacy
    /// POLYDATA or UNSTRUCTURED_GRID), .vtp (VTK XML PolyData) or .vtu (VTK XML
    /// UnstructuredGrid); the format is taken from the extension.
    pub file: PathBuf,
    /// Print the report as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Report non-manifold ("bowtie") vertices, where the surface touches itself at a single
    /// vertex, as a warning instead of refusing the mesh (the other commands refuse them).
    #[arg(long)]
    pub allow_nonmanifold_vertices: bool,
}

/// Runs `qcshape info`.
pub fn run(args: &Args) -> Result<()> {
    let path = &args.file;
    let data = io::read_mesh(path)?;
    let point_data: Vec<PointDataSummary> = data.point_data.iter().map(PointDataSummary::of).collect();
    let format = Format::from_path(path).map_or_else(|| "?".into(), |f| f.to_string());
    let mesh_err = |error| IoError::Mesh {
        path: path.clone(),
        error,
    };
    let topo = if args.allow_nonmanifold_vertices {
        Topology::allowing_nonmanifold_vertices(data.positions.len(), data.faces)
    } else {
        Topology::new(data.positions.len(), data.faces)
    }
    .map_err(mesh_err)
    .map_err(|e| {
        let hint = if e.to_string().contains("is non-manifold: its") {
            " (qcshape cannot compare such meshes; --allow-nonmanifold-vertices reports them instead)"
        } else {
            ""
        };
        anyhow::anyhow!("{e}{hint}")
    })?;
    let mut warnings = data.warnings;
    let bowties = topo.nonmanifold_vertices();
    if let Some(&(v, faces, fans)) = bowties.first() {
        warnings.push(format!(
            "{} non-manifold vertex(es) where the surface touches itself; first: vertex {v} ({faces} faces in {fans} fans)",
            bowties.len()
        ));
    }
    let shape = Shape::new(topo, data.positions).map_err(mesh_err)?;
    let (mut report, first_degenerate) = inspect(path, format, &shape, warnings);
    report.point_data = point_data;

    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &report).context("cannot write the JSON report")?;
        writeln!(out)?;
    } else {
        write_text(&mut out, &report)?;
    }
    out.flush()?;
    if let Some((face, area)) = first_degenerate {
        let f = shape.topology.faces()[face];
        bail!(
            "{}: {} face(s) have zero area (at most {DEGENERATE_REL_TOL:e} x mean edge length^2); \
             the first is face {face} {f:?} with area {area:e}. qcshape cannot use this mesh",
            path.display(),
            report.degenerate_faces
        );
    }
    Ok(())
}
