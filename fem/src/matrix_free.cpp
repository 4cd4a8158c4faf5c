#include "pmg/fem/matrix_free.hpp"

#include "pmg/fem/element_kernel.hpp"

#include <mutex>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace pmg::fem {

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

/// Element data, 16 doubles: g_k = R ∇λ_k (row-major 4x3), then 6V p² s λ_e, 6V p² s μ_e, 6V ρ m
/// (pmg/fem/element_kernel.hpp).
constexpr int kData = kElementData;

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

/// out += sign · (element products of x) over elements [begin, end) (n node indices and kData
/// doubles per element; a free index < 0 is a fixed node: read as 0, not written).
template <int P>
inline void apply_range(const index_t* free, const double* data, long begin, long end,
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
    element_apply<P>(t, data + kData * static_cast<size_t>(e), u, r);
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
// The product runs kBatch consecutive elements at a time, one element per SIMD lane (deal.II's
// VectorizedArray layout): the element data is stored structure-of-arrays per batch (datum k of
// lane l at [k * kBatch + l]), node indices node-major ([a * kBatch + l]), and the kernel below is
// element_apply() with every scalar replaced by a vector of L lanes. A batch is gathered from x
// lane by lane and scattered into the accumulation vector lane by lane in order, so two elements of
// a batch may share a node. The last batch is padded with empty lanes (index -1, data 0).
//
// The vector type is GCC's vector extension (also Clang's): unlike std::experimental::simd, whose
// width is fixed by the flags of the translation unit, it compiles to the instruction set of the
// function it is in, so one source gives the baseline x86-64 path (SSE2, a 4-lane vector split in
// two) and AVX2 + FMA and AVX-512 copies chosen at run time (function target attributes); the
// arithmetic is only +, * and lane access, which the extension covers on every compiler pmgkit
// builds with.
constexpr int kBatch = 16;

template <class T, int L>
struct Lanes;
template <>
struct Lanes<double, 4> {
  typedef double type __attribute__((vector_size(32)));
};
template <>
struct Lanes<double, 8> {
  typedef double type __attribute__((vector_size(64)));
};
template <>
struct Lanes<float, 8> {
  typedef float type __attribute__((vector_size(32)));
};
template <>
struct Lanes<float, 16> {
  typedef float type __attribute__((vector_size(64)));
};

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
  // 1. H_β = Σ_k u_{β+e_k} g_kᵀ
  V H[Q][9];
  for (int b = 0; b < Q; ++b) {
    V h[9];
    for (int c = 0; c < 9; ++c) h[c] = V{} ;
    for (int k = 0; k < 4; ++k) {
      const V* ua = u[up.v[b][k]];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) h[3 * i + j] += ua[i] * g[k][j];
    }
    for (int c = 0; c < 9; ++c) H[b][c] = h[c];
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
  for (int c = 0; c < Q; ++c) {
    // 2. Ĥ_γ = Σ_β Q_γβ H_β
    V h[9];
    for (int i = 0; i < 9; ++i) h[i] = V{};
    for (int b = 0; b < Q; ++b) {
      const T w = t.q[c][b];
      for (int i = 0; i < 9; ++i) h[i] += w * H[b][i];
    }
    // 3. T = cl tr(Ĥ) I + cm (Ĥ + Ĥᵀ)
    const V tr = cl * (h[0] + h[4] + h[8]);
    V S[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) S[3 * i + j] = cm * (h[3 * i + j] + h[3 * j + i]);
    S[0] += tr, S[4] += tr, S[8] += tr;
    // 4. r_{γ+e_k} += T g_k
    for (int k = 0; k < 4; ++k) {
      V* ra = r[up.v[c][k]];
      for (int i = 0; i < 3; ++i) ra[i] += S[3 * i] * g[k][0] + S[3 * i + 1] * g[k][1] + S[3 * i + 2] * g[k][2];
    }
  }
}

