// The vendor baselines: cuSPARSE's BSR and CSR SpMV on pmgkit's matrices.
#include "cuda_check.hpp"
#include "pmg/gpu/matrices.hpp"

#include <limits>

namespace pmg::gpu {

namespace {

// cuSPARSE's legacy BSR routines take 32-bit row pointers.
std::vector<int> narrow_row_ptr(const std::vector<offset_t>& row_ptr, const char* what) {
  if (row_ptr.back() > std::numeric_limits<int>::max())
    throw InputError(std::string(what) + ": more than 2^31 stored blocks or entries");
  return std::vector<int>(row_ptr.begin(), row_ptr.end());
}

cusparseHandle_t handle_of(void* h) { return static_cast<cusparseHandle_t>(h); }

}  // namespace

// ---- CusparseBsr -------------------------------------------------------------------------------

CusparseBsr::CusparseBsr(const Bcsr& A)
    : block_rows_(A.block_rows()), num_blocks_(static_cast<index_t>(A.num_blocks())),
      row_ptr_(narrow_row_ptr(A.pattern().row_ptr, "CusparseBsr")), col_idx_(A.pattern().col_idx),
      values_(A.values()) {
  if (A.rows() != A.cols()) throw InputError("CusparseBsr: matrix must be square");
  cusparseHandle_t h = nullptr;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreate)(&h));
  handle_ = h;
  cusparseMatDescr_t d = nullptr;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreateMatDescr)(&d));
  descr_ = d;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseSetMatType)(d, CUSPARSE_MATRIX_TYPE_GENERAL));
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseSetMatIndexBase)(d, CUSPARSE_INDEX_BASE_ZERO));
}

CusparseBsr::~CusparseBsr() {
  try {  // a destroy function the opened library lacks leaves the handle: a destructor never throws
    if (descr_) PMG_VENDOR(cusparse, cusparseDestroyMatDescr)(static_cast<cusparseMatDescr_t>(descr_));
    if (handle_) PMG_VENDOR(cusparse, cusparseDestroy)(handle_of(handle_));
  } catch (...) {
  }
}

void CusparseBsr::update_values(const Bcsr& A) {
  if (A.block_rows() != block_rows_ || A.num_blocks() != num_blocks_)
    throw InputError("CusparseBsr::update_values: the matrix does not have the uploaded pattern");
  values_.upload(A.values());
}

double CusparseBsr::bytes_per_spmv() const {
  return 8.0 * values_.size() + 4.0 * col_idx_.size() + 4.0 * row_ptr_.size() + 16.0 * rows();
}

void CusparseBsr::multiply(const DeviceVector& x, DeviceVector& y) const {
  if (x.size() != static_cast<std::size_t>(rows()))
    throw InputError("CusparseBsr::multiply: x does not match the matrix");
  y.resize(x.size());
  if (block_rows_ == 0) return;
  const double one = 1.0, zero = 0.0;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseDbsrmv)(handle_of(handle_), CUSPARSE_DIRECTION_ROW,
                              CUSPARSE_OPERATION_NON_TRANSPOSE, block_rows_, block_rows_, num_blocks_,
                              &one, static_cast<cusparseMatDescr_t>(descr_), values_.data(),
                              row_ptr_.data(), col_idx_.data(), Bcsr::kBlock, x.data(), &zero,
                              y.data()));
}

// ---- CusparseCsr -------------------------------------------------------------------------------

CusparseCsr::CusparseCsr(const Csr& A)
    : rows_(A.rows()), cols_(A.cols()), nnz_(A.nnz()),
      row_ptr_(narrow_row_ptr(A.pattern().row_ptr, "CusparseCsr")), col_idx_(A.pattern().col_idx),
      values_(A.values()) {
  cusparseHandle_t h = nullptr;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreate)(&h));
  handle_ = h;
  cusparseSpMatDescr_t m = nullptr;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreateCsr)(&m, rows_, cols_, nnz_, row_ptr_.data(), col_idx_.data(),
                                 values_.data(), CUSPARSE_INDEX_32I, CUSPARSE_INDEX_32I,
                                 CUSPARSE_INDEX_BASE_ZERO, CUDA_R_64F));
  mat_ = m;
}

CusparseCsr::~CusparseCsr() {
  try {  // a destroy function the opened library lacks leaves the handle: a destructor never throws
    if (mat_) PMG_VENDOR(cusparse, cusparseDestroySpMat)(static_cast<cusparseSpMatDescr_t>(mat_));
    if (handle_) PMG_VENDOR(cusparse, cusparseDestroy)(handle_of(handle_));
  } catch (...) {
  }
}

double CusparseCsr::bytes_per_spmv() const {
  return 12.0 * nnz_ + 4.0 * (rows_ + 1) + 8.0 * (rows_ + cols_);
}

void CusparseCsr::multiply(const DeviceVector& x, DeviceVector& y) const {
  if (x.size() != static_cast<std::size_t>(cols_))
    throw InputError("CusparseCsr::multiply: x does not match the matrix");
  y.resize(static_cast<std::size_t>(rows_));
  if (rows_ == 0) return;
  const auto destroy = PMG_VENDOR(cusparse, cusparseDestroyDnVec);  // resolved before anything is made
  cusparseDnVecDescr_t vx = nullptr, vy = nullptr;
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreateDnVec)(&vx, cols_, const_cast<double*>(x.data()), CUDA_R_64F));
  PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreateDnVec)(&vy, rows_, y.data(), CUDA_R_64F));
  const double one = 1.0, zero = 0.0;
  auto mat = static_cast<cusparseSpMatDescr_t>(mat_);
  try {
    std::size_t bytes = 0;
    PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseSpMV_bufferSize)(handle_of(handle_), CUSPARSE_OPERATION_NON_TRANSPOSE, &one,
                                         mat, vx, &zero, vy, CUDA_R_64F, CUSPARSE_SPMV_ALG_DEFAULT,
                                         &bytes));
    if (bytes > buffer_.size()) buffer_.resize(bytes);
    PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseSpMV)(handle_of(handle_), CUSPARSE_OPERATION_NON_TRANSPOSE, &one, mat, vx,
                              &zero, vy, CUDA_R_64F, CUSPARSE_SPMV_ALG_DEFAULT, buffer_.data()));
  } catch (...) {
    destroy(vx);
    destroy(vy);
    throw;
  }
  destroy(vx);
  destroy(vy);
}

}  // namespace pmg::gpu
