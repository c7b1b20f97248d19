//! Does the metric's geometry count? Two measurements with known answers (docs/geometry.md):
//!
//! - **bent tube**: a tube (length 10, radius 0.6) bent from straight to a half circle. The
//!   true middle pose, a quarter circle, keeps its centre line at length 10; the linear
//!   midpoint (every metric whose energy is mostly L2) shrinks it to `20 / pi = 6.37`. The
//!   geodesic's middle pose shows whether a metric keeps lengths.
//! - **resolution**: one smooth deformation (twist and stretch of the unit sphere) sampled on
//!   icospheres of 162 to 10,242 vertices. A metric whose meaning does not depend on the mesh
//!   gives distances that converge as the mesh is refined.
//!
//! Every row carries the energy's split into the geometric term and the L2 regularizer.

use std::f64::consts::PI;

use rayon::prelude::*;
use serde::Serialize;

use qcshape::geodesic::{geodesic_between, GeodesicError, GeodesicOptions};
use qcshape::mesh::geometry::{norm, sub};
use qcshape::mesh::Shape;
use qcshape::metric::MetricSpec;
use qcshape::synth::{bend_along_x, tube, twisted_sphere};

/// Rings and vertices per ring of the bent tube (1,440 vertices).
pub const TUBE_RINGS: usize = 60;
/// Vertices per ring of the bent tube.
pub const TUBE_AROUND: usize = 24;
/// Length of the tube's centre line.
pub const TUBE_LENGTH: f64 = 10.0;
/// Radius of the tube.
pub const TUBE_RADIUS: f64 = 0.6;

/// One geodesic of the study.
#[derive(Debug, Clone, Serialize)]
pub struct GeometryRow {
    /// `tube` or `sphere`.
    pub case: String,
    /// The metric ([`MetricSpec::label`]).
    pub metric: String,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// `dis(A, B)` in the metric's units.
    pub distance: f64,
    /// Centre-line length of the middle pose (tube; NaN for the sphere).
    pub centre_line: f64,
    /// Share of the energy carried by the L2 regularizer.
    pub regularizer_share: f64,
    /// Solver iterations.
    pub iterations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// Seconds of the solve.
    pub seconds: f64,
}

/// The straight tube and the tube bent to a half circle (1,440 vertices).
pub fn tube_pair() -> (Shape, Shape) {
    let a = tube(TUBE_LENGTH, TUBE_RADIUS, TUBE_AROUND, TUBE_RINGS);
    let b = Shape::new(a.topology.clone(), bend_along_x(&a.positions, PI)).expect("bent tube is valid");
    (a, b)
}

/// Length of the polyline through the ring centroids of a pose of [`tube_pair`]'s mesh.
pub fn centre_line_length(pose: &[[f64; 3]]) -> f64 {
    let centroid = |i: usize| {
        let ring = &pose[i * TUBE_AROUND..(i + 1) * TUBE_AROUND];
        [0, 1, 2].map(|c| ring.iter().map(|v| v[c]).sum::<f64>() / TUBE_AROUND as f64)
    };
    (1..TUBE_RINGS)
        .map(|i| norm(sub(centroid(i), centroid(i - 1))))
        .sum()
}

/// The bent-tube geodesic of every metric in `specs`, metrics in parallel.
pub fn tube_rows(specs: &[MetricSpec], options: &GeodesicOptions) -> Result<Vec<GeometryRow>, GeodesicError> {
    let (a, b) = tube_pair();
    specs
        .par_iter()
        .map(|spec| {
            let g = geodesic_between(spec, &a, &b, options)?;
            Ok(GeometryRow {
                case: "tube".into(),
                metric: spec.label(),
                vertices: a.n_vertices(),
                distance: g.length,
                centre_line: centre_line_length(&g.poses[g.poses.len() / 2]),
                regularizer_share: g.regularizer_share(),
                iterations: g.iterations,
                converged: g.converged,
                seconds: g.seconds,
            })
        })
        .collect()
}

/// The twisted-sphere distance of every metric in `specs` at every icosphere `levels`.
pub fn resolution_rows(
    specs: &[MetricSpec],
    levels: &[u32],
    options: &GeodesicOptions,
) -> Result<Vec<GeometryRow>, GeodesicError> {
    let jobs: Vec<(u32, &MetricSpec)> = levels
        .iter()
        .flat_map(|&l| specs.iter().map(move |s| (l, s)))
        .collect();
    jobs.par_iter()
        .map(|&(level, spec)| {
            let (a, b) = twisted_sphere(level);
            let g = geodesic_between(spec, &a, &b, options)?;
            Ok(GeometryRow {
                case: "sphere".into(),
                metric: spec.label(),
                vertices: a.n_vertices(),
                distance: g.length,
                centre_line: f64::NAN,
                regularizer_share: g.regularizer_share(),
                iterations: g.iterations,
                converged: g.converged,
                seconds: g.seconds,
            })
        })
        .collect()
}

/// The rows of [`tube_rows`] and [`resolution_rows`] with their tables.
#[derive(Debug, Clone, Serialize)]
pub struct GeometryReport {
    /// Every geodesic (tube rows first).
    pub rows: Vec<GeometryRow>,
}