/// out += sign · (element products of x) over batches [begin, end), L lanes at a time.
template <int P, class T, int L>
inline void apply_batches(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                          T sign, bool mass) {
  using V = typename Lanes<T, L>::type;
  constexpr int N = Tables<P>::N;
  const TablesIn<P, T>& t = tables_in<P, T>();
  for (long bt = begin; bt < end; ++bt) {
    const index_t* f = free + static_cast<size_t>(bt) * N * kBatch;
    const T* d = data + static_cast<size_t>(bt) * kData * kBatch;
    for (int o = 0; o < kBatch; o += L) {
      // Gathered into and scattered from plain arrays: lanes are written one by one.
      alignas(64) T ub[N][3][L], rb[N][3][L];
      for (int a = 0; a < N; ++a)
        for (int l = 0; l < L; ++l) {
          const index_t I = f[a * kBatch + o + l];
          if (I >= 0) {
            const T* s = xp + 3 * static_cast<size_t>(I);
            ub[a][0][l] = s[0], ub[a][1][l] = s[1], ub[a][2][l] = s[2];
          } else {
            ub[a][0][l] = ub[a][1][l] = ub[a][2][l] = T(0);
          }
        }
      V u[N][3], r[N][3];
      static_assert(sizeof(u) == sizeof(ub), "lane arrays");
      __builtin_memcpy(u, ub, sizeof(u));
      batch_apply<P, T, L>(t, d, o, mass, u, r);
      __builtin_memcpy(rb, r, sizeof(r));
      for (int l = 0; l < L; ++l)
        for (int a = 0; a < N; ++a) {
          const index_t I = f[a * kBatch + o + l];
          if (I < 0) continue;
          T* s = out + 3 * static_cast<size_t>(I);
          s[0] += sign * rb[a][0][l], s[1] += sign * rb[a][1][l], s[2] += sign * rb[a][2][l];
        }
    }
  }
}

/// The lanes per vector of each instruction set: the baseline path splits a 256-bit vector.
template <class T>
constexpr int lanes_baseline = 32 / sizeof(T);

template <int P, class T>
void apply_batches_generic(const index_t* free, const T* data, long begin, long end, const T* xp, T* out,
                           T sign, bool mass) {
  apply_batches<P, T, lanes_baseline<T>>(free, data, begin, end, xp, out, sign, mass);
}

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#define PMG_MF_X86_DISPATCH 1
template <int P, class T>
__attribute__((target("avx2,fma"), flatten)) void apply_batches_avx2(const index_t* free, const T* data,
                                                                       long begin, long end, const T* xp,
                                                                       T* out, T sign, bool mass) {
  apply_batches<P, T, 32 / sizeof(T)>(free, data, begin, end, xp, out, sign, mass);
}
template <int P, class T>
__attribute__((target("avx512f,avx512vl,avx512dq,avx2,fma"), flatten)) void apply_batches_avx512(
    const index_t* free, const T* data, long begin, long end, const T* xp, T* out, T sign, bool mass) {
  apply_batches<P, T, 64 / sizeof(T)>(free, data, begin, end, xp, out, sign, mass);
}
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
                            const T* xp, T* out, T sign, bool mass) {
#ifdef PMG_MF_X86_DISPATCH
  if (k == MatrixFreeKernel::avx512) return apply_batches_avx512<P, T>(free, data, begin, end, xp, out, sign, mass);
  if (k == MatrixFreeKernel::avx2) return apply_batches_avx2<P, T>(free, data, begin, end, xp, out, sign, mass);
#endif
  (void)k;
  apply_batches_generic<P, T>(free, data, begin, end, xp, out, sign, mass);
}

}  // namespace

