// The shared input/output checks: strict JSON, output paths checked before any work, memory.
#include "pmg/sparse/config.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/text_reader.hpp"
#include "pmg/sparse/types.hpp"

#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <fcntl.h>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>

using namespace pmg;

TEST_CASE("check_json_text refuses bad syntax, duplicate keys (with their path) and huge numbers",
          "[sparse][io]") {
  CHECK_NOTHROW(check_json_text(R"({"a": {"b": 1, "c": [1, 2]}, "d": "x"})", "ok.json"));
  CHECK_THROWS_AS(check_json_text("{", "t.json"), InputError);
  CHECK_THROWS_WITH(check_json_text("{", "t.json"), Catch::Contains("t.json: not valid JSON"));
  CHECK_THROWS_WITH(check_json_text(R"({"a": {"b": 1, "b": 2}})", "t.json"),
                    Catch::Contains("t.json: key 'a.b' appears twice"));
  // The same key in two different objects is fine.
  CHECK_NOTHROW(check_json_text(R"({"a": {"b": 1}, "c": {"b": 2}})", "t.json"));
  CHECK_THROWS_WITH(check_json_text(R"({"m": {"young": 1e400}})", "t.json"),
                    Catch::Contains("t.json: m.young: a number outside the range of a double"));
}

TEST_CASE("output paths are checked before any work", "[sparse][io]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pmg_io_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string file = (dir / "f").string();
  std::ofstream(file) << "x";
  CHECK_NOTHROW(check_output_file((dir / "new.csv").string(), "--history"));
  CHECK_THROWS_WITH(check_output_file("/nonexistent/a.csv", "--history"),
                    Catch::Contains("--history /nonexistent/a.csv: folder /nonexistent does not exist"));
  CHECK_THROWS_WITH(check_output_file(dir.string(), "--json"), Catch::Contains("is a folder"));
  CHECK_THROWS_WITH(prepare_output_directory(file, "-o"), Catch::Contains("exists and is not a folder"));
  CHECK_THROWS_WITH(prepare_output_directory(file + "/sub", "-o"), Catch::Contains("cannot create the folder"));
  CHECK_NOTHROW(prepare_output_directory((dir / "a" / "b").string(), "-o"));
  CHECK(fs::is_directory(dir / "a" / "b"));
  CHECK_THROWS_WITH(write_file_atomically("/nonexistent/x.txt", "x"), Catch::Contains("/nonexistent/x.txt: cannot write"));
  fs::remove_all(dir);
}

