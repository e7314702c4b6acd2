//! The regressions: the Gaussian process (exact and sparse) with its kernel, input normalization
//! and prior mean, and its rivals from the paper: LS-SVR, the two-step bias/scale-factor model and
//! a polynomial; and the dense linear algebra they share ([`dense`]).

pub mod dense;
pub mod gp;
pub mod kernel;
pub mod lssvr;
pub mod normalize;
pub mod poly;
pub mod prior;
pub mod two_step;
