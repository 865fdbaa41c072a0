//! Dot-product kernels for the vector index, with a runtime-dispatched AVX2 build.
//!
//! The loops are written so LLVM vectorizes them (independent lane accumulators); the AVX2
//! copies are the same source compiled with the feature enabled and chosen at run time.
#![allow(unsafe_code)]

/// f32 dot product over equal-length slices.
#[inline]
pub(crate) fn dot_f32(a: &[f32], b: &[f32]) -> f32 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the required CPU features were detected just above.
            return unsafe { dot_f32_avx2(a, b) };
        }
    }
    dot_f32_portable(a, b)
}

/// Scores a query against `n` rows of an int8 matrix, writing one i32 per row.
pub(crate) fn dot_i8_rows(query: &[i8], rows: &[i8], out: &mut Vec<i32>) {
    let dim = query.len();
    out.clear();
    if dim == 0 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the required CPU feature was detected just above.
            unsafe { dot_i8_rows_avx2(query, rows, out) };
            return;
        }
    }
    out.extend(rows.chunks_exact(dim).map(|r| dot_i8_portable(query, r)));
}

#[inline(always)]
fn dot_f32_portable(a: &[f32], b: &[f32]) -> f32 {
    const L: usize = 16;
    let mut acc = [0f32; L];
    let ca = a.chunks_exact(L);
    let cb = b.chunks_exact(L);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..L {
            acc[i] = x[i].mul_add(y[i], acc[i]);
        }
    }
    let mut s: f32 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

#[inline(always)]
fn dot_i8_portable(a: &[i8], b: &[i8]) -> i32 {
    const L: usize = 32;
    let mut acc = [0i32; L];
    let ca = a.chunks_exact(L);
    let cb = b.chunks_exact(L);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..L {
            acc[i] += i32::from(x[i]) * i32::from(y[i]);
        }
    }
    let mut s: i32 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += i32::from(*x) * i32::from(*y);
    }
    s
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn dot_f32_avx2(a: &[f32], b: &[f32]) -> f32 {
    dot_f32_portable(a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn dot_i8_rows_avx2(query: &[i8], rows: &[i8], out: &mut Vec<i32>) {
    out.extend(
        rows.chunks_exact(query.len())
            .map(|r| dot_i8_portable(query, r)),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_match_naive() {
        let a: Vec<f32> = (0..389)
            .map(|i| ((i * 7) % 13) as f32 * 0.1 - 0.6)
            .collect();
        let b: Vec<f32> = (0..389)
            .map(|i| ((i * 5) % 11) as f32 * 0.1 - 0.5)
            .collect();
        let naive: f32 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((dot_f32(&a, &b) - naive).abs() < 1e-4);
        assert!((dot_f32_portable(&a, &b) - naive).abs() < 1e-4);

        let qa: Vec<i8> = (0..389).map(|i| ((i * 37) % 255) as i16 as i8).collect();
        let qb: Vec<i8> = (0..389).map(|i| ((i * 91) % 253) as i16 as i8).collect();
        let naive_i: i32 = qa
            .iter()
            .zip(&qb)
            .map(|(x, y)| i32::from(*x) * i32::from(*y))
            .sum();
        assert_eq!(dot_i8_portable(&qa, &qb), naive_i);
        let mut out = Vec::new();
        let rows: Vec<i8> = qb.iter().chain(qa.iter()).copied().collect();
        dot_i8_rows(&qa, &rows, &mut out);
        assert_eq!(out, vec![naive_i, dot_i8_portable(&qa, &qa)]);
    }
}
