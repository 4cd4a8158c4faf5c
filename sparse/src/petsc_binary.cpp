#include "pmg/sparse/petsc_binary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>

namespace pmg {

namespace {

constexpr std::int32_t kMatClassId = 1211216;
constexpr std::int32_t kVecClassId = 1211214;

std::uint32_t swap32(std::uint32_t v) { return __builtin_bswap32(v); }
std::uint64_t swap64(std::uint64_t v) { return __builtin_bswap64(v); }

/// Reads big-endian items from a stream whose remaining size is known (or unknown: then counts
/// are checked as the items arrive).
class BinaryReader {
 public:
  BinaryReader(std::istream& in, const std::string& name) : in_(in), name_(name) {
    const auto here = in.tellg();
    if (here != std::istream::pos_type(-1) && in.seekg(0, std::ios::end)) {
      remaining_ = static_cast<long long>(in.tellg() - here);
      in.seekg(here);
    } else {
      in.clear();
    }
  }
  [[noreturn]] void fail(const std::string& what) const { throw InputError(name_ + ": " + what); }
  /// Items of `bytes` each that the rest of the file can hold.
  long long can_hold(int bytes) const { return remaining_ / bytes; }
  void read(void* dst, std::size_t bytes, const char* what) {
    if (!in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(bytes)))
      fail(std::string("file ends inside ") + what);
    remaining_ -= static_cast<long long>(bytes);
  }
  std::int32_t int32(const char* what) {
    std::uint32_t v;
    read(&v, 4, what);
    v = swap32(v);
    std::int32_t s;
    std::memcpy(&s, &v, 4);
    return s;
  }
  void int32s(std::vector<std::int32_t>& out, const char* what) {
    read(out.data(), 4 * out.size(), what);
    for (auto& v : out) {
      std::uint32_t u;
      std::memcpy(&u, &v, 4);
      u = swap32(u);
      std::memcpy(&v, &u, 4);
    }
  }
  void reals(double* out, std::size_t n, const char* what) {
    read(out, 8 * n, what);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t u;
      std::memcpy(&u, out + i, 8);
      u = swap64(u);
      std::memcpy(out + i, &u, 8);
      if (!std::isfinite(out[i])) fail(std::string(what) + ": entry " + std::to_string(i) + " is not finite");
    }
  }
  void check_count(long long count, const char* what, int bytes_each) const {
    if (count < 0) fail(std::string("negative ") + what + " " + std::to_string(count));
    if (count > can_hold(bytes_each))
      fail(std::string(what) + " " + std::to_string(count) + " is more than the " +
           std::to_string(can_hold(bytes_each)) + " the rest of the file could hold");
  }

 private:
  std::istream& in_;
  std::string name_;
  long long remaining_ = std::numeric_limits<long long>::max();
};

void put32(std::string& out, std::int32_t v) {
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  u = swap32(u);
  out.append(reinterpret_cast<const char*>(&u), 4);
}

void put_reals(std::string& out, const double* v, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + 8 * n);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t u;
    std::memcpy(&u, v + i, 8);
    u = swap64(u);
    std::memcpy(&out[at + 8 * i], &u, 8);
  }
}

std::ifstream open(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open");
  return in;
}

}  // namespace