struct ElasticityOperator::Impl {
  int p = 0, n = 0;
  index_t num_elements = 0, num_batches = 0;
  const std::vector<std::vector<index_t>>* colors = nullptr;  ///< the model's element colouring
  std::vector<index_t> free;   ///< n per element: free node index or -1
  std::vector<double> data;    ///< kData per element (the reference kernel, diagonal, forces)
  std::vector<index_t> batch_free;  ///< n x kBatch per batch, node-major (padding lanes: -1)
  std::vector<double> batch_data;   ///< kData x kBatch per batch, datum-major
  std::vector<float> batch_data_single;  ///< the same in float, kept once apply_single() asked for it
  bool single = false;
  MatrixFreeKernel resolved = MatrixFreeKernel::generic;  ///< the kernel apply() runs (never automatic)
  /// apply(): thread t > 0 accumulates its contiguous range of elements into buffers[t-1] (kept
  /// from call to call: no allocation per product), thread 0 directly into y; then y += Σ buffers.
  mutable std::vector<Vector> buffers;
  mutable std::vector<Eigen::VectorXf> buffers_single;
  /// Held by the product using `buffers`: two solvers sharing this operator on two threads take
  /// turns (a try-lock with private buffers for the loser let the compiler read the kept
  /// buffers before knowing it held them, which ThreadSanitizer reported).
  mutable std::mutex buffers_mutex;

  /// The batch layout of `data` (and its float copy where kept).
  void transpose_data() {
    batch_data.assign(static_cast<size_t>(num_batches) * kData * kBatch, 0.0);
#pragma omp parallel for schedule(static)
    for (long bt = 0; bt < static_cast<long>(num_batches); ++bt)
      for (int l = 0; l < kBatch; ++l) {
        const long e = bt * kBatch + l;
        if (e >= static_cast<long>(num_elements)) break;
        for (int k = 0; k < kData; ++k)
          batch_data[(static_cast<size_t>(bt) * kData + k) * kBatch + l] = data[static_cast<size_t>(e) * kData + k];
      }
    if (single) batch_data_single.assign(batch_data.begin(), batch_data.end());
  }

  /// y = A x, or with b: y = b - A x (the residual in the same pass). T: double, or float for
  /// apply_single() (batched kernels only).
  template <int P, class T, class Vec>
  void apply(const Vec& x, Vec& y, const Vec* b, bool mass, std::vector<Vec>& kept) const {
    // The float path has no scalar reference: the baseline batched kernel stands in for it.
    const MatrixFreeKernel kernel =
        std::is_same_v<T, float> && resolved == MatrixFreeKernel::reference ? MatrixFreeKernel::generic : resolved;
    const T* xp = x.data();
    T* yp = y.data();
    const long len = static_cast<long>(y.size());
    const int threads = omp_get_max_threads();
    // One product at a time uses the kept buffers (two solvers sharing this operator take turns).
    const std::lock_guard<std::mutex> lock(buffers_mutex);
    std::vector<Vec>& buffers = kept;
    if (static_cast<int>(buffers.size()) != threads - 1 || (threads > 1 && buffers[0].size() != len))
      buffers.assign(std::max(threads - 1, 0), Vec(len));
    const T sign = b ? T(-1) : T(1);
    const T* bdata = nullptr;
    if constexpr (std::is_same_v<T, float>) bdata = batch_data_single.data();
    else bdata = batch_data.data();
    const bool reference = kernel == MatrixFreeKernel::reference;
#pragma omp parallel num_threads(threads)
    {
      const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
      T* out = tid == 0 ? yp : buffers[tid - 1].data();
      if (tid == 0) {
        if (b) std::copy(b->data(), b->data() + len, yp);
        else std::fill(yp, yp + len, T(0));
      } else {
        std::fill(out, out + len, T(0));
      }
      if constexpr (std::is_same_v<T, double>) {
        if (reference) {
          const long begin = num_elements * static_cast<long>(tid) / nt;
          const long end = num_elements * static_cast<long>(tid + 1) / nt;
          apply_range<P>(free.data(), data.data(), begin, end, xp, out, sign);
        }
      }
      if (!reference) {
        const long begin = num_batches * static_cast<long>(tid) / nt;
        const long end = num_batches * static_cast<long>(tid + 1) / nt;
        apply_batches_dispatch<P, T>(kernel, batch_free.data(), bdata, begin, end, xp, out, sign, mass);
      }
#pragma omp barrier
      if (nt > 1) {
#pragma omp for schedule(static)
        for (long i = 0; i < len; ++i) {
          T sum = T(0);
          for (int k = 0; k < nt - 1; ++k) sum += buffers[k][i];
          yp[i] += sum;
        }
      }
    }
  }
};

