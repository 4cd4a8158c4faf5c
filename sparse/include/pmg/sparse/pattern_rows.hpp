// pmg/sparse/pattern_rows.hpp — a sparsity pattern built row by row on the threads, from each
// row's candidate columns (repeats allowed): the assembler's block pattern (the nodes sharing an
// element) and a Galerkin product's (the coarse nodes reached through R, A and P). Included by
// sources compiled with OpenMP.
#pragma once

#include "pmg/sparse/csr.hpp"

#include <algorithm>
#include <memory>
#include <vector>

namespace pmg {

/// The pattern of `rows` rows and `cols` columns whose row I holds the columns that
/// `columns(I, add)` passes to add(J), each kept once and sorted. columns is called twice per row
/// (the counts, then the columns into their places), on several threads at once; J must lie in
/// [0, cols). A marker per column and thread removes repeats, so no list of candidates is sorted.
template <typename Columns>
std::shared_ptr<CsrPattern> pattern_by_rows(index_t rows, index_t cols, const Columns& columns) {
  auto p = std::make_shared<CsrPattern>();
  p->rows = rows;
  p->cols = cols;
  p->row_ptr.assign(static_cast<size_t>(rows) + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
#pragma omp parallel
    {
      std::vector<index_t> mark(cols, -1), row;
#pragma omp for schedule(dynamic, 256)
      for (index_t I = 0; I < rows; ++I) {
        row.clear();
        columns(I, [&](index_t J) {
          if (mark[J] != I) mark[J] = I, row.push_back(J);
        });
        if (pass == 0) {
          p->row_ptr[I + 1] = static_cast<offset_t>(row.size());
        } else {
          std::sort(row.begin(), row.end());
          std::copy(row.begin(), row.end(), p->col_idx.begin() + p->row_ptr[I]);
        }
      }
    }
    if (pass == 0) {
      for (index_t I = 0; I < rows; ++I) p->row_ptr[I + 1] += p->row_ptr[I];
      p->col_idx.resize(p->row_ptr[rows]);
    }
  }
  return p;
}

}  // namespace pmg
