#include "service/cli/progress.h"

#include <unistd.h>

#include <algorithm>
#include <utility>

namespace softgrasp::cli {

ProgressBar::ProgressBar(std::string label, int total)
    : label_(std::move(label)), total_(std::max(total, 1)), enabled_(isatty(STDERR_FILENO) == 1) {}

ProgressBar::~ProgressBar() {
  if (enabled_ && last_percent_ >= 0) std::fputc('\n', stderr);
}

void ProgressBar::Update(int done) {
  if (!enabled_) return;
  const int percent = std::clamp(done * 100 / total_, 0, 100);
  if (percent == last_percent_) return;
  last_percent_ = percent;
  constexpr int kWidth = 40;
  const int filled = percent * kWidth / 100;
  std::fprintf(stderr, "\r%s [%s%s] %3d%% %d/%d", label_.c_str(),
               std::string(static_cast<std::size_t>(filled), '#').c_str(),
               std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), percent, done,
               total_);
  std::fflush(stderr);
}

}  // namespace softgrasp::cli
