//! Dot-product kernels for the vector index, with runtime-dispatched AVX2 and AVX-512 VNNI builds.
//!
//! The loops are written so LLVM vectorizes them (independent lane accumulators); the AVX2
//! copies are the same source compiled with the feature enabled and chosen at run time. The
//! int8 row scan has a hand-written AVX-512 VNNI kernel (`vpdpbusd`, 64 products a
//! instruction, four rows at a time), which runs at the memory bandwidth of one core: it
//! reads 100k × 384 codes in about 1.4 ms where the widened i32 multiply took 2.3–2.7 ms.
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
        if std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512bw")
            && std::is_x86_feature_detected!("avx512vnni")
        {
            // SAFETY: the required CPU features were detected just above.
            unsafe { dot_i8_rows_vnni(query, rows, out) };
            return;
        }
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

/// `vpdpbusd` multiplies unsigned by signed bytes, so each row byte is flipped to `r + 128`
/// (`r ^ 0x80`) and `128 · Σq` is taken off the sum: Σ (r + 128)·q − 128·Σq = Σ r·q. The
/// query is copied into a zero-padded buffer of whole 64-byte blocks and a row's last block
/// is read with a byte mask (bytes past the row are zero, flip to 128, and meet a zero
/// query byte), so nothing outside `rows` is read.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
unsafe fn dot_i8_rows_vnni(query: &[i8], rows: &[i8], out: &mut Vec<i32>) {
    let dim = query.len();
    let mut padded = vec![0i8; dim.div_ceil(64) * 64];
    padded[..dim].copy_from_slice(query);
    let shift = 128 * query.iter().map(|&x| i32::from(x)).sum::<i32>();
    let mut quads = rows.chunks_exact(4 * dim);
    for quad in &mut quads {
        // SAFETY: `quad` holds 4 rows of `dim` bytes, `padded` is `dim` rounded up to 64.
        out.extend(unsafe { vnni_rows::<4>(&padded, quad.as_ptr(), dim) }.map(|d| d - shift));
    }
    for row in quads.remainder().chunks_exact(dim) {
        // SAFETY: `row` holds 1 row of `dim` bytes.
        out.push(unsafe { vnni_rows::<1>(&padded, row.as_ptr(), dim) }[0] - shift);
    }
}

/// The `u8 x i8` dot products (rows flipped to unsigned by `xor 0x80`, so each is off by
/// `128 * sum(query)`) of `N` consecutive rows of `dim` bytes at `rows` with the query,
/// `padded` being the query zero-padded to whole 64-byte blocks.
///
/// # Safety
/// `rows` must point to `N * dim` readable bytes and `padded.len() >= dim.div_ceil(64) * 64`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[inline]
unsafe fn vnni_rows<const N: usize>(padded: &[i8], rows: *const i8, dim: usize) -> [i32; N] {
    use std::arch::x86_64::{
        __m512i, _mm512_dpbusd_epi32, _mm512_loadu_si512, _mm512_maskz_loadu_epi8,
        _mm512_reduce_add_epi32, _mm512_set1_epi8, _mm512_setzero_si512, _mm512_xor_si512,
    };
    let (full, tail) = (dim / 64, dim % 64);
    let flip = _mm512_set1_epi8(-128);
    let qp = padded.as_ptr();
    let mut acc: [__m512i; N] = [_mm512_setzero_si512(); N];
    // SAFETY (every read below): a query read at block `b <= full` is inside `padded`; a row
    // read of a whole block `b < full` ends at `64 * (b + 1) <= dim`, inside the row; the
    // masked read of the last block touches only its first `tail` bytes, in the row.
    for b in 0..full {
        let qb = unsafe { _mm512_loadu_si512(qp.add(b * 64).cast()) };
        for (k, a) in acc.iter_mut().enumerate() {
            let v = unsafe { _mm512_loadu_si512(rows.add(k * dim + b * 64).cast()) };
            *a = _mm512_dpbusd_epi32(*a, _mm512_xor_si512(v, flip), qb);
        }
    }
    if tail > 0 {
        let qb = unsafe { _mm512_loadu_si512(qp.add(full * 64).cast()) };
        let mask: u64 = (1u64 << tail) - 1;
        for (k, a) in acc.iter_mut().enumerate() {
            let v = unsafe { _mm512_maskz_loadu_epi8(mask, rows.add(k * dim + full * 64)) };
            *a = _mm512_dpbusd_epi32(*a, _mm512_xor_si512(v, flip), qb);
        }
    }
    acc.map(|a| _mm512_reduce_add_epi32(a))
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

    /// Every dispatched row kernel against the naive sum, over dimensions around the 64-byte
    /// blocks and row counts around the four-row unroll, with the extreme codes included.
    #[test]
    fn row_kernel_matches_naive_at_every_shape() {
        let mut seed = 7u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            // every byte value, -128 and 127 included
            (seed >> 24) as u8 as i8
        };
        for dim in [1, 7, 63, 64, 65, 127, 128, 130, 384, 389] {
            let query: Vec<i8> = (0..dim).map(|_| next()).collect();
            for n in 0..10 {
                let mut rows: Vec<i8> = (0..n * dim).map(|_| next()).collect();
                if n > 0 {
                    rows[0] = -128;
                    rows[n * dim - 1] = 127;
                }
                let want: Vec<i32> = rows
                    .chunks_exact(dim)
                    .map(|r| {
                        r.iter()
                            .zip(&query)
                            .map(|(a, b)| i32::from(*a) * i32::from(*b))
                            .sum()
                    })
                    .collect();
                let mut out = vec![99];
                dot_i8_rows(&query, &rows, &mut out);
                assert_eq!(out, want, "dim {dim}, {n} rows");
                let portable: Vec<i32> = rows
                    .chunks_exact(dim)
                    .map(|r| dot_i8_portable(&query, r))
                    .collect();
                assert_eq!(portable, want, "portable, dim {dim}, {n} rows");
            }
        }
    }
}
