#pragma once
/// Internal to softgrasp_train: per-(seed, step) random streams for deterministic, resumable
/// training.

#include <cstdint>

namespace softgrasp::models {

/// SplitMix64 finaliser of a combined word: distinct, well-spread streams per (a, b).
inline std::uint64_t MixSeed(std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = a * 0x9E3779B97F4A7C15ull + b + 0x632BE59BD9B4E019ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace softgrasp::models
