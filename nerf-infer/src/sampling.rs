//! Where along a ray to evaluate the network: stratified samples for the
//! coarse pass and inverse-CDF importance samples for the fine pass
//! (nerf-pytorch's `sample_pdf`, including its `+1e-5` weight floor).
//!
//! The f32 functions take `t` in world units along the ray parameter; the
//! fixed-point ones take `t` in Q16. Jitter is a deterministic hash of
//! (seed, pixel, sample index), so a render is reproducible.

/// Weight floor added to every coarse weight before building the pdf.
pub const PDF_EPS: f32 = 1e-5;
/// [`PDF_EPS`] in Q30 (`round(1e-5 · 2³⁰)`).
pub const PDF_EPS_Q30: u64 = 10737;

/// XORed into a ray's jitter key before it jitters the levels at which the
/// network's samples are drawn from a proposal grid's weights (a stream of
/// its own, apart from the stratified samples'); the trainer draws with it
/// too.
pub const PROPOSAL_DRAW_SALT: u32 = 0x5EED_0B1D;

/// CDF level of the network's sample `j` of `n` drawn from a proposal
/// grid's weights, Q16 in `(0, 65536)`: the middle of stratum `j`
/// without jitter, a random point of it with (the ray's `key`, salted
/// with [`PROPOSAL_DRAW_SALT`]). The renderer's march and the trainer
/// draw with it.
#[inline]
pub fn proposal_draw_q16(j: usize, n: usize, key: Option<u32>) -> u32 {
    let offset = match key {
        None => 32768,
        Some(k) => jitter_q16(k ^ PROPOSAL_DRAW_SALT, j) as u64,
    };
    ((j as u64 * 65536 + offset) / n as u64) as u32
}

/// XORed into a ray's jitter key before it jitters the levels at which the
/// fine pass's importance samples are drawn from the coarse weights (a
/// stream of its own, apart from the stratified samples').
pub const FINE_DRAW_SALT: u32 = 0xA511_E9B3;

/// A 32-bit integer hash (lowbias32) used for per-pixel jitter.
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Jitter in `[0, 1)` as a 16-bit fraction for sample `i` of a ray.
#[inline]
pub fn jitter_q16(ray_key: u32, i: usize) -> u32 {
    hash32(ray_key ^ hash32(i as u32).wrapping_mul(0x9E37_79B9)) >> 16
}

/// Key of a pixel's ray for jitter: mixes the seed and the pixel position.
#[inline]
pub fn ray_key(seed: u32, x: u32, y: u32) -> u32 {
    hash32(seed ^ hash32(x ^ hash32(y.wrapping_add(0x68e3_1da4))))
}

/// Stratified `t` values: `n` points evenly spaced over `[near, far]`
/// (endpoints included; one point sits at `near`); with jitter, each point
/// moves uniformly inside its stratum between the midpoints of its
/// neighbours. Output is sorted and finite: a non-finite `near` reads as 0,
/// a non-finite `far`, or one below `near`, as `near`.
pub fn stratified_f32(near: f32, far: f32, jitter: Option<u32>, out: &mut [f32]) {
    let n = out.len();
    let near = if near.is_finite() { near } else { 0.0 };
    let far = if far >= near && far.is_finite() { far } else { near };
    let lin = |i: usize| if n < 2 { near } else { near + (far - near) * (i as f32 / (n - 1) as f32) };
    for (i, o) in out.iter_mut().enumerate() {
        *o = lin(i);
    }
    if let Some(key) = jitter {
        for i in 0..n {
            let lo = if i == 0 { lin(0) } else { 0.5 * (lin(i - 1) + lin(i)) };
            let hi = if i + 1 == n { lin(i) } else { 0.5 * (lin(i) + lin(i + 1)) };
            let u = jitter_q16(key, i) as f32 / 65536.0;
            out[i] = lo + (hi - lo) * u;
        }
    }
}

/// Fixed-point [`stratified_f32`]: `near`, `far` and `out` in Q16 (`far`
/// below `near` reads as `near`).
pub fn stratified_fixed(near: i32, far: i32, jitter: Option<u32>, out: &mut [i32]) {
    stratified_fixed_from(near, far, out.len(), jitter, 0, out);
}

