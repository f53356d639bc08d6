//! A pose's three Jacobian rows into `JᵀJ` and `Jᵀr` (the library's `add_dense_rows`) written
//! with AVX2 intrinsics for `f64`: four entries per instruction, two rows of `JᵀJ` at a time
//! sharing the columns' loads. Each entry is computed with the library's operations in the
//! library's order (`v + ((xᵢ·xⱼ + yᵢ·yⱼ) + zᵢ·zⱼ)`, no fused multiply-add), so the sums are
//! bit-identical to `kinecal::identify::lm::add_dense_rows` (a test compares them).
//!
//! The loop is most of an `identify` over many poses: the compiler's own vectorisation of the
//! library's iterator chain spent ~6.7 instructions per entry on rows of ~17 entries, most in
//! the scalar ends of the rows; here the last one to three entries of a row are one masked
//! operation, and `Jᵀr` is four rows at a time. Callgrind, `identify` on 200,000 simulated UR10
//! poses (33 parameters): this loop 2.36 → 1.6 billion instructions, the whole run 7.33 → 6.94.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256d, __m256i, _mm256_add_pd, _mm256_loadu_pd, _mm256_maskload_pd, _mm256_maskstore_pd,
    _mm256_mul_pd, _mm256_set1_pd, _mm256_setr_epi64x, _mm256_storeu_pd,
};

/// `add_dense_rows` for `f64` with AVX2; `false`, with nothing done, when the processor lacks
/// AVX2 or a row of `rows` lies beyond the slices (the caller's own loop then decides).
#[cfg(target_arch = "x86_64")]
pub fn add_rows_f64(
    (jtj, jtr): (&mut [f64], &mut [f64]),
    stride: usize,
    (cx, cy, cz): (&[f64], &[f64], &[f64]),
    r: [f64; 3],
    rows: &[usize],
) -> bool {
    if !std::arch::is_x86_feature_detected!("avx2") {
        return false;
    }
    // Every row index within the columns and `Jᵀr`, every row's `i + 1` entries within `JᵀJ`.
    let Some(&top) = rows.iter().max() else {
        return true;
    };
    let fits = top < cx.len().min(cy.len()).min(cz.len()).min(jtr.len())
        && top <= stride
        && top
            .checked_mul(stride)
            .and_then(|s| s.checked_add(top + 1))
            .is_some_and(|end| end <= jtj.len());
    if !fits {
        return false;
    }
    // SAFETY: AVX2 is present (checked above) and every index the kernel touches is below the
    // lengths checked above: row `i` ≤ `top` reads columns `0..=i` and writes
    // `jtj[i·stride .. i·stride + i + 1]`.
    unsafe { kernel(jtj, jtr, stride, (cx, cy, cz), r, rows) };
    true
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn kernel(
    jtj: &mut [f64],
    jtr: &mut [f64],
    stride: usize,
    (cx, cy, cz): (&[f64], &[f64], &[f64]),
    r: [f64; 3],
    rows: &[usize],
) {
    let (px, py, pz) = (cx.as_ptr(), cy.as_ptr(), cz.as_ptr());
    let m = jtj.as_mut_ptr();
    // `Jᵀr`: four rows at a time when the rows are `0, 1, …` (every column enters, the
    // usual case), else row by row.
    if rows.iter().enumerate().all(|(a, i)| a == *i) {
        let w = [
            _mm256_set1_pd(r[0]),
            _mm256_set1_pd(r[1]),
            _mm256_set1_pd(r[2]),
        ];
        span(jtr.as_mut_ptr(), w, (px, py, pz), 0, rows.len());
    } else {
        for &i in rows {
            jtr[i] += cx[i] * r[0] + cy[i] * r[1] + cz[i] * r[2];
        }
    }
    let mut pairs = rows.chunks_exact(2);
    for pair in &mut pairs {
        // The columns both rows share (`0..=lo`), then the longer row's rest.
        let (lo, hi) = (pair[0].min(pair[1]), pair[0].max(pair[1]));
        let (a, b) = (m.add(lo * stride), m.add(hi * stride));
        let (wa, wb) = (weights(cx, cy, cz, lo), weights(cx, cy, cz, hi));
        let n = lo + 1;
        let mut j = 0;
        while j + 4 <= n {
            let (x, y, z) = (
                _mm256_loadu_pd(px.add(j)),
                _mm256_loadu_pd(py.add(j)),
                _mm256_loadu_pd(pz.add(j)),
            );
            _mm256_storeu_pd(
                a.add(j),
                _mm256_add_pd(_mm256_loadu_pd(a.add(j)), entry(wa, x, y, z)),
            );
            _mm256_storeu_pd(
                b.add(j),
                _mm256_add_pd(_mm256_loadu_pd(b.add(j)), entry(wb, x, y, z)),
            );
            j += 4;
        }
        if j < n {
            let k = tail(n - j);
            let (x, y, z) = (
                _mm256_maskload_pd(px.add(j), k),
                _mm256_maskload_pd(py.add(j), k),
                _mm256_maskload_pd(pz.add(j), k),
            );
            let va = _mm256_add_pd(_mm256_maskload_pd(a.add(j), k), entry(wa, x, y, z));
            let vb = _mm256_add_pd(_mm256_maskload_pd(b.add(j), k), entry(wb, x, y, z));
            _mm256_maskstore_pd(a.add(j), k, va);
            _mm256_maskstore_pd(b.add(j), k, vb);
            j = n;
        }
        span(b, wb, (px, py, pz), j, hi + 1);
    }
    for &i in pairs.remainder() {
        span(
            m.add(i * stride),
            weights(cx, cy, cz, i),
            (px, py, pz),
            0,
            i + 1,
        );
    }
}

/// The lanes `0..len` of a masked load or store (none for 0, all four from 4 on; also
/// `crate::compute::batch_avx2`'s masks).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn tail(len: usize) -> __m256i {
    let on = |lane: usize| if lane < len { -1 } else { 0 };
    _mm256_setr_epi64x(on(0), on(1), on(2), on(3))
}

