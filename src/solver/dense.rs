//! Small dense symmetric systems solved by Cholesky: the exact solves of small islands
//! (the soft step's islands of lopsided masses or deep overlaps, classic PGS's chains of
//! joints).

/// A pivot left with this share of its row's diagonal or less belongs to a row that
/// depends on the rows before it, to the rounding of the f32 Jacobians the matrix is
/// made of (a box's two friction rows on a face are one row twice; a closed loop of
/// joints).
const DEPENDENT: f64 = 1e-6;

/// Factors K = L L^T in place (K symmetric positive semi-definite, n x n, row-major; L
/// is left in the lower triangle). K's entries more than `band` rows off the diagonal
/// must be zero (a chain of joints in order; `band` = n for a full K): L keeps the band,
/// so only the band is worked, n band^2 operations instead of n^3 / 6. A row that
/// depends on the rows before it ([`DEPENDENT`]) gets an infinite pivot, so
/// [`solve_banded`] gives it y = 0 and the others carry what it would have: one of the
/// solutions where K is singular and r consistent. Returns false if K is not finite or
/// a pivot is negative past that rounding (K indefinite).
pub(crate) fn factor_banded(k: &mut [f64], n: usize, band: usize) -> bool {
    for j in 0..n {
        let diag = k[j * n + j];
        let mut d = diag;
        let first = j.saturating_sub(band);
        let last = (j + band + 1).min(n);
        for p in first..j {
            d -= k[j * n + p] * k[j * n + p];
        }
        if !d.is_finite() || diag <= 0.0 || d < -DEPENDENT * diag {
            return false;
        }
        if d <= DEPENDENT * diag {
            // L_jj = inf: y_j = 0 and column j below is 0 (each used only as a divisor)
            k[j * n + j] = f64::INFINITY;
            for i in j + 1..last {
                k[i * n + j] = 0.0;
            }
            continue;
        }
        let d = d.sqrt();
        k[j * n + j] = d;
        for i in j + 1..last {
            let mut s = k[i * n + j];
            for p in i.saturating_sub(band)..j {
                s -= k[i * n + p] * k[j * n + p];
            }
            k[i * n + j] = s / d;
        }
    }
    true
}

/// Solves K y = r in place (y holds r on entry) with K factored by [`factor_banded`]
/// of the same band.
pub(crate) fn solve_banded(l: &[f64], y: &mut [f64], n: usize, band: usize) {
    // L z = r, then L^T y = z
    for i in 0..n {
        let mut s = y[i];
        for p in i.saturating_sub(band)..i {
            s -= l[i * n + p] * y[p];
        }
        y[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for p in i + 1..(i + band + 1).min(n) {
            s -= l[p * n + i] * y[p];
        }
        y[i] = s / l[i * n + i];
    }
}

/// K y = r in place for a full K: [`factor_banded`], then [`solve_banded`], at band n.
/// Returns false (y untouched) where K cannot be factored.
pub(crate) fn cholesky_solve(k: &mut [f64], y: &mut [f64], n: usize) -> bool {
    if !factor_banded(k, n, n) {
        return false;
    }
    solve_banded(k, y, n, n);
    true
}

#[cfg(test)]
mod tests {
    use super::cholesky_solve;

    #[test]
    fn cholesky_solves_a_small_spd_system() {
        // K = [[4, 2], [2, 3]], K y = [2, 1] -> y = [0.5, 0]
        let mut k = vec![4.0, 2.0, 2.0, 3.0];
        let mut y = vec![2.0, 1.0];
        assert!(cholesky_solve(&mut k, &mut y, 2));
        assert!((y[0] - 0.5).abs() < 1e-12 && y[1].abs() < 1e-12, "{y:?}");
        let mut k = vec![1.0, 2.0, 2.0, 1.0];
        let mut y = vec![1.0, 1.0];
        assert!(!cholesky_solve(&mut k, &mut y, 2), "indefinite");
    }

    #[test]
    fn cholesky_gives_a_dependent_row_nothing_and_still_solves() {
        // rows 0 and 2 are one row twice (to a rounding of 1e-9): K y = r has many
        // solutions; the one given puts nothing on row 2 and meets every equation
        let k0 = [2.0, 1.0, 2.0, 1.0, 3.0, 1.0, 2.0, 1.0, 2.0 + 1e-9];
        let r = [4.0, 5.0, 4.0];
        let (mut k, mut y) = (k0.to_vec(), r.to_vec());
        assert!(cholesky_solve(&mut k, &mut y, 3));
        assert_eq!(y[2], 0.0);
        for i in 0..3 {
            let ky: f64 = (0..3).map(|j| k0[i * 3 + j] * y[j]).sum();
            assert!((ky - r[i]).abs() < 1e-6, "row {i}: {ky} against {}", r[i]);
        }
    }

    #[test]
    fn a_banded_factor_solves_as_the_full_one() {
        // a tridiagonal K (band 1) of a chain: the banded and the full solve agree
        let n = 6;
        let mut k0 = vec![0.0; n * n];
        for i in 0..n {
            k0[i * n + i] = 4.0 + i as f64;
            if i + 1 < n {
                k0[i * n + i + 1] = -1.5;
                k0[(i + 1) * n + i] = -1.5;
            }
        }
        let r: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let (mut kb, mut yb) = (k0.clone(), r.clone());
        assert!(super::factor_banded(&mut kb, n, 1));
        super::solve_banded(&kb, &mut yb, n, 1);
        let (mut kf, mut yf) = (k0.clone(), r.clone());
        assert!(cholesky_solve(&mut kf, &mut yf, n));
        for i in 0..n {
            let ky: f64 = (0..n).map(|j| k0[i * n + j] * yb[j]).sum();
            assert!((ky - r[i]).abs() < 1e-12, "row {i}: {ky} against {}", r[i]);
            assert!((yb[i] - yf[i]).abs() < 1e-12);
        }
    }
}
