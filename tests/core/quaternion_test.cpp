#include "service/core/quaternion.h"

#include <gtest/gtest.h>

namespace softgrasp::core {
namespace {

TEST(Quaternion, OrdersConvertBothWaysAndKeepTheNorm) {
  // 90 degrees about z: w = cos 45, z = sin 45.
  const double h = std::sqrt(0.5);
  const QuaternionWxyz wxyz{h, 0.0, 0.0, h};
  const QuaternionXyzw xyzw = XyzwFromWxyz(wxyz);
  EXPECT_EQ(xyzw, (QuaternionXyzw{0.0, 0.0, h, h}));
  EXPECT_EQ(WxyzFromXyzw(xyzw), wxyz);
  const QuaternionWxyz any{0.1, -0.2, 0.3, -0.4};
  EXPECT_EQ(WxyzFromXyzw(XyzwFromWxyz(any)), any);
  EXPECT_EQ(XyzwFromWxyz(any)[3], 0.1);  // w last
  EXPECT_DOUBLE_EQ(QuaternionNorm(wxyz), 1.0);
  EXPECT_DOUBLE_EQ(QuaternionNorm(any), std::sqrt(0.3));
}

}  // namespace
}  // namespace softgrasp::core
