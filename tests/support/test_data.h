#pragma once
/// The real sensor frames and meshes kept with the tests under tests/data (what each file is, its
/// source and its licence: tests/data/README.md). Found through the source tree, so the tests
/// run from a clone of the repository alone.

#include <string>

namespace softgrasp::testing {

/// The path of `relative` under tests/data, e.g. TestData("gqcnn/phoxi/phoxi.intr").
inline std::string TestData(const std::string& relative) {
  return std::string(SOFTGRASP_TEST_DATA_DIR) + "/" + relative;
}

}  // namespace softgrasp::testing
