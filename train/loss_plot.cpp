#include "train/loss_plot.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace softgrasp::models {

void PlotLossCurves(const std::string& title, const std::vector<int>& steps,
                    const std::vector<LossSeries>& series, const std::filesystem::path& png) {
  const int n = static_cast<int>(steps.size());
  if (n == 0) return;
  const int window = std::max(1, n / 100);
  std::vector<std::vector<double>> smooth(series.size());
  double y_max = 0;
  for (std::size_t k = 0; k < series.size(); ++k) {
    const std::vector<double>& v = series[k].values;
    double sum = 0;
    for (int i = 0; i < n && i < static_cast<int>(v.size()); ++i) {
      sum += v[static_cast<std::size_t>(i)];
      if (i >= window) sum -= v[static_cast<std::size_t>(i - window)];
      const double mean = sum / std::min(i + 1, window);
      smooth[k].push_back(mean);
      y_max = std::max(y_max, mean);
    }
  }
  y_max = std::max(y_max * 1.05, 1e-6);
  const int w = 800, h = 500, left = 60, right = 20, top = 30, bottom = 50;
  cv::Mat3b img(h, w, cv::Vec3b(255, 255, 255));
  const int first = steps.front(), last = std::max(steps.back(), first + 1);
  auto px = [&](int step, double v) {
    const double fx = static_cast<double>(step - first) / (last - first);
    return cv::Point(left + static_cast<int>(fx * (w - left - right)),
                     h - bottom - static_cast<int>(v / y_max * (h - top - bottom)));
  };
  cv::rectangle(img, {left, top}, {w - right, h - bottom}, {0, 0, 0}, 1);
  for (int t = 0; t <= 4; ++t) {
    const double v = y_max * t / 4;
    const cv::Point p = px(first, v);
    std::ostringstream label;
    label.precision(3);
    label << v;
    cv::putText(img, label.str(), {5, p.y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
    const int step = first + (last - first) * t / 4;
    cv::putText(img, std::to_string(step), {px(step, 0).x - 10, h - bottom + 18},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
  }
  cv::putText(img, "step", {w / 2 - 15, h - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0});
  // The legend's right edge 10 px inside the image, however long the longest name is.
  int label_px = 0;
  for (const LossSeries& s : series) {
    int baseline = 0;
    label_px = std::max(
        label_px, cv::getTextSize(s.name, cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline).width);
  }
  const int label_x = w - 10 - label_px;
  for (std::size_t k = 0; k < series.size(); ++k) {
    std::vector<cv::Point> pts;
    for (std::size_t i = 0; i < smooth[k].size(); ++i) pts.push_back(px(steps[i], smooth[k][i]));
    cv::polylines(img, pts, false, series[k].colour, 1, cv::LINE_AA);
    const int ly = top + 18 + 18 * static_cast<int>(k);
    cv::line(img, {label_x - 30, ly - 4}, {label_x - 5, ly - 4}, series[k].colour, 2);
    cv::putText(img, series[k].name, {label_x, ly}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0});
  }
  cv::putText(img, title, {left, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0});
  cv::imwrite(png.string(), img);
}

}  // namespace softgrasp::models
