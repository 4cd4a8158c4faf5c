// pmg/fem/element_kernel.hpp — the matrix-free element algorithm of pmg/fem/matrix_free.hpp as
// plain __host__ __device__ functions (PMG_HOST_DEVICE), for a GPU operator and its host tests.
//
// Element data, kElementData = 16 doubles per element (ElasticityOperator::element_arrays()):
//   d[0..11]  g_k = R ∇λ_k, row-major 4x3 (rest gradients rotated by the element's rotation R)
//   d[12]     6V p² s λ_e      d[13]  6V p² s μ_e      d[14]  6V ρ m      d[15]  unused
// (s: stiffness weight, m: mass weight, λ_e μ_e: the element's Lamé parameters).
//
// element_apply_lean computes r_e = (m M_e + s K_R,e) u_e by the five steps of matrix_free.hpp,
// but with no element-sized arrays: the gradient coefficients H_β are recomputed for every moment
// γ (Q² instead of Q gradient evaluations), coefficients are read through load(a, i) and results
// added through add(a, i, v). That keeps a GPU thread's registers to a few dozen doubles (no
// spills at p = 3, where the CPU kernel's arrays take 210 doubles) at the price of about 4x the
// flops of steps 1–2. Which layout is faster on a GPU (this, or elements spread over a warp with
// shared memory) is to be measured on a device.
#pragma once

#include "pmg/sparse/block3.hpp"

namespace pmg::fem {

/// Doubles of element data per element (see the file comment).
constexpr int kElementData = 16;

/// Nodes of a degree-p tetrahedron, (p+1)(p+2)(p+3)/6.
constexpr int element_nodes(int p) { return (p + 1) * (p + 2) * (p + 3) / 6; }

/// The per-degree tables of the lean element kernel, as plain arrays (copied to a device as they
/// are). β, γ run over the degree-(p-1) multi-indices in the order of matrix_free.cpp.
template <int P>
struct ElementKernelTables {
  static constexpr int N = element_nodes(P);      ///< nodes per element
  static constexpr int Q = element_nodes(P - 1);  ///< gradient coefficients (degree p-1 multi-indices)
  int up[Q][4];          ///< local node of β + e_k
  double q[Q][Q];        ///< ∫ B^{p-1}_γ B^{p-1}_β / (6V)
  double mass[N][N];     ///< ∫ B^p_a B^p_b / (6V)
  double gdiag[N][16];   ///< G_aa (4x4, row-major): p² ∫ B^{p-1}_{a-e_k} B^{p-1}_{a-e_l} / (6V)
};

/// The tables of degree P = 1, 2, 3, built once (host only; defined in matrix_free.cpp).
template <int P>
const ElementKernelTables<P>& element_kernel_tables();

/// Step 3 of the element product: the isotropic stress T = cl tr(Ĥ) I + cm (Ĥ + Ĥᵀ) of a weighted
/// displacement gradient Ĥ (3x3, row-major), cl and cm the element's scaled Lamé coefficients.
PMG_HOST_DEVICE void isotropic_stress(const double h[9], double cl, double cm, double T[9]) {
  const double tr = cl * (h[0] + h[4] + h[8]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) T[3 * i + j] = cm * (h[3 * i + j] + h[3 * j + i]);
  T[0] += tr, T[4] += tr, T[8] += tr;
}

/// Accumulates r_e = (m M_e + s K_R,e) u_e for one element: load(a, i) gives component i of local
/// node a of u_e, add(a, i, v) adds v to component i of local node a of r_e (see the file comment).
template <int P, class Load, class Add>
PMG_HOST_DEVICE void element_apply_lean(const ElementKernelTables<P>& t, const double* d, Load&& load,
                                        Add&& add) {
  constexpr int N = ElementKernelTables<P>::N, Q = ElementKernelTables<P>::Q;
  const double cl = d[12], cm = d[13], cmass = d[14];
  // 5. mass: r_a += 6Vρm Σ_b P_ab u_b
  if (cmass != 0.0)
    for (int a = 0; a < N; ++a)
      for (int i = 0; i < 3; ++i) {
        double s = 0.0;
        for (int b = 0; b < N; ++b) s += t.mass[a][b] * load(b, i);
        add(a, i, cmass * s);
      }
  for (int c = 0; c < Q; ++c) {
    // 1–2. Ĥ_γ = Σ_β Q_γβ Σ_k u_{β+e_k} g_kᵀ
    double h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int b = 0; b < Q; ++b) {
      const double w = t.q[c][b];
      for (int k = 0; k < 4; ++k) {
        const int a = t.up[b][k];
        const double* gk = d + 3 * k;
        for (int i = 0; i < 3; ++i) {
          const double wu = w * load(a, i);
          h[3 * i] += wu * gk[0];
          h[3 * i + 1] += wu * gk[1];
          h[3 * i + 2] += wu * gk[2];
        }
      }
    }
    double T[9];
    isotropic_stress(h, cl, cm, T);  // 3.
    // 4. r_{γ+e_k} += T g_k
    for (int k = 0; k < 4; ++k) {
      const int a = t.up[c][k];
      const double* gk = d + 3 * k;
      for (int i = 0; i < 3; ++i) add(a, i, T[3 * i] * gk[0] + T[3 * i + 1] * gk[1] + T[3 * i + 2] * gk[2]);
    }
  }
}

/// The 3x3 diagonal block of local node a of (m M_e + s K_R,e), row-major, into D:
///   S = gᵀ G_aa g (symmetrised),  D = (λ' + μ') S + (μ' tr S + 6Vρm P_aa) I,
/// λ' = d[12]/p², μ' = d[13]/p² (G_aa carries p²).
template <int P>
PMG_HOST_DEVICE void element_diagonal_block(const ElementKernelTables<P>& t, const double* d, int a, double D[9]) {
  const double* G = t.gdiag[a];
  const double lambda = d[12] / (P * P), mu = d[13] / (P * P);
  double S[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l < 4; ++l) s += d[3 * k + i] * G[4 * k + l] * d[3 * l + j];
      S[3 * i + j] = s;
    }
  const double tr = S[0] + S[4] + S[8];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) D[3 * i + j] = (lambda + mu) * 0.5 * (S[3 * i + j] + S[3 * j + i]);
  const double diag = mu * tr + d[14] * t.mass[a][a];
  D[0] += diag, D[4] += diag, D[8] += diag;
}

/// The per-step update of one element's data: d[0..11] = grad · Rᵀ (row k: R ∇λ_k), grad the rest
/// gradients (4x3 row-major), R the element's rotation (3x3 row-major; nullptr: the identity).
PMG_HOST_DEVICE void element_rotate(const double* grad, const double* R, double* d) {
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i)
      d[3 * k + i] = R ? R[3 * i] * grad[3 * k] + R[3 * i + 1] * grad[3 * k + 1] + R[3 * i + 2] * grad[3 * k + 2]
                       : grad[3 * k + i];
}

}  // namespace pmg::fem
