//! Solvers kept for the benchmark (`benches/geodesic.rs`) and the `--solver` choices, not on
//! the default path: the paper's L-BFGS through argmin ([`Solver::Lbfgs`]), truncated
//! Gauss-Newton ([`Solver::GaussNewton`]) and truncated Newton ([`Solver::Newton`], which uses
//! the metrics' second-order kernels, `Metric::add_second_order`). The default solver is
//! [`Solver::Preconditioned`] (`path/plbfgs.rs` with `path/kronecker.rs` and
//! `path/vertex_blocks.rs`); small meshes may use [`Solver::LevenbergMarquardt`]
//! (`path/levenberg_marquardt.rs`). See `docs/design.md` for what remains to be separated.
//!
//! [`Solver::Lbfgs`]: crate::geodesic::Solver::Lbfgs
//! [`Solver::GaussNewton`]: crate::geodesic::Solver::GaussNewton
//! [`Solver::Newton`]: crate::geodesic::Solver::Newton
//! [`Solver::Preconditioned`]: crate::geodesic::Solver::Preconditioned
//! [`Solver::LevenbergMarquardt`]: crate::geodesic::Solver::LevenbergMarquardt

pub(super) mod lbfgs;
pub(super) mod truncated;
