//! The default settings of the transport to the common base and the alignment, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

use super::Transport;
use crate::align::Alignment;

/// Transport of every deformation to the common base: Euclidean (`N_k = N_0 + M_k - M_0`,
/// command-line value `euclidean`). It gave the lower transfer error and the better
/// classification in the measurements (README); `parallel` is the paper's.
pub const TRANSPORT: Transport = Transport::Translate;

/// Placement of each deformation on the base before transfer: rigid (area-weighted Procrustes
/// of its first pose onto the base, the same motion for all its poses).
pub const ALIGN: Alignment = Alignment::Rigid;
