#pragma once
/// Stiffness-map and grasp metrics of the thesis (ch. 3): RMSE on the 0-255 scale (eq. 3.11),
/// MSSIM = mean SSIM over 10 x 10 = 100 equal regions (eq. 3.12, Table 3.1), and the mean
/// stiffness in a grasp region (eq. 3.13-3.14). See docs/stiffness.md, "Metrics".

#include <opencv2/core.hpp>

#include "service/core/grasp.h"
#include "service/core/status.h"

namespace softgrasp::core {

/// Root mean square error between two stiffness maps in [0, 1], on the 0-255 scale
/// (eq. 3.11 over every pixel, background included). Errors (kInvalidArgument, field "map"):
/// empty maps, different sizes, non-finite values.
Result<double> StiffnessRmse255(const cv::Mat1f& truth, const cv::Mat1f& predicted);

/// SSIM (Wang et al. 2004) of one region from its global statistics, on the 0-255 scale:
/// ((2 mu_x mu_y + C1)(2 cov_xy + C2)) / ((mu_x^2 + mu_y^2 + C1)(var_x + var_y + C2)),
/// C1 = (0.01 * 255)^2, C2 = (0.03 * 255)^2, population (co)variances. Maps in [0, 1].
double RegionSsim(const cv::Mat1f& truth, const cv::Mat1f& predicted);

/// Mean SSIM over `grid` x `grid` regions (eq. 3.12, N = grid^2 = 100 by default). Region (i, j)
/// covers rows [floor(i H / grid), floor((i + 1) H / grid)) and likewise columns, so sizes not
/// divisible by `grid` give regions differing by one pixel. Errors as StiffnessRmse255, and
/// kInvalidArgument when the map is smaller than grid x grid.
Result<double> StiffnessMssim(const cv::Mat1f& truth, const cv::Mat1f& predicted, int grid = 10);

/// Pixels of a grasp's closing region (the rectangle between the open fingers): offsets from the
/// centre with |a| <= opening/2 along the closing axis and |b| <= finger width/2 across it
/// (pixel-centre rule, docs/fge.md), clipped to the image. 255 inside.
cv::Mat1b GraspRegionMask(cv::Size size, const Grasp& grasp);

/// Eq. 3.13-3.14: mean of the stiffness map over the grasp region's object pixels (s_k > 0).
/// NaN when the region holds none (R = 0).
double MeanStiffnessInGraspRegion(const cv::Mat1f& stiffness, const Grasp& grasp);

}  // namespace softgrasp::core
