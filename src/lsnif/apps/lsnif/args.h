// args.h -- a tiny argument parser for the lsnif subcommands: --name value / --name=value options,
// boolean flags and positionals, with generated --help text. Errors name the bad option.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/format/number_text.h"  // parse_u32 ... for option values
#include "lsnif/import/mesh.h"
#include "lsnif/renderer/render_defaults.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/trainer.h"

namespace lsnif::cli {

// The ranges several commands share, defined where the library takes the values (the Python module
// checks the same): worker threads (kMaxThreads, trainer.h), an image side, samples per pixel, path
// bounces (render_defaults.h), held-out evaluation rays (kMaxEvalRays, evaluate.h).
using render::kMaxBounces;
using render::kMaxImageSide;
using render::kMaxSpp;

class Args {
 public:
  Args(std::string command, std::string summary) : command_(std::move(command)), summary_(std::move(summary)) {}

  void positional(const std::string& name, const std::string& help, std::string* out, bool required = true);
  // Zero or more positionals after those declared with positional(), appended to `out` in order
  // (shown as "[NAME...]" in the usage line).
  void rest(const std::string& name, const std::string& help, std::vector<std::string>* out);
  void option(const std::string& name, const std::string& help, std::string* out);
  // Numeric options: every one declares its range. The value is read as number_text.h reads
  // numbers (decimal only) into the destination's type and must lie in [min, max]; --help shows the range and an error names the option,
  // the value and the range.
  void option(const std::string& name, const std::string& help, uint32_t* out, uint32_t min, uint32_t max);
  void option(const std::string& name, const std::string& help, uint64_t* out, uint64_t min, uint64_t max);
  void option(const std::string& name, const std::string& help, float* out, float min, float max);
  void flag(const std::string& name, const std::string& help, bool* out);
  // An option whose value `set` takes (false: not a valid VALUE_NAME); `default_text` is shown in
  // --help. A flag when `value_name` is empty (`set` gets "").
  void option(const std::string& name, const std::string& help, const std::string& value_name,
              const std::string& default_text, std::function<bool(const std::string&)> set);
  // The same with the reason a value is refused: `check` returns "" to accept it, else why not
  // ("out of range [1, 64]"), which the error prints after the option and the value.
  void checked_option(const std::string& name, const std::string& help, const std::string& value_name,
                      const std::string& default_text, std::function<std::string(const std::string&)> check);
  // A short spelling ("-o") for a long option ("output").
  void alias(const std::string& short_name, const std::string& long_name);

  // Parses argv (after the subcommand). Returns 0 to continue, 1 after printing --help (exit 0),
  // 2 on error (message already printed to stderr).
  int parse(int argc, char** argv);
  std::string help() const;

 private:
  struct Opt {
    std::string name, help, value_name, default_text;
    bool is_flag = false;
    std::function<std::string(const std::string&)> set;  // "" or why the value is refused
  };
  struct Pos {
    std::string name, help;
    std::string* out;
    bool required;
  };
  std::string command_, summary_;
  std::vector<Opt> opts_;
  std::vector<Pos> pos_;
  std::string rest_name_, rest_help_;
  std::vector<std::string>* rest_ = nullptr;
  std::vector<std::pair<std::string, std::string>> aliases_;
};

// Registers --allow-outside-refs (and, with `meshes`, --allow-dropped-triangles) into `options`:
// the import policy flags of every command that reads a mesh or a scene.
void add_import_flags(Args& args, MeshImportOptions* options, bool meshes = true);

}  // namespace lsnif::cli
