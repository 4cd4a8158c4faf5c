// The seed's validation cases (SPEC §7, Tables 2.6 and 2.7).
#include "pmg/fem/generators.hpp"
#include "pmg/fem/static_solve.hpp"

#include <catch2/catch.hpp>
