// The element kernels of the matrix-free elasticity operator (pmg/fem/matrix_free.hpp): the scalar
// reference product of one element, and the batched product of kBatch elements in SIMD lanes with
// its baseline, AVX2 and AVX-512 copies chosen at run time. matrix_free.cpp holds the operator
// (element data, threads, accumulation) and calls them through matrix_free_kernels.hpp.
#include "matrix_free_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#include <immintrin.h>
#endif

namespace pmg::fem {

using detail::kBatch;
using detail::kData;

namespace {

/// Local index (in multi_indices(P): vertices, edges 01 02 03 12 13 23 from first to second vertex,
/// faces 012 013 023 123) of the multi-index a, at compile time.
constexpr int local_index_of(int P, const int (&a)[4]) {
  int nz = 0, first = -1;
  for (int i = 0; i < 4; ++i)
    if (a[i] > 0) ++nz, first = first < 0 ? i : first;
  if (nz == 1) return first;
  constexpr int edges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  if (nz == 2)
    for (int e = 0; e < 6; ++e)
      if (a[edges[e][0]] > 0 && a[edges[e][1]] > 0) return 4 + e * (P - 1) + a[edges[e][1]] - 1;
  constexpr int faces[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
  for (int f = 0; f < 4; ++f)
    if (a[faces[f][0]] > 0 && a[faces[f][1]] > 0 && a[faces[f][2]] > 0) return 4 + 6 * (P - 1) + f;
  return -1;  // interior nodes: none for P <= 3
}

/// v[β][k] = local index of β + e_k, for the degree-(P-1) multi-indices β in the order of Tables.
template <int P>
struct UpTable {
  int v[element_nodes(P - 1)][4] = {};
  constexpr UpTable() {
    int i = 0;
    for (int a = 0; a <= P - 1; ++a)
      for (int b = 0; a + b <= P - 1; ++b)
        for (int c = 0; a + b + c <= P - 1; ++c, ++i)
          for (int k = 0; k < 4; ++k) {
            int m[4] = {a, b, c, P - 1 - a - b - c};
            ++m[k];
            v[i][k] = local_index_of(P, m);
          }
  }
};

}  // namespace

// The per-degree tables (pmg/fem/element_kernel.hpp): q = ∫ B^{p-1}_γ B^{p-1}_β / (6V),
// mass = ∫ B^p_a B^p_b / (6V), up = the compile-time UpTable, gdiag = the G_aa of element_tables().
// The CPU kernels below read q and mass from the same object.
template <int P>
const ElementKernelTables<P>& element_kernel_tables() {
  static const ElementKernelTables<P> k = [] {
    ElementKernelTables<P> t{};
    constexpr int N = ElementKernelTables<P>::N, Q = ElementKernelTables<P>::Q;
    constexpr UpTable<P> up{};
    std::vector<MultiIndex> beta;
    for (int a = 0; a <= P - 1; ++a)
      for (int b = 0; a + b <= P - 1; ++b)
        for (int c = 0; a + b + c <= P - 1; ++c) beta.push_back({a, b, c, P - 1 - a - b - c});
    for (int i = 0; i < Q; ++i) {
      for (int kk = 0; kk < 4; ++kk) {
        MultiIndex a = beta[i];
        ++a[kk];
        if (up.v[i][kk] != local_index(a))  // the compile-time table follows multi_indices()
          throw std::logic_error("matrix-free operator: node order table out of date");
        t.up[i][kk] = up.v[i][kk];
      }
      for (int j = 0; j < Q; ++j) t.q[i][j] = bernstein_product_integral(beta[i], beta[j]);
    }
    const auto& alpha = multi_indices(P);
    const ElementTables& e = element_tables(P);
    for (int a = 0; a < N; ++a) {
      for (int b = 0; b < N; ++b) t.mass[a][b] = bernstein_product_integral(alpha[a], alpha[b]);
      for (int kk = 0; kk < 4; ++kk)
        for (int l = 0; l < 4; ++l) t.gdiag[a][4 * kk + l] = e.G[static_cast<size_t>(a * N + a)](kk, l);
    }
    return t;
  }();
  return k;
}
template const ElementKernelTables<1>& element_kernel_tables<1>();
template const ElementKernelTables<2>& element_kernel_tables<2>();
template const ElementKernelTables<3>& element_kernel_tables<3>();

namespace {

template <int P>
using Tables = ElementKernelTables<P>;

template <int P>
const Tables<P>& tables() {
  return element_kernel_tables<P>();
}

/// r = (m M_e + s K_R,e) u for one element (steps 1–5 of the header); u[a][i]: component i of
/// node a. The index table is a compile-time constant, so every loop unrolls to fixed offsets.
template <int P>
inline void element_apply(const Tables<P>& t, const double* d, const double (&u)[Tables<P>::N][3],
                          double (&r)[Tables<P>::N][3]) {
  constexpr int N = Tables<P>::N, Q = Tables<P>::Q;
  constexpr UpTable<P> up{};
  const double* g = d;
  const double cl = d[12], cm = d[13], cmass = d[14];
  // 1. H_β = Σ_k u_{β+e_k} g_kᵀ
  double H[Q][9];
  for (int b = 0; b < Q; ++b) {
    double h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      const double* ua = u[up.v[b][k]];
      const double* gk = g + 3 * k;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) h[3 * i + j] += ua[i] * gk[j];
    }
    for (int c = 0; c < 9; ++c) H[b][c] = h[c];
  }
  // 5. mass first (it initialises r): r_a = cmass Σ_b P_ab u_b
  if (cmass != 0.0) {
    // Component-major copies, so the loops over nodes run contiguously and vectorise.
    double ut[3][N], rt[3][N];
    for (int a = 0; a < N; ++a)
      for (int i = 0; i < 3; ++i) ut[i][a] = cmass * u[a][i], rt[i][a] = 0.0;
    for (int b = 0; b < N; ++b) {
      const double* pb = t.mass[b];  // P is symmetric: row b is column b
      for (int i = 0; i < 3; ++i) {
        const double w = ut[i][b];
        for (int a = 0; a < N; ++a) rt[i][a] += pb[a] * w;
      }
    }
    for (int a = 0; a < N; ++a)
      for (int i = 0; i < 3; ++i) r[a][i] = rt[i][a];
  } else {
    for (int a = 0; a < N; ++a) r[a][0] = r[a][1] = r[a][2] = 0.0;
  }
  for (int c = 0; c < Q; ++c) {
    // 2. Ĥ_γ = Σ_β Q_γβ H_β
    double h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int b = 0; b < Q; ++b) {
      const double w = t.q[c][b];
      for (int i = 0; i < 9; ++i) h[i] += w * H[b][i];
    }
    double T[9];
    isotropic_stress(h, cl, cm, T);  // 3.
    // 4. r_{γ+e_k} += T g_k
    for (int k = 0; k < 4; ++k) {
      double* ra = r[up.v[c][k]];
      const double* gk = g + 3 * k;
      for (int i = 0; i < 3; ++i) ra[i] += T[3 * i] * gk[0] + T[3 * i + 1] * gk[1] + T[3 * i + 2] * gk[2];
    }
  }
}

