#include "pmg/sparse/operator.hpp"

#include <string>

namespace pmg {

namespace {
std::string size_message(const char* what, Eigen::Index got, index_t expected) {
  return std::string(what) + ": vector has " + std::to_string(got) + " entries, operator expects " +
         std::to_string(expected);
}
}  // namespace

std::unique_lock<std::recursive_mutex> LinearOperator::hold_call_lock() const {
  return call_lock_ ? std::unique_lock<std::recursive_mutex>(*call_lock_) : std::unique_lock<std::recursive_mutex>();
}

void LinearOperator::check_square(const char* what) const {
  if (rows() != cols())
    throw InputError(std::string(what) + ": operator is " + std::to_string(rows()) + "x" +
                     std::to_string(cols()) + ", not square");
}

void LinearOperator::apply(const Vector& x, Vector& y) const {
  const auto lock = hold_call_lock();  // before the sizes: a set-up may change them
  if (x.size() != cols()) throw InputError(size_message("apply", x.size(), cols()));
  y.resize(rows());
  apply_impl(x, y);
}

double LinearOperator::apply_dot(const Vector& x, Vector& y) const {
  const auto lock = hold_call_lock();
  check_square("apply_dot");
  if (x.size() != cols()) throw InputError(size_message("apply_dot", x.size(), cols()));
  y.resize(rows());
  return apply_dot_impl(x, y);
}

void LinearOperator::residual(const Vector& b, const Vector& x, Vector& r) const {
  const auto lock = hold_call_lock();
  if (x.size() != cols()) throw InputError(size_message("residual (x)", x.size(), cols()));
  if (b.size() != rows()) throw InputError(size_message("residual (b)", b.size(), rows()));
  r.resize(rows());
  residual_impl(b, x, r);
}

double LinearOperator::apply_dot_impl(const Vector& x, Vector& y) const {
  apply_impl(x, y);
  return x.dot(y);
}

void LinearOperator::residual_impl(const Vector& b, const Vector& x, Vector& r) const {
  apply_impl(x, r);
  r = b - r;
}

}  // namespace pmg
