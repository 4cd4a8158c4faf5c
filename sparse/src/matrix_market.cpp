#include "pmg/sparse/matrix_market.hpp"

#include "pmg/sparse/text_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <unistd.h>
#include <vector>

namespace pmg {

namespace {

struct Header {
  bool coordinate = true;
  bool pattern = false;
  bool symmetric = false;
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

Header read_header(TextReader& rd) {
  std::string line;
  if (!rd.next_line(line)) rd.fail("empty file (expected a %%MatrixMarket header)");
  const auto t = split_tokens(line);
  if (t.empty() || t[0] != "%%MatrixMarket")
    rd.fail("first line must start with %%MatrixMarket");
  if (t.size() != 5)
    rd.fail("header must read '%%MatrixMarket matrix <format> <field> <symmetry>'");
  if (lower(t[1]) != "matrix") rd.fail("unsupported object '" + printable(t[1]) + "' (only 'matrix')");
  Header h;
  const std::string format = lower(t[2]), field = lower(t[3]), sym = lower(t[4]);
  if (format == "array") h.coordinate = false;
  else if (format != "coordinate")
    rd.fail("unknown format '" + printable(t[2]) + "' (expected coordinate or array)");
  if (field == "pattern") h.pattern = true;
  else if (field != "real" && field != "integer" && field != "double")
    rd.fail("unsupported field '" + printable(t[3]) + "' (real, integer or pattern)");
  if (h.pattern && !h.coordinate) rd.fail("the pattern field needs the coordinate format");
  if (sym == "symmetric") h.symmetric = true;
  else if (sym != "general")
    rd.fail("unsupported symmetry '" + printable(t[4]) + "' (general or symmetric)");
  return h;
}

index_t checked_size(const TextReader& rd, long long v, const char* what) {
  if (v < 0) rd.fail(std::string("negative ") + what);
  if (v > std::numeric_limits<index_t>::max())
    rd.fail(std::string(what) + " " + std::to_string(v) + " exceeds the 32-bit index range");
  return static_cast<index_t>(v);
}

/// Rows or columns a file may declare beyond 16 per stored entry (or array value).
constexpr long long kFreeDimension = 1 << 20;

struct Parsed {
  index_t rows = 0, cols = 0;
  std::vector<Triplet> entries;
};

Parsed parse(std::istream& in, const std::string& name) {
  TextReader rd(in, name, '%');
  const Header h = read_header(rd);
  std::string line;
  if (!rd.next_data_line(line)) rd.fail("missing size line");
  auto t = split_tokens(line);
  const size_t size_fields = h.coordinate ? 3 : 2;
  if (t.size() != size_fields)
    rd.fail("size line must hold " + std::to_string(size_fields) + " integers, found " +
            std::to_string(t.size()) + " fields");
  Parsed out;
  out.rows = checked_size(rd, rd.to_integer(t[0], "row count"), "row count");
  out.cols = checked_size(rd, rd.to_integer(t[1], "column count"), "column count");
  if (h.symmetric && out.rows != out.cols) rd.fail("a symmetric matrix must be square");
  // Every entry line holds at least `fields` one-character tokens and their separators, so the
  // rest of the file bounds the entry count before anything is allocated.
  const size_t fields = h.coordinate ? (h.pattern ? 2 : 3) : 1;
  // + 1: the last line may lack its line break and still hold a whole entry.
  const long long most_entries = (rd.remaining_bytes() + 1) / static_cast<long long>(2 * fields);
  long long count;
  if (h.coordinate) {
    count = rd.to_count(t[2], "entry count", most_entries);
  } else {
    count = static_cast<long long>(out.rows) * out.cols;
    if (count > most_entries)
      rd.fail("declares " + std::to_string(out.rows) + " x " + std::to_string(out.cols) +
              " values, more than the rest of the file can hold");
  }
  // Rows and columns the entries do not back would still cost memory (row pointers, vectors):
  // a declared size far beyond the stored entries (or an array with a zero side) is a damaged
  // header, not a sparse matrix.
  const long long backed = kFreeDimension + 16 * count;
  for (const auto& [dim, what] : {std::pair{out.rows, "rows"}, std::pair{out.cols, "columns"}})
    if (dim > backed)
      rd.fail("declares " + std::to_string(dim) + " " + what + " but only " + std::to_string(count) +
              " entries: at most " + std::to_string(backed) +
              " are accepted for that many entries (a damaged size line?)");
  out.entries.reserve(static_cast<size_t>(rd.seekable() ? count : std::min<long long>(count, 1 << 20)));
  for (long long e = 0; e < count; ++e) {
    if (!rd.next_data_line(line))
      rd.fail("file ends after " + std::to_string(e) + " of the " + std::to_string(count) +
              " declared entries");
    t = split_tokens(line);
    if (t.size() != fields)
      rd.fail("expected " + std::to_string(fields) + " fields, found " + std::to_string(t.size()));
    index_t i, j;
    double v = 1.0;
    if (h.coordinate) {
      const long long ii = rd.to_integer(t[0], "row index");
      const long long jj = rd.to_integer(t[1], "column index");
      if (ii < 1 || ii > out.rows)
        rd.fail("row index " + t[0] + " outside 1.." + std::to_string(out.rows));
      if (jj < 1 || jj > out.cols)
        rd.fail("column index " + t[1] + " outside 1.." + std::to_string(out.cols));
      i = static_cast<index_t>(ii - 1);
      j = static_cast<index_t>(jj - 1);
      if (!h.pattern) v = rd.to_real(t[2]);
      if (h.symmetric && i < j)
        rd.fail("entry (" + t[0] + ", " + t[1] +
                ") lies above the diagonal; symmetric files store the lower triangle only");
    } else {
      i = static_cast<index_t>(e % std::max<index_t>(out.rows, 1));
      j = static_cast<index_t>(e / std::max<index_t>(out.rows, 1));
      v = rd.to_real(t[0]);
      if (v == 0.0) continue;
    }
    out.entries.emplace_back(i, j, v);
    if (h.symmetric && i != j) out.entries.emplace_back(j, i, v);
  }
  if (rd.next_data_line(line))
    rd.fail("more entries than the " + std::to_string(count) + " declared");
  return out;
}

std::ifstream open_input(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open for reading");
  return in;
}

}  // namespace

Csr read_matrix_market(std::istream& in, const std::string& name) {
  Parsed p = parse(in, name);
  Csr A = Csr::from_triplets(p.rows, p.cols, p.entries);
  // Each value is finite, but repeated entries are summed (found by fuzzing: 1e308 twice).
  const CsrPattern& pat = A.pattern();
  for (index_t i = 0; i < pat.rows; ++i)
    for (offset_t k = pat.row_ptr[i]; k < pat.row_ptr[i + 1]; ++k)
      if (!std::isfinite(A.values()[k]))
        throw InputError(name + ": the repeated entries at (" + std::to_string(i + 1) + ", " +
                         std::to_string(pat.col_idx[k] + 1) + ") sum to a non-finite value");
  return A;
}

Csr read_matrix_market(const std::string& path) {
  auto in = open_input(path);
  return read_matrix_market(in, path);
}

Vector read_matrix_market_vector(std::istream& in, const std::string& name) {
  Parsed p = parse(in, name);
  if (p.cols != 1)
    throw InputError(name + ": a vector must have one column, this has " + std::to_string(p.cols));
  Vector v = Vector::Zero(p.rows);
  for (const auto& t : p.entries) v[t.row()] += t.value();
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      throw InputError(name + ": the repeated entries of row " + std::to_string(i + 1) + " sum to a non-finite value");
  return v;
}

Vector read_matrix_market_vector(const std::string& path) {
  auto in = open_input(path);
  return read_matrix_market_vector(in, path);
}

void write_matrix_market(const std::string& path, const Csr& A, bool symmetric) {
  // Round-off asymmetry (1e-12 of the largest entry) is accepted: the lower triangle is written.
  if (symmetric && !A.is_symmetric(1e-12))
    throw InputError(path + ": matrix is not symmetric; write it as general");
  const CsrPattern& p = A.pattern();
  offset_t count = 0;
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (!symmetric || p.col_idx[k] <= i) ++count;
  std::ostringstream out;
  out.precision(17);
  out << "%%MatrixMarket matrix coordinate real " << (symmetric ? "symmetric" : "general") << "\n"
      << "% written by pmgkit\n"
      << p.rows << " " << p.cols << " " << count << "\n";
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (!symmetric || p.col_idx[k] <= i)
        out << i + 1 << " " << p.col_idx[k] + 1 << " " << A.values()[k] << "\n";
  write_file_atomically(path, out.str());
}

void write_matrix_market_vector(const std::string& path, const Vector& v) {
  std::ostringstream out;
  out.precision(17);
  out << "%%MatrixMarket matrix array real general\n" << v.size() << " 1\n";
  for (Eigen::Index i = 0; i < v.size(); ++i) out << v[i] << "\n";
  write_file_atomically(path, out.str());
}

}  // namespace pmg
