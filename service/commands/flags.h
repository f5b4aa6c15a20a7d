// One flag parser for every command. A command declares its flags once, with their help; Parse
// reads the arguments in order: positional ones, "--flag VALUE" or "--flag=VALUE", switches, and
// --help / -h (the usage with every flag on stdout, exit 0), and -q / --quiet (Quiet()). An unknown
// flag or a missing value is a usage error (the message and the usage on stderr, exit 2).
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace facespace::cli {

class Flags {
 public:
  // Applies a flag's value: 0, or the exit code after printing "error: ..." (2 for a value that
  // is not allowed, 1 for a file that cannot be read).
  using Apply = std::function<int(const std::string& value)>;

  // `synopsis`: the usage lines ("usage: facespace blend RIG ... -o OUT"); `about`: what the
  // command does, printed after the flags by --help.
  Flags(std::string synopsis, std::string about = "");

  // `names`: "--keep-targets", or several spellings: "-o, --output".
  Flags& Switch(const std::string& names, const std::string& help, std::function<void()> apply);
  Flags& Value(const std::string& names, const std::string& metavar, const std::string& help,
               Apply apply);
  // A value stored as given.
  Flags& Text(const std::string& names, const std::string& metavar, const std::string& help,
              std::string* out);
  // A value that may be given again: each one appended.
  Flags& Texts(const std::string& names, const std::string& metavar, const std::string& help,
               std::vector<std::string>* out);

  // -1 when the command goes on (positional arguments appended to `positional`), else the exit
  // code.
  int Parse(const std::vector<std::string>& args, std::vector<std::string>& positional) const;

  // "error: MESSAGE" and the synopsis on stderr; returns 2.
  int UsageError(const std::string& message) const;

  // The synopsis, every flag with its help, and the about text.
  std::string Help() const;

 private:
  struct Flag {
    std::vector<std::string> names;
    std::string metavar;  // Empty: a switch.
    std::string help;
    Apply apply;
    std::function<void()> on;
  };
  const Flag* Find(const std::string& name) const;
  std::string synopsis_, about_;
  std::vector<Flag> flags_;
};

// -q / --quiet, which every command's Parse takes (one that declares its own --quiet keeps it):
// warnings are not printed (PrintWarnings), errors are.
bool& Quiet();
// -v / --verbose, which every command's Parse takes: every warning printed, where by default a kind
// that comes more than once is one line with its count (PrintWarnings).
bool& Verbose();

// Helpers for Flags::Value: parse a number in [lo, hi] or print "error: FLAG: ..." and return
// false.
bool IntIn(const std::string& flag, const std::string& value, long long lo, long long hi,
           long long* out);
bool NumberIn(const std::string& flag, const std::string& value, double lo, double hi, double* out);
// "@FILE" read into `text` (other values kept as they are); false, with the error printed, when it
// cannot be read.
bool ReadAtFile(const std::string& flag, const std::string& value, std::string& text);

}  // namespace facespace::cli
