//! The loss terms beside the photo's colour error, each with its
//! hand-written gradient: the [`distortion`] loss, the [`density`]
//! penalty (optical depth) and the proposal grid's [`interlevel`] loss.
//! `train/loss.rs` weighs them into a chunk's loss.

pub mod density;
pub mod distortion;
pub mod interlevel;