ElasticityOperator::ElasticityOperator(const ElasticityModel& model)
    : model_(&model), impl_(std::make_unique<Impl>()) {
  const BlockAssembler& as = model.assembler();
  const BBSpace& space = model.space();
  Impl& m = *impl_;
  m.p = space.degree();
  m.n = space.nodes_per_element();
  num_free_ = as.num_free();
  m.colors = &as.colors();
  m.num_elements = space.mesh().num_tets();
  const size_t ne = static_cast<size_t>(m.num_elements);
  m.free.resize(ne * m.n);
  for (size_t e = 0; e < ne; ++e)
    for (int a = 0; a < m.n; ++a) m.free[e * m.n + a] = as.free_index()[space.node(static_cast<index_t>(e), a)];
  m.num_batches = static_cast<index_t>((ne + kBatch - 1) / kBatch);
  m.batch_free.assign(static_cast<size_t>(m.num_batches) * m.n * kBatch, -1);
  for (size_t e = 0; e < ne; ++e)
    for (int a = 0; a < m.n; ++a)
      m.batch_free[((e / kBatch) * m.n + a) * kBatch + e % kBatch] = m.free[e * m.n + a];
  m.data.assign(ne * kData, 0.0);
  // PMG_MATRIX_FREE_KERNEL (auto, generic, avx2, avx512, reference) overrides the automatic
  // choice, e.g. to run the portable path on a machine that has wider vectors.
  MatrixFreeKernel kernel = MatrixFreeKernel::automatic;
  if (const char* env = std::getenv("PMG_MATRIX_FREE_KERNEL"); env && *env) {
    kernel = parse_matrix_free_kernel(env);
    if (!matrix_free_kernel_available(kernel))
      throw InputError("PMG_MATRIX_FREE_KERNEL=" + std::string(env) + ": this CPU cannot run that kernel");
  }
  m.resolved = resolve(kernel);
  update(nullptr);
}

ElasticityOperator::~ElasticityOperator() = default;

void ElasticityOperator::set_weights(double mass_weight, double stiffness_weight) {
  if (!std::isfinite(mass_weight) || !(mass_weight >= 0) || !std::isfinite(stiffness_weight) ||
      !(stiffness_weight >= 0) || !(mass_weight + stiffness_weight > 0))
    throw InputError("matrix-free operator: the weights must be finite, >= 0 and not both zero");
  mass_weight_ = mass_weight;
  stiffness_weight_ = stiffness_weight;
  const Impl& m = *impl_;
  const Material& mat = model_->material();
  const auto& scale = model_->stiffness_scale();
  const double p2 = static_cast<double>(m.p) * m.p;
#pragma omp parallel for schedule(static)
  for (long e = 0; e < static_cast<long>(m.num_elements); ++e) {
    double* d = impl_->data.data() + kData * static_cast<size_t>(e);
    const double v6 = 6.0 * model_->geometry(e).volume;
    const double s = scale.empty() ? 1.0 : scale[e];
    d[12] = v6 * p2 * stiffness_weight * s * mat.lambda();
    d[13] = v6 * p2 * stiffness_weight * s * mat.mu();
    d[14] = v6 * mat.density * mass_weight;
  }
  impl_->transpose_data();
}

