//! What a mesh holds and how usable it is (`qcshape info`): counts, boundary loops, components,
//! Euler characteristic and genus, bounding box, mean edge length, total area, smallest angle,
//! and quality warnings (near-zero-area faces, isolated vertices, slivers, components).

use std::io::Write;
use std::path::Path;

use serde::Serialize;

use crate::io::DEGENERATE_REL_TOL;
use crate::mesh::{geometry, Shape};

/// Faces with area at most this times the squared mean edge length are reported as
/// near-degenerate (a warning; at most [`DEGENERATE_REL_TOL`] they are an error).
pub const NEAR_DEGENERATE_REL: f64 = 1e-6;
/// Corner angles below this (degrees) are reported as slivers.
pub const SMALL_ANGLE_DEG: f64 = 1.0;

/// The bounding box, in the file's length unit.
#[derive(Debug, Serialize)]
pub struct BoundingBox {
    /// Smallest coordinates.
    pub min: [f64; 3],
    /// Largest coordinates.
    pub max: [f64; 3],
    /// `max - min`.
    pub size: [f64; 3],
}

/// One named per-vertex array of the file (see [`crate::io::PointArray`]).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PointDataSummary {
    /// The array name as written in the file.
    pub name: String,
    /// Components per vertex (1 for scalars, 3 for vectors).
    pub components: usize,
    /// Smallest finite value over all vertices and components (`None` if there is none).
    pub min: Option<f64>,
    /// Largest finite value over all vertices and components (`None` if there is none).
    pub max: Option<f64>,
}

impl PointDataSummary {
    /// The summary of one array read from a file.
    pub fn of(a: &crate::io::PointArray) -> Self {
        let finite = a.values.iter().copied().filter(|v| v.is_finite());
        PointDataSummary {
            name: a.name.clone(),
            components: a.components,
            min: finite.clone().reduce(f64::min),
            max: finite.reduce(f64::max),
        }
    }
}

/// Everything `info` reports (the JSON schema of `qcshape info --json`).
#[derive(Debug, Serialize)]
pub struct MeshReport {
    /// The file as given.
    pub file: String,
    /// Its format (from the extension).
    pub format: String,
    /// Vertex count (#V).
    pub vertices: usize,
    /// Face count (#F).
    pub faces: usize,
    /// Edge count.
    pub edges: usize,
    /// Vertices in no face.
    pub isolated_vertices: usize,
    /// Connected components.
    pub components: usize,
    /// Boundary loops (0: closed).
    pub boundary_loops: usize,
    /// Vertices of each boundary loop.
    pub boundary_loop_lengths: Vec<usize>,
    /// V - E + F.
    pub euler_characteristic: i64,
    /// `None` when the mesh has several components.
    pub genus: Option<i64>,
    /// The bounding box (input units).
    pub bounding_box: BoundingBox,
    /// Mean edge length `lbar` (input units).
    pub mean_edge_length: f64,
    /// Total area (input units squared).
    pub total_area: f64,
    /// Smallest corner angle (degrees).
    pub min_angle_degrees: f64,
    /// Faces with area at most 1e-12 lbar^2: they make the mesh unusable.
    pub degenerate_faces: usize,
    /// Faces with area at most 1e-6 lbar^2.
    pub near_degenerate_faces: usize,
    /// Quality warnings, reader remarks first.
    pub warnings: Vec<String>,
    /// The file's named per-vertex arrays, in file order (empty if none; filled by the
    /// caller, since a [`Shape`] holds no fields).
    pub point_data: Vec<PointDataSummary>,
}

/// The report of `shape` read from `path` (`format` its name, `reader_warnings` the reader's
/// remarks), and the first zero-area face with its area, if any (such a mesh is unusable).
pub fn inspect(
    path: &Path,
    format: String,
    shape: &Shape,
    reader_warnings: Vec<String>,
) -> (MeshReport, Option<(usize, f64)>) {
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
             {} degrees at face {min_face}",
            crate::numfmt::significant(min_angle, 4)
        ));
    }
    let components = topo.n_components();
    if components > 1 {
        warnings.push(format!(
            "the mesh has {components} connected components (genus is reported per surface only for one)"
        ));
    }
    let (min, max) = geometry::bounding_box(pos);
    let report = MeshReport {
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
        point_data: Vec::new(),
    };
    (report, degenerate.first().map(|&f| (f, areas[f])))
}

/// A number with 6 significant digits, without trailing zeros, in the one plain format of
/// [`crate::numfmt`] (fixed-point in `[1e-4, 1e6)`, `1.2345e-5` otherwise, `0` for either zero).
pub fn num(x: f64) -> String {
    let s = crate::numfmt::significant(x, 6);
    let (mantissa, exponent) = match s.split_once('e') {
        Some((m, e)) => (m, Some(e)),
        None => (s.as_str(), None),
    };
    let m = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        mantissa
    };
    match exponent {
        Some(e) => format!("{m}e{e}"),
        None => m.to_string(),
    }
}

fn vec3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// Writes the report as aligned `key value` lines (the text output of `qcshape info`).
pub fn write_text(out: &mut dyn Write, r: &MeshReport) -> std::io::Result<()> {
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
    if !r.point_data.is_empty() {
        row(out, "point data", r.point_data.len().to_string())?;
        for a in &r.point_data {
            let range = match (a.min, a.max) {
                (Some(lo), Some(hi)) => format!("{} .. {}", num(lo), num(hi)),
                _ => "no finite values".into(),
            };
            let kind = match a.components {
                1 => "scalar".to_string(),
                k => format!("{k} components"),
            };
            writeln!(out, "  - {} ({kind}): {range}", a.name)?;
        }
    }
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
        assert_eq!(num(1e-7), "1e-7");
        assert_eq!(num(-2.5e-7), "-2.5e-7");
        assert_eq!(num(123456.7), "123457");
        assert_eq!(num(1.5e7), "1.5e7");
        assert_eq!(num(-0.0), "0");
    }
}
