#include "pmg/fem/matrix_free.hpp"

#include "matrix_free_kernels.hpp"

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

using detail::kBatch;
using detail::kData;


struct ElasticityOperator::Impl {
  int p = 0, n = 0;
  index_t num_elements = 0, num_batches = 0, num_free = 0;
  const ElementRanges* ranges = nullptr;  ///< the model's element traversal on threads
  std::vector<index_t> free;   ///< n per element: free node index or -1
  /// n x kBatch per batch, node-major (padding lanes: -1); batch b holds the elements at positions
  /// [b kBatch, (b + 1) kBatch) of the mesh's order or of `ranges`' traversal (choose_order()).
  std::vector<index_t> batch_free;
  /// kData x kBatch per batch, datum-major (padding lanes: 0): the only copy of the element data in
  /// double (the reference kernel, the diagonal blocks and the forces read it here too).
  std::vector<double> batch_data;
  /// Per element its batch position where the batches follow the traversal (else empty: the
  /// mesh's order, position = element).
  std::vector<index_t> batch_pos;
  std::vector<float> batch_data_single;  ///< the same in float, kept once apply_single() asked for it
  bool single = false;
  MatrixFreeKernel resolved = MatrixFreeKernel::generic;  ///< the kernel apply() runs (never automatic)

  /// The batched product on `threads` > 1 threads: range t = batches [begin[t], begin[t + 1]) writes
  /// y in place at the nodes that only its batches hold; the nodes two ranges hold (few: the
  /// ranges are compact) are shared slots (detail::SharedSlots), which each range accumulates into
  /// its own buffer, added to y after the ranges in range order.
  struct Split {
    int threads = 0;
    std::vector<long> begin;          ///< threads + 1 batch offsets
    std::vector<index_t> free;        ///< batch_free with the shared nodes as slots
    std::vector<index_t> shared;      ///< per slot its free node index
    std::vector<std::vector<double>> out;      ///< per range 3 per slot
    std::vector<std::vector<float>> out_single;
    std::vector<std::vector<double>> blocks;   ///< per range 9 per slot (diagonal_blocks())
  };
  /// The splits made so far, by thread count (a thread budget that changes between products
  /// finds its split again; at most kKeptSplits kept, the oldest dropped).
  static constexpr size_t kKeptSplits = 4;
  mutable std::vector<Split> splits;
  /// The scalar reference kernel: thread t > 0 accumulates its contiguous range of elements into
  /// buffers[t-1], thread 0 directly into y; then y += Σ buffers.
  mutable std::vector<Vector> buffers;
  /// Held by a product: two solvers sharing this operator on two threads take turns over `splits`
  /// and `buffers` (a try-lock with private buffers for the loser let the compiler read the kept
  /// buffers before knowing it held them, which ThreadSanitizer reported).
  mutable std::mutex buffers_mutex;

  /// Whether the batches follow `ranges`' traversal (else the mesh's order).
  bool traversal_order = false;
  /// Ranges the choice of order is made for (a fixed number: the order does not depend on the
  /// threads), and the share of the free nodes that they may hold in common in the mesh's order.
  static constexpr int kProbeRanges = 8;
  static constexpr int kMaxSharedShare = 8;  ///< one node in eight

  /// The element at batch position pos (padding: -1).
  index_t batch_element(long pos) const {
    if (pos >= static_cast<long>(num_elements)) return -1;
    return traversal_order ? ranges->element(static_cast<index_t>(pos)) : static_cast<index_t>(pos);
  }

  /// The batch position of element e.
  long position(index_t e) const { return batch_pos.empty() ? static_cast<long>(e) : static_cast<long>(batch_pos[e]); }
  /// The kData data of the element at batch position pos, gathered from its batch's lane.
  void gather_at(long pos, double* d) const {
    for (int k = 0; k < kData; ++k) d[k] = batch_data[detail::batch_datum(pos, k)];
  }
  /// Element e's kData data.
  void gather(index_t e, double* d) const { gather_at(position(e), d); }

