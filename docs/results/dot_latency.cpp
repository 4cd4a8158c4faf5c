// The latency chain of a single running sum against dot_serial's eight partial sums (sparse/src/vector_ops.cpp),
// standalone copies of the two loops: ops::dot before 4c484a3 (OpenMP reduction, one sum per thread) and after
// (blocks of 8192 entries, eight partial sums each, blocks added in order). 2000 calls each, three repetitions.
//   g++ -O3 -fopenmp -o /tmp/dot_latency docs/results/dot_latency.cpp && OMP_NUM_THREADS=2 /tmp/dot_latency
#include <chrono>
#include <cstdio>
#include <vector>
#include <algorithm>
#include <omp.h>
double dot_old(const double* a, const double* b, long n) {
  double s = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (long i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}
double dot_serial(const double* a, const double* b, long n) {
  double s[8] = {};
  long k = 0;
  for (; k + 8 <= n; k += 8)
    for (int l = 0; l < 8; ++l) s[l] += a[k + l] * b[k + l];
  for (int l = 0; k < n; ++k, ++l) s[l] += a[k] * b[k];
  return ((s[0] + s[4]) + (s[2] + s[6])) + ((s[1] + s[5]) + (s[3] + s[7]));
}
double dot_new(const double* a, const double* b, long n) {
  const long B = 8192, blocks = (n + B - 1) / B;
  if (blocks <= 1) return dot_serial(a, b, n);
  double part[64];
  std::vector<double> heap; double* p = part;
  if (blocks > 64) { heap.resize(blocks); p = heap.data(); }
#pragma omp parallel for schedule(static)
  for (long q = 0; q < blocks; ++q) p[q] = dot_serial(a + q * B, b + q * B, std::min(B, n - q * B));
  double s = 0; for (long q = 0; q < blocks; ++q) s += p[q]; return s;
}
int main() {
  for (long n : {97518L, 1000000L}) {
    std::vector<double> a(n, 1.1), b(n, 0.9);
    for (int rep = 0; rep < 3; ++rep) {
      double s = 0;
      auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < 2000; ++i) s += dot_old(a.data(), b.data(), n);
      auto t1 = std::chrono::steady_clock::now();
      for (int i = 0; i < 2000; ++i) s += dot_new(a.data(), b.data(), n);
      auto t2 = std::chrono::steady_clock::now();
      std::printf("n=%ld old %.2f us new %.2f us (%g)\n", n, std::chrono::duration<double>(t1 - t0).count() / 2000 * 1e6,
                  std::chrono::duration<double>(t2 - t1).count() / 2000 * 1e6, s);
    }
  }
}
