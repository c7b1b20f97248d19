//! `qcshape info FILE [--json]`: what a mesh file holds and whether qcshape can use it.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::io::{self, Format, IoError, DEGENERATE_REL_TOL};
use qcshape::mesh::{geometry, Shape, Topology};
use serde::Serialize;

/// Faces with area at most this times the squared mean edge length are reported as
/// near-degenerate (a warning; at most [`DEGENERATE_REL_TOL`] they are an error).
const NEAR_DEGENERATE_REL: f64 = 1e-6;
/// Corner angles below this (degrees) are reported as slivers.
const SMALL_ANGLE_DEG: f64 = 1.0;

/// Arguments of `qcshape info`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Summarize a mesh: counts, boundary, components, genus, size and quality warnings",
    long_about = "Summarize a mesh file: vertex, face and edge counts, boundary loops (count and \
lengths), connected components, Euler characteristic and genus, bounding box, mean edge length, \
total area and smallest angle, with quality warnings (near-zero-area faces, isolated vertices, \
sliver triangles, fan-triangulated polygons and other reader remarks).\n\n\
The file is checked exactly as every other command loads it: it must parse, its faces must form \
a consistently oriented manifold, and no face may have zero area. If a face has zero area the \
report is still printed, and the command then fails. Exit status: 0 if the mesh is usable, 1 if \
not (with the reason on stderr), 2 for bad arguments.",
    after_help = "Examples:\n  qcshape info horse-01.ply\n  qcshape info --json scan.obj | jq .genus"
)]
pub struct Args {
    /// Mesh file: .obj, .ply (ASCII or binary), .off, .stl (ASCII or binary) or .vtk (legacy
    /// POLYDATA); the format is taken from the extension.
    pub file: PathBuf,
    /// Print the report as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Report non-manifold ("bowtie") vertices, where the surface touches itself at a single
    /// vertex, as a warning instead of refusing the mesh (the other commands refuse them).
    #[arg(long)]
    pub allow_nonmanifold_vertices: bool,
}

/// The bounding box, in the file's length unit.
#[derive(Debug, Serialize)]
struct BoundingBox {
    min: [f64; 3],
    max: [f64; 3],
    size: [f64; 3],
}

/// Everything `info` reports (the JSON schema of `--json`).
#[derive(Debug, Serialize)]
struct Report {
    file: String,
    format: String,
    vertices: usize,
    faces: usize,
    edges: usize,
    isolated_vertices: usize,
    components: usize,
    boundary_loops: usize,
    boundary_loop_lengths: Vec<usize>,
    euler_characteristic: i64,
    /// `None` when the mesh has several components.
    genus: Option<i64>,
    bounding_box: BoundingBox,
    mean_edge_length: f64,
    total_area: f64,
    min_angle_degrees: f64,
    /// Faces with area at most 1e-12 lbar^2: they make the mesh unusable.
    degenerate_faces: usize,
    /// Faces with area at most 1e-6 lbar^2.
    near_degenerate_faces: usize,
    warnings: Vec<String>,
}