void ElasticityOperator::update(const Rotations* R) {
  Impl& m = *impl_;
  if (R && R->size() != static_cast<size_t>(model_->space().mesh().num_tets()))
    throw InputError("matrix-free operator: one rotation per element expected");
#pragma omp parallel for schedule(static)
  for (long e = 0; e < static_cast<long>(m.num_elements); ++e) {
    Eigen::Matrix<double, 4, 3> g = model_->geometry(e).grad;
    if (R) g = g * (*R)[e].transpose();
    double* d = m.data.data() + kData * static_cast<size_t>(e);
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) d[3 * k + j] = g(k, j);
  }
  set_weights(mass_weight_, stiffness_weight_);
}

namespace {
/// x itself, or (where the model holds components) a copy in `scratch` with those entries zeroed:
/// the held components' columns are zero, as in the assembled matrices.
const Vector& masked_input(const ElasticityModel& model, const Vector& x, Vector& scratch) {
  if (model.constrained_free_dofs().empty()) return x;
  scratch = x;
  model.constrain(scratch);
  return scratch;
}
}  // namespace

void ElasticityOperator::apply_impl(const Vector& x, Vector& y) const {
  // Components held by ElasticityModel::constrain_components(): identity rows and zero columns,
  // as the assembled matrices: y = A (x masked), then y_c = x_c.
  const std::vector<char>& held = model_->constrained_free_dofs();
  Vector scratch;
  const Vector& in = masked_input(*model_, x, scratch);
  const bool mass = mass_weight_ != 0.0;
  switch (impl_->p) {
    case 1: impl_->apply<1, double>(in, y, static_cast<const Vector*>(nullptr), mass, impl_->buffers); break;
    case 2: impl_->apply<2, double>(in, y, static_cast<const Vector*>(nullptr), mass, impl_->buffers); break;
    default: impl_->apply<3, double>(in, y, static_cast<const Vector*>(nullptr), mass, impl_->buffers); break;
  }
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) y[static_cast<Eigen::Index>(i)] = x[static_cast<Eigen::Index>(i)];
}

void ElasticityOperator::residual_impl(const Vector& b, const Vector& x, Vector& r) const {
  r.resize(rows());
  const std::vector<char>& held = model_->constrained_free_dofs();
  Vector scratch;
  const Vector& in = masked_input(*model_, x, scratch);
  const bool mass = mass_weight_ != 0.0;
  switch (impl_->p) {
    case 1: impl_->apply<1, double>(in, r, &b, mass, impl_->buffers); break;
    case 2: impl_->apply<2, double>(in, r, &b, mass, impl_->buffers); break;
    default: impl_->apply<3, double>(in, r, &b, mass, impl_->buffers); break;
  }
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) r[static_cast<Eigen::Index>(i)] = b[static_cast<Eigen::Index>(i)] - x[static_cast<Eigen::Index>(i)];
}

void ElasticityOperator::set_kernel(MatrixFreeKernel kernel) {
  if (!matrix_free_kernel_available(kernel))
    throw InputError("matrix-free operator: this CPU cannot run the " + to_string(kernel) + " kernel");
  impl_->resolved = resolve(kernel);
}

MatrixFreeKernel ElasticityOperator::kernel() const { return impl_->resolved; }

ElasticityOperator::ElementArrays ElasticityOperator::element_arrays() const {
  const Impl& m = *impl_;
  return {m.p, m.n, m.num_elements, m.free.data(), m.data.data()};
}

void ElasticityOperator::apply_single(const Eigen::VectorXf& x, Eigen::VectorXf& y) const {
  if (x.size() != rows())
    throw InputError("matrix-free operator: apply_single() got " + std::to_string(x.size()) + " entries for " +
                     std::to_string(rows()) + " unknowns");
  if (!model_->constrained_free_dofs().empty())
    throw InputError("matrix-free operator: apply_single() does not take held components");
  if (x.data() == y.data() && x.size() > 0)
    throw InputError("matrix-free operator: apply_single() needs distinct x and y");
  Impl& m = *impl_;
  {
    std::lock_guard<std::mutex> lock(m.buffers_mutex);
    if (!m.single) {
      m.batch_data_single.assign(m.batch_data.begin(), m.batch_data.end());
      m.single = true;  // after the copy: a failed allocation leaves the next call to try again
    }
  }
  y.resize(rows());
  const bool mass = mass_weight_ != 0.0;
  switch (m.p) {
    case 1: m.apply<1, float>(x, y, static_cast<const Eigen::VectorXf*>(nullptr), mass, m.buffers_single); break;
    case 2: m.apply<2, float>(x, y, static_cast<const Eigen::VectorXf*>(nullptr), mass, m.buffers_single); break;
    default: m.apply<3, float>(x, y, static_cast<const Eigen::VectorXf*>(nullptr), mass, m.buffers_single); break;
  }
}