impl GeometryReport {
    /// Every row as CSV (`case,metric,vertices,distance,centre_line,regularizer_share,
    /// iterations,converged,seconds`, full precision).
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "case,metric,vertices,distance,centre_line,regularizer_share,iterations,converged,seconds\n",
        );
        for r in &self.rows {
            out.push_str(&format!(
                "{},\"{}\",{},{:?},{:?},{:?},{},{},{:.3}\n",
                r.case,
                r.metric,
                r.vertices,
                r.distance,
                r.centre_line,
                r.regularizer_share,
                r.iterations,
                r.converged,
                r.seconds
            ));
        }
        out
    }

    /// Two Markdown tables: the bent tube per metric, the sphere's distances per metric and
    /// resolution with the change of the last refinement.
    pub fn markdown(&self) -> String {
        let num = |x: f64| qcshape::numfmt::significant(x, 4);
        let mut md = String::new();
        let tube: Vec<&GeometryRow> = self.rows.iter().filter(|r| r.case == "tube").collect();
        if !tube.is_empty() {
            md.push_str(&format!(
                "## Bent tube\n\nA tube of length {TUBE_LENGTH} and radius {TUBE_RADIUS} ({} vertices) bent from \
                 straight to a half circle. Centre-line length of the geodesic's middle pose: {TUBE_LENGTH} \
                 keeps the length (the true quarter circle), {} is the linear midpoint.\n\n\
                 | metric | centre line | distance | L2 regularizer's share of the energy | iterations | converged |\n\
                 |---|---:|---:|---:|---:|---|\n",
                tube[0].vertices,
                num(2.0 * TUBE_LENGTH / PI),
            ));
            for r in &tube {
                md.push_str(&format!(
                    "| {} | {} | {} | {:.1} % | {} | {} |\n",
                    r.metric,
                    num(r.centre_line),
                    num(r.distance),
                    100.0 * r.regularizer_share,
                    r.iterations,
                    if r.converged { "yes" } else { "no" }
                ));
            }
        }
        let sphere: Vec<&GeometryRow> = self.rows.iter().filter(|r| r.case == "sphere").collect();
        if !sphere.is_empty() {
            let mut sizes: Vec<usize> = sphere.iter().map(|r| r.vertices).collect();
            sizes.sort_unstable();
            sizes.dedup();
            let mut metrics: Vec<&str> = Vec::new();
            for r in &sphere {
                if !metrics.contains(&r.metric.as_str()) {
                    metrics.push(&r.metric);
                }
            }
            md.push_str(
                "\n## Resolution\n\nThe unit sphere twisted by 1.2 z radians about z and stretched by 1.5 along z, \
                 the same smooth deformation at every resolution: `dis(A, B)` per number of vertices, the \
                 relative change of the last refinement, and the regularizer's share at the finest mesh.\n\n",
            );
            md.push_str("| metric |");
            for n in &sizes {
                md.push_str(&format!(" {n} |"));
            }
            md.push_str(" last change | regularizer share |\n|---|");
            md.push_str(&"---:|".repeat(sizes.len() + 2));
            md.push('\n');
            for m in metrics {
                let row: Vec<Option<&&GeometryRow>> = sizes
                    .iter()
                    .map(|n| sphere.iter().find(|r| r.metric == m && r.vertices == *n))
                    .collect();
                md.push_str(&format!("| {m} |"));
                for r in &row {
                    md.push_str(&match r {
                        Some(r) => format!(" {} |", num(r.distance)),
                        None => " - |".into(),
                    });
                }
                let have: Vec<&&GeometryRow> = row.iter().flatten().copied().collect();
                let change = match have.as_slice() {
                    [.., a, b] => format!("{:+.2} %", 100.0 * (b.distance - a.distance) / a.distance),
                    _ => "-".into(),
                };
                let share = have
                    .last()
                    .map_or("-".into(), |r| format!("{:.1} %", 100.0 * r.regularizer_share));
                md.push_str(&format!(" {change} | {share} |\n"));
            }
        }
        md
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_linear_midpoint_of_the_tube_is_a_chord_of_length_20_over_pi() {
        let (a, b) = tube_pair();
        assert!((centre_line_length(&a.positions) - TUBE_LENGTH).abs() < 1e-12);
        let mid: Vec<[f64; 3]> = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(p, q)| [0, 1, 2].map(|c| 0.5 * (p[c] + q[c])))
            .collect();
        // The ring centroids of the linear midpoint lie on a half circle of radius 10 / (2 pi)...
        // scaled by 1/2 towards the straight line: their polyline is within 1 % of 20 / pi.
        let l = centre_line_length(&mid);
        assert!((l - 20.0 / PI).abs() < 0.01 * l + 0.05, "{l}");
    }

    #[test]
    fn the_report_tables_every_row() {
        let specs = [MetricSpec::new(qcshape::metric::MetricKind::L2)];
        let o = GeodesicOptions {
            steps: 2,
            ..Default::default()
        };
        let mut rows = resolution_rows(&specs, &[0, 1], &o).unwrap();
        rows.extend(tube_rows(&specs, &o).unwrap());
        let r = GeometryReport { rows };
        let md = r.markdown();
        assert!(md.contains("| 12 | 42 |") && md.contains("## Bent tube"), "{md}");
        assert_eq!(r.csv().lines().count(), 4);
    }
}
