// pmg/sparse/types.hpp — index types, the vector type and the error types used across pmgkit.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <stdexcept>
#include <string>

namespace pmg {

/// Row and column indices (32-bit: halves index traffic in SpMV; checked on construction).
using index_t = std::int32_t;
/// Positions in value arrays (64-bit: nonzero counts may exceed 2^31).
using offset_t = std::int64_t;
/// Dense vector type of every public interface.
using Vector = Eigen::VectorXd;

/// Base of every error pmgkit throws.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Malformed input: a file, a matrix with the wrong shape, non-finite or out-of-range values.
class InputError : public Error {
 public:
  using Error::Error;
};

}  // namespace pmg