  /// batch_free from `free` in the order batch_element() gives.
  void make_batch_free() {
    const size_t ne = static_cast<size_t>(num_elements);
    batch_free.assign(static_cast<size_t>(num_batches) * n * kBatch, -1);
    for (size_t pos = 0; pos < ne; ++pos) {
      const size_t e = static_cast<size_t>(batch_element(static_cast<long>(pos)));
      for (int a = 0; a < n; ++a) batch_free[((pos / kBatch) * n + a) * kBatch + pos % kBatch] = free[e * n + a];
    }
  }

  /// Per free node its shared slot among `parts` contiguous ranges of batches (-1: held by one
  /// range or none), and the range offsets.
  std::vector<index_t> shared_slots(int parts, std::vector<long>& begin, index_t& count) const {
    return shared_slots_of(batch_free, num_free, parts, begin, count);
  }
  /// The same for any batch index array `idx` over `indices` indices (index < 0: none).
  std::vector<index_t> shared_slots_of(const std::vector<index_t>& idx, index_t indices, int parts,
                                       std::vector<long>& begin, index_t& count) const {
    begin.resize(static_cast<size_t>(parts) + 1);
    for (int t = 0; t <= parts; ++t) begin[t] = static_cast<long>(num_batches) * t / parts;
    std::vector<int> lo(static_cast<size_t>(indices), parts), hi(static_cast<size_t>(indices), -1);
    const size_t per = static_cast<size_t>(n) * kBatch;
    for (int t = 0; t < parts; ++t)
      for (size_t k = begin[t] * per; k < begin[t + 1] * per; ++k)
        if (const index_t I = idx[k]; I >= 0) lo[I] = std::min(lo[I], t), hi[I] = std::max(hi[I], t);
    std::vector<index_t> slot(static_cast<size_t>(indices), -1);
    count = 0;
    for (index_t I = 0; I < indices; ++I)
      if (lo[I] < hi[I]) slot[I] = count++;
    return slot;
  }

  /// Shared slot s of node `node`: y[node] += each range's 3 entries of the slot, in range order
  /// (the order that makes a sum over ranges the same bits on any number of threads).
  template <class T>
  static void add_slot(T* y, index_t node, const std::vector<std::vector<T>>& outs, long s) {
    T* o = y + 3 * static_cast<size_t>(node);
    for (const std::vector<T>& out : outs) {
      const T* src = out.data() + 3 * s;
      o[0] += src[0], o[1] += src[1], o[2] += src[2];
    }
  }

  /// element_force()'s batches, made on its first call: every element node's index (fixed nodes
  /// too; padding -1), each lane's element, and kForceRanges contiguous ranges of batches (fewer
  /// on a small mesh; a number that does not depend on the threads) with the nodes that two ranges
  /// hold as slots (as Split, over all nodes).
  static constexpr int kForceRanges = 8;
  struct NodeSplit {
    std::vector<long> begin;
    std::vector<index_t> nodes;   ///< the node indices with the shared nodes as slots
    std::vector<index_t> elements;
    std::vector<index_t> shared;  ///< per slot its node
    std::vector<std::vector<double>> out;  ///< per range 3 per slot
  };
  mutable NodeSplit node_split;
  NodeSplit& make_node_split(const BBSpace& space) const {
    NodeSplit& s = node_split;
    if (!s.begin.empty()) return s;
    const index_t num_nodes = static_cast<index_t>(space.positions().size());
    std::vector<index_t> nodes(static_cast<size_t>(num_batches) * n * kBatch, -1);
    s.elements.assign(static_cast<size_t>(num_batches) * kBatch, -1);
    for (long pos = 0; pos < static_cast<long>(num_elements); ++pos) {
      const index_t e = batch_element(pos);
      const index_t* en = space.element_nodes(e);
      s.elements[static_cast<size_t>(pos)] = e;
      for (int a = 0; a < n; ++a) nodes[((static_cast<size_t>(pos) / kBatch) * n + a) * kBatch + pos % kBatch] = en[a];
    }
    const int parts = std::clamp(static_cast<int>(num_batches / 2), 1, kForceRanges);
    index_t count = 0;
    const std::vector<index_t> slot = shared_slots_of(nodes, num_nodes, parts, s.begin, count);
    s.shared.resize(static_cast<size_t>(count));
    for (index_t I = 0; I < num_nodes; ++I)
      if (slot[I] >= 0) s.shared[slot[I]] = I;
    for (index_t& I : nodes)
      if (I >= 0 && slot[I] >= 0) I = -2 - slot[I];
    s.nodes = std::move(nodes);
    s.out.assign(static_cast<size_t>(parts), std::vector<double>(3 * s.shared.size()));
    return s;
  }