void ElasticityOperator::diagonal_blocks(std::vector<double>& blocks) const {
  const Impl& m = *impl_;
  const ElementTables& t = element_tables(m.p);
  const size_t nodes = static_cast<size_t>(num_free_);
  blocks.assign(9 * nodes, 0.0);
  const double p2 = static_cast<double>(m.p) * m.p;
  // Element e's diagonal blocks added at out + 9 (I - first) for each free node I >= first.
  auto add_element = [&](size_t pos, double* out, index_t first) {
    const double* d = m.data.data() + kData * pos;
    Eigen::Matrix<double, 4, 3> g;
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) g(k, j) = d[3 * k + j];
    // d[12], d[13] carry 6V p² s λ, 6V p² s μ; the G tables carry p² already.
    const double lambda = d[12] / p2, mu = d[13] / p2;
    for (int a = 0; a < m.n; ++a) {
      const index_t I = m.free[pos * m.n + a];
      if (I < 0) continue;
      Mat3 S = g.transpose() * t.G[a * m.n + a] * g;
      S = 0.5 * (S + S.transpose()).eval();
      const Mat3 B = (lambda + mu) * S + (mu * S.trace() + d[14] * t.mass(a, a)) * Mat3::Identity();
      double* o = out + 9 * static_cast<size_t>(I - first);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) o[3 * r + c] += B(r, c);
    }
  };
  // Each thread a contiguous range of elements, as apply(): thread 0 into `blocks`, thread t > 0
  // into a buffer over the span of free nodes its range touches (nodes are numbered in the order
  // the elements meet them, so the spans are short), added after.
  const int threads = omp_get_max_threads();
  std::vector<std::vector<double>> spans(static_cast<size_t>(std::max(threads - 1, 0)));
  std::vector<index_t> firsts(spans.size(), 0);
  const size_t ne = static_cast<size_t>(m.num_elements);
#pragma omp parallel num_threads(threads)
  {
    const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
    const size_t begin = ne * static_cast<size_t>(tid) / static_cast<size_t>(nt);
    const size_t end = ne * static_cast<size_t>(tid + 1) / static_cast<size_t>(nt);
    if (tid == 0) {
      for (size_t e = begin; e < end; ++e) add_element(e, blocks.data(), 0);
    } else {
      index_t lo = std::numeric_limits<index_t>::max(), hi = -1;
      for (size_t k = begin * m.n; k < end * m.n; ++k)
        if (m.free[k] >= 0) lo = std::min(lo, m.free[k]), hi = std::max(hi, m.free[k]);
      std::vector<double>& span = spans[static_cast<size_t>(tid - 1)];
      firsts[static_cast<size_t>(tid - 1)] = hi >= lo ? lo : 0;  // an empty span adds nothing
      span.assign(hi >= lo ? 9 * static_cast<size_t>(hi - lo + 1) : 0, 0.0);
      for (size_t e = begin; e < end; ++e) add_element(e, span.data(), lo);
    }
#pragma omp barrier
    for (int k = 0; k + 1 < nt; ++k) {  // one span after another, each spread over the threads
      const std::vector<double>& span = spans[static_cast<size_t>(k)];
      double* out = blocks.data() + 9 * static_cast<size_t>(firsts[static_cast<size_t>(k)]);
#pragma omp for schedule(static)
      for (size_t i = 0; i < span.size(); ++i) out[i] += span[i];
    }
  }
  const std::vector<char>& held = model_->constrained_free_dofs();  // identity rows, as apply()
  for (size_t i = 0; i < held.size(); ++i) {
    if (!held[i]) continue;
    double* out = blocks.data() + 9 * (i / 3);
    const size_t r = i % 3;
    for (size_t j = 0; j < 3; ++j) out[3 * r + j] = out[3 * j + r] = 0.0;
    out[4 * r] = 1.0;
  }
}

