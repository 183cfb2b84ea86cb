#include "drivers/imu_can/can_id_filter.hpp"

#include <algorithm>

namespace seavio::drivers {

namespace {
void addId(std::vector<can_filter>& out, uint32_t id, bool extended) {
  can_filter f{};
  f.can_id = extended ? (id & CAN_EFF_MASK) | CAN_EFF_FLAG : id & CAN_SFF_MASK;
  f.can_mask = (extended ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
  const bool known = std::any_of(out.begin(), out.end(), [&](const can_filter& g) {
    return g.can_id == f.can_id && g.can_mask == f.can_mask;
  });
  if (!known) out.push_back(f);
}
}  // namespace

std::vector<can_filter> canIdFilters(const CanProfile& profile) {
  std::vector<can_filter> out;
  for (const CanField& f : profile.gyro) addId(out, f.id, f.extended);
  for (const CanField& f : profile.accel) addId(out, f.id, f.extended);
  if (profile.timestamp) addId(out, profile.timestamp->id, profile.timestamp->extended);
  addId(out, profile.emit_on_id, profile.emit_on_extended);
  return out;
}

bool canFilterAccepts(const std::vector<can_filter>& filters, canid_t can_id) {
  return std::any_of(filters.begin(), filters.end(), [&](const can_filter& f) {
    return (can_id & f.can_mask) == (f.can_id & f.can_mask);
  });
}

}  // namespace seavio::drivers
