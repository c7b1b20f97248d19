//! Library errors as Python exceptions: bad input -> `ValueError`, file system -> `OSError`,
//! a cancelled run -> `KeyboardInterrupt`, a failed computation -> `RuntimeError`. The message
//! is the library's (file name, line, argument and problem).

use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use qcshape::dataset::DatasetError;
use qcshape::geodesic::{GeodesicError, InterpolationError};
use qcshape::io::IoError;
use qcshape::similarity::{PipelineError, SimilarityError};
use qcshape::space::SpaceError;
use qcshape::transport::TransportError;

/// A shape-space error as a Python exception.
pub fn space(e: SpaceError) -> PyErr {
    let msg = e.to_string();
    let value = match &e {
        SpaceError::Shape { .. }
        | SpaceError::Setting(_)
        | SpaceError::Empty { .. }
        | SpaceError::Shard
        | SpaceError::Matrix(_) => true,
        SpaceError::Geodesic(g) => geodesic_input(g),
        SpaceError::Transport(t) => transport_input(t),
        SpaceError::Interpolation(i) => {
            matches!(
                i,
                InterpolationError::Setting(_)
                    | InterpolationError::EmptySequence
                    | InterpolationError::Mesh(_)
                    | InterpolationError::Geodesic(GeodesicError::Normalization { .. })
            )
        }
        SpaceError::Pipeline(p) => match p {
            PipelineError::NoBase { .. }
            | PipelineError::PoseCount { .. }
            | PipelineError::TooFewPoses { .. }
            | PipelineError::Setting(_)
            | PipelineError::Mesh { .. } => true,
            PipelineError::Similarity(SimilarityError::Cancelled) => {
                return PyKeyboardInterrupt::new_err(msg)
            }
            PipelineError::Similarity(s) if similarity_input(s) => true,
            PipelineError::Matrix(_) => true,
            PipelineError::Similarity(SimilarityError::Journal { .. }) => return PyOSError::new_err(msg),
            PipelineError::Geodesic(g) => geodesic_input(g),
            _ => false,
        },
        SpaceError::Similarity(SimilarityError::Cancelled) => return PyKeyboardInterrupt::new_err(msg),
        SpaceError::Similarity(s) => similarity_input(s),
        _ => false,
    };
    if value {
        PyValueError::new_err(msg)
    } else {
        PyRuntimeError::new_err(msg)
    }
}

/// A similarity error caused by the arguments (names, pose counts, pairs, shards, a metric the
/// tangent approximation cannot use, a degenerate base).
fn similarity_input(e: &SimilarityError) -> bool {
    matches!(
        e,
        SimilarityError::NotAPair { .. }
            | SimilarityError::NameCount { .. }
            | SimilarityError::PoseCount { .. }
            | SimilarityError::ListedNotJournaled
            | SimilarityError::NoShards
            | SimilarityError::MissingShards { .. }
            | SimilarityError::NotTangent { .. }
            | SimilarityError::AuxJacobian { .. }
            | SimilarityError::AuxNotFinite
            | SimilarityError::AuxEigen
    )
}

fn geodesic_input(e: &GeodesicError) -> bool {
    // A calibration failure is a degenerate reference shape (zero size or area): bad input.
    matches!(
        e,
        GeodesicError::Setting(_)
            | GeodesicError::VertexBlockWeight(_)
            | GeodesicError::StartPath { .. }
            | GeodesicError::Interior { .. }
            | GeodesicError::Normalization { .. }
            | GeodesicError::Mesh(_)
            | GeodesicError::Calibration(_)
    )
}

fn transport_input(e: &TransportError) -> bool {
    matches!(
        e,
        TransportError::Setting(_)
            | TransportError::NotPositive { .. }
            | TransportError::SchildSteps { .. }
            | TransportError::Empty { .. }
            | TransportError::VertexCount { .. }
            | TransportError::VectorLength { .. }
            | TransportError::Normalization { .. }
            | TransportError::Mismatch { .. }
            | TransportError::Mesh(_)
    )
}

/// A mesh file error: unreadable / unwritable files -> `OSError`, bad contents -> `ValueError`.
pub fn io(e: IoError) -> PyErr {
    match e {
        IoError::Read { .. } | IoError::Write { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// A data set error (manifest, folders, mesh files).
pub fn dataset(e: DatasetError) -> PyErr {
    let msg = e.to_string();
    let os = match &e {
        DatasetError::Read { .. } => true,
        DatasetError::Io(i) => matches!(i, IoError::Read { .. } | IoError::Write { .. }),
        _ => false,
    };
    if os {
        PyOSError::new_err(msg)
    } else {
        PyValueError::new_err(msg)
    }
}
