#pragma once
// Sums of absolute differences of 5-pixel horizontal windows between a left and a right
// row: the local stereo test of the far people's stage (vision/standing_people.hpp) and of
// the localization's leg pixels (vision/human_localizer.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>

namespace sg {

constexpr int kSadHalfWidth = 2;  // the window is 2 * kSadHalfWidth + 1 pixels wide

// SAD of the windows at column x of the left row and x - offset of the right row; the
// caller keeps both inside their rows.
inline int sadAt(const std::uint8_t* left, const std::uint8_t* right, int x, int offset) {
  int s = 0;
  for (int i = -kSadHalfWidth; i <= kSadHalfWidth; ++i)
    s += std::abs(static_cast<int>(left[x + i]) - static_cast<int>(right[x + i - offset]));
  return s;
}

// The lowest SAD at column x over the offsets centre - 1 .. centre + 1 that are not
// negative and keep the right window inside its row; `none` when there is no such offset.
// The left window must lie inside its row.
inline int lowestSadAround(const std::uint8_t* left, const std::uint8_t* right, int x, int centre, int none) {
  int best = none;
  for (int e = std::max(0, centre - 1); e <= centre + 1; ++e)
    if (x - e - kSadHalfWidth >= 0) best = std::min(best, sadAt(left, right, x, e));
  return best;
}

// The lowest SAD at `offset` +-1 of the pixel at column x when it stands there rather than at
// `line`, its row's ground/background offset: the line is finite and more than `clearance`
// from `offset` (nearer, the two cannot be told apart), that SAD is at most `max_cost`, and it
// is lower by `margin` than the lowest at the line's offset +-1. `none` otherwise.
inline int standingCost(const std::uint8_t* left, const std::uint8_t* right, int x, int offset, float line,
                        float clearance, int max_cost, int margin, int none) {
  if (!std::isfinite(line) || std::fabs(line - static_cast<float>(offset)) <= clearance) return none;
  const int at_offset = lowestSadAround(left, right, x, offset, none);
  if (at_offset > max_cost) return none;
  const int at_line = lowestSadAround(left, right, x, static_cast<int>(std::lround(line)), none);
  return at_line != none && at_offset + margin < at_line ? at_offset : none;
}

}  // namespace sg