/// Row `i`'s three column values, broadcast.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn weights(cx: &[f64], cy: &[f64], cz: &[f64], i: usize) -> [__m256d; 3] {
    [
        _mm256_set1_pd(cx[i]),
        _mm256_set1_pd(cy[i]),
        _mm256_set1_pd(cz[i]),
    ]
}

/// Four entries' `(xᵢ·xⱼ + yᵢ·yⱼ) + zᵢ·zⱼ`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn entry(w: [__m256d; 3], x: __m256d, y: __m256d, z: __m256d) -> __m256d {
    _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(w[0], x), _mm256_mul_pd(w[1], y)),
        _mm256_mul_pd(w[2], z),
    )
}

/// Entries `from..to` of `out += (w₀·x + w₁·y) + w₂·z` over the columns' entries (a row of
/// `JᵀJ`, or `Jᵀr` with `w` the residual); the last one to three entries masked.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn span(
    out: *mut f64,
    w: [__m256d; 3],
    (px, py, pz): (*const f64, *const f64, *const f64),
    from: usize,
    to: usize,
) {
    let mut j = from;
    while j + 4 <= to {
        let (x, y, z) = (
            _mm256_loadu_pd(px.add(j)),
            _mm256_loadu_pd(py.add(j)),
            _mm256_loadu_pd(pz.add(j)),
        );
        _mm256_storeu_pd(
            out.add(j),
            _mm256_add_pd(_mm256_loadu_pd(out.add(j)), entry(w, x, y, z)),
        );
        j += 4;
    }
    if j < to {
        let k = tail(to - j);
        let (x, y, z) = (
            _mm256_maskload_pd(px.add(j), k),
            _mm256_maskload_pd(py.add(j), k),
            _mm256_maskload_pd(pz.add(j), k),
        );
        let v = _mm256_add_pd(_mm256_maskload_pd(out.add(j), k), entry(w, x, y, z));
        _mm256_maskstore_pd(out.add(j), k, v);
    }
}
