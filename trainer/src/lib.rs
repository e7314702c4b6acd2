//! Host trainer for FOG temperature-drift compensation: loads rate-table data, fits the reference
//! paper's Gaussian-process map ω = f(T, V) and its rivals (LS-SVR, the traditional two-step
//! bias/scale-factor model), and evaluates them the way the paper does.

pub mod cause;
pub mod cli;
pub mod console;
pub mod data;
pub mod dataset;
pub mod diagnose;
pub mod evaluate;
pub mod export;
pub mod extend;
pub mod gp;
pub mod investigate;
pub mod io;
pub mod kernel;
pub mod lssvr;
pub mod normalize;
pub mod poly;
pub mod prior;
pub mod replay;
pub mod report;
pub mod reproduce;
pub mod sparse;
pub mod stream;
pub mod table;
pub mod two_step;