/// out += sign · (element products of x) over elements [begin, end) (n node indices per element, a
/// free index < 0 a fixed node: read as 0, not written; the data in the batch layout, element e at
/// position pos[e], or e where pos is nullptr).
template <int P>
inline void apply_range(const index_t* free, const double* batch_data, const index_t* pos, long begin, long end,
                        const double* xp, double* out, double sign) {
  const Tables<P>& t = tables<P>();
  constexpr int N = Tables<P>::N;
  for (long e = begin; e < end; ++e) {
    const index_t* f = free + static_cast<size_t>(e) * N;
    double u[N][3], r[N][3];
    for (int a = 0; a < N; ++a) {
      const index_t I = f[a];
      if (I >= 0) {
        const double* s = xp + 3 * static_cast<size_t>(I);
        u[a][0] = s[0], u[a][1] = s[1], u[a][2] = s[2];
      } else {
        u[a][0] = u[a][1] = u[a][2] = 0.0;
      }
    }
    double d[kData];
    const long at = pos ? static_cast<long>(pos[e]) : e;
    for (int k = 0; k < kData; ++k) d[k] = batch_data[detail::batch_datum(at, k)];
    element_apply<P>(t, d, u, r);
    for (int a = 0; a < N; ++a) {
      const index_t I = f[a];
      if (I < 0) continue;
      double* s = out + 3 * static_cast<size_t>(I);
      s[0] += sign * r[a][0], s[1] += sign * r[a][1], s[2] += sign * r[a][2];
    }
  }
}

