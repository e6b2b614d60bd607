#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "vision/correlation.hpp"
#include "vision/feature_image.hpp"

namespace sg {
namespace {

TEST(FeatureParams, ValidateNamesTheField) {
  FeatureParams p;
  p.edge_threshold = 0;
  try {
    p.validate();
    FAIL() << "edge_threshold 0 accepted";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("features.edge_threshold"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FeatureExtractor{p}, ParamError);
}

TEST(FeatureExtractor, UniformImageHasNoFeatures) {
  FeatureExtractor fx;
  const cv::Mat grey(40, 50, CV_8UC1, cv::Scalar(90));
  cv::Mat features;
  fx.compute(grey, features);
  EXPECT_EQ(cv::countNonZero(features), 0);
}

TEST(FeatureExtractor, VerticalStepKeepsGreyInsideTheDilatedBand) {
  // Columns < 20 are 0 (black), the rest 200: the edge lies between columns 19 and 20.
  cv::Mat grey(10, 40, CV_8UC1, cv::Scalar(200));
  grey.colRange(0, 20).setTo(0);
  FeatureParams p;
  p.dilation_half_width_px = 2;
  FeatureExtractor fx(p);
  cv::Mat features;
  fx.compute(grey, features);
  for (int y = 0; y < grey.rows; ++y) {
    for (int x = 0; x < grey.cols; ++x) {
      // Sobel marks columns 19 and 20; dilation by 2 gives 17..22.
      const bool inside = x >= 17 && x <= 22;
      const int expected = inside ? (grey.at<std::uint8_t>(y, x) == 0 ? 1 : 200) : 0;
      ASSERT_EQ(features.at<std::uint8_t>(y, x), expected) << "x=" << x << " y=" << y;
    }
  }
}

TEST(FeatureExtractor, RejectsColourInput) {
  FeatureExtractor fx;
  cv::Mat features;
  EXPECT_THROW(fx.compute(cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(0)), features), InputError);
  EXPECT_THROW(fx.compute(cv::Mat(), features), InputError);
}

TEST(Correlation, CountsMatchesByTheDefinition) {
  // One row, 8 columns. Left features at x = 3, 4, 6; right at x = 1, 2, 4.
  cv::Mat left = cv::Mat::zeros(2, 8, CV_8UC1), right = cv::Mat::zeros(2, 8, CV_8UC1);
  left.at<std::uint8_t>(0, 3) = 100;
  left.at<std::uint8_t>(0, 4) = 50;
  left.at<std::uint8_t>(0, 6) = 10;
  right.at<std::uint8_t>(0, 1) = 105;  // matches left 3 at d = 2 (|100 - 105| <= 12)
  right.at<std::uint8_t>(0, 2) = 70;   // left 4 at d = 2: |50 - 70| > 12, no match
  right.at<std::uint8_t>(0, 4) = 20;   // left 6 at d = 2: |10 - 20| <= 12, match
  CorrelationParams p;
  p.offsets = 6;
  p.min_row_features = 2;
  Correlator c(p);
  cv::Mat score, matches;
  c.computeReference(left, right, score, matches);
  ASSERT_EQ(score.size(), cv::Size(6, 2));
  EXPECT_EQ(matches.at<int>(0, 2), 2);
  EXPECT_FLOAT_EQ(score.at<float>(0, 2), 2.0f / 3.0f);
  // Every other offset pairs a feature with an empty pixel or a grey difference above 12.
  for (int d = 0; d < 6; ++d)
    if (d != 2) {
      EXPECT_EQ(matches.at<int>(0, d), 0) << "d=" << d;
    }
  EXPECT_EQ(cv::countNonZero(matches.row(1)), 0);
}

TEST(Correlation, EmptyRowsScoreZero) {
  cv::Mat left = cv::Mat::zeros(3, 30, CV_8UC1), right = cv::Mat::zeros(3, 30, CV_8UC1);
  Correlator c;
  cv::Mat score;
  c.compute(left, right, score);
  EXPECT_EQ(cv::countNonZero(score), 0);
  EXPECT_EQ(score.cols, 128);
}

TEST(Correlation, ShiftedTexturePeaksAtItsShift) {
  cv::RNG rng(7);
  cv::Mat right(20, 300, CV_8UC1);
  rng.fill(right, cv::RNG::UNIFORM, 1, 255);
  cv::Mat left = cv::Mat::zeros(right.size(), CV_8UC1);
  const int shift = 37;
  right.colRange(0, right.cols - shift).copyTo(left.colRange(shift, left.cols));
  Correlator c;
  cv::Mat score, matches;
  c.compute(left, right, score, matches);
  for (int y = 0; y < score.rows; ++y) {
    cv::Point best;
    cv::minMaxLoc(score.row(y), nullptr, nullptr, nullptr, &best);
    EXPECT_EQ(best.x, shift);
    EXPECT_EQ(matches.at<int>(y, shift), left.cols - shift);
  }
}

TEST(Correlation, RejectsSizeMismatch) {
  Correlator c;
  cv::Mat score;
  EXPECT_THROW(c.compute(cv::Mat::zeros(4, 10, CV_8UC1), cv::Mat::zeros(4, 11, CV_8UC1), score), InputError);
}

}  // namespace
}  // namespace sg
