// Ctrl-C for the subcommands: a flag set by SIGINT, read between steps (commands.hpp).
#include "commands.hpp"

#include <csignal>

namespace pmg::tools {

namespace {
volatile std::sig_atomic_t g_interrupted = 0;
extern "C" void on_interrupt(int) { g_interrupted = 1; }
}  // namespace

void catch_interrupt() {
  struct sigaction sa {};
  sa.sa_handler = on_interrupt;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, nullptr);
}

const volatile std::sig_atomic_t* interrupt_flag() { return &g_interrupted; }

bool interrupted() { return g_interrupted != 0; }

}  // namespace pmg::tools
