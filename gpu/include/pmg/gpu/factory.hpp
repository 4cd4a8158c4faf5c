// pmg/gpu/factory.hpp — the GPU solvers as factory methods (pmg/sparse/factory.hpp), so that
// `pmg compare --solvers gpu-pmg,pmg,...` and scene files run them beside the CPU solvers:
//
//   gpu-mcg   the merged CG with block Jacobi (gpu::Mcg on BIN-BCSR); check_every (default 10)
//   gpu-pcg   block-Jacobi PCG from cuSPARSE/cuBLAS calls (gpu::LibraryPcg), the vendor baseline
//   gpu-pmg   stationary p-multigrid, Chebyshev V-cycle on the GPU, CHOLMOD on the host for the
//             lowest level (gpu::VCycle + gpu::multigrid_solve); reads the levels' assembled
//             matrices; degree and lower_fraction set the Chebyshev smoother (first kind)
//   gpu-mgpcg PCG preconditioned by one device V-cycle (gpu::mgpcg_solve) on matrix-free levels
//             (DeviceElasticityOperator, where the hierarchy offers them) or assembled ones;
//             optimised fourth-kind Chebyshev of degree 3 as the CPU mgpcg; CHOLMOD on the host
//
// Each is a pmg::Solver on host vectors: solve() uploads b and x, solves on the device and
// downloads x. The copies are timed apart from the device solve and reported by describe()
// ("set-up S ms; last solve: upload U ms, device D ms, download W ms"); set-up is
// the whole of it (host work such as BIN-BCSR slicing, gpu-pmg's CHOLMOD factorisation and λmax
// estimates, then the uploads). SolveResult::seconds covers the whole call, copies included.
// Stopping rules, keys and messages are those of the CPU methods.
#pragma once

namespace pmg::gpu {

/// Registers gpu-mcg, gpu-pcg, gpu-pmg and gpu-mgpcg (idempotent; a name the user registered is kept).
/// Registering needs no device; setting a solver up without one throws pmg::InputError saying so.
void register_solvers();

}  // namespace pmg::gpu
