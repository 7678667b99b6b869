//! The sizes of the values an embedding program keeps, on the target it is
//! built for, in the line format `scripts/check/stack_table.sh` reads from the
//! firmware too:
//!
//!     cargo run -p nerf-infer --release --example sizes

use nerf_infer::{Model, RendererFixed, ScratchF32, ScratchFixed};

fn main() {
    println!(
        "sizes: Model={} RendererFixed={} ScratchFixed1={} ScratchFixed4={} ScratchFixed8={} ScratchF32_1={} \
         ScratchF32_8={}",
        size_of::<Model<'static>>(),
        size_of::<RendererFixed<'static, 'static>>(),
        size_of::<ScratchFixed<1>>(),
        size_of::<ScratchFixed<4>>(),
        size_of::<ScratchFixed<8>>(),
        size_of::<ScratchF32<1>>(),
        size_of::<ScratchF32<8>>()
    );
}
