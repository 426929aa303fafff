#include "lsnif/apps/lsnif/args.h"

#include <cstdio>
#include <cstdlib>

#include "lsnif/format/number_text.h"
#include "lsnif/format/status.h"

namespace lsnif::cli {

void Args::alias(const std::string& short_name, const std::string& long_name) {
  aliases_.push_back({short_name, long_name});
}

void Args::positional(const std::string& name, const std::string& help, std::string* out, bool required) {
  pos_.push_back({name, help, out, required});
}

void Args::rest(const std::string& name, const std::string& help, std::vector<std::string>* out) {
  rest_name_ = name;
  rest_help_ = help;
  rest_ = out;
}

void Args::option(const std::string& name, const std::string& help, std::string* out) {
  opts_.push_back({name, help, "TEXT", out->empty() ? "" : *out, false, [out](const std::string& v) {
                     *out = v;
                     return std::string();
                   }});
}

namespace {

std::string range_text(double min, double max) { return format("[%g, %g]", min, max); }

// "" with `x` set when `v` is a whole number in [min, max], else why not.
std::string whole_in_range(const std::string& v, uint64_t min, uint64_t max, uint64_t& x) {
  if (std::string why = whole_number_error(v); !why.empty()) return why;
  x = std::strtoull(v.c_str(), nullptr, 10);
  if (x < min || x > max) return format("out of range [%llu, %llu]", (unsigned long long)min, (unsigned long long)max);
  return "";
}

}  // namespace

void Args::option(const std::string& name, const std::string& help, uint32_t* out, uint32_t min, uint32_t max) {
  checked_option(name, help + " " + format("[%u, %u]", min, max), "N", std::to_string(*out),
                 [out, min, max](const std::string& v) {
                   uint64_t x = 0;
                   std::string why = whole_in_range(v, min, max, x);
                   if (why.empty()) *out = uint32_t(x);
                   return why;
                 });
}

void Args::option(const std::string& name, const std::string& help, uint64_t* out, uint64_t min, uint64_t max) {
  checked_option(name, help + " " + format("[%llu, %llu]", (unsigned long long)min, (unsigned long long)max), "N",
                 std::to_string(*out), [out, min, max](const std::string& v) {
                   uint64_t x = 0;
                   std::string why = whole_in_range(v, min, max, x);
                   if (why.empty()) *out = x;
                   return why;
                 });
}

void Args::option(const std::string& name, const std::string& help, float* out, float min, float max) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", double(*out));
  checked_option(name, help + " " + range_text(min, max), "X", buf, [out, min, max](const std::string& v) {
    if (std::string why = float_error(v); !why.empty()) return why;
    const float x = std::strtof(v.c_str(), nullptr);
    if (!(x >= min && x <= max)) return "out of range " + range_text(min, max);
    *out = x;
    return std::string();
  });
}

void Args::option(const std::string& name, const std::string& help, const std::string& value_name,
                  const std::string& default_text, std::function<bool(const std::string&)> set) {
  const std::string expected = value_name + " expected";
  opts_.push_back({name, help, value_name, default_text, value_name.empty(),
                   [set = std::move(set), expected](const std::string& v) {
                     return set(v) ? std::string() : expected;
                   }});
}

void Args::checked_option(const std::string& name, const std::string& help, const std::string& value_name,
                          const std::string& default_text, std::function<std::string(const std::string&)> check) {
  opts_.push_back({name, help, value_name, default_text, false, std::move(check)});
}

void Args::flag(const std::string& name, const std::string& help, bool* out) {
  opts_.push_back({name, help, "", "", true, [out](const std::string&) {
                     *out = true;
                     return std::string();
                   }});
}