  /// The batch order: the mesh's, which keeps the gathers close in memory where nodes are numbered
  /// as the elements meet them, unless its kProbeRanges contiguous ranges hold more than one free
  /// node in kMaxSharedShare in common (a mesh generator's scattered order): then the traversal's
  /// (the Morton order of the centroids), whose ranges are compact.
  void choose_order() {
    traversal_order = false;
    batch_pos.clear();
    make_batch_free();
    if (!ranges->reordered() || num_batches < 2 * kProbeRanges) return;
    std::vector<long> begin;
    index_t count = 0;
    shared_slots(kProbeRanges, begin, count);
    if (static_cast<long long>(count) * kMaxSharedShare <= num_free) return;
    traversal_order = true;
    make_batch_free();
    batch_pos.assign(static_cast<size_t>(num_elements), 0);
    for (index_t pos = 0; pos < num_elements; ++pos) batch_pos[static_cast<size_t>(ranges->element(pos))] = pos;
  }

  /// The float copy of batch_data.
  void copy_single() { batch_data_single.assign(batch_data.begin(), batch_data.end()); }
  /// The float copy refreshed, where kept.
  void refresh_single() {
    if (single) copy_single();
  }

  /// The split for `threads` ranges (found among the kept ones or made).
  Split& make_split(int threads) const {
    for (Split& k : splits)
      if (k.threads == threads) return k;
    Split s;
    s.threads = threads;
    index_t count = 0;
    const std::vector<index_t> slot = shared_slots(threads, s.begin, count);
    s.shared.resize(static_cast<size_t>(count));
    for (index_t I = 0; I < num_free; ++I)
      if (slot[I] >= 0) s.shared[slot[I]] = I;
    s.free = batch_free;
    for (index_t& I : s.free)
      if (I >= 0 && slot[I] >= 0) I = -2 - slot[I];
    s.out.assign(static_cast<size_t>(threads), std::vector<double>(3 * s.shared.size()));
    s.out_single.assign(static_cast<size_t>(threads), std::vector<float>(3 * s.shared.size()));
    if (splits.size() == kKeptSplits) splits.erase(splits.begin());
    splits.push_back(std::move(s));
    return splits.back();
  }

  template <class T>
  static std::vector<std::vector<T>>& split_out(Split& split) {
    if constexpr (std::is_same_v<T, float>) return split.out_single;
    else return split.out;
  }