/// Samples `first .. first + out.len()` of the `n` that [`stratified_fixed`]
/// would place between `near` and `far` (Q16), bit-identical to those
/// entries of its output: a ray clipped to the occupied box needs only the
/// samples around the box. Requires `first + out.len() ≤ n`.
pub fn stratified_fixed_from(near: i32, far: i32, n: usize, jitter: Option<u32>, first: usize, out: &mut [i32]) {
    debug_assert!(first + out.len() <= n);
    if n < 2 {
        out.fill(near);
        return;
    }
    let Some(key) = jitter else {
        let mut lin = Linspace::new(near, far, n, first);
        out.iter_mut().for_each(|o| *o = lin.next() as i32);
        return;
    };
    // each point moves inside its stratum, between the midpoints of its
    // neighbours: lin(i − 1), lin(i) and lin(i + 1) are kept in step
    let mut lin = Linspace::new(near, far, n, first.saturating_sub(1));
    let mut prev = lin.next();
    let mut cur = if first == 0 { prev } else { lin.next() };
    for (j, o) in out.iter_mut().enumerate() {
        let i = first + j;
        let next = if i + 1 < n { lin.next() } else { cur };
        let lo = if i == 0 { cur } else { (prev + cur) >> 1 };
        let hi = if i + 1 == n { cur } else { (cur + next) >> 1 };
        let u = jitter_q16(key, i) as i64;
        *o = (lo + (((hi - lo) * u) >> 16)) as i32;
        (prev, cur) = (cur, next);
    }
}

/// `lin(i) = near + ⌊span·i/(n−1)⌋` for `i = first, first + 1, …`, stepped
/// exactly: quotient and remainder advance by those of `span/(n−1)` (no
/// division per sample). Q16.
struct Linspace {
    near: i64,
    d: i64,
    step: (i64, i64),
    q: i64,
    r: i64,
}

impl Linspace {
    fn new(near: i32, far: i32, n: usize, first: usize) -> Self {
        let span = (far as i64 - near as i64).max(0);
        let d = (n - 1) as i64;
        let at = span * first as i64;
        Self { near: near as i64, d, step: (span / d, span % d), q: at / d, r: at % d }
    }

    #[inline(always)]
    fn next(&mut self) -> i64 {
        let v = self.near + self.q;
        self.q += self.step.0;
        self.r += self.step.1;
        // branch-free carry: the remainder's pattern defeats prediction
        let carry = (self.r >= self.d) as i64;
        self.q += carry;
        self.r -= carry * self.d;
        v
    }
}

/// Importance samples from the coarse pass (nerf-pytorch `sample_pdf`).
///
/// `t` holds the `n_c ≥ 3` sorted coarse samples and `w` their weights;
/// bins are the midpoints of `t`, with the weights of the interior samples
/// plus [`PDF_EPS`] as their mass. `u(j)` gives the CDF level of sample `j`
/// in `[0, 1]`, non-decreasing in `j`. `cdf` is scratch of length ≥ `n_c − 1`.
/// The `out.len()` samples are written in non-decreasing order.
pub fn sample_pdf_f32(t: &[f32], w: &[f32], u: impl Fn(usize) -> f32, cdf: &mut [f32], out: &mut [f32]) {
    let nc = t.len();
    let nb = nc - 1; // bins = cdf entries
    let mut total = 0.0f32;
    cdf[0] = 0.0;
    for k in 1..nb {
        let wk = w[k];
        total += if wk.is_finite() { wk.max(0.0) } else { 0.0 } + PDF_EPS;
        cdf[k] = total;
    }
    let inv = 1.0 / total;
    for c in cdf[..nb].iter_mut() {
        *c *= inv;
    }
    let bin = |i: usize| 0.5 * (t[i] + t[i + 1]);
    let mut inds = 0usize; // number of cdf entries ≤ u
    for (j, o) in out.iter_mut().enumerate() {
        let uj = u(j);
        while inds < nb && cdf[inds] <= uj {
            inds += 1;
        }
        let below = inds.saturating_sub(1);
        let above = inds.min(nb - 1);
        let mut denom = cdf[above] - cdf[below];
        if denom < PDF_EPS {
            denom = 1.0;
        }
        let f = (uj - cdf[below]) / denom;
        *o = bin(below) + f * (bin(above) - bin(below));
    }
}

/// Fixed-point [`sample_pdf_f32`]: `t` and `out` in Q16, weights in Q30,
/// `u_q16(j)` in Q16 `[0, 65536]`; `cdf` holds unnormalised Q30 prefix sums.
pub fn sample_pdf_fixed(t: &[i32], w: &[u32], u_q16: impl Fn(usize) -> u32, cdf: &mut [u64], out: &mut [i32]) {
    let nc = t.len();
    let nb = nc - 1;
    let mut total = 0u64;
    cdf[0] = 0;
    for k in 1..nb {
        total += w[k] as u64 + PDF_EPS_Q30;
        cdf[k] = total;
    }
    let bin = |i: usize| ((t[i] as i64 + t[i + 1] as i64) >> 1) as i32;
    let eps_total = (total * 10737) >> 30; // 1e-5 of the total, in the same units
    let mut inds = 0usize;
    for (j, o) in out.iter_mut().enumerate() {
        let target = (total * u_q16(j) as u64) >> 16;
        while inds < nb && cdf[inds] <= target {
            inds += 1;
        }
        let below = inds.saturating_sub(1);
        let above = inds.min(nb - 1);
        let (b0, b1) = (bin(below) as i64, bin(above) as i64);
        let denom = cdf[above] - cdf[below];
        let num = target - cdf[below];
        *o = if denom <= eps_total {
            // nerf-pytorch replaces a vanishing denominator by 1 (the total).
            (b0 + ((b1 - b0) as i128 * num as i128 / total as i128) as i64) as i32
        } else {
            (b0 + ((b1 - b0) as i128 * num as i128 / denom as i128) as i64) as i32
        };
    }
}

