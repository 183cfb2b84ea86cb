// Every test of this binary runs in a private network namespace with multicast on loopback
// (see tests/drivers/lcm/private_netns.hpp); the seaviod and lcm-logplayer it spawns inherit it.
#include "tests/drivers/lcm/private_netns.hpp"

namespace {
const auto* const kEnv = ::testing::AddGlobalTestEnvironment(new seavio::test::PrivateNetnsEnvironment);
}  // namespace
