// pmg/sparse/vector_ops.hpp — the few OpenMP-parallel vector primitives every Krylov method and
// smoother is written on (Eigen's own vector expressions run on one thread).
#pragma once

#include "pmg/sparse/types.hpp"

namespace pmg::ops {

double dot(const Vector& x, const Vector& y);
double norm2(const Vector& x);
/// y += a x
void axpy(double a, const Vector& x, Vector& y);
/// y = x + b y
void xpby(const Vector& x, double b, Vector& y);
/// True if every entry is finite.
bool all_finite(const Vector& x);

}  // namespace pmg::ops
