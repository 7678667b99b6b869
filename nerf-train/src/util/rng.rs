//! A small seeded generator (PCG-XSH-RR 32) so training is reproducible.

/// PCG32 random number generator.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator from a seed (any value).
    pub fn new(seed: u64) -> Self {
        let mut r = Self { state: seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407) };
        r.u32();
        r
    }
    /// Next 32 random bits.
    pub fn u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in `[0, 1)` with 24 bits.
    pub fn f32(&mut self) -> f32 {
        (self.u32() >> 8) as f32 / (1u32 << 24) as f32
    }
    /// Uniform integer in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.u32() as u64 * n as u64) >> 32) as usize
    }
}

/// The salts that keep a run's random streams apart: each is XORed into
/// the run's seed (or a step's key) before it seeds or keys one use, so
/// no two uses draw the same numbers. Changing one changes every model
/// trained after.
pub mod stream {
    /// The fine network's initialisation (the coarse network's is the run
    /// seed itself).
    pub const FINE_INIT: u64 = 0x5EED_F1E0;
    /// The feature-table values of random models (benchmarks, tests).
    pub const RANDOM_TABLE: u64 = 0xFEA7;
    /// The points at which the occupancy grid's update samples each cell.
    pub const GRID_UPDATE: u32 = 0x6121_D000;
    /// A ray's importance samples in the fine pass.
    pub const FINE_SAMPLES: u32 = 0xF1AE;
    /// The CDF levels at which the trainer draws the network's samples from
    /// a proposal grid's weights.
    pub const PROPOSAL_PDF: u32 = 0x9E37_79B9;
    /// The rays `nerf train` draws once to calibrate the exported model's
    /// activation ranges and to find its dead neurons.
    pub const CALIBRATION: u64 = 0xCA11;
}
