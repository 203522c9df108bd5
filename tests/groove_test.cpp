// The groove (deformers/groove.h): its alpha is the signed distance of its ring, it moves
// nothing, and bad parameters name themselves. Its cylindrical alpha map is in cylindrical_test.
#include "deformers/groove.h"

#include <gtest/gtest.h>

#include <string>

#include "base/error.h"

using namespace raywarp;

namespace {

const Eigen::Vector3d kHalf(1.0, 1.5, 1.0);

TEST(Groove, AlphaIsTheSignedDistanceOfItsRing) {
  const auto g = make_groove(kHalf, Axis::Y, 0.6, 0.5);
  EXPECT_TRUE(g->has_cut());
  EXPECT_TRUE(g->moves_nothing());
  // Removed: farther than 0.6 from the y axis within |y| <= 0.25.
  EXPECT_NEAR(g->alpha(Eigen::Vector3d(0.9, 0.0, 0.0)), 0.25, 1e-12);
  EXPECT_NEAR(g->alpha(Eigen::Vector3d(0.0, 0.1, 0.8)), 0.15, 1e-12);
  EXPECT_NEAR(g->alpha(Eigen::Vector3d(0.3, 0.0, 0.4)), -0.1, 1e-12);
  EXPECT_NEAR(g->alpha(Eigen::Vector3d(0.9, 0.5, 0.0)), -0.25, 1e-12);
  const Eigen::Vector3d p(0.3, -0.2, -0.9);
  EXPECT_EQ(g->forward(p), p);
  EXPECT_EQ(g->inverse(p), p);
  // Bad parameters name themselves.
  EXPECT_THROW(make_groove(kHalf, Axis::Y, 0.0, 0.5), Error);
  try {
    make_groove(kHalf, Axis::Y, 0.6, 3.5);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("groove width = 3.5: must be in (0, 2 h_y = 3]"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
