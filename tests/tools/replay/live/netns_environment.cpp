// Every test of this binary runs in a private network namespace with multicast on loopback
// (see tests/drivers/lcm/private_netns.hpp); the seaviod and lcm-logplayer it spawns inherit it.
#include <gtest/gtest.h>

#include <cstdio>

#include "tests/drivers/lcm/private_netns.hpp"

namespace {
class NetnsEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    const std::string why = seavio::test::enterPrivateMulticastNetns();
    if (!why.empty()) std::fprintf(stderr, "private network namespace unavailable: %s\n", why.c_str());
  }
};
const auto* const kEnv = ::testing::AddGlobalTestEnvironment(new NetnsEnvironment);
}  // namespace
