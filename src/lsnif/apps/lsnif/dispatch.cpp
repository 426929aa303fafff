// dispatch.cpp -- the main of the lsnif programs (commands.h dispatch).
#include <omp.h>

#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>

#include "lsnif/apps/lsnif/commands.h"

namespace lsnif::cli {

namespace {

void usage(FILE* out, const char* program, const char* about, const Command* commands, size_t count) {
  std::fprintf(out, "usage: %s COMMAND [arguments] [--help]\n\n%s\n\ncommands:\n", program, about);
  for (size_t i = 0; i < count; ++i) std::fprintf(out, "  %-12s %s\n", commands[i].name, commands[i].summary);
}

// Runs one command. Sizes are checked against budgets before anything large is allocated; an
// allocation that fails all the same ends the command with a message and exit 1, not an abort.
int run_command(const char* program, const Command& command, int argc, char** argv) {
  try {
    return command.run(argc, argv);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s %s: out of memory while the command ran (%s); lower the sizes it was given\n", program,
                 command.name, command.summary);
  } catch (const std::length_error& e) {
    std::fprintf(stderr, "%s %s: out of memory while the command ran (%s): a size past the limit (%s)\n", program,
                 command.name, command.summary, e.what());
  }
  return 1;
}

// The instruction set this program was compiled for (a native build: -march=native on the build
// machine, scripts/build.sh) that this CPU lacks, or null. Checked before any command runs, so that
// a program carried to another machine (the GPU check folder) stops with a message instead of an
// illegal instruction somewhere in its work.
const char* missing_cpu_feature() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
#ifdef __AVX512F__
  if (!__builtin_cpu_supports("avx512f")) return "avx512f";
#endif
#ifdef __AVX2__
  if (!__builtin_cpu_supports("avx2")) return "avx2";
#endif
#ifdef __FMA__
  if (!__builtin_cpu_supports("fma")) return "fma";
#endif
#endif
  return nullptr;
}

}  // namespace

int start_threads(uint32_t threads) {
  if (threads) omp_set_num_threads(int(threads));
  int started = 0;  // (a region with an empty body is compiled away)
#pragma omp parallel reduction(+ : started)
  started += 1;
  return started;
}

int dispatch(int argc, char** argv, const char* program, const char* about, const Command* commands, size_t count) {
  if (const char* feature = missing_cpu_feature()) {
    std::fprintf(stderr, "%s: built for CPUs with %s (a native build: -march=native on the build machine), which this "
                 "CPU lacks; build it without (scripts/build.sh -DLSNIF_AVX512=OFF for AVX-512, -DLSNIF_NATIVE=OFF "
                 "for any x86-64)\n", program, feature);
    return 1;
  }
  if (argc < 2) {
    usage(stderr, program, about, commands, count);
    return 2;
  }
  if (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    usage(stdout, program, about, commands, count);
    return 0;
  }
  for (size_t i = 0; i < count; ++i)
    if (!std::strcmp(argv[1], commands[i].name)) {
      start_threads(0);
      return run_command(program, commands[i], argc - 2, argv + 2);
    }
  std::fprintf(stderr, "%s: unknown command '%s'\n", program, argv[1]);
  usage(stderr, program, about, commands, count);
  return 2;
}

}  // namespace lsnif::cli
