#pragma once
// Vector kernels shared by the correlation, the ground estimate, the feature
// images, the obstacle loop and the symmetry scan. Integer arithmetic, except
// the Hough window sums, whose float additions are the reference's, in its
// order, lane by lane: every kernel gives exactly the results of its scalar
// reference. Written with the compiler's portable vector
// types; on x86-64 an AVX2 build of each kernel is picked at run time when the
// processor has it, otherwise the baseline (SSE2) build runs. The environment
// variable SG_SIMD=baseline selects the baseline build on any processor.
#include <cstddef>
#include <cstdint>

namespace sg::simd {

// Offsets are handled in groups of this many lanes.
constexpr int kLanes = 32;

// Zero bytes a right row needs in front of its first pixel for `offsets`
// offsets (the kernel reads right x - d for d up to the rounded-up offset count).
constexpr int rightPadding(int offsets) { return ((offsets + kLanes - 1) / kLanes) * kLanes; }

// For every left pixel x in [x0, x1) with left[x] != 0 (and skip[x] == 0 when
// skip is not null), adds 1 to counts[d] for each offset d in [0, offsets)
// where right[x - d] != 0 and |left[x] - right[x - d]| <= grey_tolerance.
// `right` must be readable (and 0) at indices -rightPadding(offsets) .. -1.
void accumulateMatches(const std::uint8_t* left, const std::uint8_t* skip, const std::uint8_t* right, int x0, int x1,
                       int offsets, int grey_tolerance, int* counts);

// accumulateMatches over [x0, x1) split at the column strips [bounds[k], bounds[k + 1])
// (k < strips, bounds increasing): strip_counts + k * offsets gets strip k's counts
// (overwritten, zeros for an empty strip), and `counts` gets all of them added.
void accumulateMatchesStrips(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int offsets,
                             int grey_tolerance, const int* bounds, int strips, int* strip_counts, int* counts);

// Same for a window of offsets [d_first, d_first + count) with count <= kLanes:
// counts[i] gets the matches at offset d_first + i. `right` must be readable
// (and 0) down to index x0 - d_first - kLanes + 1 when that is negative.
void accumulateMatchesWindow(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d_first,
                             int count, int grey_tolerance, int* counts);

// One row of a feature image (FeatureExtractor): Sobel |gx| + |gy| of row p0
// with rows pm (above) and pp (below), replicated at the row ends; edge where it
// reaches `threshold`; edges dilated horizontally by `radius`; out[x] =
// max(p0[x], 1) inside the dilated mask, else 0. `scratch` holds at least
// featureScratchSize(width, radius) bytes.
constexpr int featureScratchSize(int width, int radius) {
  // The edge bytes with their padding, then two rows of 16-bit column sums (one column of
  // padding on each side, a vector of slack).
  return width + 2 * radius + 2 * kLanes + 2 * 2 * (width + 2 + kLanes);
}
void featureRow(const std::uint8_t* pm, const std::uint8_t* p0, const std::uint8_t* pp, int width, int threshold,
                int radius, std::uint8_t* scratch, std::uint8_t* out);

// Removal (FeatureRemover): for x in [max(x0, d), x1) and every offset d in
// [d0, d1] (d0 >= 0), sets marks[x] = 0xFF where left[x] != 0, right[x - d] != 0
// and |left[x] - right[x - d]| <= grey_tolerance; other marks are left alone.
void markMatches(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d0, int d1,
                 int grey_tolerance, std::uint8_t* marks);

// Obstacles (ObstacleExtractor): for x in [x0, x1), out[x] = 1 when left pixel x
// matches the right row at some offset d in [d0, d1] over its window, else 0.
// It matches at d when left[x] != 0, d <= x, and every pixel j of [x - half,
// x + half] with d <= j < width either is no left feature (j != x) or has
// right[j - d] != 0 and |left[j] - right[j - d]| <= grey_tolerance. `scratch`
// holds at least windowMatchScratchSize(x1 - x0, half) bytes.
constexpr int kWindowGroup = 4;  // offsets matched together
constexpr int windowMatchScratchSize(int span, int half) { return kWindowGroup * (span + 2 * half); }
void windowMatchRow(const std::uint8_t* left, const std::uint8_t* right, int width, int x0, int x1, int d0, int d1,
                    int grey_tolerance, int half, std::uint8_t* scratch, std::uint8_t* out);
// windowMatchRow on `rows` consecutive rows (row i at left + i * left_step, right + i *
// right_step, out + i * out_step): one call's set-up for all of them.
void windowMatchRows(const std::uint8_t* left, std::size_t left_step, const std::uint8_t* right,
                     std::size_t right_step, int width, int rows, int x0, int x1, int d0, int d1, int grey_tolerance,
                     int half, std::uint8_t* scratch, std::uint8_t* out, std::size_t out_step);

// Where a predicate holds along a row: the first pixel, one past the last (both n when
// nowhere) and how many.
struct ByteSpan {
  int first = 0, end = 0, count = 0;
};
// Feature rows: the nonzero bytes of p[0, n).
ByteSpan nonZeroSpan(const std::uint8_t* p, int n);
// A row after pixels were taken out of it: the pixels of `before` that are 0 in `after`.
// `subset` tells whether every nonzero pixel of `after` is the pixel of `before` there.
ByteSpan removedSpan(const std::uint8_t* after, const std::uint8_t* before, int n, bool& subset);

// sums[i] += bytes[i] (modulo 2^16) for i in [0, n): per-column counts of a 0/1 mask row.
void addBytes(const std::uint8_t* bytes, std::uint16_t* sums, int n);
// sums[i] += bytes[i] (modulo 2^8) for i in [0, n): up to 255 mask rows counted in bytes
// before addBytes takes them into the wider counts.
void addBytesToBytes(const std::uint8_t* bytes, std::uint8_t* sums, int n);

// Obstacle offset histogram, one row: for d in [0, n), the row's excess e = counts[d] -
// median where it is at least min_excess and row <= last_row[d], else 0, replaces its
// previous excess held in excess[d], and sum[d] follows (sum[d] += e - excess[d]).
void replaceRowExcess(const int* counts, int median, int min_excess, int row, const int* last_row, int n, int* excess,
                      int* sum);

// Obstacle row medians: sets `value` to the k-th smallest (0-based, k < n) of counts[0, n)
// when it is `previous` or one of the max_steps distinct values of counts below it (the
// counts of a row only decrease between two of its medians: a few vector passes instead of
// a selection). Returns false, `value` unchanged, when it is neither.
bool kthSmallestFrom(const int* counts, int n, int k, int previous, int max_steps, int& value);

// The k-th smallest (0-based, 0 <= k < n, n > 0) of counts[0, n), as std::nth_element would
// place it, found by bisection over the values (a counting pass per step, no branch per count).
int kthSmallest(const int* counts, int n, int k);

// Symmetry scan (SymmetryScanner), one row: for pairs j = 1..n about column `axis`
// of a row of quantized edge weights w, their mirror m and grey levels g,
//   sm[j] += w[axis - j] * m[axis + j] + m[axis - j] * w[axis + j]
//   sab[j] += g[axis - j] * g[axis + j]
// in 32-bit integers (the caller bounds the sums). The rows must be readable at
// axis - n .. axis + n.
void mirroredRowSums(const std::int32_t* w, const std::int32_t* m, const std::uint8_t* g, int axis, int n,
                     std::int32_t* sm, std::int32_t* sab);

// Hough 3x3 window sums (GroundEstimator): out[b] = 0.0f + lo[b - 1] + lo[b] +
// lo[b + 1] + mid[b - 1] + mid[b] + mid[b + 1] + hi[b - 1] + hi[b] + hi[b + 1],
// added left to right in float, for b in [0, n). The rows must be readable at
// -1 and n. Returns the largest out[b] and 0 if none is above 0.
float houghWindowSums(const float* lo, const float* mid, const float* hi, int n, float* out);

// Name of the build in use ("avx2" or "baseline").
const char* kernelName();

// 1 in every byte of w that is nonzero, 0 in the others, without a branch (the feature flags
// of a word of pixels): a byte's low seven bits carry into its high bit, or it is set already.
template <class Word>
constexpr Word nonZeroBytes(Word w) {
  constexpr Word ones = static_cast<Word>(~Word{0} / 255), low7 = static_cast<Word>(ones * 0x7f);
  return static_cast<Word>(((((w & low7) + low7) | w) >> 7) & ones);
}
static_assert(nonZeroBytes<std::uint32_t>(0x00ff0180u) == 0x00010101u);
static_assert(nonZeroBytes<std::uint64_t>(0x7f00000100800000ull) == 0x0100000100010000ull);

}  // namespace sg::simd
