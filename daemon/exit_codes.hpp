#pragma once
/// seaviod's exit statuses. systemd restarts the unit on any non-zero one (Restart=on-failure
/// in systemd/seaviod.service); the number says why in `systemctl status` and the journal
/// (docs/reliability.md, "Exit statuses").
namespace seavio::daemon {

inline constexpr int kExitOk = 0;
/// Start-up failed (a device or the LCM provider did not open), or frames or global requests
/// were not all accounted for at exit.
inline constexpr int kExitFailure = 1;
/// The configuration (or a file it names: calibration, CAN profile) is invalid. A restart
/// cannot help: the unit's RestartPreventExitStatus= keeps systemd from looping.
inline constexpr int kExitConfig = 2;
/// A pipeline thread (camera, IMU, estimator, publisher, ICP, status) or an LCM receive
/// callback threw an exception nothing below it caught; the status says which and why.
inline constexpr int kExitThreadFault = 3;
/// The IMU delivered nothing for daemon.imu.dead_after_ms with daemon.imu.dead_policy exit.
inline constexpr int kExitImuDead = 4;

}  // namespace seavio::daemon
