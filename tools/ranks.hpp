// tools/ranks.hpp — a command under mpirun: every rank must be given the same command.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace pmg::tools {

/// Under mpirun with several ranks, checks collectively, before any work, that every rank was given
/// the same options of `sub` (--threads and --quiet aside: they change no answer) and the same
/// contents of `inputs` (files read by every rank, on machines that may differ). A difference is an
/// InputError on every rank naming the first one ("pmg compare: the ranks disagree on --poisson:
/// rank 0 has '0.3', rank 1 has '0.2'"). Nothing on one process.
void agree_across_ranks(const CLI::App& sub, const std::vector<std::string>& inputs);

}  // namespace pmg::tools
