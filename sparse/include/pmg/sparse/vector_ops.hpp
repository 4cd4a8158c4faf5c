// pmg/sparse/vector_ops.hpp — the few OpenMP-parallel vector primitives every Krylov method and
// smoother is written on (Eigen's own vector expressions run on one thread).
#pragma once

#include "pmg/sparse/types.hpp"

#include <cstddef>
#include <vector>

namespace pmg::ops {

/// Σ a[k] b[k] over k < n on the calling thread, in a fixed order: eight partial sums over k mod 8,
/// added pairwise at the end. The same bits for the same inputs, and eight independent chains of
/// additions where one running sum waits on each addition's latency.
double dot_serial(const double* a, const double* b, std::ptrdiff_t n);
/// The same with a in float (each product formed in double).
double dot_serial(const float* a, const double* b, std::ptrdiff_t n);
/// xᵀy over fixed blocks of entries (dot_serial each), the blocks' sums added in order: the same
/// bits on any number of threads.
double dot(const Vector& x, const Vector& y);
/// The same in float, each product and sum formed in double.
double dot(const Eigen::VectorXf& x, const Eigen::VectorXf& y);
/// ‖x‖₂, without overflow or underflow for any finite x.
double norm2(const Vector& x);
/// y += a x
void axpy(double a, const Vector& x, Vector& y);
/// y = x + b y
void xpby(const Vector& x, double b, Vector& y);
/// True if every entry is finite.
bool all_finite(const Vector& x);
/// True if each of the n entries from x is finite (a matrix's values, say).
bool all_finite(const double* x, std::int64_t n);
/// z = D r, D block diagonal: 3x3 row-major blocks (9 doubles each), one per 3 entries of r.
void block_diagonal_apply(const std::vector<double>& D, const Vector& r, Vector& z);
/// z = D r for `blocks` 3x3 blocks on raw arrays (D: 9 doubles per block, r and z: 3 per block; z
/// must not alias r): the same kernel for vectors another library owns (a PETSc Vec's array).
void block_diagonal_apply(const double* D, const double* r, double* z, index_t blocks);
/// The same in float (a float cycle's or estimate's D⁻¹).
void block_diagonal_apply(const float* D, const float* r, float* z, index_t blocks);
/// r += a w, then z = D r, returning rᵀz, in one pass (a preconditioned CG step's residual update
/// with a block-diagonal D, as for block_diagonal_apply; a = 0 with w = r: z = D r and rᵀz). The
/// dot product sums fixed blocks of entries in order: the same bits on any number of threads.
/// z must not alias r or w.
double block_diagonal_update_dot(double a, const Vector& w, const std::vector<double>& D, Vector& r, Vector& z);
/// The same in float (D: 9 floats per block; a rounded to float), the sum formed in double.
double block_diagonal_update_dot(double a, const Eigen::VectorXf& w, const std::vector<float>& D, Eigen::VectorXf& r,
                                 Eigen::VectorXf& z);
/// y = x + b y in float (b rounded to float).
void xpby(const Eigen::VectorXf& x, double b, Eigen::VectorXf& y);
/// x += a D r, D as for block_diagonal_apply.
void block_diagonal_axpy(double a, const std::vector<double>& D, const Vector& r, Vector& x);

}  // namespace pmg::ops