Csr read_petsc_binary_matrix(std::istream& in, const std::string& name) {
  BinaryReader rd(in, name);
  const std::int32_t id = rd.int32("the header");
  if (id == kVecClassId) rd.fail("a PETSc vector, not a matrix");
  if (id != kMatClassId)
    rd.fail("not a PETSc binary matrix (class id " + std::to_string(id) + ", expected " +
            std::to_string(kMatClassId) + "; 64-bit-index PETSc files are not read)");
  const std::int32_t rows = rd.int32("the header"), cols = rd.int32("the header"),
                     nnz = rd.int32("the header");
  if (rows < 0 || cols < 0) rd.fail("negative size " + std::to_string(rows) + "x" + std::to_string(cols));
  if (nnz == -1) rd.fail("a dense PETSc matrix (nnz = -1); only sparse (AIJ) matrices are read");
  rd.check_count(rows, "row count", 4);
  rd.check_count(nnz, "nonzero count", 12);
  std::vector<std::int32_t> lengths(rows), cols_idx(nnz);
  rd.int32s(lengths, "the row lengths");
  auto p = std::make_shared<CsrPattern>();
  p->rows = rows;
  p->cols = cols;
  p->row_ptr.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (std::int32_t i = 0; i < rows; ++i) {
    if (lengths[i] < 0 || lengths[i] > cols)
      rd.fail("row " + std::to_string(i) + " has " + std::to_string(lengths[i]) + " entries (" +
              std::to_string(cols) + " columns)");
    p->row_ptr[i + 1] = p->row_ptr[i] + lengths[i];
  }
  if (p->row_ptr[rows] != nnz)
    rd.fail("the row lengths add up to " + std::to_string(p->row_ptr[rows]) + ", the header says " +
            std::to_string(nnz) + " nonzeros");
  rd.int32s(cols_idx, "the column indices");
  std::vector<double> values(nnz);
  rd.reals(values.data(), values.size(), "the values");
  // Sort each row by column (PETSc writes sorted rows; other writers may not); refuse repeats.
  p->col_idx.resize(nnz);
  std::vector<double> sorted(nnz);
  std::vector<std::int32_t> order;
  for (std::int32_t i = 0; i < rows; ++i) {
    const offset_t b = p->row_ptr[i], e = p->row_ptr[i + 1];
    order.resize(e - b);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int x, int y) { return cols_idx[b + x] < cols_idx[b + y]; });
    for (offset_t k = b; k < e; ++k) {
      const std::int32_t c = cols_idx[b + order[k - b]];
      if (c < 0 || c >= cols)
        rd.fail("row " + std::to_string(i) + ": column " + std::to_string(c) + " outside 0.." +
                std::to_string(cols - 1));
      if (k > b && c == p->col_idx[k - 1])
        rd.fail("row " + std::to_string(i) + ": column " + std::to_string(c) + " appears twice");
      p->col_idx[k] = c;
      sorted[k] = values[b + order[k - b]];
    }
  }
  return Csr(std::move(p), std::move(sorted));
}

Csr read_petsc_binary_matrix(const std::string& path) {
  std::ifstream in = open(path);
  return read_petsc_binary_matrix(in, path);
}

Vector read_petsc_binary_vector(std::istream& in, const std::string& name) {
  BinaryReader rd(in, name);
  const std::int32_t id = rd.int32("the header");
  if (id == kMatClassId) rd.fail("a PETSc matrix, not a vector");
  if (id != kVecClassId)
    rd.fail("not a PETSc binary vector (class id " + std::to_string(id) + ", expected " +
            std::to_string(kVecClassId) + ")");
  const std::int32_t n = rd.int32("the header");
  rd.check_count(n, "vector length", 8);
  Vector v(n);
  rd.reals(v.data(), static_cast<std::size_t>(n), "the values");
  return v;
}

Vector read_petsc_binary_vector(const std::string& path) {
  std::ifstream in = open(path);
  return read_petsc_binary_vector(in, path);
}

void write_petsc_binary(const std::string& path, const Csr& A) {
  if (A.nnz() > std::numeric_limits<std::int32_t>::max())
    throw InputError(path + ": " + std::to_string(A.nnz()) + " nonzeros do not fit PETSc's 32-bit format");
  std::string out;
  out.reserve(16 + 4 * static_cast<std::size_t>(A.rows()) + 12 * static_cast<std::size_t>(A.nnz()));
  put32(out, kMatClassId);
  put32(out, A.rows());
  put32(out, A.cols());
  put32(out, static_cast<std::int32_t>(A.nnz()));
  const CsrPattern& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i) put32(out, static_cast<std::int32_t>(p.row_ptr[i + 1] - p.row_ptr[i]));
  for (index_t c : p.col_idx) put32(out, c);
  put_reals(out, A.values().data(), A.values().size());
  write_file_atomically(path, out);
}

void write_petsc_binary(const std::string& path, const Vector& v) {
  // The reader refuses NaN and Inf: never write a file it would refuse.
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) throw InputError(path + ": vector entry " + std::to_string(i) + " is NaN or Inf");
  std::string out;
  put32(out, kVecClassId);
  put32(out, static_cast<std::int32_t>(v.size()));
  put_reals(out, v.data(), static_cast<std::size_t>(v.size()));
  write_file_atomically(path, out);
}

}  // namespace pmg
