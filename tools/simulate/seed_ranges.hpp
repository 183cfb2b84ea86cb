#pragma once
/// The simulator's seeds in two disjoint ranges. Tuning seeds are the ones parameters may be
/// chosen on (every test, `seavio simulate`, the tuning benches); validation seeds are rendered
/// only by `seavio bench validate`, so the figures it reports come from data no parameter was
/// fitted to. Defined here and nowhere else.
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

namespace seavio::simulate {

struct SeedRange {
  uint32_t first = 0;
  uint32_t last = 0;  ///< inclusive
  bool contains(uint32_t seed) const { return seed >= first && seed <= last; }
};

/// No test, bench or document has used a seed in this range.
inline constexpr SeedRange kValidationSeeds{70000, 70999};

/// What a simulated configuration is rendered for: tuning (the default) may not take a
/// validation seed, validation must.
enum class SeedUse { kTuning, kValidation };

inline std::string validationSeedRangeText() {
  std::ostringstream os;  // not operator+: GCC 12 -O3 warns falsely (-Wrestrict) on it
  os << '[' << kValidationSeeds.first << ", " << kValidationSeeds.last << ']';
  return os.str();
}

/// Throws std::invalid_argument naming the validation range when `seed` is on the wrong side.
inline void checkSeedUse(uint32_t seed, SeedUse use) {
  const bool validation = kValidationSeeds.contains(seed);
  std::ostringstream os;
  if (use == SeedUse::kTuning && validation)
    os << "seed " << seed << " is a validation seed (" << validationSeedRangeText()
       << "): only `seavio bench validate` renders those; pick a seed outside that range";
  if (use == SeedUse::kValidation && !validation)
    os << "seed " << seed << " is not a validation seed (" << validationSeedRangeText() << ")";
  if (!os.str().empty()) throw std::invalid_argument(os.str());
}

}  // namespace seavio::simulate
