#pragma once
/// The CAN identifiers a profile reads, as SocketCAN receive filters. On a shared vehicle bus
/// the IMU is one node of many: with these set as CAN_RAW_FILTER the kernel drops every other
/// node's frames before they reach the socket, so they neither wake the IMU thread nor count
/// as faults. The same rule is applied in user space to inputs without a kernel filter (an
/// already-open fd, a candump log of the whole bus).
#include <linux/can.h>

#include <vector>

#include "drivers/imu_can/can_profile.hpp"

namespace seavio::drivers {

/// One exact-match filter per distinct identifier of `profile` (axes, timestamp, emit_on):
/// the mask covers the identifier, the extended-frame flag (a standard 0x100 is not the
/// extended 0x100) and the remote-request flag (remote frames carry no data).
std::vector<can_filter> canIdFilters(const CanProfile& profile);

/// True if a frame with `can_id` passes `filters` by the kernel's rule for CAN_RAW_FILTER
/// (net/can/af_can.c: (can_id & mask) == (filter id & mask) for any filter).
bool canFilterAccepts(const std::vector<can_filter>& filters, canid_t can_id);

}  // namespace seavio::drivers
