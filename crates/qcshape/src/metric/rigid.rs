//! Placeholder module, replaced by the rigid metric.