void ElasticityOperator::element_force(const Vector& u, const Rotations* Rs, Vector& force,
                                       double* energy) const {
  const Impl& m = *impl_;
  if (Rs && Rs->size() != static_cast<size_t>(model_->space().mesh().num_tets()))
    throw InputError("matrix-free operator: one rotation per element expected");
  if (u.size() != model_->num_dofs())
    throw InputError("matrix-free operator: the displacement has " + std::to_string(u.size()) +
                     " entries for " + std::to_string(model_->num_dofs()) + " unknowns");
  force.setZero(model_->num_dofs());
  const auto& X = model_->space().positions();
  double total = 0.0;
  for (const auto& elements : *m.colors) {
#pragma omp parallel for schedule(static) reduction(+ : total)
    for (size_t k = 0; k < elements.size(); ++k) {
      const index_t e = elements[k];
      const size_t pos = static_cast<size_t>(e);
      const index_t* nodes = model_->space().element_nodes(e);
      double d[kData];
      const double* src = m.data.data() + kData * static_cast<size_t>(pos);
      for (int i = 0; i < kData; ++i) d[i] = src[i];
      // K_R,e alone: the unweighted Lamé factors (the stored ones carry the stiffness weight).
      const double v6p2 = 6.0 * model_->geometry(e).volume * m.p * m.p;
      const double s = model_->stiffness_scale().empty() ? 1.0 : model_->stiffness_scale()[e];
      d[12] = v6p2 * s * model_->material().lambda(), d[13] = v6p2 * s * model_->material().mu(), d[14] = 0.0;
      const Mat3 R = Rs ? (*Rs)[e] : Mat3::Identity();
      auto run = [&](auto tag) {
        constexpr int P = decltype(tag)::value;
        constexpr int N = Tables<P>::N;
        double y[N][3], r[N][3];
        for (int a = 0; a < N; ++a) {
          const Vec3& Xa = X[nodes[a]];
          const Vec3 ya = Xa + u.segment<3>(3 * nodes[a]) - R * Xa;
          y[a][0] = ya[0], y[a][1] = ya[1], y[a][2] = ya[2];
        }
        element_apply<P>(tables<P>(), d, y, r);
        for (int a = 0; a < N; ++a) {
          total += 0.5 * (y[a][0] * r[a][0] + y[a][1] * r[a][1] + y[a][2] * r[a][2]);
          double* f = force.data() + 3 * static_cast<size_t>(nodes[a]);
          f[0] -= r[a][0], f[1] -= r[a][1], f[2] -= r[a][2];
        }
      };
      switch (m.p) {
        case 1: run(std::integral_constant<int, 1>{}); break;
        case 2: run(std::integral_constant<int, 2>{}); break;
        default: run(std::integral_constant<int, 3>{}); break;
      }
    }
  }
  if (energy) *energy = total;
}

double ElasticityOperator::flops_per_apply() const {
  const double n = impl_->n, q = element_nodes(impl_->p - 1);
  const double per = 72 * q + 18 * q * q + 12 * q + 72 * q + (mass_weight_ != 0 ? 6 * n * n : 0.0);
  return per * static_cast<double>(impl_->num_elements);
}

double ElasticityOperator::bytes_per_apply() const {
  const double per = kData * 8.0 + 4.0 * impl_->n;
  return per * static_cast<double>(impl_->num_elements) + 3.0 * 8.0 * rows();
}

}  // namespace pmg::fem
