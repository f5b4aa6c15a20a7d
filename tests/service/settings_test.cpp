// `facespace serve`'s one table of settings (service/server/settings.h): flags and environment read
// alike, ranges checked, and every limit listed for /openapi.json.
#include "server/settings.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <string>
#include <vector>

namespace facespace::cli {
namespace settings_test {

std::map<std::string, double> LimitsOf(const ServeConfig& c) {
  std::map<std::string, double> out;
  for (const auto& [name, value] : Limits(c)) out[name] = value;
  return out;
}

TEST(Settings, FlagsAndTheEnvironmentSetTheConfigurationFlagsWinning) {
  ::setenv("FACESPACE_MAX_CONNECTIONS", "77", 1);
  ::setenv("FACESPACE_KEYED_CPU", "12.5", 1);
  ServeConfig c;
  EXPECT_EQ(
      ReadServeConfig({"--max-connections", "5", "--max-jobs", "9", "--keep-free-mb", "3"}, c), -1);
  ::unsetenv("FACESPACE_MAX_CONNECTIONS");
  ::unsetenv("FACESPACE_KEYED_CPU");
  EXPECT_EQ(c.max_connections, 5u);
  EXPECT_EQ(c.keyed_cpu, 12.5);
  EXPECT_EQ(c.job_limits.max_jobs, 9u);
  EXPECT_EQ(c.job_limits.keep_free, size_t{3} << 20);
}

TEST(Settings, AValueOutOfItsRangeOrOfTheWrongKindIsRefused) {
  for (const std::vector<std::string>& args : {std::vector<std::string>{"--port", "65536"},
                                               {"--threads", "0"},
                                               {"--threads", "2.5"},
                                               {"--anonymous-cpu", "0"},
                                               {"--max-body", "12x"}}) {
    ServeConfig c;
    EXPECT_EQ(ReadServeConfig(args, c), 2) << args[0] << " " << args[1];
  }
}

TEST(Settings, EveryLimitIsListedWithItsValue) {
  ServeConfig c;
  c.max_client_requests = 3;
  const std::map<std::string, double> limits = LimitsOf(c);
  EXPECT_EQ(limits.at("max_body"), 64.0 * 1024 * 1024);
  EXPECT_EQ(limits.at("max_client_requests"), 3);
  EXPECT_EQ(limits.at("keyed_deadline"), 1800);
  EXPECT_EQ(limits.at("body_budget_mb"), 1024);
  EXPECT_EQ(limits.count("port"), 0u);  // Not a limit.
  EXPECT_EQ(limits.count("rigs"), 0u);  // Not a number.
}

}  // namespace settings_test
}  // namespace facespace::cli
