//! This core's peak multiply-accumulate rate for the instruction mixes the
//! kernels use, so that the per-ray MAC/s can be read against a measured
//! ceiling rather than a datasheet: register-only loops of independent
//! accumulators, no memory traffic.
//!
//! - `f32_mul_add`: `vmulps` + `vaddps` on 16 lanes (the f32 kernel keeps
//!   multiply and add separate so results match targets without FMA);
//! - `f32_fma`: `vfmadd231ps` on 16 lanes (the FPU's ceiling);
//! - `i16_vnni`: `vpdpwssd`, 32 i16 multiply-accumulates per instruction
//!   (the int8-weight kernel on AVX-512 VNNI);
//! - `avx2_f32_mul_add`, `avx2_f32_fma`: the same on 8 lanes (AVX2 + FMA);
//! - `avx2_i16_madd`: `vpmaddwd` + `vpaddd`, 16 i16 multiply-accumulates per
//!   pair (the int8-weight kernel on AVX2 without VNNI).
//!
//! Each group is built when the target has its features
//! (`target-cpu=native` in `.cargo/config.toml`).
//!
//! `cargo bench --bench peak` — `thrpt` is MAC/s (one thread).

// a target with none of these features measures nothing
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// Loop trips per measured iteration.
const TRIPS: u64 = 4096;

#[cfg(all(target_arch = "x86_64", target_feature = "avx512f", target_feature = "avx512vnni"))]
mod x86 {
    use super::TRIPS;
    use std::arch::x86_64::*;
    use std::hint::black_box;

    /// Independent accumulators (enough to hide every latency; 32 registers).
    pub const ACCS: usize = 24;

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

#[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
mod avx2 {
    use super::TRIPS;
    use std::arch::x86_64::*;
    use std::hint::black_box;

    /// Independent accumulators (16 registers).
    pub const ACCS_AVX2: usize = 12;

    type Step = fn(__m256, __m256, __m256) -> __m256;

    /// Runs `step` on `ACCS_AVX2` accumulators `TRIPS` times; 8 lanes each.
    #[inline(always)]
    fn run_f32(step: Step) -> f32 {
        // SAFETY: the module is compiled only with avx2 enabled.
        unsafe {
            let x = _mm256_set1_ps(black_box(0.999));
            let w = _mm256_set1_ps(black_box(1e-6));
            let mut acc = [_mm256_setzero_ps(); ACCS_AVX2];
            for _ in 0..TRIPS {
                for a in acc.iter_mut() {
                    *a = step(*a, x, w);
                }
            }
            let mut s = _mm256_setzero_ps();
            for a in acc {
                s = _mm256_add_ps(s, a);
            }
            let mut lanes = [0f32; 8];
            _mm256_storeu_ps(lanes.as_mut_ptr(), s);
            lanes.iter().sum()
        }
    }

    pub fn f32_mul_add() -> f32 {
        // SAFETY: avx2 is enabled for this build.
        run_f32(|a, x, w| unsafe { _mm256_add_ps(_mm256_mul_ps(a, x), w) })
    }

    pub fn f32_fma() -> f32 {
        // SAFETY: fma is enabled for this build.
        run_f32(|a, x, w| unsafe { _mm256_fmadd_ps(a, x, w) })
    }

    pub fn i16_madd() -> i32 {
        // SAFETY: avx2 is enabled for this build.
        unsafe {
            let w = _mm256_set1_epi32(black_box(0x0001_0001));
            let mut acc = [_mm256_set1_epi32(black_box(1)); ACCS_AVX2];
            for _ in 0..TRIPS {
                for a in acc.iter_mut() {
                    // the accumulator is also the multiplicand, so the
                    // product cannot be hoisted out of the loop
                    *a = _mm256_add_epi32(*a, _mm256_madd_epi16(*a, w));
                }
            }
            let mut s = _mm256_setzero_si256();
            for a in acc {
                s = _mm256_add_epi32(s, a);
            }
            let mut lanes = [0i32; 8];
            _mm256_storeu_si256(lanes.as_mut_ptr().cast(), s);
            lanes.iter().sum()
        }
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("peak");
    g.sample_size(30);
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f", target_feature = "avx512vnni"))]
    {
        let per = TRIPS * x86::ACCS as u64;
        g.throughput(Throughput::Elements(per * 16));
        g.bench_function("f32_mul_add", |b| b.iter(x86::f32_mul_add));
        g.bench_function("f32_fma", |b| b.iter(x86::f32_fma));
        g.throughput(Throughput::Elements(per * 32));
        g.bench_function("i16_vnni", |b| b.iter(x86::i16_vnni));
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    {
        let per = TRIPS * avx2::ACCS_AVX2 as u64;
        g.throughput(Throughput::Elements(per * 8));
        g.bench_function("avx2_f32_mul_add", |b| b.iter(avx2::f32_mul_add));
        g.bench_function("avx2_f32_fma", |b| b.iter(avx2::f32_fma));
        g.throughput(Throughput::Elements(per * 16));
        g.bench_function("avx2_i16_madd", |b| b.iter(avx2::i16_madd));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
