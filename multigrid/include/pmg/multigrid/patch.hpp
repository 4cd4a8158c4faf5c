// pmg/multigrid/patch.hpp — additive Schwarz on vertex patches, the smoother that keeps p-multigrid
// robust for nearly incompressible materials and thin parts.
//
// Each patch P (a set of a level's nodes, LevelProvider::vertex_patches(): the open star of a mesh
// vertex) has the dense local matrix A_P = R_P A R_Pᵀ of its 3|P| unknowns, read from the level's
// assembled matrix, factorised (Cholesky) and inverted once per set-up or update. One application is
//
//   z = Σ_P R_Pᵀ A_P⁻¹ R_P r,
//
// symmetric and positive definite: the preconditioner of Chebyshev smoothing (smoother=chebyshev
// with preconditioner=patch, the Chebyshev polynomial then in M⁻¹A) or of Richardson. On the open
// vertex star the local spaces hold the divergence-free functions that point smoothers miss as
// λ/μ grows (J. Schöberl, "Robust multigrid methods for parameter dependent problems", PhD thesis,
// Linz 1999; P. E. Farrell, M. G. Knepley, L. Mitchell and F. Wechsung, "PCPATCH: software for the
// topological construction of multigrid relaxation methods", ACM TOMS 47, 2021), and the strong
// couplings across a thin part's thickness.
//
// Patches are solved in parallel (each thread its own work vectors) into one correction per patch
// unknown; each unknown then sums its patches' corrections (a fixed order: the same result on any
// number of threads). Memory: the inverses' lower triangles, Σ_P n_P (n_P + 1) / 2 floats with
// n_P = 3|P| (doubles with factors=double); both this and the set-up cost are reported by
// describe().
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/solver.hpp"

#include <vector>

namespace pmg::mg {

/// Parameters of PatchSchwarz (solver keys: see visit()).
struct PatchParams {
  /// Precision of the stored patch inverses and of their products: float (the default: half the
  /// memory and bytes per application; the same iterations as double on the cubic Homer at
  /// ν = 0.3 and 0.499, docs/robustness.md) or double. Factorisation and inversion run in double,
  /// the patch vectors are summed in double. Float falls back to double where a patch is too
  /// ill-conditioned for float to keep M positive definite (describe() says so).
  bool single = true;
  /// The key factors.
  void visit(ParamVisitor& v);
};

/// Additive Schwarz on node patches (see the file comment), as a Solver: apply(r, z) gives z.
class PatchSchwarz final : public Solver {
 public:
  /// Patches of block rows (each non-empty, ascending, no repeats; checked at setup() against the
  /// matrix's size). Throws InputError for no patches or an empty one.
  explicit PatchSchwarz(std::vector<std::vector<index_t>> patches, const PatchParams& params = {});
  std::string name() const override { return "patch"; }
  /// Number of patches.
  index_t num_patches() const { return static_cast<index_t>(patches_.size()); }
  /// Bytes of the stored patch inverses (0 before setup()).
  size_t factor_bytes() const { return factors_.size() * sizeof(double) + factors_single_.size() * sizeof(float); }
  /// Patches, their sizes, the factors' memory per unknown and the last set-up's time.
  std::string describe() const override;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  /// Reads every patch matrix from A's values, factorises and inverts it: in float where
  /// params_.single and every patch is well enough conditioned for it, else in double.
  void factorise();
  /// The inverses in float or double; returns the smallest reciprocal condition number (1-norm
  /// estimate) over the patches. Throws InputError naming a patch that is not positive definite.
  double invert(bool single);
  template <typename T>
  void solve_patches(const std::vector<T>& factors, const Vector& r) const;

  std::vector<std::vector<index_t>> patches_;
  const Bcsr* A_ = nullptr;
  std::vector<size_t> offset_;        ///< [p]: patch p's first unknown in the concatenated patch vectors
  std::vector<size_t> factor_offset_; ///< [p]: patch p's inverse in factors_ or factors_single_
  PatchParams params_;
  bool single_ = false;     ///< the inverses in float (params_.single, unless a patch was too ill-conditioned)
  double min_rcond_ = 0.0;  ///< the smallest reciprocal condition number of the last set-up
  std::vector<double> factors_;        ///< the patch inverses' lower triangles, packed by columns (or empty)
  std::vector<float> factors_single_;  ///< the same in float (params_.single only)
  /// Per unknown of A: its positions in the concatenated patch vectors (CSR over rows).
  std::vector<size_t> incidence_ptr_, incidence_;
  mutable std::vector<double> corrections_;  ///< concatenated A_P⁻¹ R_P r
  double seconds_ = 0.0;                     ///< the last factorisation
  size_t largest_ = 0;                       ///< unknowns of the largest patch
};

}  // namespace pmg::mg