// ---- Element batches in SIMD lanes ------------------------------------------------------------
//
// The product runs kBatch elements at a time (consecutive in the operator's batch order), one
// element per SIMD lane (deal.II's VectorizedArray layout): the element data is stored
// structure-of-arrays per batch (datum k of lane l at [k * kBatch + l]), node indices node-major
// ([a * kBatch + l]), and the kernel below is element_apply() with every scalar replaced by a
// vector of L lanes. A batch is gathered from x lane by lane and scattered into the accumulation
// vector lane by lane in order, so two elements of a batch may share a node. The last batch is
// padded with empty lanes (index -1, data 0).
//
// The vector type is GCC's vector extension (also Clang's): unlike std::experimental::simd, whose
// width is fixed by the flags of the translation unit, it compiles to the instruction set of the
// function it is in, so one source gives the baseline x86-64 path (SSE2, a 4-lane vector split in
// two) and AVX2 + FMA and AVX-512 copies chosen at run time (function target attributes); the
// arithmetic is only +, * and lane access, which the extension covers on every compiler pmgkit
// builds with.

/// L lanes of T as one vector of the extension.
template <class T, int L>
struct Lanes {
  typedef T type __attribute__((vector_size(L * sizeof(T))));
};

/// What the gather reads for a fixed node or a padding lane.
template <class T>
constexpr T kZeros[3] = {T(0), T(0), T(0)};

/// The degree-P tables in the kernel's precision.
template <int P, class T>
struct TablesIn {
  static constexpr int N = Tables<P>::N, Q = Tables<P>::Q;
  T q[Q][Q];
  T mass[N][N];
  TablesIn() {
    const Tables<P>& t = tables<P>();
    for (int i = 0; i < Q; ++i)
      for (int j = 0; j < Q; ++j) q[i][j] = static_cast<T>(t.q[i][j]);
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) mass[i][j] = static_cast<T>(t.mass[i][j]);
  }
};

template <int P, class T>
const TablesIn<P, T>& tables_in() {
  static const TablesIn<P, T> t;
  return t;
}

/// r = (m M_e + s K_R,e) u for the L elements of lanes [o, o + L) of one batch: element_apply()
/// lane-wise. d: the batch's kData x kBatch data.
template <int P, class T, int L>
inline void batch_apply(const TablesIn<P, T>& t, const T* d, int o, bool mass,
                        const typename Lanes<T, L>::type (&u)[Tables<P>::N][3],
                        typename Lanes<T, L>::type (&r)[Tables<P>::N][3]) {
  using V = typename Lanes<T, L>::type;
  constexpr int N = Tables<P>::N, Q = Tables<P>::Q;
  constexpr UpTable<P> up{};
  // Datum k of the L lanes (by reference: vector values never cross a function boundary, whose
  // ABI would depend on the instruction set).
  auto load = [&](V& v, int k) { __builtin_memcpy(&v, d + k * kBatch + o, sizeof(V)); };
  V g[4][3], cl, cm;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 3; ++j) load(g[k][j], 3 * k + j);
  load(cl, 12);
  load(cm, 13);
  // 1. E_β = H_β + H_βᵀ with H_β = Σ_k u_{β+e_k} g_kᵀ, its 6 components (00 11 22 01 02 12; the
  //    diagonal stored halved, i.e. H_ii): the stress needs only the symmetric part, and
  //    step 2 commutes with taking it, so the moments run on 6 components instead of 9.
  //    Every product is accumulated on its own (one fused multiply-add each), and the loops are
  //    unrolled so that the node table's entries become fixed offsets.
  V E[Q][6];