TEST_CASE("writing an output changes the named file only: links stay links, devices and FIFOs stay",
          "[sparse][io]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pmg_out_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto read = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  // A regular file is replaced whole; no temporary is left beside it.
  const fs::path plain = dir / "plain.txt";
  write_file_atomically(plain.string(), "one");
  write_file_atomically(plain.string(), "two");
  CHECK(read(plain) == "two");
  CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);

  // A link keeps pointing at its target, which receives the contents; a dangling link creates it.
  const fs::path target = dir / "target.txt", link = dir / "link.txt";
  std::ofstream(target) << "old";
  fs::create_symlink("target.txt", link);
  write_file_atomically(link.string(), "new");
  CHECK(fs::is_symlink(link));
  CHECK(read(target) == "new");
  const fs::path dangling = dir / "dangling.txt";
  fs::create_symlink(dir / "created.txt", dangling);
  write_file_atomically(dangling.string(), "made");
  CHECK(fs::is_symlink(dangling));
  CHECK(read(dir / "created.txt") == "made");

  // Devices are written in place, never replaced (as root, a rename would replace /dev/null).
  write_file_atomically("/dev/null", "discarded");
  struct stat st {};
  REQUIRE(::stat("/dev/null", &st) == 0);
  CHECK(S_ISCHR(st.st_mode));
  CHECK_NOTHROW(check_output_file("/dev/null", "--json"));
  if (fs::exists("/dev/full")) {
    CHECK_THROWS_WITH(write_file_atomically("/dev/full", "x"), Catch::Contains("/dev/full: write failed"));
    REQUIRE(::stat("/dev/full", &st) == 0);
    CHECK(S_ISCHR(st.st_mode));
  }

  // A FIFO: its reader gets the contents; without a reader the write fails instead of hanging.
  const fs::path fifo = dir / "fifo";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK_THROWS_WITH(write_file_atomically(fifo.string(), "x"), Catch::Contains("a FIFO with no reader"));
  std::string received;
  std::thread reader([&] { received = read(fifo); });
  // The reader opens the FIFO when its thread runs; retry until it is there.
  bool written = false;
  for (int attempt = 0; attempt < 500 && !written; ++attempt) {
    try {
      write_file_atomically(fifo.string(), "through the fifo");
      written = true;
    } catch (const Error&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  if (!written) {  // unblock the reader before failing
    const int fd = ::open(fifo.c_str(), O_WRONLY);
    if (fd >= 0) ::close(fd);
  }
  reader.join();
  CHECK(written);
  CHECK(received == "through the fifo");
  CHECK(fs::is_fifo(fifo));
  fs::remove_all(dir);
}

TEST_CASE("require_memory refuses an estimate beyond the machine, naming both", "[sparse][io]") {
  CHECK(physical_memory_bytes() > 0);
  CHECK_NOTHROW(require_memory(1e6, "a small run"));
  CHECK_THROWS_WITH(require_memory(1e18, "a huge run"),
                    Catch::Contains("a huge run would need an estimated 1000000000.0 GB of memory; this machine has"));
  CHECK_THROWS_AS(require_memory(std::nan(""), "a NaN estimate"), InputError);
}

TEST_CASE("TextReader counts are checked against the rest of the input", "[sparse][io]") {
  std::istringstream in("3\n1 2 3\n");
  TextReader rd(in, "t.txt");
  const auto t = rd.next_tokens("a count");
  CHECK(rd.remaining_bytes() == 6);
  CHECK(rd.to_count(t[0], "count", rd.remaining_bytes() / 2) == 3);
  CHECK_THROWS_WITH(rd.to_count("4", "count", 3), Catch::Contains("t.txt:1: count 4 is more than the 3"));
  CHECK_THROWS_WITH(rd.to_count("-1", "count", 3), Catch::Contains("t.txt:1: negative count -1"));
  CHECK_THROWS_WITH(rd.to_integer(std::string("1\0", 2), "x"), Catch::Contains("expected an integer x, found '1\\x00'"));
}

TEST_CASE("a configuration key is a value or a section, never both (found by fuzzing)", "[sparse][io]") {
  // "smoother" = name, then "smoother.sweeps": the name moves to smoother.method.
  Config c = Config::from_pairs({"smoother=chebyshev", "smoother.degree=3"}, "t");
  CHECK(c.get_string("smoother.method", "") == "chebyshev");
  CHECK_NOTHROW(Config::from_json(c.to_json(), "back"));
  // A key below the moved value would leave "method" both a value and a section.
  CHECK_THROWS_WITH(Config::from_json(R"({"method": "pmg", "method.method.x": 1})", "t.json"),
                    Catch::Contains("'method.method.x' reaches below 'method.method', which holds 'pmg'"));
  CHECK_THROWS_WITH(Config::from_pairs({"a.method.b=1", "a=x"}, "t"),
                    Catch::Contains("'a' = 'x' has no place: 'a.method' is a section of its own"));
}

TEST_CASE("a configuration key given twice is refused, never resolved silently", "[sparse][io]") {
  CHECK_THROWS_WITH(Config::from_pairs({"tol=1e-3", "tol=1e-4"}, "--set"), Catch::Contains("--set: tol: given twice"));
  CHECK_THROWS_WITH(Config::from_pairs({"smoother=chebyshev", "smoother.method=jacobi"}, "--set"),
                    Catch::Contains("smoother.method: given twice"));
  CHECK_THROWS_WITH(Config::from_json(R"({"preconditioner.method": "jacobi", "preconditioner": {"method": "block-jacobi"}})",
                                      "t.json"),
                    Catch::Contains("t.json: preconditioner.method: given twice"));
  CHECK_THROWS_WITH(Config::from_json(R"({"smoother.method": "jacobi", "smoother": "chebyshev"})", "t.json"),
                    Catch::Contains("t.json: smoother") && Catch::Contains("given twice"));
  // Different keys of one section, dotted or nested, are fine.
  const Config c = Config::from_json(R"({"smoother": {"method": "chebyshev"}, "smoother.degree": 3})", "t.json");
  CHECK(c.get_string("smoother.degree", "") == "3");
  // merge() and set() replace on purpose (presets, --set over a file's options).
  Config d = Config::from_pairs({"tol=1e-3"}, "d");
  d.merge(Config::from_pairs({"tol=1e-6"}, "e"));
  CHECK(d.get_string("tol", "") == "1e-6");
}

TEST_CASE("reads are bounded: a line without end and an endless file are refused after a fixed amount",
          "[sparse][io]") {
  // A line of 2 MiB without a line break: refused at 1 MiB, naming the line.
  std::istringstream endless(std::string(2u << 20, 'x'));
  TextReader reader(endless, "endless.txt");
  std::string line;
  CHECK_THROWS_WITH(reader.next_line(line), Catch::Contains("endless.txt:1: a line longer than 1048576"));
  // A line of exactly the limit is accepted; the lines around it are read as usual.
  std::istringstream ok("a\r\n" + std::string(TextReader::kMaxLineLength, 'y') + "\nlast");
  TextReader r2(ok, "ok.txt");
  REQUIRE(r2.next_line(line));
  CHECK(line == "a");
  REQUIRE(r2.next_line(line));
  CHECK(line.size() == TextReader::kMaxLineLength);
  REQUIRE(r2.next_line(line));
  CHECK(line == "last");
  CHECK_FALSE(r2.next_line(line));
  CHECK(r2.line_number() == 4);
  // A seekable input bounds declared counts by its size; an unseekable one (a pipe: a stream
  // buffer that cannot seek) by this machine's memory, not without end.
  std::istringstream sized("1 2 3\n");
  TextReader r3(sized, "file");
  CHECK(r3.seekable());
  CHECK(r3.remaining_bytes() == 6);
  struct PipeBuffer : std::stringbuf {  // seeking fails, as on a pipe
    using std::stringbuf::stringbuf;
    pos_type seekoff(off_type, std::ios::seekdir, std::ios::openmode) override { return pos_type(off_type(-1)); }
    pos_type seekpos(pos_type, std::ios::openmode) override { return pos_type(off_type(-1)); }
  };
  PipeBuffer pipe_buffer("1 2 3\n");
  std::istream pipe(&pipe_buffer);
  TextReader r4(pipe, "pipe");
  CHECK_FALSE(r4.seekable());
  CHECK(r4.remaining_bytes() == static_cast<long long>(physical_memory_bytes()));
  REQUIRE(r4.next_line(line));
  CHECK(line == "1 2 3");
  // Whole files: /dev/zero never ends; it is refused once it passes the limit.
  CHECK_THROWS_WITH(read_text_file("/dev/zero", 1 << 16, "scene"),
                    Catch::Contains("scene: '/dev/zero' is longer than 65536 bytes"));
  const auto path = std::filesystem::temp_directory_path() / "pmg_read_text_file.json";
  {
    std::ofstream out(path);
    out << "{\"a\": 1}";
  }
  CHECK(read_text_file(path.string(), 8, "config") == "{\"a\": 1}");
  CHECK_THROWS_WITH(read_text_file(path.string(), 7, "config"), Catch::Contains("longer than 7 bytes"));
  std::filesystem::remove(path);
  CHECK_THROWS_WITH(read_text_file("/nonexistent/x.json", 100, "scene"), Catch::Contains("cannot open"));
}

TEST_CASE("a read error (a folder opened as a file) is named, not taken for the end of the file",
          "[sparse][io]") {
  std::ifstream folder(std::filesystem::temp_directory_path());
  if (!folder) return;  // this platform refuses to open a folder at all: nothing to read
  TextReader reader(folder, "tmpdir");
  std::string line;
  CHECK_THROWS_WITH(reader.next_line(line), Catch::Contains("tmpdir:1: read error"));
}
