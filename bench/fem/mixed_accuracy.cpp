// The accuracy of mixed (Taylor–Hood) against displacement-only BB elements as ν -> 1/2: the
// manufactured solution of tests/fem/mixed_manufactured.hpp on Kuhn cubes of n³ cells (6 tets
// each), L2 errors of displacement and pressure (λ div u_h for displacement-only elements) and the
// observed orders between successive n. Not a timing benchmark: a table for docs/robustness.md.
//
//   bench/fem/mixed_accuracy [--degrees 2,3] [--cells 2,4,8] [--nu 0.3,0.49,0.4999]
#include "../../tests/fem/mixed_mms.hpp"

#include "table_cli.hpp"
#include "pmg/multigrid/factory.hpp"

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

int run(int argc, char** argv) {
  using namespace pmg::fem::test;
  std::vector<double> degrees{2, 3}, cells{2, 4, 8}, nus{0.3, 0.49, 0.4999};
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--degrees")) degrees = parse_list(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--cells")) cells = parse_list(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--nu")) nus = parse_list(argv[i + 1]);
    else {
      std::fprintf(stderr, "unknown option %s (--degrees, --cells, --nu)\n", argv[i]);
      return 2;
    }
  }
  pmg::mg::register_solvers();
  std::printf("%-3s %-7s %-5s | %-12s %-5s %-12s %-5s | %-12s %-5s %-12s %-5s\n", "k", "nu", "n", "mixed u L2", "order",
              "mixed p L2", "order", "disp. u L2", "order", "lam div u", "order");
  for (double kd : degrees)
    for (double nu : nus) {
      MmsErrors pm{}, pd{};
      for (size_t c = 0; c < cells.size(); ++c) {
        const int k = static_cast<int>(kd), n = static_cast<int>(cells[c]);
        const MmsErrors m = mms_mixed(n, k, nu), d = mms_displacement(n, k, nu);
        auto order = [&](double prev, double now) { return c == 0 ? 0.0 : std::log2(prev / now) / std::log2(cells[c] / cells[c - 1]); };
        std::printf("%-3d %-7g %-5d | %-12.4e %-5.2f %-12.4e %-5.2f | %-12.4e %-5.2f %-12.4e %-5.2f\n", k, nu, n, m.u,
                    order(pm.u, m.u), m.p, order(pm.p, m.p), d.u, order(pd.u, d.u), d.p, order(pd.p, d.p));
        pm = m, pd = d;
      }
    }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run_reporting_errors(run, argc, argv); }
