//! Tests of the whole fit (closest points, alignment and the non-rigid solve together).
