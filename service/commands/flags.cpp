#include "commands/flags.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "commands/cli.h"

namespace facespace::cli {

namespace {

std::vector<std::string> SplitNames(const std::string& names) {
  std::vector<std::string> out;
  for (std::string n : SplitList(names)) {
    while (!n.empty() && n.front() == ' ') n.erase(0, 1);
    out.push_back(n);
  }
  return out;
}

}  // namespace

Flags::Flags(std::string synopsis, std::string about)
    : synopsis_(std::move(synopsis)), about_(std::move(about)) {}

Flags& Flags::Switch(const std::string& names, const std::string& help,
                     std::function<void()> apply) {
  flags_.push_back({SplitNames(names), "", help, nullptr, std::move(apply)});
  return *this;
}

Flags& Flags::Value(const std::string& names, const std::string& metavar, const std::string& help,
                    Apply apply) {
  flags_.push_back({SplitNames(names), metavar, help, std::move(apply), nullptr});
  return *this;
}

Flags& Flags::Text(const std::string& names, const std::string& metavar, const std::string& help,
                   std::string* out) {
  return Value(names, metavar, help, [out](const std::string& v) {
    *out = v;
    return 0;
  });
}

Flags& Flags::Texts(const std::string& names, const std::string& metavar, const std::string& help,
                    std::vector<std::string>* out) {
  return Value(names, metavar, help, [out](const std::string& v) {
    out->push_back(v);
    return 0;
  });
}

const Flags::Flag* Flags::Find(const std::string& name) const {
  for (const Flag& f : flags_) {
    for (const std::string& n : f.names) {
      if (n == name) return &f;
    }
  }
  return nullptr;
}

int Flags::Parse(const std::vector<std::string>& args, std::vector<std::string>& positional) const {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::fputs(Help().c_str(), stdout);
      return 0;
    }
    if ((a == "--quiet" || a == "-q") && !Find(a)) {  // Every command's, unless it has its own.
      Quiet() = true;
      continue;
    }
    if ((a == "--verbose" || a == "-v") &&
        !Find(a)) {  // Every command's: each warning on a line of its own.
      Verbose() = true;
      continue;
    }
    if (a.size() < 2 || a[0] != '-') {  // "-" alone is a positional argument (stdout, stdin).
      positional.push_back(a);
      continue;
    }
    const size_t eq = a.rfind("--", 0) == 0 ? a.find('=') : std::string::npos;
    const std::string name = a.substr(0, eq);
    const Flag* f = Find(name);
    if (!f) return UsageError("unknown option '" + name + "'");
    if (f->metavar.empty()) {
      if (eq != std::string::npos) return UsageError(name + " takes no value");
      f->on();
      continue;
    }
    std::string value;
    if (eq != std::string::npos) {
      value = a.substr(eq + 1);
    } else if (i + 1 < args.size()) {
      value = args[++i];
    } else {
      return UsageError(name + " needs a value (" + f->metavar + ")");
    }
    if (int rc = f->apply(value); rc != 0) return rc;
  }
  return -1;
}

int Flags::UsageError(const std::string& message) const {
  std::fprintf(stderr, "error: %s\n%s(facespace %s --help lists every flag)\n", message.c_str(),
               synopsis_.c_str(),
               synopsis_.size() > 17 ? synopsis_.substr(17, synopsis_.find(' ', 17) - 17).c_str()
                                     : "COMMAND");
  return 2;
}

std::string Flags::Help() const {
  std::string out = synopsis_ + "\nflags:\n";
  for (const Flag& f : flags_) {
    std::string left = "  ";
    for (size_t k = 0; k < f.names.size(); ++k) left += (k ? ", " : "") + f.names[k];
    if (!f.metavar.empty()) left += " " + f.metavar;
    if (left.size() < 30)
      left.resize(30, ' ');
    else
      left += "\n" + std::string(30, ' ');
    out += left + f.help + "\n";
  }
  if (!Find("--quiet"))
    out += "  -q, --quiet                 no warnings on stderr (errors still)\n";
  if (!Find("--verbose"))
    out +=
        "  -v, --verbose               every warning on a line of its own (else one line per kind, "
        "counted)\n";
  out += "  -h, --help                  this text\n";
  if (!about_.empty()) out += "\n" + about_;
  return out;
}

bool& Quiet() {
  static bool quiet = false;
  return quiet;
}

bool& Verbose() {
  static bool verbose = false;
  return verbose;
}

bool IntIn(const std::string& flag, const std::string& value, long long lo, long long hi,
           long long* out) {
  long long v = 0;
  const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
  if (r.ec != std::errc() || r.ptr != value.data() + value.size() || v < lo || v > hi) {
    std::fprintf(stderr, "error: %s must be an integer in %lld..%lld, not '%s'\n", flag.c_str(), lo,
                 hi, value.c_str());
    return false;
  }
  *out = v;
  return true;
}

bool NumberIn(const std::string& flag, const std::string& value, double lo, double hi,
              double* out) {
  double v = 0;
  const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
  if (r.ec != std::errc() || r.ptr != value.data() + value.size() || !std::isfinite(v) || v < lo ||
      v > hi) {
    std::fprintf(stderr, "error: %s: '%s' is not a number in [%g, %g]\n", flag.c_str(),
                 value.c_str(), lo, hi);
    return false;
  }
  *out = v;
  return true;
}

bool ReadAtFile(const std::string& flag, const std::string& value, std::string& text) {
  if (value.empty() || value[0] != '@') {
    text = value;
    return true;
  }
  if (ReadFile(value.substr(1), text)) return true;
  std::fprintf(stderr, "error: %s: cannot read '%s'\n", flag.c_str(), value.substr(1).c_str());
  return false;
}

// The argument helpers cli.h declares that flags use too: kept here so the parser stands alone
// (tests/service).
std::vector<std::string> SplitList(const std::string& value) {
  std::vector<std::string> items;
  size_t start = 0;
  while (start <= value.size()) {
    size_t end = value.find(',', start);
    if (end == std::string::npos) end = value.size();
    if (end > start) items.push_back(value.substr(start, end - start));
    start = end + 1;
  }
  return items;
}

bool ReadFile(const std::string& path, std::string& out) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return false;
  out.assign((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return true;
}

}  // namespace facespace::cli