/// Runs `qcshape info`.
pub fn run(args: &Args) -> Result<()> {
    let path = &args.file;
    let data = io::read_mesh(path)?;
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
    let (report, first_degenerate) = analyse(path, format, &shape, warnings);

    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &report).context("cannot write the JSON report")?;
        writeln!(out)?;
    } else {
        print_text(&mut out, &report)?;
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

fn analyse(
    path: &std::path::Path,
    format: String,
    shape: &Shape,
    reader_warnings: Vec<String>,
) -> (Report, Option<(usize, f64)>) {
    let topo = &shape.topology;
    let pos = &shape.positions;
    let lbar = geometry::mean_edge_length(topo, pos);
    let areas = geometry::face_areas(topo, pos);
    let mut warnings = reader_warnings;

    let degenerate: Vec<usize> = (0..areas.len())
        .filter(|&f| areas[f].is_nan() || areas[f] <= DEGENERATE_REL_TOL * lbar * lbar)
        .collect();
    let near: Vec<usize> = (0..areas.len())
        .filter(|&f| areas[f].is_nan() || areas[f] <= NEAR_DEGENERATE_REL * lbar * lbar)
        .collect();
    if let Some(&f) = degenerate.first() {
        warnings.push(format!(
            "{} face(s) have zero area; first: face {f} (area {:e})",
            degenerate.len(),
            areas[f]
        ));
    }
    if near.len() > degenerate.len() {
        let f = near
            .iter()
            .copied()
            .find(|f| !degenerate.contains(f))
            .unwrap_or(near[0]);
        warnings.push(format!(
            "{} face(s) have near-zero area (at most {NEAR_DEGENERATE_REL:e} x mean edge length^2); \
             first: face {f} (area {:e})",
            near.len() - degenerate.len(),
            areas[f]
        ));
    }
    let isolated = topo.isolated_vertices();
    if let Some(&v) = isolated.first() {
        warnings.push(format!(
            "{} isolated vertex(es) belong to no face; first: vertex {v}",
            isolated.len()
        ));
    }
    let angles = geometry::corner_angles(topo, pos);
    let mut min_angle = f64::INFINITY;
    let mut min_face = 0;
    let mut n_small = 0;
    for (f, a) in angles.iter().enumerate() {
        let m = a[0].min(a[1]).min(a[2]).to_degrees();
        if m < SMALL_ANGLE_DEG {
            n_small += 1;
        }
        if m < min_angle {
            min_angle = m;
            min_face = f;
        }
    }
    if n_small > 0 {
        warnings.push(format!(
            "{n_small} face(s) have an angle below {SMALL_ANGLE_DEG} degree; the smallest is \
             {min_angle:.3e} degrees at face {min_face}"
        ));
    }
    let components = topo.n_components();
    if components > 1 {
        warnings.push(format!(
            "the mesh has {components} connected components (genus is reported per surface only for one)"
        ));
    }
    let (min, max) = geometry::bounding_box(pos);
    let report = Report {
        file: path.display().to_string(),
        format,
        vertices: topo.n_vertices(),
        faces: topo.n_faces(),
        edges: topo.n_edges(),
        isolated_vertices: isolated.len(),
        components,
        boundary_loops: topo.boundary_loops().len(),
        boundary_loop_lengths: topo.boundary_loops().iter().map(Vec::len).collect(),
        euler_characteristic: topo.euler_characteristic(),
        genus: topo.genus(),
        bounding_box: BoundingBox {
            min,
            max,
            size: [0, 1, 2].map(|c| max[c] - min[c]),
        },
        mean_edge_length: lbar,
        total_area: areas.iter().sum(),
        min_angle_degrees: min_angle,
        degenerate_faces: degenerate.len(),
        near_degenerate_faces: near.len(),
        warnings,
    };
    (report, degenerate.first().map(|&f| (f, areas[f])))
}

/// A number with 6 significant digits, without trailing zeros.
fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if !(1e-4..1e7).contains(&a) {
        return format!("{x:.5e}");
    }
    let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn vec3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

fn print_text(out: &mut dyn Write, r: &Report) -> std::io::Result<()> {
    let row = |out: &mut dyn Write, k: &str, v: String| writeln!(out, "{k:<22}{v}");
    row(out, "file", format!("{} ({})", r.file, r.format))?;
    row(out, "vertices", r.vertices.to_string())?;
    row(out, "faces", r.faces.to_string())?;
    row(out, "edges", r.edges.to_string())?;
    row(out, "components", r.components.to_string())?;
    let loops = if r.boundary_loops == 0 {
        "0 (closed)".to_string()
    } else {
        let lens: Vec<String> = r.boundary_loop_lengths.iter().map(|l| l.to_string()).collect();
        format!("{} (lengths {})", r.boundary_loops, lens.join(", "))
    };
    row(out, "boundary loops", loops)?;
    row(out, "euler characteristic", r.euler_characteristic.to_string())?;
    row(
        out,
        "genus",
        r.genus
            .map_or_else(|| "n/a (several components)".into(), |g| g.to_string()),
    )?;
    let b = &r.bounding_box;
    row(out, "bounding box min", vec3(b.min))?;
    row(out, "bounding box max", vec3(b.max))?;
    row(out, "bounding box size", vec3(b.size))?;
    row(out, "mean edge length", num(r.mean_edge_length))?;
    row(out, "total area", num(r.total_area))?;
    row(out, "min angle", format!("{} deg", num(r.min_angle_degrees)))?;
    if r.warnings.is_empty() {
        row(out, "warnings", "none".into())?;
    } else {
        row(out, "warnings", r.warnings.len().to_string())?;
        for w in &r.warnings {
            writeln!(out, "  - {w}")?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::num;

    #[test]
    fn number_formatting() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(2.0), "2");
        assert_eq!(num(0.1), "0.1");
        assert_eq!(num(12.5663706), "12.5664");
        assert_eq!(num(-1.0 / 3.0), "-0.333333");
        assert_eq!(num(1e-7), "1.00000e-7");
        assert_eq!(num(123456.7), "123457");
    }
}
