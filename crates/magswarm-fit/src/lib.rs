//! Fitting helpers that no kept crate offers, shared by identify, the paper's reproduction and
//! diagnose: [`lm`], the one Levenberg-Marquardt problem every least-squares fit runs
//! through, and [`optim`] (a box-constrained Nelder-Mead, finite-difference Jacobians).

pub mod lm;
pub mod optim;
