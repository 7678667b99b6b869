//! Where a ray's network samples go during training: the occupancy grid
//! that keeps them out of empty space ([`occupancy`]) and the proposal
//! grid that places them where its density says the surfaces are
//! ([`proposal`]); a step's samples are drawn from them by `train/samples.rs`.
//! Named as the renderer's `nerf_infer::occupancy` and `nerf_infer::proposal`,
//! which read what these export.

pub mod occupancy;
pub mod proposal;
