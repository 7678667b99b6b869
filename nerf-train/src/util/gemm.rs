//! A safe, bounds-checked wrapper over the `gemm` crate's f32 kernel.

/// A strided read-only matrix view: element `(i, j)` is `data[i·rs + j·cs]`.
#[derive(Clone, Copy)]
pub struct View<'a> {
    /// Backing storage.
    pub data: &'a [f32],
    /// Row stride in elements.
    pub rs: usize,
    /// Column stride in elements.
    pub cs: usize,
}

impl<'a> View<'a> {
    /// Row-major `rows × cols` matrix.
    pub fn rows(data: &'a [f32], cols: usize) -> Self {
        Self { data, rs: cols, cs: 1 }
    }
    /// The transpose of a row-major matrix with `cols` columns.
    pub fn t(data: &'a [f32], cols: usize) -> Self {
        Self { data, rs: 1, cs: cols }
    }
    /// Checks that the view holds an `r × c` matrix: every element within
    /// `data`, each stride at most `isize::MAX` (the kernel's offsets).
    ///
    /// # Panics
    /// If it does not (an element's index that overflows `usize` included).
    fn check(&self, r: usize, c: usize) {
        assert!(
            self.rs <= isize::MAX as usize && self.cs <= isize::MAX as usize,
            "matrix view stride above isize::MAX"
        );
        if r > 0 && c > 0 {
            let last =
                (r - 1).checked_mul(self.rs).zip((c - 1).checked_mul(self.cs)).and_then(|(a, b)| a.checked_add(b));
            assert!(last.is_some_and(|last| last < self.data.len()), "matrix view out of bounds");
        }
    }
}

/// `dst[m×n] (+)= a[m×k] · b[k×n]`; `dst` is row-major with row stride
/// `dst_rs`; accumulates when `accumulate`, otherwise overwrites.
///
/// # Panics
/// If `dst` (row stride `dst_rs`), `a` or `b` does not hold its matrix:
/// an element beyond its slice, its index overflowing `usize`, or a stride
/// above `isize::MAX`.
#[allow(clippy::too_many_arguments)]
pub fn matmul(
    m: usize,
    n: usize,
    k: usize,
    dst: &mut [f32],
    dst_rs: usize,
    accumulate: bool,
    a: View<'_>,
    b: View<'_>,
) {
    if m == 0 || n == 0 {
        return;
    }
    assert!(dst_rs <= isize::MAX as usize, "destination stride above isize::MAX");
    let end = (m - 1).checked_mul(dst_rs).and_then(|r| r.checked_add(n));
    assert!(end.is_some_and(|end| end <= dst.len()), "destination out of bounds");
    if k == 0 {
        if !accumulate {
            for r in 0..m {
                dst[r * dst_rs..r * dst_rs + n].fill(0.0);
            }
        }
        return;
    }
    a.check(m, k);
    b.check(k, n);
    // Safety: every index the kernel touches was bounds-checked above
    // (last row/column of each operand), and `dst` is uniquely borrowed.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            dst_rs as isize,
            accumulate,
            a.data.as_ptr(),
            a.cs as isize,
            a.rs as isize,
            b.data.as_ptr(),
            b.cs as isize,
            b.rs as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_naive_product_including_transposes() {
        let (m, n, k) = (5, 7, 3);
        let a: Vec<f32> = (0..m * k).map(|i| i as f32 * 0.5 - 3.0).collect();
        let b: Vec<f32> = (0..k * n).map(|i| (i as f32).sin()).collect();
        let mut c = vec![1.0; m * n];
        matmul(m, n, k, &mut c, n, true, View::rows(&a, k), View::rows(&b, n));
        for i in 0..m {
            for j in 0..n {
                let want: f32 = 1.0 + (0..k).map(|p| a[i * k + p] * b[p * n + j]).sum::<f32>();
                assert!((c[i * n + j] - want).abs() < 1e-5);
            }
        }
        // aᵀ (k×m) as a view of the same storage
        let mut d = vec![0.0; k * k];
        matmul(k, k, m, &mut d, k, false, View::t(&a, k), View::rows(&a, k));
        let want: f32 = (0..m).map(|p| a[p * k] * a[p * k + 1]).sum();
        assert!((d[1] - want).abs() < 1e-4);
    }

    #[test]
    #[should_panic(expected = "matrix view out of bounds")]
    fn a_stride_whose_last_element_overflows_panics_before_the_kernel() {
        // 4 · 2⁶² wraps to 0 in release: the last row would pass for the first
        let a = View { data: &[1.0; 4], rs: 1 << 62, cs: 1 };
        let mut c = vec![0.0; 5];
        matmul(5, 1, 1, &mut c, 1, false, a, View::rows(&[1.0], 1));
    }

    #[test]
    #[should_panic(expected = "stride above isize::MAX")]
    fn a_stride_above_isize_max_panics_before_the_kernel() {
        let a = View { data: &[1.0; 4], rs: isize::MAX as usize + 1, cs: 1 };
        let mut c = vec![0.0; 1];
        matmul(1, 1, 1, &mut c, 1, false, a, View::rows(&[1.0], 1));
    }

    #[test]
    #[should_panic(expected = "destination out of bounds")]
    fn a_destination_stride_that_overflows_panics_before_the_kernel() {
        let one = [1.0];
        let mut c = vec![0.0; 4];
        matmul(5, 1, 1, &mut c, 1 << 62, false, View::rows(&[1.0; 5], 1), View::rows(&one, 1));
    }
}