#pragma GCC unroll 20
  for (int b = 0; b < Q; ++b) {
    V h[6];
    for (int c = 0; c < 6; ++c) h[c] = V{};
#pragma GCC unroll 4
    for (int k = 0; k < 4; ++k) {
      const V* ua = u[up.v[b][k]];
      h[0] += ua[0] * g[k][0];
      h[1] += ua[1] * g[k][1];
      h[2] += ua[2] * g[k][2];
      h[3] += ua[0] * g[k][1];
      h[3] += ua[1] * g[k][0];
      h[4] += ua[0] * g[k][2];
      h[4] += ua[2] * g[k][0];
      h[5] += ua[1] * g[k][2];
      h[5] += ua[2] * g[k][1];
    }
    for (int c = 0; c < 6; ++c) E[b][c] = h[c];
  }
  // 5. mass first (it initialises r): r_a = cmass Σ_b P_ab u_b
  if (mass) {
    V cmass;
    load(cmass, 14);
    for (int a = 0; a < N; ++a) {
      V s[3] = {V{}, V{}, V{}};
      for (int b = 0; b < N; ++b) {
        const T w = t.mass[a][b];
        for (int i = 0; i < 3; ++i) s[i] += w * u[b][i];
      }
      for (int i = 0; i < 3; ++i) r[a][i] = cmass * s[i];
    }
  } else {
    for (int a = 0; a < N; ++a) r[a][0] = r[a][1] = r[a][2] = V{};
  }
  const V cm2 = cm + cm;
  for (int c = 0; c < Q; ++c) {
    // 2. Ê_γ = Σ_β Q_γβ E_β
    V h[6];
    for (int i = 0; i < 6; ++i) h[i] = V{};
    for (int b = 0; b < Q; ++b) {
      const T w = t.q[c][b];
      for (int i = 0; i < 6; ++i) h[i] += w * E[b][i];
    }
    // 3. T = cl tr(Ĥ) I + cm (Ĥ + Ĥᵀ): diagonal cl tr + 2 cm Ĥ_ii, off-diagonal cm Ê_ij
    const V tr = cl * (h[0] + h[1] + h[2]);
    const V t00 = tr + cm2 * h[0], t11 = tr + cm2 * h[1], t22 = tr + cm2 * h[2];
    const V t01 = cm * h[3], t02 = cm * h[4], t12 = cm * h[5];
    // 4. r_{γ+e_k} += T g_k
#pragma GCC unroll 4
    for (int k = 0; k < 4; ++k) {
      V* ra = r[up.v[c][k]];
      ra[0] += t00 * g[k][0];
      ra[0] += t01 * g[k][1];
      ra[0] += t02 * g[k][2];
      ra[1] += t01 * g[k][0];
      ra[1] += t11 * g[k][1];
      ra[1] += t12 * g[k][2];
      ra[2] += t02 * g[k][0];
      ra[2] += t12 * g[k][1];
      ra[2] += t22 * g[k][2];
    }
  }
}

/// out += sign · r, lane by lane in order (so a node two lanes share sums in element order), for
/// the L lanes at offset o of a batch with node indices f: index -1 is skipped, an index <= -2 is
/// shared slot -2 - index in shared_out (detail::SharedSlots).
template <class T, int L, int N>
inline void scatter_lanes(const index_t* f, int o, const typename Lanes<T, L>::type (&r)[N][3], T sign, T* out,
                          T* shared_out) {
  for (int l = 0; l < L; ++l)
    for (int a = 0; a < N; ++a) {
      const index_t I = f[a * kBatch + o + l];
      T* s;
      if (__builtin_expect(I >= 0, 1)) s = out + 3 * static_cast<size_t>(I);
      else if (I == -1) continue;
      else s = shared_out + 3 * static_cast<size_t>(-2 - I);
      s[0] += sign * r[a][0][l], s[1] += sign * r[a][1][l], s[2] += sign * r[a][2][l];
    }
}

/// out += sign · (element products of x) over batches [begin, end), L lanes at a time; an index
/// <= -2 is shared slot -2 - index (detail::SharedSlots).
/// Io (void: none) gathers one node of all L lanes: Io::gather(src, u) sets u[i][l] = src[l][i].
template <int P, class T, int L, class Io = void>
inline void apply_batches(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                          const index_t* shared, T* shared_out, T sign, bool mass) {
  constexpr bool Wide = !std::is_same_v<Io, void>;
  using V = typename Lanes<T, L>::type;
  constexpr int N = Tables<P>::N;
  const TablesIn<P, T>& t = tables_in<P, T>();
  for (long bt = begin; bt < end; ++bt) {
    const index_t* f = free + static_cast<size_t>(bt) * N * kBatch;
    const T* d = data + static_cast<size_t>(bt) * kData * kBatch;
    for (int o = 0; o < kBatch; o += L) {
      // Gathered lane by lane into vectors: by Io (one masked load per lane and a transposition:
      // the AVX2 and AVX-512 copies), else by inserts (up to 8 lanes) or through memory (16). A
      // fixed node or padding lane reads zeros, a shared slot its node.
      V u[N][3], r[N][3];
      for (int a = 0; a < N; ++a) {
        const T* src[L];
        for (int l = 0; l < L; ++l) {
          const index_t I = f[a * kBatch + o + l];
          src[l] = __builtin_expect(I >= 0, 1) ? xp + 3 * static_cast<size_t>(I)
                   : I == -1                   ? kZeros<T>
                                               : xp + 3 * static_cast<size_t>(shared[-2 - I]);
        }
        if constexpr (Wide) {
          Io::gather(src, u[a]);
        } else if constexpr (L <= 8) {
          for (int i = 0; i < 3; ++i) {
            V v;
            for (int l = 0; l < L; ++l) v[l] = src[l][i];
            u[a][i] = v;
          }
        } else {  // 16 lanes: one chain of 16 dependent inserts is slower than stores and a load
          for (int l = 0; l < L; ++l) u[a][0][l] = src[l][0], u[a][1][l] = src[l][1], u[a][2][l] = src[l][2];
        }
      }
      batch_apply<P, T, L>(t, d, o, mass, u, r);
      scatter_lanes<T, L, N>(f, o, r, sign, out, shared_out);
    }
  }
}

