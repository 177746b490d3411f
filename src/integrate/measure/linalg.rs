//! The linear algebra of the fast path: dot products of node values with hat moments, the
//! matrix product that evaluates a whole table at once, and the tridiagonal solve of a projection
//! onto hat functions; and the eigen-decomposition of a small symmetric matrix (a fitted form's
//! identifiability).

use rayon::prelude::*;

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A dense row-major matrix view.
#[derive(Debug, Clone, Copy)]
pub struct MatrixRef<'a> {
    pub data: &'a [f64],
    pub rows: usize,
    pub cols: usize,
}

impl<'a> MatrixRef<'a> {
    pub fn new(data: &'a [f64], rows: usize, cols: usize) -> Self {
        assert_eq!(data.len(), rows * cols, "matrix of {rows} x {cols} needs {} values", rows * cols);
        MatrixRef { data, rows, cols }
    }
}

/// `C = A B^T` for row-major `A` (m x k) and `B` (n x k), into row-major `C` (m x n), with the
/// rows of `C` split across threads. Each element is one dot product over `k` computed by the same
/// kernel whatever the split, so the result does not depend on the thread count.
pub fn multiply_transposed(a: MatrixRef, b: MatrixRef, c: &mut [f64]) {
    assert_eq!(a.cols, b.cols, "inner dimensions differ");
    assert_eq!(c.len(), a.rows * b.rows, "output size");
    let (k, n) = (a.cols, b.rows);
    const ROWS_PER_TASK: usize = 64;
    c.par_chunks_mut(ROWS_PER_TASK * n).enumerate().for_each(|(task, c_rows)| {
        let first = task * ROWS_PER_TASK;
        let m = c_rows.len() / n;
        let a_rows = &a.data[first * k..(first + m) * k];
        // SAFETY: the pointers and strides describe slices whose lengths were checked above:
        // A rows m x k (row stride k), B^T as k x n through B's strides (row stride 1, column
        // stride k), C m x n (row stride n); C does not alias A or B.
        unsafe {
            matrixmultiply::dgemm(
                m,
                k,
                n,
                1.0,
                a_rows.as_ptr(),
                k as isize,
                1,
                b.data.as_ptr(),
                1,
                k as isize,
                0.0,
                c_rows.as_mut_ptr(),
                n as isize,
                1,
            );
        }
    });
}

/// Solve `A x = b` for the symmetric tridiagonal `A` of `b.len()` rows with `diagonal(k)` on its
/// diagonal and `off(k)` at `(k, k + 1)` and `(k + 1, k)` (Thomas algorithm, no pivoting: `A` must
/// be diagonally dominant, as a Gram matrix of hat functions is).
pub fn solve_symmetric_tridiagonal(
    diagonal: impl Fn(usize) -> f64,
    off: impl Fn(usize) -> f64,
    mut b: Vec<f64>,
) -> Vec<f64> {
    let n = b.len() - 1;
    let mut c_prime = vec![0.0; n + 1];
    c_prime[0] = off(0) / diagonal(0);
    b[0] /= diagonal(0);
    for k in 1..=n {
        let denominator = diagonal(k) - off(k - 1) * c_prime[k - 1];
        c_prime[k] = if k < n { off(k) / denominator } else { 0.0 };
        b[k] = (b[k] - off(k - 1) * b[k - 1]) / denominator;
    }
    for k in (0..n).rev() {
        b[k] -= c_prime[k] * b[k + 1];
    }
    b
}

/// Eigenvalues and eigenvectors (columns of the row-major `n x n` result) of the symmetric
/// row-major `n x n` matrix `a`, by the cyclic Jacobi eigenvalue algorithm (Golub & Van Loan,
/// "Matrix Computations", 4th ed., sec. 8.5): sweeps of a Jacobi rotation per off-diagonal pair,
/// at most 100, until the off-diagonal part is negligible. For a small matrix (the few parameters
/// of a fitted form, whose identifiability reads it), simple and accurate to rounding. The
/// eigenvalues are in no particular order.
pub fn symmetric_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = a.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j].powi(2))
            .sum();
        let total: f64 = a.iter().map(|x| x * x).sum();
        if off <= 1e-30 * total || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_product_matches_the_definition() {
        let (m, k, n) = (70, 9, 13);
        let a: Vec<f64> = (0..m * k).map(|i| (i as f64 * 0.37).sin()).collect();
        let b: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.11).cos()).collect();
        let mut c = vec![0.0; m * n];
        multiply_transposed(MatrixRef::new(&a, m, k), MatrixRef::new(&b, n, k), &mut c);
        for i in 0..m {
            for j in 0..n {
                let expected: f64 = (0..k).map(|l| a[i * k + l] * b[j * k + l]).sum();
                assert!((c[i * n + j] - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn tridiagonal_solve_reproduces_the_right_hand_side() {
        let n = 9;
        let diagonal = |k: usize| 2.0 + 0.1 * k as f64;
        let off = |k: usize| 0.5 - 0.03 * k as f64;
        let x: Vec<f64> = (0..n).map(|k| (k as f64 * 0.7).cos()).collect();
        let b: Vec<f64> = (0..n)
            .map(|k| {
                let below = if k > 0 { off(k - 1) * x[k - 1] } else { 0.0 };
                let above = if k + 1 < n { off(k) * x[k + 1] } else { 0.0 };
                below + diagonal(k) * x[k] + above
            })
            .collect();
        let solved = solve_symmetric_tridiagonal(diagonal, off, b);
        for k in 0..n {
            assert!((solved[k] - x[k]).abs() < 1e-14, "row {k}: {} vs {}", solved[k], x[k]);
        }
    }

    #[test]
    fn symmetric_eigen_reconstructs_the_matrix_from_orthonormal_eigenvectors() {
        let n = 6;
        let b: Vec<f64> = (0..n * n).map(|i| (i as f64 * 0.43).sin()).collect();
        // A = B B^T: symmetric.
        let a: Vec<f64> = (0..n * n).map(|ij| (0..n).map(|k| b[ij / n * n + k] * b[ij % n * n + k]).sum()).collect();
        let (values, vectors) = symmetric_eigen(&a, n);
        for i in 0..n {
            for j in 0..n {
                let rebuilt: f64 = (0..n).map(|k| vectors[i * n + k] * values[k] * vectors[j * n + k]).sum();
                assert!((rebuilt - a[i * n + j]).abs() < 1e-12, "A[{i}][{j}]: {rebuilt} vs {}", a[i * n + j]);
                let dot: f64 = (0..n).map(|k| vectors[k * n + i] * vectors[k * n + j]).sum();
                assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12, "V^T V [{i}][{j}] = {dot}");
            }
        }
    }
}
