#include "fixture.hpp"

#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/matrix_market.hpp"

#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <unistd.h>

using namespace pmg;
using namespace pmg::test;

namespace {
Csr parse(const std::string& text) {
  std::istringstream in(text);
  return read_matrix_market(in, "t.mtx");
}
std::filesystem::path temp_dir() {
  auto d = std::filesystem::temp_directory_path() / ("pmg_mm_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}
}  // namespace

TEST_CASE("Matrix Market reads general, symmetric, integer and pattern files", "[sparse][mm]") {
  const Csr g = parse(
      "%%MatrixMarket matrix coordinate real general\n% a comment\n\n3 3 4\n1 1 2.5\n3 1 -1e-3\n"
      "2 3 4\n1 1 0.5\n");
  Eigen::MatrixXd D(3, 3);
  D << 3.0, 0, 0, 0, 0, 4, -1e-3, 0, 0;
  CHECK(Eigen::MatrixXd(g.to_eigen()) == D);

  const Csr s = parse("%%MatrixMarket matrix coordinate integer symmetric\n2 2 2\n1 1 4\n2 1 -1\n");
  Eigen::MatrixXd S(2, 2);
  S << 4, -1, -1, 0;
  CHECK(Eigen::MatrixXd(s.to_eigen()) == S);

  const Csr p = parse("%%MatrixMarket matrix coordinate pattern general\r\n2 2 1\r\n2 2\r\n");
  CHECK(p.to_eigen().coeff(1, 1) == 1.0);
}

TEST_CASE("Matrix Market write then read gives the same matrix", "[sparse][mm]") {
  const auto dir = temp_dir();
  const Csr A = spring_lattice(3).to_csr();
  for (bool symmetric : {false, true}) {
    const auto path = (dir / (symmetric ? "sym.mtx" : "gen.mtx")).string();
    write_matrix_market(path, A, symmetric);
    const Csr B = read_matrix_market(path);
    CHECK(Eigen::MatrixXd(B.to_eigen()) == Eigen::MatrixXd(A.to_eigen()));
  }
  const Vector v = random_vector(10, 3);
  write_matrix_market_vector((dir / "v.mtx").string(), v);
  CHECK(read_matrix_market_vector((dir / "v.mtx").string()) == v);
  // Written through a temporary name: nothing but the three files is left behind.
  CHECK(std::distance(std::filesystem::directory_iterator(dir), {}) == 3);
  CHECK_THROWS_WITH(write_matrix_market((dir / "x.mtx").string(),
                                        Csr::from_triplets(2, 2, {{0, 1, 1.0}}), true),
                    Catch::Contains("not symmetric"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("malformed Matrix Market files name the line and what is wrong", "[sparse][mm]") {
  const std::string hdr = "%%MatrixMarket matrix coordinate real general\n";
  struct Case {
    std::string text, message;
  };
  const std::vector<Case> cases{
      {"", "t.mtx:1: empty file"},
      {"3 3 1\n1 1 1\n", "t.mtx:1: first line must start with %%MatrixMarket"},
      {"%%MatrixMarket matrix coordinate complex general\n", "t.mtx:1: unsupported field 'complex'"},
      {"%%MatrixMarket matrix coordinate real hermitian\n", "unsupported symmetry"},
      {"%%MatrixMarket vector coordinate real general\n", "unsupported object"},
      {hdr, "t.mtx:2: missing size line"},
      {hdr + "3 3\n", "t.mtx:2: size line must hold 3 integers"},
      {hdr + "3 x 1\n", "t.mtx:2: expected an integer column count, found 'x'"},
      {hdr + "3 3 2\n1 1 1.0\n2 2\n", "t.mtx:4: expected 3 fields, found 2"},
      {hdr + "3 3 1\n4 1 1.0\n", "t.mtx:3: row index 4 outside 1..3"},
      {hdr + "3 3 1\n1 0 1.0\n", "t.mtx:3: column index 0 outside 1..3"},
      {hdr + "3 3 1\n1 1 abc\n", "t.mtx:3: expected a real value, found 'abc'"},
      {hdr + "3 3 1\n1 1 nan\n", "t.mtx:3: value 'nan' is not finite"},
      {hdr + "3 3 1\n1 1 1.5x\n", "expected a real value, found '1.5x'"},
      {hdr + "3 3 3\n1 1 1\n2 2 2\n", "t.mtx:2: entry count 3 is more than the 2 the rest of the file could hold"},
      {hdr + "3 3 3\n1 1 1\n2 2 2\n% a comment is no entry\n", "t.mtx:6: file ends after 2 of the 3 declared entries"},
      {hdr + "3 3 1\n1 1 1\n2 2 2\n", "t.mtx:4: more entries than the 1 declared"},
      {hdr + "3 3 -1\n", "negative entry count"},
      {hdr + "99999999999 3 1\n", "exceeds the 32-bit index range"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 2 1\n",
       "t.mtx:3: entry (1, 2) lies above the diagonal"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 3 0\n", "must be square"},
  };
  for (const auto& c : cases) {
    INFO(c.text);
    CHECK_THROWS_WITH(parse(c.text), Catch::Contains(c.message));
    CHECK_THROWS_AS(parse(c.text), InputError);
  }
  CHECK_THROWS_WITH(read_matrix_market("/nonexistent/a.mtx"), Catch::Contains("cannot open"));
}

TEST_CASE("Matrix Market vectors: array format and n x 1 coordinate", "[sparse][mm]") {
  std::istringstream a("%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n");
  CHECK(read_matrix_market_vector(a) == Vector::LinSpaced(3, 1, 3));
  std::istringstream c("%%MatrixMarket matrix coordinate real general\n3 1 1\n2 1 7\n");
  CHECK(read_matrix_market_vector(c) == Vector::Unit(3, 1) * 7);
  std::istringstream bad("%%MatrixMarket matrix array real general\n3 2\n1\n2\n3\n4\n5\n6\n");
  CHECK_THROWS_WITH(read_matrix_market_vector(bad), Catch::Contains("one column"));
}

TEST_CASE("hostile Matrix Market input: blank-looking lines, NUL bytes, sizes the data does not back",
          "[sparse][mm]") {
  const std::string hdr = "%%MatrixMarket matrix coordinate real general\n";
  // Lines of only \v, \f or \r are blank, as they are to the tokenizer.
  CHECK(parse(hdr + "\v\n2 2 1\n\f\n1 1 3\n\r\n").rows() == 2);
  CHECK_THROWS_WITH(parse(hdr + "1 1 1\n1 1 2" + std::string(1, '\0') + "junk\n"),
                    Catch::Contains("t.mtx:3: expected a real value, found '2\\x00junk'"));
  CHECK_THROWS_WITH(parse(hdr + "100000000 100000000 1\n1 1 1\n"),
                    Catch::Contains("declares 100000000 rows but only 1 entries"));
  CHECK_THROWS_WITH(parse(hdr + "2 2 1000000000000\n1 1 1\n"),
                    Catch::Contains("entry count 1000000000000 is more than the"));
  CHECK_THROWS_WITH(parse("%%MatrixMarket matrix array real general\n100000 100000\n1\n"),
                    Catch::Contains("declares 100000 x 100000 values, more than the rest of the file"));
  // Found by fuzzing: an array with no columns declared 1e8 rows (row pointers for nothing).
  CHECK_THROWS_WITH(parse("%%MatrixMarket matrix array real general\n100000000 0\n"),
                    Catch::Contains("declares 100000000 rows but only 0 entries"));
  // Each value is finite, but repeated entries are summed: their sum must be too.
  CHECK_THROWS_WITH(parse(hdr + "1 1 2\n1 1 1e308\n1 1 1e308\n"),
                    Catch::Contains("t.mtx: the repeated entries at (1, 1) sum to a non-finite value"));
  // A large but backed size reads: 2 million rows for 200,000 entries.
  std::string big = hdr + "2000000 1 200000\n";
  for (int i = 0; i < 200000; ++i) big += std::to_string(10 * i + 1) + " 1 1\n";
  CHECK(parse(big).rows() == 2000000);
}
