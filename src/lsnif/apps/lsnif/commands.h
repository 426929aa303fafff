// commands.h -- the lsnif subcommands; each takes the arguments after its name and returns the
// process exit code (0 ok, 1 failure, 2 usage error).
#pragma once

namespace lsnif::cli {
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
int cmd_bench_size(int argc, char** argv);
int cmd_view(int argc, char** argv);
int cmd_convert(int argc, char** argv);
}  // namespace lsnif::cli
