//! Evaluates FOG temperature-drift compensation models on the gyro's microcontroller.
//!
//! `no_std`, no allocation: everything lives in fixed-size storage chosen by the integrator.
#![cfg_attr(not(test), no_std)]