std::string Args::help() const {
  std::string s = "usage: lsnif " + command_;
  for (const Pos& p : pos_) s += p.required ? " " + p.name : " [" + p.name + "]";
  if (rest_) s += " [" + rest_name_ + "...]";
  s += " [options]\n\n" + summary_ + "\n";
  if (!pos_.empty() || rest_) s += "\narguments:\n";
  for (const Pos& p : pos_) s += "  " + p.name + std::string(p.name.size() < 22 ? 22 - p.name.size() : 1, ' ') + p.help + "\n";
  if (rest_)
    s += "  " + rest_name_ + "..." + std::string(rest_name_.size() + 3 < 22 ? 22 - rest_name_.size() - 3 : 1, ' ') +
         rest_help_ + "\n";
  s += "\noptions:\n";
  for (const Opt& o : opts_) {
    std::string left = "--" + o.name + (o.is_flag ? "" : " " + o.value_name);
    for (const auto& [short_name, long_name] : aliases_)
      if (long_name == o.name) left = short_name + ", " + left;
    s += "  " + left + std::string(left.size() < 22 ? 22 - left.size() : 1, ' ') + o.help;
    if (!o.is_flag && !o.default_text.empty()) s += " (default " + o.default_text + ")";
    s += "\n";
  }
  s += "  --help                show this help\n";
  return s;
}

int Args::parse(int argc, char** argv) {
  // Two options of one name would silently share the command line (the last registered wins).
  for (size_t i = 0; i < opts_.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (opts_[i].name == opts_[j].name) {
        std::fprintf(stderr, "lsnif %s: internal error: option --%s is registered twice\n", command_.c_str(),
                     opts_[i].name.c_str());
        return 2;
      }
  size_t next_pos = 0;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    for (const auto& [short_name, long_name] : aliases_)
      if (a == short_name) a = "--" + long_name;
    if (a == "--help" || a == "-h") {
      std::fputs(help().c_str(), stdout);
      return 1;
    }
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string name = a.substr(2), value;
      bool has_value = false;
      if (size_t eq = name.find('='); eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_value = true;
      }
      const Opt* opt = nullptr;
      for (const Opt& o : opts_)
        if (o.name == name) opt = &o;
      if (!opt) {
        std::fprintf(stderr, "lsnif %s: unknown option --%s (see --help)\n", command_.c_str(), name.c_str());
        return 2;
      }
      if (opt->is_flag) {
        if (has_value) {
          std::fprintf(stderr, "lsnif %s: --%s takes no value\n", command_.c_str(), name.c_str());
          return 2;
        }
        opt->set("");
        continue;
      }
      if (!has_value) {
        if (i + 1 >= argc) {
          std::fprintf(stderr, "lsnif %s: --%s needs a value\n", command_.c_str(), name.c_str());
          return 2;
        }
        value = argv[++i];
      }
      if (std::string why = opt->set(value); !why.empty()) {
        std::fprintf(stderr, "lsnif %s: invalid value '%s' for --%s: %s\n", command_.c_str(),
                     excerpt(value, 80).c_str(), name.c_str(), why.c_str());
        return 2;
      }
      continue;
    }
    if (next_pos >= pos_.size() && rest_) {
      rest_->push_back(a);
      continue;
    }
    if (next_pos >= pos_.size()) {
      std::fprintf(stderr, "lsnif %s: unexpected argument '%s' (see --help)\n", command_.c_str(), a.c_str());
      return 2;
    }
    *pos_[next_pos++].out = a;
  }
  for (size_t p = next_pos; p < pos_.size(); ++p)
    if (pos_[p].required) {
      std::fprintf(stderr, "lsnif %s: missing argument %s (see --help)\n", command_.c_str(), pos_[p].name.c_str());
      return 2;
    }
  return 0;
}

void add_import_flags(Args& args, MeshImportOptions* options, bool meshes) {
  args.flag("allow-outside-refs",
            "let files the input refers to (buffers, images, mtllib, models, HDR) lie outside its folder",
            &options->allow_outside_refs);
  if (meshes)
    args.flag("allow-dropped-triangles", "import a mesh even when most of its triangles are degenerate or invalid",
              &options->allow_dropping_most);
}

}  // namespace lsnif::cli
