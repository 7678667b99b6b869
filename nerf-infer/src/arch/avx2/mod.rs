//! AVX2 kernels (x86-64 builds with `target-feature=+avx2`): the int8
//! layer and its requantiser, the encoding's sine, and width-2 feature-grid
//! lookups. Each matches its portable reference bit for bit.

mod features;
mod layer;
mod sine;

pub(crate) use features::features_w2;
// (with VNNI built, the tests still check the AVX2 layer kernels)
#[cfg(all(target_feature = "avx512bw", target_feature = "avx512vnni"))]
pub(crate) use layer::live_pairs;
#[cfg(any(test, not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))))]
pub(crate) use layer::{accumulate_i8, requant_i32};
pub(crate) use sine::sin_turns_q15_x8;