/// y_a = (X_a + u_a) - R_l X_a for the L lanes of a batch's N nodes (f: the batch's node indices
/// at the lanes' offset, node a of lane l at f[a * kBatch + l]; see force_batches; Re[l]: lane l's
/// rotation, nullptr for R = I) into y, lane-major ([a][i][l], 3 L per node). Kept out of line and
/// compiled for the baseline instruction set: without fused multiply-adds it rounds as the
/// element-by-element evaluation and the assembled pass do (ElasticityModel::evaluate), which
/// matters here: y is a small difference of positions, and a contraction's other rounding of R X
/// showed in a stiff bar's force at 4e-12 relative.
__attribute__((noinline)) void lanes_state(int N, int L, const index_t* f, const index_t* shared, const double* X,
                                           const double* u, const double* const* Re, double* y) {
  for (int a = 0; a < N; ++a)
    for (int l = 0; l < L; ++l) {
      const index_t I = f[a * kBatch + l];
      const index_t node = I >= 0 ? I : I == -1 ? -1 : shared[-2 - I];
      double* ya = y + 3 * static_cast<size_t>(a) * L + l;
      if (node < 0) {
        ya[0] = ya[L] = ya[2 * L] = 0.0;
        continue;
      }
      const double* Xa = X + 3 * static_cast<size_t>(node);
      const double* ua = u + 3 * static_cast<size_t>(node);
      const double* R = Re[l];
      for (int i = 0; i < 3; ++i) {
        const double RX = R ? R[i] * Xa[0] + R[3 + i] * Xa[1] + R[6 + i] * Xa[2] : Xa[i];
        ya[i * L] = (Xa[i] + ua[i]) - RX;
      }
    }
}

/// detail::force_element_batches over batches [begin, end), L lanes at a time; returns the energy.
template <int P, int L>
inline double force_batches(const index_t* nodes, const index_t* elements, const double* data, double inv_weight,
                            const double* X, const double* u, const double* R, long begin, long end, double* force,
                            const index_t* shared, double* shared_out) {
  using V = typename Lanes<double, L>::type;
  constexpr int N = Tables<P>::N;
  const TablesIn<P, double>& t = tables_in<P, double>();
  V esum{};
  alignas(64) double d[kData * kBatch];
  for (long bt = begin; bt < end; ++bt) {
    const index_t* f = nodes + static_cast<size_t>(bt) * N * kBatch;
    const index_t* el = elements + static_cast<size_t>(bt) * kBatch;
    const double* src = data + static_cast<size_t>(bt) * kData * kBatch;
    // The stiffness alone: the stored Lamé factors carry the operator's stiffness weight.
    for (int k = 0; k < 12 * kBatch; ++k) d[k] = src[k];
    for (int l = 0; l < kBatch; ++l) d[12 * kBatch + l] = src[12 * kBatch + l] * inv_weight;
    for (int l = 0; l < kBatch; ++l) d[13 * kBatch + l] = src[13 * kBatch + l] * inv_weight;
    for (int o = 0; o < kBatch; o += L) {
      V y[N][3], r[N][3];
      const double* Re[L];
      for (int l = 0; l < L; ++l) Re[l] = R && el[o + l] >= 0 ? R + 9 * static_cast<size_t>(el[o + l]) : nullptr;
      alignas(64) double ys[N][3][L];
      lanes_state(N, L, f + o, shared, X, u, Re, &ys[0][0][0]);
      for (int a = 0; a < N; ++a)
        for (int i = 0; i < 3; ++i) __builtin_memcpy(&y[a][i], ys[a][i], sizeof(V));
      batch_apply<P, double, L>(t, d, o, false, y, r);
      for (int a = 0; a < N; ++a)
        for (int i = 0; i < 3; ++i) esum += y[a][i] * r[a][i];
      scatter_lanes<double, L, N>(f, o, r, -1.0, force, shared_out);
    }
  }
  double e = 0.0;
  for (int l = 0; l < L; ++l) e += esum[l];
  return 0.5 * e;
}

/// The lanes per vector of each instruction set: the baseline path splits a 256-bit vector.
template <class T>
constexpr int lanes_baseline = 32 / sizeof(T);

template <int P>
double force_batches_generic(const index_t* nodes, const index_t* elements, const double* data, double inv_weight,
                             const double* X, const double* u, const double* R, long begin, long end, double* force,
                             const index_t* shared, double* shared_out) {
  return force_batches<P, lanes_baseline<double>>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared,
                                                  shared_out);
}

