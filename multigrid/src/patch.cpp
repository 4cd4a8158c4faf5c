#include "pmg/multigrid/patch.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/timer.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace pmg::mg {

void PatchParams::visit(ParamVisitor& v) {
  v.choice("factors", single, {{"double", false}, {"float", true}},
           "precision of the stored patch inverses and their products (float: half the memory and bytes; "
           "factorised and inverted in double, summed in double)");
}

PatchSchwarz::PatchSchwarz(std::vector<std::vector<index_t>> patches, const PatchParams& params)
    : patches_(std::move(patches)), params_(params) {
  if (patches_.empty()) throw InputError("patch: no patches (the levels define no vertex patches)");
  for (size_t p = 0; p < patches_.size(); ++p)
    if (patches_[p].empty()) throw InputError("patch: patch " + std::to_string(p) + " is empty");
}

void PatchSchwarz::setup_impl(const LinearOperator& A) {
  check_interleaved(A, "patch");
  A_ = nullptr;
  const Bcsr* B = A.bcsr_matrix();
  if (!B)
    throw InputError("patch: the patch matrices are read from the level's assembled matrix (BCSR); this level "
                     "is applied without one (use operator=assembled)");
  const index_t rows = B->pattern().rows;
  offset_.assign(patches_.size() + 1, 0);
  factor_offset_.assign(patches_.size() + 1, 0);
  std::vector<size_t> count(static_cast<size_t>(rows) + 1, 0);
  largest_ = 0;
  for (size_t p = 0; p < patches_.size(); ++p) {
    const std::vector<index_t>& P = patches_[p];
    for (size_t k = 0; k < P.size(); ++k) {
      if (P[k] < 0 || P[k] >= rows)
        throw InputError("patch: patch " + std::to_string(p) + " names block row " + std::to_string(P[k]) +
                         " of a matrix with " + std::to_string(rows));
      if (k > 0 && P[k] <= P[k - 1])
        throw InputError("patch: the rows of patch " + std::to_string(p) + " are not ascending without repeats");
      ++count[P[k] + 1];
    }
    const size_t n = 3 * P.size();
    offset_[p + 1] = offset_[p] + n;
    factor_offset_[p + 1] = factor_offset_[p] + n * (n + 1) / 2;  // the lower triangle, packed
    largest_ = std::max(largest_, n);
  }
  // Every row needs a patch: an unknown in none would never be corrected.
  for (index_t i = 0; i < rows; ++i)
    if (count[i + 1] == 0)
      throw InputError("patch: block row " + std::to_string(i) + " lies in no patch (the patches must cover the level)");
  incidence_ptr_.assign(static_cast<size_t>(rows) + 1, 0);
  for (index_t i = 0; i < rows; ++i) incidence_ptr_[i + 1] = incidence_ptr_[i] + count[i + 1];
  incidence_.resize(incidence_ptr_.back());
  std::vector<size_t> fill(incidence_ptr_.begin(), incidence_ptr_.end() - 1);
  for (size_t p = 0; p < patches_.size(); ++p)
    for (size_t k = 0; k < patches_[p].size(); ++k) incidence_[fill[patches_[p][k]]++] = offset_[p] + 3 * k;
  corrections_.assign(offset_.back(), 0.0);
  A_ = B;
  try {
    factorise();
  } catch (...) {
    A_ = nullptr;  // not set up: describe() must not read a matrix that may be gone
    throw;
  }
}

void PatchSchwarz::update_impl() { factorise(); }

void PatchSchwarz::factorise() {
  const auto t0 = Clock::now();
  // Rounding an inverse S = A_P⁻¹ of n unknowns to float perturbs it by at most
  // ||δS||₂ ≤ ||δS||_F ≤ 2⁻²⁴ ||S||_F ≤ 2⁻²⁴ √n ||S||₂, which keeps S positive definite while
  // 2⁻²⁴ √n cond₂(A_P) < 1; cond₂ ≤ cond₁ for a symmetric matrix, and LLT::rcond() estimates
  // 1 / cond₁. Below twice that bound the inverses are kept in double.
  const double float_rcond = 2.0 * std::sqrt(static_cast<double>(largest_)) * std::ldexp(1.0, -24);
  single_ = params_.single;
  min_rcond_ = invert(single_);
  if (single_ && min_rcond_ < float_rcond) {
    single_ = false;
    invert(false);
  }
  seconds_ = seconds_since(t0);
}