/// Merges two non-decreasing sequences into `out` (length `a.len() + b.len()`).
pub fn merge_sorted<T: Copy + PartialOrd>(a: &[T], b: &[T], out: &mut [T]) {
    let (mut i, mut j) = (0, 0);
    for o in out.iter_mut() {
        if j >= b.len() || (i < a.len() && a[i] <= b[j]) {
            *o = a[i];
            i += 1;
        } else {
            *o = b[j];
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stratified_without_jitter_is_linspace() {
        let mut t = [0.0; 5];
        stratified_f32(2.0, 6.0, None, &mut t);
        assert_eq!(t, [2.0, 3.0, 4.0, 5.0, 6.0]);
        let mut q = [0; 5];
        stratified_fixed(2 << 16, 6 << 16, None, &mut q);
        assert_eq!(q, [2 << 16, 3 << 16, 4 << 16, 5 << 16, 6 << 16]);
    }

    #[test]
    fn jitter_stays_in_strata_and_is_sorted() {
        let mut t = [0.0; 64];
        stratified_f32(2.0, 6.0, Some(ray_key(7, 3, 4)), &mut t);
        assert!(t.windows(2).all(|p| p[0] <= p[1]));
        assert!(t[0] >= 2.0 && t[63] <= 6.0);
    }

    #[test]
    fn pdf_samples_concentrate_on_the_peak() {
        let mut t = [0.0f32; 16];
        stratified_f32(0.0, 15.0, None, &mut t);
        let mut w = [0.0f32; 16];
        w[8] = 1.0;
        let mut cdf = [0.0f32; 16];
        let mut out = [0.0f32; 32];
        sample_pdf_f32(&t, &w, |j| j as f32 / 31.0, &mut cdf, &mut out);
        let inside = out.iter().filter(|&&x| (7.5..=8.5).contains(&x)).count();
        assert!(inside >= 28, "{inside} of 32 in the peak bin: {out:?}");
        assert!(out.windows(2).all(|p| p[0] <= p[1]));
        // the fixed path agrees within a Q16 step
        let tq = t.map(|x| (x * 65536.0) as i32);
        let wq = w.map(|x| (x * 1073741824.0) as u32);
        let mut cq = [0u64; 16];
        let mut oq = [0i32; 32];
        sample_pdf_fixed(&tq, &wq, |j| ((j as u64 * 65536) / 31) as u32, &mut cq, &mut oq);
        for (a, b) in out.iter().zip(oq.iter()) {
            assert!((a - *b as f32 / 65536.0).abs() < 1e-3, "{a} vs {}", *b as f32 / 65536.0);
        }
    }

    #[test]
    fn stratified_fixed_steps_exactly() {
        for &(near, far) in &[(0, 1), (131_072, 393_216), (7, 1_966_080_000), (5, 5), (100, 3)] {
            for n in [2usize, 3, 7, 64, 192, 256] {
                let mut out = [0i32; 256];
                stratified_fixed(near, far, None, &mut out[..n]);
                let span = (far as i64 - near as i64).max(0);
                for i in 0..n {
                    assert_eq!(out[i] as i64, near as i64 + span * i as i64 / (n as i64 - 1), "{near} {far} {n} {i}");
                }
            }
        }
    }

    #[test]
    fn any_run_of_stratified_samples_matches_the_whole_set() {
        for &(near, far) in &[(0, 1), (131_072, 393_216), (7, 1_966_080_000), (5, 5), (-9, 70_000)] {
            for n in [2usize, 3, 7, 192] {
                for jitter in [None, Some(1), Some(0xdead_beef)] {
                    let mut all = [0i32; 192];
                    stratified_fixed(near, far, jitter, &mut all[..n]);
                    for first in 0..n {
                        for len in [0, 1, 2, n - first] {
                            let len = len.min(n - first);
                            let mut part = [0i32; 192];
                            stratified_fixed_from(near, far, n, jitter, first, &mut part[..len]);
                            assert_eq!(
                                part[..len],
                                all[first..first + len],
                                "{near} {far} {n} {jitter:?} {first} {len}"
                            );
                        }
                    }
                }
            }
        }
    }
}