  /// y = A x, or with b: y = b - A x (the residual in the same pass). T: double, or float for
  /// apply_single() (batched kernels only).
  template <int P, class T, class Vec>
  void apply(const Vec& x, Vec& y, const Vec* b, bool mass) const {
    // The float path has no scalar reference: the baseline batched kernel stands in for it.
    const MatrixFreeKernel kernel =
        std::is_same_v<T, float> && resolved == MatrixFreeKernel::reference ? MatrixFreeKernel::generic : resolved;
    const T* xp = x.data();
    T* yp = y.data();
    const long len = static_cast<long>(y.size());
    // Inside a parallel region that cannot start another active one, the product runs on one
    // thread (omp_get_max_threads() would still name the outer team's size).
    const int threads = omp_get_active_level() >= omp_get_max_active_levels() ? 1 : omp_get_max_threads();
    const T sign = b ? T(-1) : T(1);
    // One product at a time uses the kept buffers (two solvers sharing this operator take turns).
    const std::lock_guard<std::mutex> lock(buffers_mutex);
    if constexpr (std::is_same_v<T, double>) {
      if (kernel == MatrixFreeKernel::reference) return apply_reference<P>(x, y, b, threads);
    }
    const T* bdata = nullptr;
    if constexpr (std::is_same_v<T, float>) bdata = batch_data_single.data();
    else bdata = batch_data.data();
    if (threads <= 1 || num_batches < 2 * threads) {
      if (!b) std::fill(yp, yp + len, T(0));
      else if (b->data() != yp) std::copy(b->data(), b->data() + len, yp);  // b may be y itself
      detail::apply_element_batches<P, T>(kernel, batch_free.data(), bdata, 0, num_batches, xp, yp, {}, sign, mass);
      return;
    }
    Split& split = make_split(threads);
    std::vector<std::vector<T>>& outs = split_out<T>(split);
    const long slots = static_cast<long>(split.shared.size());
#pragma omp parallel num_threads(threads)
    {
      const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
      if (!b || b->data() != yp) {  // y = b or 0 first (with b = y the ranges add to it as it is)
#pragma omp for schedule(static)
        for (long i = 0; i < len; ++i) yp[i] = b ? (*b)[i] : T(0);
      }
      // Range t runs on thread t mod nt (the runtime may give fewer threads than asked for).
      for (int t = tid; t < threads; t += nt) {
        std::vector<T>& out = outs[static_cast<size_t>(t)];
        std::fill(out.begin(), out.end(), T(0));
        detail::apply_element_batches<P, T>(kernel, split.free.data(), bdata, split.begin[t], split.begin[t + 1], xp,
                                            yp, {split.shared.data(), out.data()}, sign, mass);
      }
#pragma omp barrier
#pragma omp for schedule(static)
      for (long s = 0; s < slots; ++s) add_slot(yp, split.shared[s], outs, s);
    }
  }

