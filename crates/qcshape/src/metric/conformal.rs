//! Placeholder module, replaced by the conformal and quasi-conformal metrics.
