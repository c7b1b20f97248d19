//! The clustering methods by name, so that a command or a study can choose one
//! (`kmeans`, `kmedoids`, `spectral[:SCALE]`, `mds-kmeans[:DIMS]`, `intrinsic`).

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use super::{kernel_kmeans, kmedoids, mds_kmeans, spectral, ClusterError, ClusterOptions, Clustering};
use crate::similarity::DistanceMatrix;

/// A clustering method of a distance matrix (or, for `Intrinsic`, of the deformations behind
/// it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(into = "String")]
pub enum ClusterMethod {
    /// Kernel k-means on squared distances ([`kernel_kmeans()`], eq. 14 from the matrix alone).
    KernelKMeans,
    /// k-medoids by PAM ([`kmedoids()`]).
    KMedoids,
    /// Spectral clustering, Gaussian affinity of bandwidth `scale` x the median distance
    /// ([`spectral()`]).
    Spectral {
        /// Bandwidth in medians of the off-diagonal distances (1: the median heuristic).
        scale: f64,
    },
    /// k-means in the `dims` leading classical-MDS coordinates ([`mds_kmeans()`]).
    MdsKMeans {
        /// Coordinates kept (>= 1).
        dims: usize,
    },
    /// k-means with intrinsic (Karcher) means of the deformations, eq. 14
    /// ([`crate::cluster::intrinsic_kmeans`]), started from the kernel k-means partition;
    /// needs the deformations, not only the matrix.
    Intrinsic,
}

/// Why a method name cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "unknown clustering {0:?}: expected kmeans, kmedoids, spectral[:SCALE] (SCALE > 0), \
     mds-kmeans[:DIMS] (DIMS >= 1) or intrinsic"
)]
pub struct ParseMethodError(pub String);

impl FromStr for ClusterMethod {
    type Err = ParseMethodError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || ParseMethodError(s.to_string());
        let (name, arg) = match s.split_once(':') {
            Some((n, a)) => (n, Some(a)),
            None => (s, None),
        };
        Ok(match (name, arg) {
            ("kmeans", None) => ClusterMethod::KernelKMeans,
            ("kmedoids", None) => ClusterMethod::KMedoids,
            ("intrinsic", None) => ClusterMethod::Intrinsic,
            ("spectral", a) => {
                let scale = a.map_or(Ok(1.0), |a| a.parse::<f64>()).map_err(|_| bad())?;
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(bad());
                }
                ClusterMethod::Spectral { scale }
            }
            ("mds-kmeans", a) => {
                let dims = a.map_or(Ok(2), |a| a.parse::<usize>()).map_err(|_| bad())?;
                if dims == 0 {
                    return Err(bad());
                }
                ClusterMethod::MdsKMeans { dims }
            }
            _ => return Err(bad()),
        })
    }
}

impl fmt::Display for ClusterMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClusterMethod::KernelKMeans => write!(f, "kmeans"),
            ClusterMethod::KMedoids => write!(f, "kmedoids"),
            ClusterMethod::Spectral { scale } => write!(f, "spectral:{scale}"),
            ClusterMethod::MdsKMeans { dims } => write!(f, "mds-kmeans:{dims}"),
            ClusterMethod::Intrinsic => write!(f, "intrinsic"),
        }
    }
}

impl From<ClusterMethod> for String {
    fn from(m: ClusterMethod) -> String {
        m.to_string()
    }
}

impl ClusterMethod {
    /// A sentence naming the method, for reports.
    pub fn describe(&self) -> String {
        match self {
            ClusterMethod::KernelKMeans => "kernel k-means on squared similarities".into(),
            ClusterMethod::KMedoids => "k-medoids (PAM)".into(),
            ClusterMethod::Spectral { scale } => {
                format!("spectral clustering (Gaussian affinity, bandwidth {scale} x the median distance)")
            }
            ClusterMethod::MdsKMeans { dims } => {
                format!("k-means in the {dims} leading classical-MDS coordinates")
            }
            ClusterMethod::Intrinsic => {
                "k-means with intrinsic means (eq. 14), from the kernel k-means partition".into()
            }
        }
    }

    /// Clusters the items of a distance matrix (n x n). `Intrinsic` is not a matrix method:
    /// [`ClusterError::NeedsDeformations`].
    pub fn on_matrix(&self, d: &DistanceMatrix, opts: &ClusterOptions) -> Result<Clustering, ClusterError> {
        match *self {
            ClusterMethod::KernelKMeans => kernel_kmeans(d, opts),
            ClusterMethod::KMedoids => kmedoids(d, opts),
            ClusterMethod::Spectral { scale } => spectral(d, scale, opts),
            ClusterMethod::MdsKMeans { dims } => mds_kmeans(d, dims, opts),
            ClusterMethod::Intrinsic => Err(ClusterError::NeedsDeformations),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_ones_are_refused() {
        for s in ["kmeans", "kmedoids", "spectral:0.5", "mds-kmeans:3", "intrinsic"] {
            let m: ClusterMethod = s.parse().unwrap();
            assert_eq!(m.to_string(), s);
        }
        assert_eq!(
            "spectral".parse::<ClusterMethod>().unwrap(),
            ClusterMethod::Spectral { scale: 1.0 }
        );
        for s in ["kmean", "spectral:0", "spectral:x", "mds-kmeans:0", "kmeans:2"] {
            assert!(s.parse::<ClusterMethod>().is_err(), "{s}");
        }
    }
}
