//! faer's owned matrices (the fit's Jacobians and their products) read a
//! column at a time: as contiguous slices, and copied into nalgebra's dense
//! matrices for the small solves of the diagnosis (both store by columns);
//! and the scale of a normal matrix to a unit diagonal, which the fit, the
//! folds and the deleted residuals all solve in.

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, Par};
use nalgebra::{DMatrix, DVector};

/// Why a column of an owned matrix is a slice.
pub const CONTIGUOUS: &str = "a column of an owned matrix is contiguous";

/// Column `c` of `m`.
pub fn column(m: &Mat<f64>, c: usize) -> &[f64] {
    m.col(c).try_as_col_major().expect(CONTIGUOUS).as_slice()
}

/// `m` as nalgebra's dense matrix.
pub fn to_nalgebra(m: &Mat<f64>) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(m.nrows(), m.ncols());
    for (c, mut into) in out.column_iter_mut().enumerate() {
        into.as_mut_slice().copy_from_slice(column(m, c));
    }
    out
}

/// The single column of `v` as nalgebra's vector.
pub fn to_vector(v: &Mat<f64>) -> DVector<f64> {
    DVector::from_column_slice(column(v, 0))
}

/// The normal equations `(JᵀJ, Jᵀr)` of rows `j`, `r`: the lower half of
/// `JᵀJ` by one product (half the work of the whole), mirrored.
pub fn normal_equations(j: &Mat<f64>, r: &Mat<f64>) -> (DMatrix<f64>, DVector<f64>) {
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
    let mut a = to_nalgebra(&a);
    a.fill_upper_triangle_with_lower_triangle();
    let b = j.transpose() * r;
    (a, to_vector(&b))
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
