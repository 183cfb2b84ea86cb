#pragma once
/// The one rule every replay pacer shares (the daemon's dataset pacing and the LCM log reader).
#include <cstdint>

namespace seavio::drivers {

/// A stamp further than this past the previous sample of its stream is released at once
/// instead of paced [ns]: a far-future stamp in a log (a corrupt or foreign clock) would
/// otherwise hold the stream, and the replay, for good. Longer than any pause a recording
/// keeps on purpose; the daemon's timestamp checks then count the stamp as a gap and
/// re-anchor on the stamps that follow.
inline constexpr int64_t kMaxPacedStepNs = 60'000'000'000;

}  // namespace seavio::drivers
