//! This core's peak multiply-accumulate rate for the instruction mixes the
//! kernels use, so that the per-ray MAC/s can be read against a measured
//! ceiling rather than a datasheet: register-only loops of independent
//! accumulators, no memory traffic.
//!
//! - `f32_mul_add`: `vmulps` + `vaddps` on 16 lanes (the f32 kernel keeps
//!   multiply and add separate so results match targets without FMA);
//! - `f32_fma`: `vfmadd231ps` on 16 lanes (the FPU's ceiling);
//! - `i16_vnni`: `vpdpwssd`, 32 i16 multiply-accumulates per instruction
//!   (the int8-weight kernel).
//!
//! `cargo bench --bench peak` — `thrpt` is MAC/s (one thread).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// Loop trips per measured iteration.
const TRIPS: u64 = 4096;
/// Independent accumulators (enough to hide every latency).
const ACCS: usize = 24;

#[cfg(all(target_arch = "x86_64", target_feature = "avx512f", target_feature = "avx512vnni"))]
mod x86 {
    use super::{ACCS, TRIPS};
    use std::arch::x86_64::*;
    use std::hint::black_box;

    type Step = fn(__m512, __m512, __m512) -> __m512;

    /// Runs `step` on `ACCS` accumulators `TRIPS` times; 16 lanes each.
    /// Each step multiplies the accumulator (`a·x + w`), so no product can
    /// be hoisted out of the loop.
    #[inline(always)]
    fn run_f32(step: Step) -> f32 {
        // SAFETY: the module is compiled only with avx512f enabled.
        unsafe {
            let x = _mm512_set1_ps(black_box(0.999));
            let w = _mm512_set1_ps(black_box(1e-6));
            let mut acc = [_mm512_setzero_ps(); ACCS];
            for _ in 0..TRIPS {
                for a in acc.iter_mut() {
                    *a = step(*a, x, w);
                }
            }
            let mut s = _mm512_setzero_ps();
            for a in acc {
                s = _mm512_add_ps(s, a);
            }
            _mm512_reduce_add_ps(s)
        }
    }

    pub fn f32_mul_add() -> f32 {
        // SAFETY: avx512f is enabled for this build.
        run_f32(|a, x, w| unsafe { _mm512_add_ps(_mm512_mul_ps(a, x), w) })
    }

    pub fn f32_fma() -> f32 {
        // SAFETY: avx512f is enabled for this build.
        run_f32(|a, x, w| unsafe { _mm512_fmadd_ps(a, x, w) })
    }

    pub fn i16_vnni() -> i32 {
        // SAFETY: avx512f and avx512vnni are enabled for this build.
        unsafe {
            let x = _mm512_set1_epi32(black_box(0x0001_0001));
            let w = _mm512_set1_epi32(black_box(0x0001_0001));
            let mut acc = [_mm512_setzero_si512(); ACCS];
            for _ in 0..TRIPS {
                for a in acc.iter_mut() {
                    *a = _mm512_dpwssd_epi32(*a, x, w);
                }
            }
            let mut s = _mm512_setzero_si512();
            for a in acc {
                s = _mm512_add_epi32(s, a);
            }
            _mm512_reduce_add_epi32(s)
        }
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("peak");
    g.sample_size(30);
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f", target_feature = "avx512vnni"))]
    {
        let per = TRIPS * ACCS as u64;
        g.throughput(Throughput::Elements(per * 16));
        g.bench_function("f32_mul_add", |b| b.iter(x86::f32_mul_add));
        g.bench_function("f32_fma", |b| b.iter(x86::f32_fma));
        g.throughput(Throughput::Elements(per * 32));
        g.bench_function("i16_vnni", |b| b.iter(x86::i16_vnni));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
