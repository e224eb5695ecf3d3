//! faer's owned matrices (the fit's Jacobians and their products) read a
//! column at a time, as contiguous slices; the normal equations of some rows,
//! in faer like the rows themselves (the folds' training sets, which the
//! cross-validation and the test of alike causes solve with faer's Cholesky
//! factor); and the scale of a normal matrix to a unit diagonal, which the
//! fit, the folds and the deleted residuals all solve in.

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Col, Mat, Par};

/// Why a column of an owned matrix is a slice.
pub const CONTIGUOUS: &str = "a column of an owned matrix is contiguous";

/// Column `c` of `m`.
pub fn column(m: &Mat<f64>, c: usize) -> &[f64] {
    m.col(c).try_as_col_major().expect(CONTIGUOUS).as_slice()
}

/// The normal equations `(JᵀJ, Jᵀr)` of rows `j`, `r`: the lower half of
/// `JᵀJ` by one product (half the work of the whole), mirrored.
pub fn normal_equations(j: &Mat<f64>, r: &Mat<f64>) -> (Mat<f64>, Col<f64>) {
    let mut a = Mat::zeros(j.ncols(), j.ncols());
    triangular::matmul(
        a.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        j.transpose(),
        BlockStructure::Rectangular,
        j,
        BlockStructure::Rectangular,
        1.0,
        Par::Seq,
    );
    mirror_lower(&mut a);
    let b = j.transpose() * r;
    (a, b.col(0).to_owned())
}

/// `m`'s strictly upper triangle set to its lower one: a symmetric matrix of
/// which a product computed the lower half.
fn mirror_lower(m: &mut Mat<f64>) {
    for c in 1..m.ncols() {
        for r in 0..c.min(m.nrows()) {
            m[(r, c)] = m[(c, r)];
        }
    }
}

/// The factors `1/√G_kk` that scale a normal matrix `G = JᵀJ` to a unit diagonal
/// (its columns of `J` to unit norm); 0 for a zero column, which cannot move anything.
pub fn unit_diagonal_scale(g: &Mat<f64>) -> Vec<f64> {
    (0..g.nrows()).map(|k| unit_scale(g[(k, k)])).collect()
}

/// The factor `1/√d` that scales a normal matrix's diagonal entry `d` to 1; 0
/// for a zero column.
pub fn unit_scale(d: f64) -> f64 {
    if d > 0.0 { 1.0 / d.sqrt() } else { 0.0 }
}
