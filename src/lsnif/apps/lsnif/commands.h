// commands.h -- the lsnif subcommands; each takes the arguments after its name and returns the
// process exit code (0 ok, 1 failure, 2 usage error).
#pragma once
#include <cstddef>
#include <cstdint>

namespace lsnif::cli {

// One subcommand of a program: its name, its entry point, its one-line summary for the usage text.
struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};

// The program's main: runs the command argv[1] of `commands` with the arguments after it; prints the
// usage ("usage: PROGRAM COMMAND ...", `about`, the commands) for --help (exit 0), no command or an
// unknown one (exit 2).
int dispatch(int argc, char** argv, const char* program, const char* about, const Command* commands, size_t count);

// Sets the OpenMP threads of the command's loops (`threads`; 0 keeps the current number, every core
// by default) and starts them now, before the command allocates its large buffers: a thread that
// cannot be created later, its stack no longer fitting in the memory left, ends the program with
// libgomp's own message instead of the command's "out of memory". dispatch calls it with 0 before
// every command; commands with a --threads option call it again with theirs. Returns the threads
// of the region that started them.
int start_threads(uint32_t threads);

int cmd_train(int argc, char** argv);
int cmd_eval(int argc, char** argv);
int cmd_info(int argc, char** argv);
int cmd_demo(int argc, char** argv);
int cmd_devices(int argc, char** argv);
int cmd_bench_trace(int argc, char** argv);
int cmd_bench_memory(int argc, char** argv);
int cmd_flip(int argc, char** argv);
int cmd_render(int argc, char** argv);
int cmd_bench(int argc, char** argv);
int cmd_bench_prepared(int argc, char** argv);  // bench_run.cpp: `lsnif-gpu bench`, models from --models
int cmd_check(int argc, char** argv);  // cmd_check.cpp: `lsnif-gpu check`
int cmd_bench_size(int argc, char** argv);
int cmd_view(int argc, char** argv);
int cmd_convert(int argc, char** argv);
}  // namespace lsnif::cli
