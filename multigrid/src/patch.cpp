#include "pmg/multigrid/patch.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/timer.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cstdio>
#include <string>

namespace pmg::mg {

PatchSchwarz::PatchSchwarz(std::vector<std::vector<index_t>> patches) : patches_(std::move(patches)) {
  if (patches_.empty()) throw InputError("patch: no patches (the levels define no vertex patches)");
  for (size_t p = 0; p < patches_.size(); ++p)
    if (patches_[p].empty()) throw InputError("patch: patch " + std::to_string(p) + " is empty");
}

void PatchSchwarz::setup_impl(const LinearOperator& A) {
  check_interleaved(A, "patch");
  A_ = dynamic_cast<const Bcsr*>(&A);
  if (!A_)
    throw InputError("patch: the patch matrices are read from the level's assembled matrix (BCSR); this level "
                     "is applied without one (use operator=assembled)");
  const index_t rows = A_->pattern().rows;
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
    factor_offset_[p + 1] = factor_offset_[p] + n * n;
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
  factors_.assign(factor_offset_.back(), 0.0);
  corrections_.assign(offset_.back(), 0.0);
  factorise();
}

void PatchSchwarz::update_impl() { factorise(); }

void PatchSchwarz::factorise() {
  const auto t0 = Clock::now();
  const BlockPattern& pattern = A_->pattern();
  const index_t rows = pattern.rows;
  const auto num = static_cast<std::ptrdiff_t>(patches_.size());
  std::ptrdiff_t failed = -1;
#pragma omp parallel
  {
    std::vector<int> local(static_cast<size_t>(rows), -1);  // block row -> position in the patch
#pragma omp for schedule(dynamic, 8)
    for (std::ptrdiff_t p = 0; p < num; ++p) {
      const std::vector<index_t>& P = patches_[p];
      const auto n = static_cast<Eigen::Index>(3 * P.size());
      Eigen::Map<Eigen::MatrixXd> M(factors_.data() + factor_offset_[p], n, n);
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
      }
    }
  }
  if (failed >= 0)
    throw InputError("patch: the local matrix of patch " + std::to_string(failed) + " (" +
                     std::to_string(patches_[failed].size()) +
                     " nodes) is not positive definite: the level's matrix is singular or indefinite there "
                     "(a part held by no clamp, or a material with nu >= 0.5)");
  seconds_ = seconds_since(t0);
}

void PatchSchwarz::apply_impl(const Vector& r, Vector& z) const {
  const auto num = static_cast<std::ptrdiff_t>(patches_.size());
  double* c = corrections_.data();
#pragma omp parallel for schedule(dynamic, 8)
  for (std::ptrdiff_t p = 0; p < num; ++p) {
    const std::vector<index_t>& P = patches_[p];
    const auto n = static_cast<Eigen::Index>(3 * P.size());
    Eigen::Map<Eigen::VectorXd> y(c + offset_[p], n);
    for (size_t k = 0; k < P.size(); ++k)
      for (int d = 0; d < 3; ++d) y[3 * static_cast<Eigen::Index>(k) + d] = r[3 * static_cast<Eigen::Index>(P[k]) + d];
    const Eigen::Map<const Eigen::MatrixXd> L(factors_.data() + factor_offset_[p], n, n);
    L.triangularView<Eigen::Lower>().solveInPlace(y);
    L.triangularView<Eigen::Lower>().transpose().solveInPlace(y);
  }
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
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "additive Schwarz on %zu patches of up to %zu unknowns; factors %.1f MB (%.0f bytes per unknown), "
                "factorised in %.3f s",
                patches_.size(), largest_, factor_bytes() / 1e6,
                static_cast<double>(factor_bytes()) / static_cast<double>(A_->rows()), seconds_);
  return buf;
}

}  // namespace pmg::mg
