//! `qs.fit`: one template mesh fitted to a target of any triangulation or a point cloud
//! ([`qcshape::fit`], issue 49).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use qcshape::align::Alignment;
use qcshape::fit::{FitOptions, Target};
use qcshape::mesh::Shape;

use crate::convert::{count, faces, points, points_out, AnyInt};

/// fit(template_vertices, template_faces, target_vertices, target_faces=None, *,
/// alignment="similarity", prior="smooth", stages=6, max_samples=1000, global_degree=0) -> (V, residual, quality)
///
/// Fits the template (vertices (nV, 3), faces (nF, 3); a trimesh / pyvista / meshio mesh may
/// stand for either) to the target surface (vertices (nP, 3) and faces (nT, 3) of any
/// triangulation; a mesh object's own faces when target_faces is None and target_vertices is
/// a mesh; a plain (nP, 3) array alone is a point cloud). Returns the fitted positions V
/// (nV, 3) on the template's connectivity in the target's frame and units, the distance of
/// each fitted vertex to the target (nV,), and the quality as a dict: mean, p95, hausdorff and
/// median_vertex (symmetric surface distance in template mean edge lengths), min_angle
/// (degrees), flipped (triangles), strain_rms, strain_max, edge_length (target units), scale
/// (of the initial alignment), iterations and poor (bool). alignment: "similarity", "rigid" or
/// "none"; prior: "smooth" (local affine maps near similarities varying smoothly; the
/// default), "affine" (one affine map per vertex, stiffness annealed from one map for the
/// whole template to edge-scale detail), "arap" (as-rigid-as-possible) or "asap" (local scaling free); stages: stiffness
/// stages; max_samples: target points pulling the template surface at most (at least twice
/// the template's vertex count are used); global_degree: degree (0 to 5; 0 = none) of a
/// polynomial warp of space fitted first, for global motions of closed surfaces (taper, bend,
/// stretch; it spreads a local dent or bulge over the shape and made the tracked LV phantom
/// cohort worse). ValueError for bad input (empty target, NaN, a
/// non-manifold template, no overlap). A poor fit (quality["poor"]) issues a QcshapeWarning
/// naming what makes it poor, as ``qcshape fit`` does.
#[pyfunction]
#[pyo3(signature = (template_vertices, template_faces, target_vertices, target_faces=None, *, alignment="similarity", prior="smooth", stages=AnyInt::new(6), max_samples=AnyInt::new(1000), global_degree=AnyInt::new(0)))]
#[allow(clippy::too_many_arguments)]
pub fn fit<'py>(
    py: Python<'py>,
    template_vertices: &Bound<'py, PyAny>,
    template_faces: &Bound<'py, PyAny>,
    target_vertices: &Bound<'py, PyAny>,
    target_faces: Option<&Bound<'py, PyAny>>,
    alignment: &str,
    prior: &str,
    stages: AnyInt,
    max_samples: AnyInt,
    global_degree: AnyInt,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let alignment: Alignment = alignment
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("alignment: {e}")))?;
    let prior: qcshape::fit::Prior = prior
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("prior: {e}")))?;
    let opts = FitOptions {
        alignment,
        prior,
        stages: count("stages", stages, 1, qcshape::limits::MAX_SWEEPS)?,
        max_samples: count("max_samples", max_samples, 1, qcshape::limits::MAX_VERTICES)?,
        global_degree: count("global_degree", global_degree, 0, qcshape::fit::MAX_GLOBAL_DEGREE)?,
        ..FitOptions::default()
    };
    let tv = points(template_vertices, "template_vertices", None)?;
    let tf = faces(template_faces, "template_faces")?;
    let topo = crate::meshes::topology(tv.len(), tf, "template_faces")?;
    let template =
        Shape::new(topo, tv).map_err(|e| PyValueError::new_err(format!("template_vertices: {e}")))?;
    let pv = points(target_vertices, "target_vertices", None)?;
    let pf: Vec<[u32; 3]> = match target_faces {
        Some(f) => faces(f, "target_faces")?,
        None => match crate::meshes::faces_arg(target_vertices)? {
            (f, Some(_)) => faces(&f, "target_vertices")?,
            _ => Vec::new(),
        },
    };
    // The fit's loop has no stop hook yet: Ctrl-C is raised when it returns (not lost).
    let fitted = crate::run::detached(py, None, |_| {
        qcshape::fit::fit(
            &template,
            &Target {
                positions: &pv,
                faces: &pf,
            },
            &opts,
        )
        .map_err(|e| PyValueError::new_err(format!("fit: {e}")))
    })?;
    let q = &fitted.quality;
    if q.poor {
        // As `qcshape fit` and `Dataset.load(template=...)` warn.
        crate::warn::warn(
            py,
            &format!(
                "poor fit of the template to the target: {} (quality[\"poor\"] is True; docs/fit.md)",
                q.problems().join(", ")
            ),
        )?;
    }
    let d = PyDict::new(py);
    for (k, v) in [
        ("mean", q.mean),
        ("p95", q.p95),
        ("hausdorff", q.hausdorff),
        ("median_vertex", q.median_vertex),
        ("min_angle", q.min_angle),
        ("strain_rms", q.strain_rms),
        ("strain_max", q.strain_max),
        ("edge_length", q.edge_length),
        ("scale", fitted.motion.scale),
    ] {
        d.set_item(k, v)?;
    }
    d.set_item("flipped", q.flipped)?;
    d.set_item("template_min_angle", q.template_min_angle)?;
    d.set_item("new_slivers", q.new_slivers)?;
    d.set_item("slide", q.slide)?;
    d.set_item("iterations", fitted.iterations)?;
    d.set_item("poor", q.poor)?;
    let residual = numpy::PyArray1::from_vec(py, fitted.residual).into_any();
    Ok((points_out(py, &fitted.positions)?, residual, d))
}
