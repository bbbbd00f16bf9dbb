#pragma once
/// A one-line progress bar on stderr when stderr is a terminal; silent otherwise (CI, pipes).

#include <cstdio>
#include <string>

namespace softgrasp::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, int total);
  ~ProgressBar();  ///< ends the line if one was drawn
  void Update(int done);

 private:
  std::string label_;
  int total_;
  bool enabled_;
  int last_percent_ = -1;
};

}  // namespace softgrasp::cli