template <int P, class T>
void apply_batches_generic(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                           const index_t* shared, T* shared_out, T sign, bool mass) {
  apply_batches<P, T, lanes_baseline<T>>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
}

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#define PMG_MF_X86_DISPATCH 1
// One attribute per instruction set, for the product's and the force's copies alike.
#define PMG_MF_AVX2 __attribute__((target("avx2,fma"), flatten))
#define PMG_MF_AVX512 __attribute__((target("avx512f,avx512vl,avx512dq,avx2,fma"), flatten))
// The masked-load gathers below transpose with __builtin_shufflevector (Clang, GCC from 12); an
// older GCC builds the copies with the inserts instead (Io = void).
#if defined(__clang__) || __GNUC__ >= 12
#define PMG_MF_MASKED_GATHER 1
#endif
#ifdef PMG_MF_MASKED_GATHER
// The masked-load gathers: each lane's three components by one masked load (masked-off entries
// are neither read nor faulted on, so a node at the end of x needs no padding), lane j + 4 g into
// group g (4 entries) of vector j < 4, then per group the 4 x 4 transposition into the components'
// vectors. (The scatter stays scalar: a masked store does not forward to a load of the same
// entries right after it, and lanes of a batch share nodes; docs/performance.md.)

/// Entry k of a two-vector shuffle of W-entry vectors (W a multiple of 4), within k's group of 4
/// (base 4 (k / 4); b: the second vector, W on): the interleavings of the transposition.
template <int W>
struct Pick {
  static constexpr int base(int k) { return 4 * (k / 4); }
  struct Low {  // a0 b0 a1 b1
    static constexpr int at(int k) { return base(k) + (k % 2) * W + (k % 4) / 2; }
  };
  struct High {  // a2 b2 a3 b3
    static constexpr int at(int k) { return base(k) + (k % 2) * W + 2 + (k % 4) / 2; }
  };
  struct PairLow {  // a0 a1 b0 b1
    static constexpr int at(int k) { return base(k) + (k % 4) / 2 * W + k % 2; }
  };
  struct PairHigh {  // a2 a3 b2 b3
    static constexpr int at(int k) { return base(k) + (k % 4) / 2 * W + 2 + k % 2; }
  };
};
/// out = the shuffle of a and b by F (by reference: vector values cross no function boundary).
template <class F, class V, std::size_t... K>
inline void shuffle(const V& a, const V& b, V& out, std::index_sequence<K...>) {
  out = __builtin_shufflevector(a, b, F::at(static_cast<int>(K))...);
}
/// u[i] = the components i < 3 of z's groups: z[j]'s group g holds lane j + 4 g as (x, y, z, ·);
/// u[i]'s entry j + 4 g is its component i.
template <int W, class V>
inline void transpose_groups(const V (&z)[4], V (&u)[3]) {
  using S = std::make_index_sequence<W>;
  using K = Pick<W>;
  V a, b, c, d;
  shuffle<typename K::Low>(z[0], z[1], a, S{});
  shuffle<typename K::Low>(z[2], z[3], b, S{});
  shuffle<typename K::High>(z[0], z[1], c, S{});
  shuffle<typename K::High>(z[2], z[3], d, S{});
  shuffle<typename K::PairLow>(a, b, u[0], S{});
  shuffle<typename K::PairHigh>(a, b, u[1], S{});
  shuffle<typename K::PairLow>(c, d, u[2], S{});
}
/// The address 4 g entries below p: a masked load from it whose mask selects entries 4g..4g+2
/// reads p[0..2] into group g.
template <class T>
const T* below(const T* p, int g) {
  return reinterpret_cast<const T*>(reinterpret_cast<std::uintptr_t>(p) - 4 * g * sizeof(T));
}

/// AVX2, 4 lanes of doubles: one group per vector.
struct Avx2Lanes4 {
  using V = Lanes<double, 4>::type;
  PMG_MF_AVX2 static inline void gather(const double* const (&src)[4], V (&u)[3]) {
    const __m256i m = _mm256_set_epi64x(0, -1, -1, -1);
    const V z[4] = {(V)_mm256_maskload_pd(src[0], m), (V)_mm256_maskload_pd(src[1], m),
                    (V)_mm256_maskload_pd(src[2], m), (V)_mm256_maskload_pd(src[3], m)};
    transpose_groups<4>(z, u);
  }
};
/// AVX2, 8 lanes of floats: two 128-bit loads per vector.
struct Avx2Lanes8 {
  using V = Lanes<float, 8>::type;
  using Q = Lanes<float, 4>::type;
  PMG_MF_AVX2 static inline void gather(const float* const (&src)[8], V (&u)[3]) {
    const __m128i m = _mm_set_epi32(0, -1, -1, -1);
    V z[4];
    for (int j = 0; j < 4; ++j) {
      const Q lo = (Q)_mm_maskload_ps(src[j], m), hi = (Q)_mm_maskload_ps(src[j + 4], m);
      z[j] = __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7);
    }
    transpose_groups<8>(z, u);
  }
};
#else
using Avx2Lanes4 = void;
using Avx2Lanes8 = void;
#endif

