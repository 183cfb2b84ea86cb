#pragma once
/// Helpers shared by the libFuzzer targets whose readers only take a path: the input bytes
/// go to a file in a per-process scratch folder (libFuzzer runs one input at a time).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace seavio::fuzz {

/// A scratch folder unique to this process, created on first use (under TMPDIR or /tmp).
/// Left behind on exit on purpose: libFuzzer ends with _exit on a crash, and the folder
/// holds at most a few small files.
inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path d = std::filesystem::temp_directory_path() /
                              ("seavio_fuzz_" + std::to_string(static_cast<long>(::getpid())));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

/// Writes `size` bytes to `path` (truncating). Traps if the file cannot be written: that is
/// a broken fuzzing setup, never a finding.
inline void writeFile(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) __builtin_trap();
}

inline void writeFile(const std::filesystem::path& path, const std::string& text) {
  writeFile(path, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

}  // namespace seavio::fuzz
