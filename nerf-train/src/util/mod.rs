//! Helpers the stages share: [`atomic`] file writes, [`userfile`] (reading
//! a file a user names), the [`rng`] and its named streams, step
//! [`timing`], and the [`gemm`] matrix products.

pub mod atomic;
pub mod gemm;
pub mod rng;
pub mod timing;
pub mod userfile;