template <int P, class T>
PMG_MF_AVX2 void apply_batches_avx2(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                                    const index_t* shared, T* shared_out, T sign, bool mass) {
  if constexpr (std::is_same_v<T, double>)
    apply_batches<P, T, 4, Avx2Lanes4>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
  else
    apply_batches<P, T, 8, Avx2Lanes8>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
}
#ifdef PMG_MF_MASKED_GATHER
/// AVX-512, 8 lanes of doubles: two masked loads per vector (groups 0 and 1).
struct Avx512Lanes8 {
  using V = Lanes<double, 8>::type;
  PMG_MF_AVX512 static inline void gather(const double* const (&src)[8], V (&u)[3]) {
    V z[4];
    for (int j = 0; j < 4; ++j)
      z[j] = (V)_mm512_mask_loadu_pd(_mm512_maskz_loadu_pd(0x07, src[j]), 0x70, below(src[j + 4], 1));
    transpose_groups<8>(z, u);
  }
};
/// AVX-512, 16 lanes of floats: four masked loads per vector (groups 0-3).
struct Avx512Lanes16 {
  using V = Lanes<float, 16>::type;
  PMG_MF_AVX512 static inline void gather(const float* const (&src)[16], V (&u)[3]) {
    V z[4];
    for (int j = 0; j < 4; ++j) {
      __m512 v = _mm512_maskz_loadu_ps(0x0007, src[j]);
      v = _mm512_mask_loadu_ps(v, 0x0070, below(src[j + 4], 1));
      v = _mm512_mask_loadu_ps(v, 0x0700, below(src[j + 8], 2));
      z[j] = (V)_mm512_mask_loadu_ps(v, 0x7000, below(src[j + 12], 3));
    }
    transpose_groups<16>(z, u);
  }
};
#else
using Avx512Lanes8 = void;
using Avx512Lanes16 = void;
#endif

template <int P, class T>
PMG_MF_AVX512 void apply_batches_avx512(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                                        const index_t* shared, T* shared_out, T sign, bool mass) {
  if constexpr (std::is_same_v<T, double>)
    apply_batches<P, T, 8, Avx512Lanes8>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
  else
    apply_batches<P, T, 16, Avx512Lanes16>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
}
template <int P>
PMG_MF_AVX2 double force_batches_avx2(const index_t* nodes, const index_t* elements, const double* data,
                                      double inv_weight, const double* X, const double* u, const double* R,
                                      long begin, long end, double* force, const index_t* shared,
                                      double* shared_out) {
  return force_batches<P, 32 / sizeof(double)>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared,
                                                shared_out);
}
template <int P>
PMG_MF_AVX512 double force_batches_avx512(const index_t* nodes, const index_t* elements, const double* data,
                                          double inv_weight, const double* X, const double* u, const double* R,
                                          long begin, long end, double* force, const index_t* shared,
                                          double* shared_out) {
  return force_batches<P, 64 / sizeof(double)>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared,
                                                shared_out);
}
#undef PMG_MF_AVX2
#undef PMG_MF_AVX512
#undef PMG_MF_MASKED_GATHER
#endif

}  // namespace

bool matrix_free_kernel_available(MatrixFreeKernel k) {
  switch (k) {
    case MatrixFreeKernel::automatic:
    case MatrixFreeKernel::reference:
    case MatrixFreeKernel::generic: return true;
#ifdef PMG_MF_X86_DISPATCH
    case MatrixFreeKernel::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case MatrixFreeKernel::avx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
    default: return false;
  }
}

std::string to_string(MatrixFreeKernel k) {
  switch (k) {
    case MatrixFreeKernel::automatic: return "auto";
    case MatrixFreeKernel::reference: return "reference";
    case MatrixFreeKernel::generic: return "generic";
    case MatrixFreeKernel::avx2: return "avx2";
    case MatrixFreeKernel::avx512: return "avx512";
  }
  return "?";
}