  /// The scalar reference kernel, element by element in mesh order.
  template <int P>
  void apply_reference(const Vector& x, Vector& y, const Vector* b, int threads) const {
    const long len = static_cast<long>(y.size());
    if (static_cast<int>(buffers.size()) != threads - 1 || (threads > 1 && buffers[0].size() != len))
      buffers.assign(std::max(threads - 1, 0), Vector(len));
    const double sign = b ? -1.0 : 1.0;
#pragma omp parallel num_threads(threads)
    {
      const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
      double* out = tid == 0 ? y.data() : buffers[tid - 1].data();
      if (tid == 0) {
        if (b) std::copy(b->data(), b->data() + len, y.data());
        else std::fill(y.data(), y.data() + len, 0.0);
      } else {
        std::fill(out, out + len, 0.0);
      }
      const long begin = num_elements * static_cast<long>(tid) / nt;
      const long end = num_elements * static_cast<long>(tid + 1) / nt;
      detail::apply_elements<P>(free.data(), batch_data.data(), batch_pos.empty() ? nullptr : batch_pos.data(), begin,
                                end, x.data(), out, sign);
#pragma omp barrier
      if (nt > 1) {
#pragma omp for schedule(static)
        for (long i = 0; i < len; ++i) {
          double sum = 0.0;
          for (int k = 0; k < nt - 1; ++k) sum += buffers[k][i];
          y[i] += sum;
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
  m.ranges = &as.ranges();
  m.num_elements = space.mesh().num_tets();
  const size_t ne = static_cast<size_t>(m.num_elements);
  m.free.resize(ne * m.n);
  for (size_t e = 0; e < ne; ++e)
    for (int a = 0; a < m.n; ++a) m.free[e * m.n + a] = as.free_index()[space.node(static_cast<index_t>(e), a)];
  m.num_free = as.num_free();
  m.num_batches = static_cast<index_t>((ne + kBatch - 1) / kBatch);
  m.choose_order();
  m.batch_data.assign(static_cast<size_t>(m.num_batches) * kData * kBatch, 0.0);
  // PMG_MATRIX_FREE_KERNEL (auto, generic, avx2, avx512, reference) overrides the automatic
  // choice, e.g. to run the portable path on a machine that has wider vectors.
  MatrixFreeKernel kernel = MatrixFreeKernel::automatic;
  if (const char* env = std::getenv("PMG_MATRIX_FREE_KERNEL"); env && *env) {
    kernel = parse_matrix_free_kernel(env);
    if (!matrix_free_kernel_available(kernel))
      throw InputError("PMG_MATRIX_FREE_KERNEL=" + std::string(env) + ": this CPU cannot run that kernel");
  }
  m.resolved = detail::resolve_kernel(kernel);
  update(nullptr);
}

ElasticityOperator::~ElasticityOperator() = default;

void ElasticityOperator::set_weights(double mass_weight, double stiffness_weight) {
  if (!std::isfinite(mass_weight) || !(mass_weight >= 0) || !std::isfinite(stiffness_weight) ||
      !(stiffness_weight >= 0) || !(mass_weight + stiffness_weight > 0))
    throw InputError("matrix-free operator: the weights must be finite, >= 0 and not both zero");
  mass_weight_ = mass_weight;
  stiffness_weight_ = stiffness_weight;
  Impl& m = *impl_;
  const Material& mat = model_->material();
  const auto& scale = model_->stiffness_scale();
  const double p2 = static_cast<double>(m.p) * m.p;
  double* data = m.batch_data.data();
#pragma omp parallel for schedule(static)
  for (long pos = 0; pos < static_cast<long>(m.num_elements); ++pos) {
    const index_t e = m.batch_element(pos);
    const double v6 = 6.0 * model_->geometry(e).volume;
    const double s = scale.empty() ? 1.0 : scale[e];
    data[detail::batch_datum(pos, 12)] = v6 * p2 * stiffness_weight * s * mat.lambda();
    data[detail::batch_datum(pos, 13)] = v6 * p2 * stiffness_weight * s * mat.mu();
    data[detail::batch_datum(pos, 14)] = v6 * mat.density * mass_weight;
  }
  m.refresh_single();
}

void ElasticityOperator::update(const Rotations* R) {
  Impl& m = *impl_;
  if (R && R->size() != static_cast<size_t>(model_->space().mesh().num_tets()))
    throw InputError("matrix-free operator: one rotation per element expected");
  double* data = m.batch_data.data();
#pragma omp parallel for schedule(static)
  for (long pos = 0; pos < static_cast<long>(m.num_elements); ++pos) {
    const index_t e = m.batch_element(pos);
    Eigen::Matrix<double, 4, 3> g = model_->geometry(e).grad;
    if (R) g = g * (*R)[e].transpose();
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) data[detail::batch_datum(pos, 3 * k + j)] = g(k, j);
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
    case 1: impl_->apply<1, double>(in, y, static_cast<const Vector*>(nullptr), mass); break;
    case 2: impl_->apply<2, double>(in, y, static_cast<const Vector*>(nullptr), mass); break;
    default: impl_->apply<3, double>(in, y, static_cast<const Vector*>(nullptr), mass); break;
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
    case 1: impl_->apply<1, double>(in, r, &b, mass); break;
    case 2: impl_->apply<2, double>(in, r, &b, mass); break;
    default: impl_->apply<3, double>(in, r, &b, mass); break;
  }
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) r[static_cast<Eigen::Index>(i)] = b[static_cast<Eigen::Index>(i)] - x[static_cast<Eigen::Index>(i)];
}

void ElasticityOperator::set_kernel(MatrixFreeKernel kernel) {
  if (!matrix_free_kernel_available(kernel))
    throw InputError("matrix-free operator: this CPU cannot run the " + to_string(kernel) + " kernel");
  impl_->resolved = detail::resolve_kernel(kernel);
}

MatrixFreeKernel ElasticityOperator::kernel() const { return impl_->resolved; }

ElasticityOperator::ElementArrays ElasticityOperator::element_arrays() const {
  const Impl& m = *impl_;
  ElementArrays arr{m.p, m.n, m.num_elements, m.free.data(), {}};
  arr.data.resize(static_cast<size_t>(m.num_elements) * kData);
#pragma omp parallel for schedule(static)
  for (long e = 0; e < static_cast<long>(m.num_elements); ++e)
    m.gather(static_cast<index_t>(e), arr.data.data() + kData * static_cast<size_t>(e));
  return arr;
}

void ElasticityOperator::apply_single(const Eigen::VectorXf& x, Eigen::VectorXf& y) const {
  apply_single_checked(x, y, nullptr, "apply_single()");
}

void ElasticityOperator::residual_single(const Eigen::VectorXf& b, const Eigen::VectorXf& x,
                                         Eigen::VectorXf& r) const {
  if (b.size() != rows())
    throw InputError("matrix-free operator: residual_single() got " + std::to_string(b.size()) +
                     " right-hand side entries for " + std::to_string(rows()) + " unknowns");
  apply_single_checked(x, r, &b, "residual_single()");
}

void ElasticityOperator::apply_single_checked(const Eigen::VectorXf& x, Eigen::VectorXf& y, const Eigen::VectorXf* b,
                                              const char* what) const {
  const std::string name = std::string("matrix-free operator: ") + what;
  if (x.size() != rows())
    throw InputError(name + " got " + std::to_string(x.size()) + " entries for " + std::to_string(rows()) +
                     " unknowns");
  if (!model_->constrained_free_dofs().empty()) throw InputError(name + " does not take held components");
  if (x.data() == y.data() && x.size() > 0) throw InputError(name + " needs x distinct from its output");
  Impl& m = *impl_;
  {
    std::lock_guard<std::mutex> lock(m.buffers_mutex);
    if (!m.single) {
      m.copy_single();
      m.single = true;  // after the copy: a failed allocation leaves the next call to try again
    }
  }
  y.resize(rows());
  const bool mass = mass_weight_ != 0.0;
  switch (m.p) {
    case 1: m.apply<1, float>(x, y, b, mass); break;
    case 2: m.apply<2, float>(x, y, b, mass); break;
    default: m.apply<3, float>(x, y, b, mass); break;
  }
}

void ElasticityOperator::diagonal_blocks(std::vector<double>& blocks) const {
  const Impl& m = *impl_;
  const ElementTables& t = element_tables(m.p);
  const size_t nodes = static_cast<size_t>(num_free_);
  blocks.assign(9 * nodes, 0.0);
  const double p2 = static_cast<double>(m.p) * m.p;
  // The diagonal blocks of element e at batch position pos, node by node: add(a, B) for each
  // element node a.
  //
  // With G_aa symmetric, S_a = gᵀ G_aa g = Σ_{k≤l} G_aa(k,l) O_kl, O_kk = g_k g_kᵀ and
  // O_kl = g_k g_lᵀ + g_l g_kᵀ (k < l): the element's ten symmetric products (six entries each) are
  // formed once, and each node's S_a sums only the pairs its G_aa holds (G_aa(k,l) ≠ 0 needs
  // α_a,k and α_a,l > 0: one pair at a vertex node, three at an edge node, six at a face node),
  // symmetric to the last bit by construction.
  struct Term {
    int pair;
    double weight;
  };
  std::vector<std::vector<Term>> terms(static_cast<size_t>(m.n));
  for (int a = 0; a < m.n; ++a)
    for (int k = 0, q = 0; k < 4; ++k)
      for (int l = k; l < 4; ++l, ++q)
        if (const double w = t.G[a * m.n + a](k, l); w != 0.0) terms[static_cast<size_t>(a)].push_back({q, w});
  auto element_blocks = [&](size_t e, long pos, auto&& add) {
    double d[kData];
    m.gather_at(pos, d);
    const double* g = d;  // ∇λ_k at d[3k..3k+2]
    double O[10][6];      // xx, yy, zz, xy, xz, yz of O_kl, pairs k ≤ l in order
    for (int k = 0, q = 0; k < 4; ++k)
      for (int l = k; l < 4; ++l, ++q) {
        const double *u = g + 3 * k, *v = g + 3 * l;
        const double f = k == l ? 1.0 : 2.0;
        O[q][0] = f * (u[0] * v[0]), O[q][1] = f * (u[1] * v[1]), O[q][2] = f * (u[2] * v[2]);
        O[q][3] = k == l ? u[0] * v[1] : u[0] * v[1] + u[1] * v[0];
        O[q][4] = k == l ? u[0] * v[2] : u[0] * v[2] + u[2] * v[0];
        O[q][5] = k == l ? u[1] * v[2] : u[1] * v[2] + u[2] * v[1];
      }
    // d[12], d[13] carry 6V p² s λ, 6V p² s μ; the G tables carry p² already.
    const double lambda = d[12] / p2, mu = d[13] / p2, w = lambda + mu;
    for (int a = 0; a < m.n; ++a) {
      if (m.free[e * m.n + a] < 0) continue;
      double S[6] = {0, 0, 0, 0, 0, 0};
      for (const Term& term : terms[static_cast<size_t>(a)])
        for (int i = 0; i < 6; ++i) S[i] += term.weight * O[term.pair][i];
      const double diagonal = mu * (S[0] + S[1] + S[2]) + d[14] * t.mass(a, a);
      Mat3 B;
      B << w * S[0] + diagonal, w * S[3], w * S[4],  //
          w * S[3], w * S[1] + diagonal, w * S[5],   //
          w * S[4], w * S[5], w * S[2] + diagonal;
      add(a, B);
    }
  };
  auto add_to = [](double* o, const Mat3& B) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) o[3 * r + c] += B(r, c);
  };
  const size_t ne = static_cast<size_t>(m.num_elements);
  const int threads = omp_get_active_level() >= omp_get_max_active_levels() ? 1 : omp_get_max_threads();
  if (threads <= 1 || m.num_batches < 2 * threads) {
    for (size_t e = 0; e < ne; ++e)
      element_blocks(e, m.position(static_cast<index_t>(e)),
                     [&](int a, const Mat3& B) { add_to(blocks.data() + 9 * static_cast<size_t>(m.free[e * m.n + a]), B); });
  } else {
    // The product's ranges of batches (apply()): each range adds the nodes that only it holds in
    // place and the shared ones into its own 9 per slot, added after the ranges in range order.
    const std::lock_guard<std::mutex> lock(m.buffers_mutex);
    Impl::Split& split = m.make_split(threads);
    const size_t slots = split.shared.size();
    std::vector<std::vector<double>>& own = split.blocks;  // kept: a time step's update allocates none
    own.resize(static_cast<size_t>(threads));
#pragma omp parallel num_threads(threads)
    {
      const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
      for (int r = tid; r < threads; r += nt) {
        std::vector<double>& out = own[static_cast<size_t>(r)];
        out.assign(9 * slots, 0.0);
        for (long pos = split.begin[r] * kBatch; pos < split.begin[r + 1] * kBatch; ++pos) {
          const index_t e = m.batch_element(pos);
          if (e < 0) break;  // the last batch's padding
          const index_t* f = split.free.data() + (static_cast<size_t>(pos / kBatch) * m.n) * kBatch + pos % kBatch;
          element_blocks(static_cast<size_t>(e), pos, [&](int a, const Mat3& B) {
            const index_t I = f[static_cast<size_t>(a) * kBatch];
            add_to(I >= 0 ? blocks.data() + 9 * static_cast<size_t>(I) : out.data() + 9 * static_cast<size_t>(-2 - I), B);
          });
        }
      }
#pragma omp barrier
#pragma omp for schedule(static)
      for (long k = 0; k < static_cast<long>(slots); ++k) {
        double* o = blocks.data() + 9 * static_cast<size_t>(split.shared[static_cast<size_t>(k)]);
        for (int r = 0; r < threads; ++r)
          for (int i = 0; i < 9; ++i) o[i] += own[static_cast<size_t>(r)][9 * static_cast<size_t>(k) + i];
      }
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
  if (stiffness_weight_ > 0.0 && m.resolved != MatrixFreeKernel::reference) {
    // The batched kernels over a fixed number of contiguous ranges of batches, spread over the
    // threads: each range writes the nodes that only it holds in place and the shared ones into
    // its own slots, added after in range order, and its energy is summed in range order. Every
    // node and the energy thus sum in the same order on any number of threads.
    const std::lock_guard<std::mutex> lock(m.buffers_mutex);
    Impl::NodeSplit& split = m.make_node_split(model_->space());
    const double inv_weight = 1.0 / stiffness_weight_;
    const double* Xp = X.data()->data();
    const double* Rp = Rs ? Rs->data()->data() : nullptr;
    const int parts = static_cast<int>(split.out.size());
    const long slots = static_cast<long>(split.shared.size());
    auto range = [&](int r) {
      double* out = split.out[static_cast<size_t>(r)].data();
      std::fill(out, out + 3 * slots, 0.0);
      const detail::SharedSlots<double> shared{split.shared.data(), out};
      auto run = [&](auto tag) {
        constexpr int P = decltype(tag)::value;
        return detail::force_element_batches<P>(m.resolved, split.nodes.data(), split.elements.data(),
                                                 m.batch_data.data(), inv_weight, Xp, u.data(), Rp, split.begin[r],
                                                 split.begin[r + 1], force.data(), shared);
      };
      switch (m.p) {
        case 1: return run(std::integral_constant<int, 1>{});
        case 2: return run(std::integral_constant<int, 2>{});
        default: return run(std::integral_constant<int, 3>{});
      }
    };
    std::vector<double> part(static_cast<size_t>(parts), 0.0);
    const int threads = omp_get_active_level() >= omp_get_max_active_levels() ? 1 : std::min(omp_get_max_threads(), parts);
#pragma omp parallel num_threads(threads)
    {
#pragma omp for schedule(static)
      for (int r = 0; r < parts; ++r) part[static_cast<size_t>(r)] = range(r);
#pragma omp for schedule(static)
      for (long k = 0; k < slots; ++k) m.add_slot(force.data(), split.shared[static_cast<size_t>(k)], split.out, k);
    }
    double total = 0.0;
    for (double p : part) total += p;
    if (energy) *energy = total;
    return;
  }
  const double total = m.ranges->for_each([&](int, index_t e, const ElementRanges::Writes& writes, bool) {
    const index_t* nodes = model_->space().element_nodes(e);
    double d[kData];
    m.gather(e, d);
    // K_R,e alone: the unweighted Lamé factors (the stored ones carry the stiffness weight).
    const double v6p2 = 6.0 * model_->geometry(e).volume * m.p * m.p;
    const double s = model_->stiffness_scale().empty() ? 1.0 : model_->stiffness_scale()[e];
    d[12] = v6p2 * s * model_->material().lambda(), d[13] = v6p2 * s * model_->material().mu(), d[14] = 0.0;
    const Mat3 R = Rs ? (*Rs)[e] : Mat3::Identity();
    double part = 0.0;
    auto run = [&](auto tag) {
      constexpr int P = decltype(tag)::value;
      constexpr int N = ElementKernelTables<P>::N;
      double y[N][3], r[N][3];
      for (int a = 0; a < N; ++a) {
        const Vec3& Xa = X[nodes[a]];
        const Vec3 ya = Xa + u.segment<3>(3 * nodes[a]) - R * Xa;
        y[a][0] = ya[0], y[a][1] = ya[1], y[a][2] = ya[2];
      }
      detail::element_product<P>(d, y, r);
      for (int a = 0; a < N; ++a) {
        part += 0.5 * (y[a][0] * r[a][0] + y[a][1] * r[a][1] + y[a][2] * r[a][2]);
        if (!writes(nodes[a])) continue;
        double* f = force.data() + 3 * static_cast<size_t>(nodes[a]);
        f[0] -= r[a][0], f[1] -= r[a][1], f[2] -= r[a][2];
      }
    };
    switch (m.p) {
      case 1: run(std::integral_constant<int, 1>{}); break;
      case 2: run(std::integral_constant<int, 2>{}); break;
      default: run(std::integral_constant<int, 3>{}); break;
    }
    return part;
  });
  if (energy) *energy = total;
}

double ElasticityOperator::flops_per_apply() const {
  const double n = impl_->n, q = element_nodes(impl_->p - 1);
  // The batched kernels' operations: steps 1–4 on the 6 symmetric components (header), the mass.
  const double per = 72 * q + 12 * q * q + 12 * q + 72 * q + (mass_weight_ != 0 ? 6 * n * n : 0.0);
  return per * static_cast<double>(impl_->num_elements);
}

double ElasticityOperator::bytes_per_apply() const {
  const double per = kData * 8.0 + 4.0 * impl_->n;
  return per * static_cast<double>(impl_->num_elements) + 3.0 * 8.0 * rows();
}

}  // namespace pmg::fem
