// Every test of this binary runs in a private network namespace with multicast on loopback
// (see private_netns.hpp).
#include "tests/drivers/lcm/private_netns.hpp"

namespace netns_environment {
namespace {
const auto* const kEnv = ::testing::AddGlobalTestEnvironment(new seavio::test::PrivateNetnsEnvironment);
}  // namespace
}  // namespace netns_environment