MatrixFreeKernel parse_matrix_free_kernel(const std::string& name) {
  for (MatrixFreeKernel k : {MatrixFreeKernel::automatic, MatrixFreeKernel::reference, MatrixFreeKernel::generic,
                             MatrixFreeKernel::avx2, MatrixFreeKernel::avx512})
    if (to_string(k) == name) return k;
  throw InputError("matrix-free kernel: unknown name '" + name + "' (auto, reference, generic, avx2, avx512)");
}

namespace {

MatrixFreeKernel resolve(MatrixFreeKernel k) {
  if (k != MatrixFreeKernel::automatic) return k;
  // AVX-512 where the CPU has it (on AMD Zen 4 it runs 512-bit vectors in two halves: the gain is
  // the 32 vector registers), else AVX2 + FMA, else the baseline path.
  for (MatrixFreeKernel c : {MatrixFreeKernel::avx512, MatrixFreeKernel::avx2})
    if (matrix_free_kernel_available(c)) return c;
  return MatrixFreeKernel::generic;
}

template <int P, class T>
void apply_batches_dispatch(MatrixFreeKernel k, const index_t* free, const T* data, long begin, long end,
                            const T* xp, T* out, const index_t* shared, T* shared_out, T sign, bool mass) {
#ifdef PMG_MF_X86_DISPATCH
  if (k == MatrixFreeKernel::avx512)
    return apply_batches_avx512<P, T>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
  if (k == MatrixFreeKernel::avx2)
    return apply_batches_avx2<P, T>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
#endif
  (void)k;
  apply_batches_generic<P, T>(free, data, begin, end, xp, out, shared, shared_out, sign, mass);
}

}  // namespace

namespace detail {

template <int P>
void element_product(const double* d, const double (&u)[ElementKernelTables<P>::N][3],
                     double (&r)[ElementKernelTables<P>::N][3]) {
  element_apply<P>(tables<P>(), d, u, r);
}

template <int P>
void apply_elements(const index_t* free, const double* batch_data, const index_t* pos, long begin, long end,
                    const double* xp, double* out, double sign) {
  apply_range<P>(free, batch_data, pos, begin, end, xp, out, sign);
}

template <int P, class T>
void apply_element_batches(MatrixFreeKernel k, const index_t* free, const T* data, long begin, long end, const T* xp,
                           T* out, SharedSlots<T> shared, T sign, bool mass) {
  apply_batches_dispatch<P, T>(k, free, data, begin, end, xp, out, shared.nodes, shared.out, sign, mass);
}

template <int P>
double force_element_batches(MatrixFreeKernel k, const index_t* nodes, const index_t* elements, const double* data,
                             double inv_weight, const double* X, const double* u, const double* R, long begin,
                             long end, double* force, SharedSlots<double> shared) {
#ifdef PMG_MF_X86_DISPATCH
  if (k == MatrixFreeKernel::avx512)
    return force_batches_avx512<P>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared.nodes,
                                   shared.out);
  if (k == MatrixFreeKernel::avx2)
    return force_batches_avx2<P>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared.nodes,
                                 shared.out);
#endif
  (void)k;
  return force_batches_generic<P>(nodes, elements, data, inv_weight, X, u, R, begin, end, force, shared.nodes,
                                  shared.out);
}

MatrixFreeKernel resolve_kernel(MatrixFreeKernel k) { return resolve(k); }

#define PMG_MF_INSTANTIATE(P)                                                                                  \
  template void element_product<P>(const double*, const double (&)[ElementKernelTables<P>::N][3],             \
                                   double (&)[ElementKernelTables<P>::N][3]);                                  \
  template void apply_elements<P>(const index_t*, const double*, const index_t*, long, long, const double*,      \
                                  double*, double);                                                           \
  template void apply_element_batches<P, double>(MatrixFreeKernel, const index_t*, const double*, long, long,   \
                                                 const double*, double*, SharedSlots<double>, double, bool);   \
  template void apply_element_batches<P, float>(MatrixFreeKernel, const index_t*, const float*, long, long,     \
                                                const float*, float*, SharedSlots<float>, float, bool);      \
  template double force_element_batches<P>(MatrixFreeKernel, const index_t*, const index_t*, const double*, double, \
                                           const double*, const double*, const double*, long, long, double*,     \
                                           SharedSlots<double>);
PMG_MF_INSTANTIATE(1)
PMG_MF_INSTANTIATE(2)
PMG_MF_INSTANTIATE(3)
#undef PMG_MF_INSTANTIATE

}  // namespace detail

}  // namespace pmg::fem
