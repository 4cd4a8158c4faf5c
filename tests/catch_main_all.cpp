// The test main of suites that build solvers of every component through the factory.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "pmg/solvers.hpp"

int main(int argc, char** argv) {
  pmg::register_all_solvers();
  return Catch::Session().run(argc, argv);
}
