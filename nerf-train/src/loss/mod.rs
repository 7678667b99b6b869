//! The loss terms, each with its hand-written gradient: the [`photo`]
//! loss (the colour error after compositing, which weighs the others in),
//! the [`distortion`] loss, the [`density`] penalty (optical depth) and
//! the proposal grid's [`interlevel`] loss. `train/loss.rs` sets their
//! weights from the run's configuration.

pub mod density;
pub mod distortion;
pub mod interlevel;
pub mod photo;