double PatchSchwarz::invert(bool single) {
  if (single) factors_single_.assign(factor_offset_.back(), 0.0f), factors_ = {};
  else factors_.assign(factor_offset_.back(), 0.0), factors_single_ = {};
  const BlockPattern& pattern = A_->pattern();
  const index_t rows = pattern.rows;
  const auto num = static_cast<std::ptrdiff_t>(patches_.size());
  std::ptrdiff_t failed = -1;
  double min_rcond = 1.0;
#pragma omp parallel reduction(min : min_rcond)
  {
    // Work space of this thread, allocated before the loop: nothing in it allocates or throws.
    std::vector<int> local(static_cast<size_t>(rows), -1);  // block row -> position in the patch
    std::vector<double> scratch(largest_ * largest_), inverse(largest_ * largest_);
#pragma omp for schedule(dynamic, 8)
    for (std::ptrdiff_t p = 0; p < num; ++p) {
      const std::vector<index_t>& P = patches_[p];
      const auto n = static_cast<Eigen::Index>(3 * P.size());
      Eigen::Map<Eigen::MatrixXd> M(scratch.data(), n, n);
      M.setZero();
      for (size_t k = 0; k < P.size(); ++k) local[P[k]] = static_cast<int>(k);
      for (size_t k = 0; k < P.size(); ++k)
        for (offset_t b = pattern.row_ptr[P[k]]; b < pattern.row_ptr[P[k] + 1]; ++b) {
          const int j = local[pattern.col_idx[b]];
          if (j >= 0) M.block<3, 3>(3 * static_cast<Eigen::Index>(k), 3 * j) = A_->block(b);
        }
      for (const index_t i : P) local[i] = -1;
      Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(M);  // in place: M's lower triangle becomes L
      if (llt.info() != Eigen::Success) {
#pragma omp critical(patch_failure)
        if (failed < 0 || p < failed) failed = p;
        continue;
      }
      min_rcond = std::min(min_rcond, llt.rcond());
      // A_P⁻¹ = L⁻ᵀ L⁻¹, its lower triangle stored packed: one pass over it per application, which
      // measured faster than two triangular solves with L, than Eigen's product with the whole
      // inverse and than its product with a triangle of a full matrix (CHANGELOG).
      Eigen::Map<Eigen::MatrixXd> Inv(inverse.data(), n, n);
      Inv.setIdentity();
      llt.matrixL().solveInPlace(Inv);
      llt.matrixL().transpose().solveInPlace(Inv);
      M = Inv.transpose();  // L is no longer needed: its storage takes the transpose
      Inv = 0.5 * (Inv + M);  // exactly symmetric, in either precision
      // Packed column by column: column j holds S(j..n-1, j).
      size_t at = factor_offset_[p];
      for (Eigen::Index j = 0; j < n; ++j)
        for (Eigen::Index i = j; i < n; ++i, ++at) {
          if (single) factors_single_[at] = static_cast<float>(Inv(i, j));
          else factors_[at] = Inv(i, j);
        }
    }
  }
  if (failed >= 0)
    throw InputError("patch: the local matrix of patch " + std::to_string(failed) + " (" +
                     std::to_string(patches_[failed].size()) +
                     " nodes) is not positive definite: the level's matrix is singular or indefinite there "
                     "(a part held by no clamp, or a material with nu >= 0.5)");
  return min_rcond;
}

// Every patch's A_P⁻¹ R_P r into corrections_, in the factors' precision T.
template <typename T>
void PatchSchwarz::solve_patches(const std::vector<T>& factors, const Vector& r) const {
  using Vec = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  const auto num = static_cast<std::ptrdiff_t>(patches_.size());
  double* c = corrections_.data();
#pragma omp parallel
  {
    Vec y(static_cast<Eigen::Index>(largest_)), w(static_cast<Eigen::Index>(largest_));
#pragma omp for schedule(dynamic, 8)
    for (std::ptrdiff_t p = 0; p < num; ++p) {
      const std::vector<index_t>& P = patches_[p];
      const auto n = static_cast<Eigen::Index>(3 * P.size());
      auto yp = y.head(n);
      for (size_t k = 0; k < P.size(); ++k)
        for (int d = 0; d < 3; ++d)
          yp[3 * static_cast<Eigen::Index>(k) + d] = static_cast<T>(r[3 * static_cast<Eigen::Index>(P[k]) + d]);
      // out = S yp from the packed lower triangle, each stored entry read once: column j gives
      // out_j += S(j.., j) · yp(j..) and out(j+1..) += yp_j S(j+1.., j).
      auto out = w.head(n);
      out.setZero();
      const T* col = factors.data() + factor_offset_[p];
      for (Eigen::Index j = 0; j < n; ++j) {
        const Eigen::Map<const Vec> Sj(col, n - j);
        out[j] += Sj.dot(yp.segment(j, n - j));
        out.segment(j + 1, n - j - 1) += yp[j] * Sj.tail(n - j - 1);
        col += n - j;
      }
      for (Eigen::Index a = 0; a < n; ++a) c[offset_[p] + a] = static_cast<double>(out[a]);
    }
  }
}

void PatchSchwarz::apply_impl(const Vector& r, Vector& z) const {
  if (single_) solve_patches(factors_single_, r);
  else solve_patches(factors_, r);
  const double* c = corrections_.data();
  z.resize(r.size());
  const auto rows = static_cast<std::ptrdiff_t>(incidence_ptr_.size() - 1);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < rows; ++i) {
    double s0 = 0, s1 = 0, s2 = 0;
    for (size_t k = incidence_ptr_[i]; k < incidence_ptr_[i + 1]; ++k) {
      const double* v = c + incidence_[k];
      s0 += v[0], s1 += v[1], s2 += v[2];
    }
    z[3 * i] = s0, z[3 * i + 1] = s1, z[3 * i + 2] = s2;
  }
}

std::string PatchSchwarz::describe() const {
  if (!A_) return "additive Schwarz on " + std::to_string(patches_.size()) + " patches (not set up)";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "additive Schwarz on %zu patches of up to %zu unknowns; %s inverses %.1f MB (%.0f bytes per unknown)%s, "
                "smallest reciprocal condition number %.1e, set up in %.3f s",
                patches_.size(), largest_, single_ ? "float" : "double", factor_bytes() / 1e6,
                static_cast<double>(factor_bytes()) / static_cast<double>(A_->rows()),
                params_.single && !single_ ? " (float would not keep every patch definite)" : "", min_rcond_, seconds_);
  return buf;
}

}  // namespace pmg::mg
