#include "vision/simd_match.hpp"

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string_view>

// The 32-byte vector helpers below are internal and always inlined: the note
// about their calling convention without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace sg::simd {

namespace {

typedef std::uint8_t U8x32 __attribute__((vector_size(32)));
typedef std::uint32_t U32x8 __attribute__((vector_size(32)));

[[gnu::always_inline]] inline U8x32 load(const std::uint8_t* p) {
  U8x32 v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

// Every byte value repeated over one vector: a broadcast of a variable is one
// load from here. (GCC 12 assembles a broadcast built from a scalar, byte- or
// word-wise, lane by lane with inserts inside the target("avx2") functions: nine
// instructions per broadcast in the correlation's loop over feature pixels.)
struct SplatTable {
  alignas(kLanes) std::uint8_t values[256][kLanes];
};
constexpr SplatTable makeSplatTable() {
  SplatTable t{};
  for (int v = 0; v < 256; ++v)
    for (int j = 0; j < kLanes; ++j) t.values[v][j] = static_cast<std::uint8_t>(v);
  return t;
}
constexpr SplatTable kSplats = makeSplatTable();

[[gnu::always_inline]] inline U8x32 splatFromTable(int value) { return load(kSplats.values[value & 0xFF]); }

// Broadcast of a loop-invariant value (set-up code; constant-folded).
[[gnu::always_inline]] inline U8x32 splat(int value) {
  const std::uint32_t word = static_cast<std::uint32_t>(value & 0xFF) * 0x01010101u;
  return std::bit_cast<U8x32>(U32x8{} + word);
}

typedef std::uint8_t U8x8 __attribute__((vector_size(8)));
typedef std::int32_t I32x8 __attribute__((vector_size(32)));

// counts[0..7] += part.
[[gnu::always_inline]] inline void addWidened(I32x8 part, int* counts) {
  I32x8 c;
  std::memcpy(&c, counts, sizeof(c));
  c += part;
  std::memcpy(counts, &c, sizeof(c));
}

// counts[0..7] = part.
[[gnu::always_inline]] inline void storeWidened(I32x8 part, int* counts) { std::memcpy(counts, &part, sizeof(part)); }

// Lanes 31 - 8 P, 31 - 8 P - 1, ..., 31 - 8 P - 7 of acc widened to 32 bits, in that order: one
// shuffle with zeros (a conversion from eight bytes is assembled lane by lane by GCC 12).
template <int P>
[[gnu::always_inline]] inline I32x8 reversedPart(const U8x32& acc) {
  constexpr int b = 31 - 8 * P;
  constexpr int z = 32;  // a lane of the zero vector
  const U8x32 zero{};
  const U8x32 w = __builtin_shufflevector(acc, zero, b, z, z, z, b - 1, z, z, z, b - 2, z, z, z, b - 3, z, z, z,
                                          b - 4, z, z, z, b - 5, z, z, z, b - 6, z, z, z, b - 7, z, z, z);
  return std::bit_cast<I32x8>(w);
}

// Adds the byte lanes of `acc` to counts[first_lane_offset - j] for lane j (offsets
// below `offsets` only) and clears them; with `strip` (not null), also stores them there
// when `store`, else adds them. Where some of the 32 offsets do not exist, lanes go through
// memory one by one: indexing a vector register by a variable would keep the accumulators
// out of registers.
[[gnu::always_inline]] inline void flushLanesTwice(U8x32& acc, int first_lane_offset, int offsets, int* strip,
                                                   bool store, int* counts) {
  static_assert(kLanes == 32);
  if (first_lane_offset - (kLanes - 1) >= 0 && first_lane_offset < offsets) {
    // All 32 offsets exist: the lanes reversed (lane k then holds offset first - 31 + k),
    // widened to 32 bits eight at a time.
    const int first = first_lane_offset - (kLanes - 1);
    const I32x8 parts[4] = {reversedPart<0>(acc), reversedPart<1>(acc), reversedPart<2>(acc), reversedPart<3>(acc)};
    for (int p = 0; p < 4; ++p) {
      if (strip != nullptr && store) storeWidened(parts[p], strip + first + 8 * p);
      else if (strip != nullptr) addWidened(parts[p], strip + first + 8 * p);
      addWidened(parts[p], counts + first + 8 * p);
    }
    acc = U8x32{};
    return;
  }
  std::uint8_t lanes[kLanes];
  std::memcpy(lanes, &acc, sizeof(lanes));
  for (int j = 0; j < kLanes; ++j) {
    const int d = first_lane_offset - j;
    if (d < 0 || d >= offsets) continue;
    if (strip != nullptr) strip[d] = store ? lanes[j] : strip[d] + lanes[j];
    counts[d] += lanes[j];
  }
  acc = U8x32{};
}

[[gnu::always_inline]] inline void flushLanes(U8x32& acc, int first_lane_offset, int offsets, int* counts) {
  flushLanesTwice(acc, first_lane_offset, offsets, nullptr, false, counts);
}

// b matches a when b lies in [lo, hi] = [max(a - tol, 1), min(a + tol, 255)]:
// (b - lo) mod 256 <= hi - lo. b = 0 wraps to 256 - lo > hi - lo, so non-features never match
// (mismatchMask below tests the complement).
// The range for each lane of a != 0: lo = max(a - tol, 1) and width = min(a + tol, 255) - lo,
// with vtol = tol in every lane (for a = 0 the range is meaningless: callers mask those lanes).
// As byte minima, which compile to single instructions: for a >= 1, max(a - tol, 1) is
// a - min(a - 1, tol), and min(a + tol, 255) is a + min(255 - a, tol) (255 - a is ~a), so that
// width = min(a - 1, tol) + min(~a, tol).
[[gnu::always_inline]] inline void matchRange(const U8x32& a, const U8x32& vtol, U8x32& lo, U8x32& width) {
  const U8x32 below = a - 1;
  const U8x32 down = below < vtol ? below : vtol;
  const U8x32 room = ~a;
  const U8x32 up = room < vtol ? room : vtol;
  lo = a - down;
  width = down + up;
}

// Calls vec(x) for whole vectors x = a, a + Step, ... inside [a, b), then for the rest either
// vec(b - Step), a last vector overlapping the one before (for callers whose results do not
// change when a pixel is done twice), or, when [a, b) is shorter than a vector, scalar(x) for
// each pixel left.
template <int Step = kLanes, class Vector, class Scalar>
[[gnu::always_inline]] inline void forVectors(int a, int b, Vector vec, Scalar scalar) {
  int x = a;
  for (; x + Step <= b; x += Step) vec(x);
  if (x < b && b - Step >= a) {
    vec(b - Step);
    x = b;
  }
  for (; x < b; ++x) scalar(x);
}

// Bit j set where byte j of w is non-zero: the multiplication moves the 0/1 flag of each
// byte (nonZeroBytes) into the top byte (the partial products never overlap).
[[gnu::always_inline]] constexpr unsigned nonZeroBits(std::uint64_t w) {
  return static_cast<unsigned>((nonZeroBytes(w) * 0x0102040810204080ull) >> 56);
}
static_assert(nonZeroBits(0) == 0 && nonZeroBits(0x0100ff0000800001ull) == 0b10100101u);

// For each 8-bit mask, the positions of its set bits in increasing order (the entries
// past the last set bit are 0), as 32-bit integers: one vector load each.
struct CompressTable {
  alignas(32) std::int32_t positions[256][8];
};
constexpr CompressTable makeCompressTable() {
  CompressTable t{};
  for (unsigned m = 0; m < 256; ++m) {
    int n = 0;
    for (unsigned j = 0; j < 8; ++j)
      if (m & (1u << j)) t.positions[m][n++] = static_cast<std::int32_t>(j);
  }
  return t;
}
constexpr CompressTable kCompress = makeCompressTable();

// Gathers into idx the x in [x, x1) with left[x] != 0 (and skip[x] == 0 when skip
// is not null), without a branch per pixel, until x1 or until idx holds kMaxGather - 7 or more;
// returns how many and advances x. Eight pixels at a time: the mask of those to keep
// selects their positions from kCompress, stored as eight indices of which the first
// popcount(mask) count (idx has room for the rest).
constexpr int kMaxGather = 255;  // the most a byte lane can count
[[gnu::always_inline]] inline int gatherFeatures(const std::uint8_t* left, const std::uint8_t* skip, int& x, int x1,
                                                 int* idx) {
  int n = 0;
  while (x + 8 <= x1 && n <= kMaxGather - 8) {
    std::uint64_t word;
    std::memcpy(&word, left + x, sizeof(word));
    if constexpr (std::endian::native != std::endian::little) {  // byte j is not bits 8j .. 8j + 7
      for (int j = 0; j < 8; ++j) {
        idx[n] = x + j;
        n += skip == nullptr ? left[x + j] != 0 : (left[x + j] != 0) & (skip[x + j] == 0);
      }
      x += 8;
      continue;
    }
    unsigned keep = nonZeroBits(word);
    if (skip != nullptr) {
      std::uint64_t skipped;
      std::memcpy(&skipped, skip + x, sizeof(skipped));
      keep &= ~nonZeroBits(skipped);
    }
    if (keep != 0) {
      I32x8 xs;
      std::memcpy(&xs, kCompress.positions[keep], sizeof(xs));
      xs += x;
      std::memcpy(idx + n, &xs, sizeof(xs));
      n += std::popcount(keep);
    }
    x += 8;
  }
  if (x + 8 > x1)
    for (; x < x1 && n < kMaxGather; ++x) {
      idx[n] = x;
      n += skip == nullptr ? left[x] != 0 : (left[x] != 0) & (skip[x] == 0);
    }
  return n;
}

// The gathered feature pixels count mismatches, in two instructions per vector: b misses a
// when (b - lo) mod 256 > width unsigned, i.e. when (b - lo + 128) mod 256 > width - 128 as
// signed bytes (adding 128 maps the unsigned order onto the signed one). Per grey value a
// and one tolerance, as broadcasts: bias = 128 - lo and limit = width ^ 0x80, lo and width as
// in matchRange, one cache line per grey value. Built once per thread and tolerance.
struct RangeSplats {
  struct Entry {
    std::uint8_t bias[kLanes];
    std::uint8_t limit[kLanes];
  };
  alignas(64) Entry of[256];
  int tol = -1;
};
[[gnu::always_inline]] inline const RangeSplats& rangeSplats(int tol) {
  static thread_local RangeSplats table;
  if (table.tol != tol) {
    for (int a = 0; a < 256; ++a) {
      const int lo = std::max(a - tol, 1);
      const int hi = std::min(a + tol, 255);
      std::memset(table.of[a].bias, (128 - lo) & 0xFF, kLanes);
      std::memset(table.of[a].limit, ((hi - lo) ^ 0x80) & 0xFF, kLanes);
    }
    table.tol = tol;
  }
  return table;
}

typedef std::int8_t S8x32 __attribute__((vector_size(32)));
// 0xFF in the lanes where b misses the range of (bias, limit) (see RangeSplats).
[[gnu::always_inline]] inline U8x32 mismatchMask(U8x32 b, U8x32 bias, U8x32 limit) {
  return std::bit_cast<U8x32>(std::bit_cast<S8x32>(b + bias) > std::bit_cast<S8x32>(limit));
}

// mismatchMask's (bias, limit) for each lane of a (matchRange's range); a lane without a feature
// (a = 0) gets the widest range, width 255, limit 127: nothing misses it.
[[gnu::always_inline]] inline void mismatchRange(const U8x32& a, const U8x32& vtol, U8x32& bias, U8x32& limit) {
  U8x32 lo, width;
  matchRange(a, vtol, lo, width);
  width |= __builtin_convertvector(a == U8x32{}, U8x32);
  bias = (U8x32{} + 128) - lo;
  limit = width ^ 0x80;
}

// The n (at most 255) gathered feature pixels idx[0..n) matched against the right row at the
// offsets first - j: lane j of acc[i] ends with the matches at offset
// first - (kLanes * i + j), counted as n minus the mismatches.
[[gnu::always_inline]] inline void matchGathered(const std::uint8_t* left, const std::uint8_t* right, const int* idx,
                                                 int n, const RangeSplats& ranges, int first, int nv, U8x32* acc) {
  for (int k = 0; k < n; ++k) {
    const int xi = idx[k];
    const RangeSplats::Entry& range = ranges.of[left[xi]];
    const U8x32 bias = load(range.bias);
    const U8x32 limit = load(range.limit);
    const std::uint8_t* base = right + xi - first;
    for (int i = 0; i < nv; ++i) acc[i] -= mismatchMask(load(base + kLanes * i), bias, limit);
  }
  const U8x32 all = splatFromTable(n);
  for (int i = 0; i < nv; ++i) acc[i] = all - acc[i];
}

// Lane j of vector i holds the count of offset d = dv - 1 - (kLanes * i + j).
template <int NV>
[[gnu::always_inline]] inline void accumulateImpl(const std::uint8_t* left, const std::uint8_t* skip,
                                                  const std::uint8_t* right, int x0, int x1, int nv_runtime,
                                                  int offsets, int tol, int* counts) {
  constexpr int kMaxVectors = 1024 / kLanes;
  const int nv = NV > 0 ? NV : nv_runtime;
  const int dv = nv * kLanes;
  U8x32 acc[NV > 0 ? NV : kMaxVectors];
  for (int i = 0; i < nv; ++i) acc[i] = U8x32{};
  auto flush = [&] {
    for (int i = 0; i < nv; ++i) flushLanes(acc[i], dv - 1 - kLanes * i, offsets, counts);
  };
  // Feature pixels are gathered into chunks of at most 255, the most a byte lane
  // can count, then matched and flushed.
  int idx[kMaxGather];
  const RangeSplats& ranges = rangeSplats(tol);
  int x = x0;
  while (x < x1) {
    // A literal nullptr lets the inlined gather drop the skip test.
    const int n = skip == nullptr ? gatherFeatures(left, nullptr, x, x1, idx) : gatherFeatures(left, skip, x, x1, idx);
    matchGathered(left, right, idx, n, ranges, dv - 1, nv, acc);
    if (n > 0) flush();
  }
}

// accumulateImpl strip by strip (accumulateMatchesStrips): each strip's first flush stores
// its counts, so an empty strip gets zeros.
template <int NV>
[[gnu::always_inline]] inline void accumulateStripsImpl(const std::uint8_t* left, const std::uint8_t* right, int x0,
                                                        int x1, int nv_runtime, int offsets, int tol,
                                                        const int* bounds, int strips, int* strip_counts,
                                                        int* counts) {
  constexpr int kMaxVectors = 1024 / kLanes;
  const int nv = NV > 0 ? NV : nv_runtime;
  const int dv = nv * kLanes;
  U8x32 acc[NV > 0 ? NV : kMaxVectors];
  for (int i = 0; i < nv; ++i) acc[i] = U8x32{};
  int idx[kMaxGather];
  const RangeSplats& ranges = rangeSplats(tol);
  for (int k = 0; k < strips; ++k) {
    int* strip = strip_counts + static_cast<std::size_t>(k) * static_cast<std::size_t>(offsets);
    bool first = true;
    auto flush = [&] {
      for (int i = 0; i < nv; ++i) flushLanesTwice(acc[i], dv - 1 - kLanes * i, offsets, strip, first, counts);
      first = false;
    };
    int x = std::max(x0, bounds[k]);
    const int xb = std::min(x1, bounds[k + 1]);
    while (x < xb) {
      const int n = gatherFeatures(left, nullptr, x, xb, idx);
      matchGathered(left, right, idx, n, ranges, dv - 1, nv, acc);
      if (n > 0) flush();
    }
    if (first) std::fill(strip, strip + offsets, 0);
  }
}

[[gnu::always_inline]] inline void dispatchAccumulateStrips(const std::uint8_t* left, const std::uint8_t* right,
                                                            int x0, int x1, int offsets, int tol, const int* bounds,
                                                            int strips, int* strip_counts, int* counts) {
  const int nv = rightPadding(offsets) / kLanes;
  switch (nv) {
    case 4: accumulateStripsImpl<4>(left, right, x0, x1, nv, offsets, tol, bounds, strips, strip_counts, counts); break;
    default:
      accumulateStripsImpl<0>(left, right, x0, x1, nv, offsets, tol, bounds, strips, strip_counts, counts);
      break;
  }
}

[[gnu::always_inline]] inline void dispatchAccumulate(const std::uint8_t* left, const std::uint8_t* skip,
                                                      const std::uint8_t* right, int x0, int x1, int offsets,
                                                      int tol, int* counts) {
  const int nv = rightPadding(offsets) / kLanes;
  switch (nv) {
    case 1: accumulateImpl<1>(left, skip, right, x0, x1, nv, offsets, tol, counts); break;
    case 2: accumulateImpl<2>(left, skip, right, x0, x1, nv, offsets, tol, counts); break;
    case 4: accumulateImpl<4>(left, skip, right, x0, x1, nv, offsets, tol, counts); break;
    case 8: accumulateImpl<8>(left, skip, right, x0, x1, nv, offsets, tol, counts); break;
    default: accumulateImpl<0>(left, skip, right, x0, x1, nv, offsets, tol, counts); break;
  }
}

[[gnu::always_inline]] inline void windowImpl(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1,
                                              int d_first, int count, int tol, int* counts) {
  U8x32 acc{};
  // Lane j is offset d_first + kLanes - 1 - j, i.e. counts index kLanes - 1 - j.
  int idx[kMaxGather];
  const RangeSplats& ranges = rangeSplats(tol);
  int x = std::max(x0, d_first);
  while (x < x1) {
    const int n = gatherFeatures(left, nullptr, x, x1, idx);
    matchGathered(left, right, idx, n, ranges, d_first + kLanes - 1, 1, &acc);
    if (n > 0) flushLanes(acc, kLanes - 1, count, counts);
  }
}

typedef std::uint8_t U8x16 __attribute__((vector_size(16)));
typedef std::int16_t I16x16 __attribute__((vector_size(32)));

typedef std::uint16_t U16x16 __attribute__((vector_size(32)));

// Sixteen bytes at p zero-extended to 16-bit lanes. On little-endian machines as a shuffle with
// zeros, which GCC 12 assembles as one widening load; a conversion it assembles as two
// half-width widenings, a shift and an insert.
[[gnu::always_inline]] inline U16x16 widenBytes(const std::uint8_t* p) {
  U8x16 v;
  std::memcpy(&v, p, sizeof(v));
  if constexpr (std::endian::native == std::endian::little) {
    const U8x16 z{};
    return std::bit_cast<U16x16>(__builtin_shufflevector(v, z, 0, 16, 1, 16, 2, 16, 3, 16, 4, 16, 5, 16, 6, 16, 7, 16,
                                                         8, 16, 9, 16, 10, 16, 11, 16, 12, 16, 13, 16, 14, 16, 15, 16));
  } else {
    return __builtin_convertvector(v, U16x16);
  }
}

[[gnu::always_inline]] inline I16x16 widen(const std::uint8_t* p) { return std::bit_cast<I16x16>(widenBytes(p)); }

[[gnu::always_inline]] inline void featureRowImpl(const std::uint8_t* pm, const std::uint8_t* p0,
                                                  const std::uint8_t* pp, int w, int thr, int r,
                                                  std::uint8_t* scratch, std::uint8_t* out) {
  // Edge bytes (0 / 0xFF) with r zeros on the left and r + kLanes on the right.
  std::uint8_t* e = scratch + r;
  std::memset(scratch, 0, static_cast<std::size_t>(r));
  std::memset(e + w, 0, static_cast<std::size_t>(r + kLanes));
  // Sobel separated: per column the vertical sum v = pm + 2 p0 + pp and difference
  // dv = pp - pm (16 bits, the end columns repeated once beyond the row), then
  // gx = v[x + 1] - v[x - 1] and gy = dv[x - 1] + 2 dv[x] + dv[x + 1]: the same integers as
  // the 3x3 masks with the row ends replicated.
  std::uint8_t* const sums = scratch + w + 2 * r + 2 * kLanes;
  std::uint8_t* const vsum = sums + 2;                          // column x at vsum + 2 x
  std::uint8_t* const vdif = sums + 2 * (w + 2 + kLanes) + 2;   // the same for dv
  auto put = [](std::uint8_t* row, int x, int value) __attribute__((always_inline)) {
    const auto v = static_cast<std::int16_t>(value);
    std::memcpy(row + 2 * x, &v, sizeof(v));
  };
  auto get = [](const std::uint8_t* row, int x) __attribute__((always_inline)) {
    std::int16_t v;
    std::memcpy(&v, row + 2 * x, sizeof(v));
    return static_cast<int>(v);
  };
  auto loadSums = [](const std::uint8_t* row, int x) __attribute__((always_inline)) {
    I16x16 v;
    std::memcpy(&v, row + 2 * x, sizeof(v));
    return v;
  };
  // Each pass below goes over the row in vectors, the last one overlapping the one before it
  // where the row is not a whole number of vectors (the same values written twice).
  constexpr int kStep = 16;
  auto sumsAt = [&](int x) __attribute__((always_inline)) {
    const I16x16 a = widen(pm + x), b = widen(p0 + x), c = widen(pp + x);
    const I16x16 v = a + b + b + c;
    const I16x16 dv = c - a;
    std::memcpy(vsum + 2 * x, &v, sizeof(v));
    std::memcpy(vdif + 2 * x, &dv, sizeof(dv));
  };
  forVectors<kStep>(0, w, sumsAt, [&](int x) __attribute__((always_inline)) {
    put(vsum, x, pm[x] + 2 * p0[x] + pp[x]);
    put(vdif, x, pp[x] - pm[x]);
  });
  if (w > 0) {
    put(vsum, -1, get(vsum, 0));
    put(vdif, -1, get(vdif, 0));
    put(vsum, w, get(vsum, w - 1));
    put(vdif, w, get(vdif, w - 1));
  }
  // |gx| + |gy| <= 8 * 255 fits 16 bits.
  const I16x16 vthr = I16x16{} + static_cast<std::int16_t>(std::min(thr, 32767));
  auto edgesAt = [&](int x) __attribute__((always_inline)) {
    const I16x16 gx = loadSums(vsum, x + 1) - loadSums(vsum, x - 1);
    const I16x16 d0 = loadSums(vdif, x);
    const I16x16 gy = loadSums(vdif, x - 1) + d0 + d0 + loadSums(vdif, x + 1);
    const I16x16 ax = gx < 0 ? -gx : gx;
    const I16x16 ay = gy < 0 ? -gy : gy;
    const auto edge = __builtin_convertvector((ax + ay) >= vthr, U8x16);  // -1 -> 0xFF
    std::memcpy(e + x, &edge, sizeof(edge));
  };
  forVectors<kStep>(0, w, edgesAt, [&](int x) __attribute__((always_inline)) {
    const int gx = get(vsum, x + 1) - get(vsum, x - 1);
    const int gy = get(vdif, x - 1) + 2 * get(vdif, x) + get(vdif, x + 1);
    e[x] = std::abs(gx) + std::abs(gy) >= thr ? 0xFF : 0;
  });
  // Dilation and masked copy.
  const U8x32 one = splat(1);
  auto featuresAt = [&](int x) __attribute__((always_inline)) {
    U8x32 on = load(e + x - r);
    for (int k = -r + 1; k <= r; ++k) on |= load(e + x + k);
    U8x32 grey = load(p0 + x);
    grey = grey < one ? one : grey;
    const U8x32 v = grey & on;
    std::memcpy(out + x, &v, sizeof(v));
  };
  forVectors(0, w, featuresAt, [&](int x) __attribute__((always_inline)) {
    int on = 0;
    for (int k = -r; k <= r; ++k) on |= e[x + k];
    out[x] = on ? std::max<std::uint8_t>(p0[x], 1) : std::uint8_t{0};
  });
}

[[gnu::always_inline]] inline void markImpl(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1,
                                            int d0, int d1, int tol, std::uint8_t* marks) {
  const U8x32 vtol = splatFromTable(tol);  // tol in [0, 255]
  const U8x32 zero{};
  auto scalar = [&](int x, int d) __attribute__((always_inline)) {
    const int a = left[x];
    const int b = right[x - d];
    if (a != 0 && b != 0 && std::abs(a - b) <= tol) marks[x] = 0xFF;
  };
  // From x = d1 on every offset has a right pixel: a left vector's range serves all offsets,
  // and a pixel is marked unless it misses at every one (or is no feature).
  const int xs_all = std::min(std::max(x0, d1), x1);
  // Marks are ORed in: the last vector may overlap the one before it (same values again).
  forVectors(xs_all, x1, [&](int x) __attribute__((always_inline)) {
    const U8x32 a = load(left + x);
    U8x32 bias, limit;
    mismatchRange(a, vtol, bias, limit);
    U8x32 none = zero + 255;
    for (int d = d0; d <= d1; ++d) none &= mismatchMask(load(right + x - d), bias, limit);
    U8x32 old = load(marks + x);
    old |= ~(none | __builtin_convertvector(a == zero, U8x32));
    std::memcpy(marks + x, &old, sizeof(old));
  }, [&](int x) __attribute__((always_inline)) {
    for (int d = d0; d <= d1; ++d) scalar(x, d);
  });
  // Before it, offset by offset over the pixels that have a right pixel there.
  for (int d = d0; d <= d1; ++d) {
    forVectors(std::max(x0, d), xs_all, [&](int x) __attribute__((always_inline)) {
      const U8x32 a = load(left + x);
      U8x32 bias, limit;
      mismatchRange(a, vtol, bias, limit);
      U8x32 old = load(marks + x);
      old |= ~(mismatchMask(load(right + x - d), bias, limit) | __builtin_convertvector(a == zero, U8x32));
      std::memcpy(marks + x, &old, sizeof(old));
    }, [&](int x) __attribute__((always_inline)) { scalar(x, d); });
  }
}

// q[j] = 0xFF where pixel j spoils a window at offset d (a left feature without a right match
// within the tolerance), 0 where it cannot (j < d, outside the row, no left feature, or a
// match); a window over [-half, half] matches where none of its pixels spoils it.
// N offsets d .. d + N - 1 at a time, one q row each: a left vector and its grey range
// serve all of them, and their windows are ORed before `out` is updated.
// H >= 0 is the window's half width known at compile time (its loops unrolled), H < 0 takes `half`.
template <int N, int H>
[[gnu::always_inline]] inline void windowGroup(const std::uint8_t* left, const std::uint8_t* right, int width, int x0,
                                               int x1, int d, int tol, int runtime_half, std::uint8_t* scratch,
                                               std::uint8_t* out) {
  const int half = H >= 0 ? H : runtime_half;
  const U8x32 vtol = splatFromTable(tol);  // tol in [0, 255]
  const U8x32 one = splat(1);
  const U8x32 zero{};
  const int qlo = x0 - half;  // q[i][j - qlo] describes pixel j at offset d + i
  const int qhi = x1 + half;
  const int jw = std::min(qhi, width);  // pixels from here on are outside the row
  std::uint8_t* q[N];
  for (int i = 0; i < N; ++i) q[i] = scratch + i * (qhi - qlo);
  auto qScalar = [&](int i, int j) __attribute__((always_inline)) {
    const int a = left[j];
    const int b = right[j - d - i];
    q[i][j - qlo] = (a == 0 || (b != 0 && std::abs(a - b) <= tol)) ? 0 : 0xFF;
  };
  // Per offset, the pixels [ja, jb) are compared; all offsets together from the largest ja.
  const int ja_all = std::min(std::max(qlo, d + N - 1), qhi);
  for (int i = 0; i < N; ++i) {
    const int ja = std::min(std::max(qlo, d + i), qhi);
    const int jb = std::max(jw, ja);
    if (ja > qlo) std::memset(q[i], 0, static_cast<std::size_t>(ja - qlo));
    for (int j = ja; j < std::min(ja_all, jb); ++j) qScalar(i, j);
    if (qhi > jb) std::memset(q[i] + (jb - qlo), 0, static_cast<std::size_t>(qhi - jb));
  }
  // The last vector may overlap the one before it (same values written twice).
  auto qVector = [&](int j) __attribute__((always_inline)) {
    U8x32 bias, limit;
    mismatchRange(load(left + j), vtol, bias, limit);
    for (int i = 0; i < N; ++i) {
      const U8x32 miss = mismatchMask(load(right + j - d - i), bias, limit);
      std::memcpy(q[i] + (j - qlo), &miss, sizeof(miss));
    }
  };
  forVectors(ja_all, jw, qVector, [&](int j) __attribute__((always_inline)) {
    for (int i = 0; i < N; ++i) qScalar(i, j);
  });
  // Windows, ORed over the offsets; ORing a pixel's result twice changes nothing: the last
  // vector may overlap too. Pixel x matches at offset d + i only from x = d + i on.
  auto outScalar = [&](int i, int x) __attribute__((always_inline)) {
    int m = left[x] != 0;
    for (int k = -half; k <= half; ++k) m &= q[i][x + k - qlo] == 0;
    out[x] = static_cast<std::uint8_t>(out[x] | m);
  };
  // A pixel matches at an offset when no pixel of its window misses there: it matches at none
  // when every offset's window holds a miss.
  auto outVector = [&](int xv) __attribute__((always_inline)) {
    U8x32 none = zero + 255;
    for (int i = 0; i < N; ++i) {
      U8x32 missed = load(q[i] + (xv - half - qlo));
      for (int k = -half + 1; k <= half; ++k) missed |= load(q[i] + (xv + k - qlo));
      none &= missed;
    }
    U8x32 o = load(out + xv);
    o |= ~(none | __builtin_convertvector(load(left + xv) == zero, U8x32)) & one;
    std::memcpy(out + xv, &o, sizeof(o));
  };
  const int xa_all = std::max(x0, d + N - 1);
  for (int i = 0; i + 1 < N; ++i)
    for (int x = std::max(x0, d + i); x < std::min(xa_all, x1); ++x) outScalar(i, x);
  forVectors(xa_all, x1, outVector, [&](int x) __attribute__((always_inline)) {
    for (int i = 0; i < N; ++i) outScalar(i, x);
  });
}

// windowGroup for n (1..kWindowGroup) offsets at d, half width H (see windowGroup).
template <int H>
[[gnu::always_inline]] inline void windowGroupOf(int n, const std::uint8_t* left, const std::uint8_t* right,
                                                 int width, int x0, int x1, int d, int tol, int half,
                                                 std::uint8_t* scratch, std::uint8_t* out) {
  static_assert(kWindowGroup == 4);
  switch (n) {
    case 1: windowGroup<1, H>(left, right, width, x0, x1, d, tol, half, scratch, out); break;
    case 2: windowGroup<2, H>(left, right, width, x0, x1, d, tol, half, scratch, out); break;
    case 3: windowGroup<3, H>(left, right, width, x0, x1, d, tol, half, scratch, out); break;
    default: windowGroup<4, H>(left, right, width, x0, x1, d, tol, half, scratch, out); break;
  }
}

// The window of half width H (0 or 1) over a short span inside the row, every offset at once:
// the window pixels' grey ranges are held in registers and each output vector is finished where
// it is computed, with no q rows (their set-up costs more than a short span's vectors). Requires
// x1 - x0 >= kLanes and every window pixel inside the row with a right pixel at every offset:
// x0 - H - d1 >= 0, x1 + H <= width. Per pixel the same test as windowGroup.
constexpr int kFusedMaxSpan = 256;  // beyond it the q rows' two passes are cheaper
constexpr int kFusedMaxOffsets = 8;
[[gnu::always_inline]] inline bool fusedWindowApplies(int width, int x0, int x1, int d0, int d1, int half) {
  return (half == 0 || half == 1) && d0 >= 0 && d1 >= d0 && d1 - d0 < kFusedMaxOffsets && x1 - x0 >= kLanes &&
         x1 - x0 <= kFusedMaxSpan && x0 - half - d1 >= 0 && x1 + half <= width;
}
// N > 0: the number of offsets d1 - d0 + 1 known at compile time (the loop over them unrolled).
template <int H, int N>
[[gnu::always_inline]] inline void fusedWindow(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1,
                                               int d0, int d1, int tol, std::uint8_t* out) {
  if constexpr (N > 0) d1 = d0 + N - 1;
  const U8x32 vtol = splatFromTable(tol);  // tol in [0, 255]
  const U8x32 one = splat(1);
  const U8x32 zero{};
  auto vec = [&](int xv) __attribute__((always_inline)) {
    U8x32 bias[2 * H + 1], limit[2 * H + 1];
    for (int k = 0; k <= 2 * H; ++k) mismatchRange(load(left + xv + k - H), vtol, bias[k], limit[k]);
    U8x32 none = zero + 255;  // lanes where every offset's window holds a miss
    for (int d = d0; d <= d1; ++d) {
      const std::uint8_t* r = right + xv - d - H;
      U8x32 missed = mismatchMask(load(r), bias[0], limit[0]);
      for (int k = 1; k <= 2 * H; ++k) missed |= mismatchMask(load(r + k), bias[k], limit[k]);
      none &= missed;
    }
    const U8x32 o = ~(none | __builtin_convertvector(load(left + xv) == zero, U8x32)) & one;
    std::memcpy(out + xv, &o, sizeof(o));
  };
  // The span is at least a vector wide: the last vector overlaps the one before it (the same
  // values again) and no pixel is left to a scalar loop.
  forVectors(x0, x1, vec, [](int) {});
}

[[gnu::always_inline]] inline void windowMatchImpl(const std::uint8_t* left, const std::uint8_t* right, int width,
                                                   int x0, int x1, int d0, int d1, int tol, int half,
                                                   std::uint8_t* scratch, std::uint8_t* out) {
  if (x1 <= x0) return;
  if (fusedWindowApplies(width, x0, x1, d0, d1, half)) {
    // The candidates' three offsets (+-1) and the sweeps' five (+-2) unrolled.
    const int n = d1 - d0 + 1;
    if (half == 1 && n == 3) fusedWindow<1, 3>(left, right, x0, x1, d0, d1, tol, out);
    else if (half == 1 && n == 5) fusedWindow<1, 5>(left, right, x0, x1, d0, d1, tol, out);
    else if (half == 1) fusedWindow<1, 0>(left, right, x0, x1, d0, d1, tol, out);
    else if (n == 3) fusedWindow<0, 3>(left, right, x0, x1, d0, d1, tol, out);
    else fusedWindow<0, 0>(left, right, x0, x1, d0, d1, tol, out);
    return;
  }
  std::memset(out + x0, 0, static_cast<std::size_t>(x1 - x0));
  const int dlast = std::min(d1, x1 - 1);
  for (int d = std::max(d0, 0); d <= dlast; d += kWindowGroup) {
    const int n = std::min(kWindowGroup, dlast - d + 1);
    // The default window (half width 1) has its loops unrolled.
    if (half == 1) windowGroupOf<1>(n, left, right, width, x0, x1, d, tol, half, scratch, out);
    else windowGroupOf<-1>(n, left, right, width, x0, x1, d, tol, half, scratch, out);
  }
}

[[gnu::always_inline]] inline void windowMatchRowsImpl(const std::uint8_t* left, std::size_t left_step,
                                                       const std::uint8_t* right, std::size_t right_step, int width,
                                                       int rows, int x0, int x1, int d0, int d1, int tol, int half,
                                                       std::uint8_t* scratch, std::uint8_t* out, std::size_t out_step) {
  for (int i = 0; i < rows; ++i) {
    const auto k = static_cast<std::size_t>(i);
    windowMatchImpl(left + k * left_step, right + k * right_step, width, x0, x1, d0, d1, tol, half, scratch,
                    out + k * out_step);
  }
}

[[gnu::always_inline]] inline void rowExcessImpl(const int* counts, int median, int min_excess, int row,
                                                 const int* last_row, int n, int* excess, int* sum) {
  const I32x8 vmed = I32x8{} + median;
  const I32x8 vmin = I32x8{} + min_excess;
  const I32x8 vrow = I32x8{} + row;
  int d = 0;
  for (; d + 8 <= n; d += 8) {
    I32x8 c, lim, old, s;
    std::memcpy(&c, counts + d, sizeof(c));
    std::memcpy(&lim, last_row + d, sizeof(lim));
    std::memcpy(&old, excess + d, sizeof(old));
    std::memcpy(&s, sum + d, sizeof(s));
    const I32x8 e = c - vmed;
    const I32x8 now = e & ((e >= vmin) & (vrow <= lim));
    s += now - old;
    std::memcpy(excess + d, &now, sizeof(now));
    std::memcpy(sum + d, &s, sizeof(s));
  }
  for (; d < n; ++d) {
    const int e = counts[d] - median;
    const int now = e >= min_excess && row <= last_row[d] ? e : 0;
    sum[d] += now - excess[d];
    excess[d] = now;
  }
}

[[gnu::always_inline]] inline bool kthSmallestImpl(const int* counts, int n, int k, int previous, int max_steps,
                                                   int& value) {
  // How many counts lie below `previous`, and at or below it.
  int below = 0, at_most = 0;
  {
    const I32x8 vp = I32x8{} + previous;
    I32x8 b{}, a{};
    int d = 0;
    for (; d + 8 <= n; d += 8) {
      I32x8 c;
      std::memcpy(&c, counts + d, sizeof(c));
      b -= c < vp;  // true is -1
      a -= c <= vp;
    }
    int lb[8], la[8];
    std::memcpy(lb, &b, sizeof(lb));
    std::memcpy(la, &a, sizeof(la));
    for (int j = 0; j < 8; ++j) {
      below += lb[j];
      at_most += la[j];
    }
    for (; d < n; ++d) {
      below += counts[d] < previous;
      at_most += counts[d] <= previous;
    }
  }
  if (k >= at_most) return false;  // the k-th smallest is above `previous`
  // Down over the distinct values below v while more than k counts lie below it: the largest
  // value w below v has below(v) counts at or below it, and below(v) - count(w) below it.
  int v = previous;
  for (int step = 0; below > k; ++step) {
    if (step == max_steps) return false;
    constexpr int kNone = std::numeric_limits<int>::min();
    const I32x8 vv = I32x8{} + v;
    I32x8 top = I32x8{} + kNone, many{};  // per lane: the largest count below v, how often
    int d = 0;
    for (; d + 8 <= n; d += 8) {
      I32x8 c;
      std::memcpy(&c, counts + d, sizeof(c));
      const I32x8 valid = c < vv;
      const I32x8 greater = valid & (c > top);
      const I32x8 equal = valid & (c == top);
      top = greater ? c : top;
      many = greater ? I32x8{} + 1 : many - equal;
    }
    int lt[8], lm[8];
    std::memcpy(lt, &top, sizeof(lt));
    std::memcpy(lm, &many, sizeof(lm));
    int w = kNone, times = 0;
    for (int j = 0; j < 8; ++j) w = std::max(w, lt[j]);
    for (int j = 0; j < 8; ++j) times += lt[j] == w ? lm[j] : 0;
    for (; d < n; ++d) {
      if (counts[d] >= v) continue;
      if (counts[d] > w) {
        w = counts[d];
        times = 1;
      } else if (counts[d] == w) {
        ++times;
      }
    }
    v = w;
    below -= times;
  }
  value = v;
  return true;
}

// The k-th smallest of counts[0, n) by bisection over the values: the smallest v with more
// than k counts at or below it. Each step is one counting pass, with no branch per count.
[[gnu::always_inline]] inline int countAtMost(const int* counts, int n, int v) {
  const I32x8 vv = I32x8{} + v;
  I32x8 a{};
  int d = 0;
  for (; d + 8 <= n; d += 8) {
    I32x8 c;
    std::memcpy(&c, counts + d, sizeof(c));
    a -= c <= vv;  // true is -1
  }
  int la[8];
  std::memcpy(la, &a, sizeof(la));
  int at_most = 0;
  for (int j = 0; j < 8; ++j) at_most += la[j];
  for (; d < n; ++d) at_most += counts[d] <= v;
  return at_most;
}

[[gnu::always_inline]] inline int kthSmallestBisectImpl(const int* counts, int n, int k) {
  // The range of the values, lane-wise selects rather than a branch per count.
  I32x8 vlo = I32x8{} + std::numeric_limits<int>::max(), vhi = I32x8{} + std::numeric_limits<int>::min();
  int d = 0;
  for (; d + 8 <= n; d += 8) {
    I32x8 c;
    std::memcpy(&c, counts + d, sizeof(c));
    vlo = c < vlo ? c : vlo;
    vhi = c > vhi ? c : vhi;
  }
  int llo[8], lhi[8];
  std::memcpy(llo, &vlo, sizeof(llo));
  std::memcpy(lhi, &vhi, sizeof(lhi));
  int lowest = llo[0], highest = lhi[0];
  for (int j = 1; j < 8; ++j) {
    lowest = std::min(lowest, llo[j]);
    highest = std::max(highest, lhi[j]);
  }
  for (; d < n; ++d) {
    lowest = std::min(lowest, counts[d]);
    highest = std::max(highest, counts[d]);
  }
  std::int64_t lo = lowest, hi = highest;
  while (lo < hi) {
    const std::int64_t mid = lo + (hi - lo) / 2;
    if (countAtMost(counts, n, static_cast<int>(mid)) > k) hi = mid;
    else lo = mid + 1;
  }
  return static_cast<int>(lo);
}

// One row of the fast path's mirrored sums, for pairs j = 1..n about the column
// `axis` of the row's quantized weights w, their mirror m and grey levels g:
//   sm[j] += w[axis - j] * m[axis + j] + m[axis - j] * w[axis + j]
//   sab[j] += g[axis - j] * g[axis + j]
// kLanes pairs per step: the left side is loaded below the axis and reversed
// in the register. Exact integer arithmetic, so any grouping gives the same sums.
typedef std::int32_t I32x4 __attribute__((vector_size(16)));
typedef std::uint8_t U8x4 __attribute__((vector_size(4)));
typedef std::uint8_t U8x8 __attribute__((vector_size(8)));

// Reverses the lanes of a vector (GCC and Clang). Through a reference: a 32-byte
// vector passed by value to a function without the AVX target changes the ABI.
[[gnu::always_inline]] inline void reverseLanes(I32x4& v) { v = __builtin_shufflevector(v, v, 3, 2, 1, 0); }
[[gnu::always_inline]] inline void reverseLanes(I32x8& v) {
  v = __builtin_shufflevector(v, v, 7, 6, 5, 4, 3, 2, 1, 0);
}

template <class I32, class U8>
[[gnu::always_inline]] inline void mirroredRowImpl(const std::int32_t* w, const std::int32_t* m, const std::uint8_t* g,
                                                   int axis, int n, std::int32_t* sm, std::int32_t* sab) {
  constexpr int kLanes = sizeof(I32) / sizeof(std::int32_t);
  static_assert(sizeof(U8) == kLanes);
  // Loads and stores through memcpy: the rows and sums have no vector alignment.
  auto load = [](const auto* p, auto& v) { std::memcpy(&v, p, sizeof v); };
  const std::int32_t* wa = w + axis;
  const std::int32_t* ma = m + axis;
  const std::uint8_t* ga = g + axis;
  int j = 1;
  for (; j + kLanes - 1 <= n; j += kLanes) {
    I32 wr, mr, wl, ml, s, t;
    U8 gr8, gl8;
    load(wa + j, wr);
    load(ma + j, mr);
    load(wa - j - (kLanes - 1), wl);
    load(ma - j - (kLanes - 1), ml);
    load(ga + j, gr8);
    load(ga - j - (kLanes - 1), gl8);
    reverseLanes(wl);
    reverseLanes(ml);
    I32 gl = __builtin_convertvector(gl8, I32);
    reverseLanes(gl);
    const I32 gr = __builtin_convertvector(gr8, I32);
    load(sm + j, s);
    load(sab + j, t);
    s += wl * mr + ml * wr;
    t += gl * gr;
    std::memcpy(sm + j, &s, sizeof s);
    std::memcpy(sab + j, &t, sizeof t);
  }
  for (; j <= n; ++j) {
    sm[j] += wa[-j] * ma[j] + ma[-j] * wa[j];
    sab[j] += static_cast<std::int32_t>(ga[-j]) * static_cast<std::int32_t>(ga[j]);
  }
}

// kFloats lanes: 8 in the AVX2 build, 4 in the baseline one (wider selections
// there become scalar code through the stack).
template <int kFloats>
[[gnu::always_inline]] inline float windowSumsImpl(const float* lo, const float* mid, const float* hi, int n,
                                                   float* out) {
  typedef float F32xN __attribute__((vector_size(kFloats * sizeof(float))));
  // Adds through a reference: a lambda does not inherit the caller's target, and a
  // 32-byte vector returned by value from it would change the calling convention.
  auto add = [](F32xN& sum, const float* p) {
    F32xN v;
    std::memcpy(&v, p, sizeof(v));
    sum += v;
  };
  F32xN m{};
  int b = 0;
  for (; b + kFloats <= n; b += kFloats) {
    F32xN sum{};
    add(sum, lo + b - 1);
    add(sum, lo + b);
    add(sum, lo + b + 1);
    add(sum, mid + b - 1);
    add(sum, mid + b);
    add(sum, mid + b + 1);
    add(sum, hi + b - 1);
    add(sum, hi + b);
    add(sum, hi + b + 1);
    std::memcpy(out + b, &sum, sizeof(sum));
    m = sum > m ? sum : m;
  }
  float lanes[kFloats];
  std::memcpy(lanes, &m, sizeof(lanes));
  float best = 0.0f;
  for (const float v : lanes) best = std::max(best, v);
  for (; b < n; ++b) {
    float sum = 0.0f;
    sum += lo[b - 1];
    sum += lo[b];
    sum += lo[b + 1];
    sum += mid[b - 1];
    sum += mid[b];
    sum += mid[b + 1];
    sum += hi[b - 1];
    sum += hi[b];
    sum += hi[b + 1];
    out[b] = sum;
    best = std::max(best, sum);
  }
  return best;
}

[[gnu::always_inline]] inline void addBytesImpl(const std::uint8_t* bytes, std::uint16_t* sums, int n) {
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    U16x16 s;
    std::memcpy(&s, sums + i, sizeof(s));
    s += widenBytes(bytes + i);
    std::memcpy(sums + i, &s, sizeof(s));
  }
  for (; i < n; ++i) sums[i] = static_cast<std::uint16_t>(sums[i] + bytes[i]);
}

[[gnu::always_inline]] inline void addBytesToBytesImpl(const std::uint8_t* bytes, std::uint8_t* sums, int n) {
  int i = 0;
  for (; i + kLanes <= n; i += kLanes) {
    U8x32 s = load(sums + i);
    s += load(bytes + i);
    std::memcpy(sums + i, &s, sizeof(s));
  }
  for (; i < n; ++i) sums[i] = static_cast<std::uint8_t>(sums[i] + bytes[i]);
}

// The pixels of [0, n) where flags(x) holds: the first, one past the last, and how many.
// vflags(x) gives the flags of pixels x .. x + kLanes - 1 as 0/1 bytes, sflag(x) one pixel's.
template <class VFlags, class SFlag>
[[gnu::always_inline]] inline ByteSpan spanOf(int n, VFlags vflags, SFlag sflag) {
  ByteSpan span{n, n, 0};
  auto anyOf = [](const U8x32& v) __attribute__((always_inline)) {
    std::uint64_t w[4];
    std::memcpy(w, &v, sizeof(w));
    return (w[0] | w[1] | w[2] | w[3]) != 0;
  };
  // Counts in byte lanes, added up every 255 vectors.
  int x = 0;
  while (x + kLanes <= n) {
    U8x32 acc{};
    const int stop = std::min(n - kLanes, x + 254 * kLanes);
    for (; x <= stop; x += kLanes) acc += vflags(x);
    std::uint8_t lanes[kLanes];
    std::memcpy(lanes, &acc, sizeof(lanes));
    for (int j = 0; j < kLanes; ++j) span.count += lanes[j];
  }
  const int vector_end = x;
  for (; x < n; ++x) span.count += sflag(x);
  if (span.count == 0) return span;
  // The first: the first vector with a flag, then its pixels.
  int a = 0;
  while (a < vector_end && !anyOf(vflags(a))) a += kLanes;
  while (!sflag(a)) ++a;
  // The last: likewise from the end (the pixels after the whole vectors first).
  int b = n;
  while (b > vector_end && !sflag(b - 1)) --b;
  if (b == vector_end) {
    while (b > a && !anyOf(vflags(b - kLanes))) b -= kLanes;
    while (!sflag(b - 1)) --b;
  }
  span.first = a;
  span.end = b;
  return span;
}

[[gnu::always_inline]] inline ByteSpan nonZeroSpanImpl(const std::uint8_t* p, int n) {
  const U8x32 zero{};
  return spanOf(
      n,
      [&](int x) __attribute__((always_inline)) { return __builtin_convertvector(load(p + x) != zero, U8x32) & 1; },
      [&](int x) __attribute__((always_inline)) { return p[x] != 0 ? 1 : 0; });
}

[[gnu::always_inline]] inline ByteSpan removedSpanImpl(const std::uint8_t* after, const std::uint8_t* before, int n,
                                                       bool& subset) {
  const U8x32 zero{};
  // A pixel of `after` that is neither 0 nor the pixel of `before`: not a removal.
  U8x32 foreign{};
  int x = 0;
  for (; x + kLanes <= n; x += kLanes) {
    const U8x32 a = load(after + x), b = load(before + x);
    foreign |= __builtin_convertvector((a != zero) & (a != b), U8x32);
  }
  std::uint64_t w[4];
  std::memcpy(w, &foreign, sizeof(w));
  bool clean = (w[0] | w[1] | w[2] | w[3]) == 0;
  for (; x < n; ++x) clean = clean && (after[x] == 0 || after[x] == before[x]);
  subset = clean;
  return spanOf(
      n,
      [&](int i) __attribute__((always_inline)) {
        return __builtin_convertvector((load(before + i) != zero) & (load(after + i) == zero), U8x32) & 1;
      },
      [&](int i) __attribute__((always_inline)) { return before[i] != 0 && after[i] == 0 ? 1 : 0; });
}

#if defined(__x86_64__) || defined(__i386__)
#define SG_SIMD_X86 1
[[gnu::target("avx2")]] void addBytesAvx2(const std::uint8_t* bytes, std::uint16_t* sums, int n) {
  addBytesImpl(bytes, sums, n);
}
[[gnu::target("avx2")]] void addBytesToBytesAvx2(const std::uint8_t* bytes, std::uint8_t* sums, int n) {
  addBytesToBytesImpl(bytes, sums, n);
}
[[gnu::target("avx2")]] ByteSpan nonZeroSpanAvx2(const std::uint8_t* p, int n) { return nonZeroSpanImpl(p, n); }
[[gnu::target("avx2")]] ByteSpan removedSpanAvx2(const std::uint8_t* after, const std::uint8_t* before, int n,
                                                 bool& subset) {
  return removedSpanImpl(after, before, n, subset);
}
[[gnu::target("avx2")]] float windowSumsAvx2(const float* lo, const float* mid, const float* hi, int n, float* out) {
  return windowSumsImpl<8>(lo, mid, hi, n, out);
}
[[gnu::target("avx2")]] void accumulateAvx2(const std::uint8_t* left, const std::uint8_t* skip,
                                            const std::uint8_t* right, int x0, int x1, int offsets, int tol,
                                            int* counts) {
  dispatchAccumulate(left, skip, right, x0, x1, offsets, tol, counts);
}
[[gnu::target("avx2")]] void accumulateStripsAvx2(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1,
                                                  int offsets, int tol, const int* bounds, int strips,
                                                  int* strip_counts, int* counts) {
  dispatchAccumulateStrips(left, right, x0, x1, offsets, tol, bounds, strips, strip_counts, counts);
}
[[gnu::target("avx2")]] void windowAvx2(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1,
                                        int d_first, int count, int tol, int* counts) {
  windowImpl(left, right, x0, x1, d_first, count, tol, counts);
}
[[gnu::target("avx2")]] void featureRowAvx2(const std::uint8_t* pm, const std::uint8_t* p0, const std::uint8_t* pp,
                                            int w, int thr, int r, std::uint8_t* scratch, std::uint8_t* out) {
  featureRowImpl(pm, p0, pp, w, thr, r, scratch, out);
}
[[gnu::target("avx2")]] void windowMatchAvx2(const std::uint8_t* left, const std::uint8_t* right, int width, int x0,
                                             int x1, int d0, int d1, int tol, int half, std::uint8_t* q,
                                             std::uint8_t* out) {
  windowMatchImpl(left, right, width, x0, x1, d0, d1, tol, half, q, out);
}
[[gnu::target("avx2")]] void windowMatchRowsAvx2(const std::uint8_t* left, std::size_t ls, const std::uint8_t* right,
                                                 std::size_t rs, int width, int rows, int x0, int x1, int d0, int d1,
                                                 int tol, int half, std::uint8_t* q, std::uint8_t* out, std::size_t os) {
  windowMatchRowsImpl(left, ls, right, rs, width, rows, x0, x1, d0, d1, tol, half, q, out, os);
}
[[gnu::target("avx2")]] void rowExcessAvx2(const int* counts, int median, int min_excess, int row, const int* last_row,
                                           int n, int* excess, int* sum) {
  rowExcessImpl(counts, median, min_excess, row, last_row, n, excess, sum);
}
[[gnu::target("avx2")]] bool kthSmallestAvx2(const int* counts, int n, int k, int previous, int max_steps, int& value) {
  return kthSmallestImpl(counts, n, k, previous, max_steps, value);
}
[[gnu::target("avx2")]] int kthSmallestBisectAvx2(const int* counts, int n, int k) {
  return kthSmallestBisectImpl(counts, n, k);
}
[[gnu::target("avx2")]] void mirroredRowAvx2(const std::int32_t* w, const std::int32_t* m, const std::uint8_t* g,
                                             int axis, int n, std::int32_t* sm, std::int32_t* sab) {
  mirroredRowImpl<I32x8, U8x8>(w, m, g, axis, n, sm, sab);
}
[[gnu::target("avx2")]] void markAvx2(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d0,
                                      int d1, int tol, std::uint8_t* marks) {
  markImpl(left, right, x0, x1, d0, d1, tol, marks);
}
#endif

void windowMatchBaseline(const std::uint8_t* left, const std::uint8_t* right, int width, int x0, int x1, int d0,
                         int d1, int tol, int half, std::uint8_t* q, std::uint8_t* out) {
  windowMatchImpl(left, right, width, x0, x1, d0, d1, tol, half, q, out);
}

void windowMatchRowsBaseline(const std::uint8_t* left, std::size_t ls, const std::uint8_t* right, std::size_t rs,
                             int width, int rows, int x0, int x1, int d0, int d1, int tol, int half, std::uint8_t* q,
                             std::uint8_t* out, std::size_t os) {
  windowMatchRowsImpl(left, ls, right, rs, width, rows, x0, x1, d0, d1, tol, half, q, out, os);
}

void addBytesBaseline(const std::uint8_t* bytes, std::uint16_t* sums, int n) { addBytesImpl(bytes, sums, n); }
void addBytesToBytesBaseline(const std::uint8_t* bytes, std::uint8_t* sums, int n) {
  addBytesToBytesImpl(bytes, sums, n);
}

ByteSpan nonZeroSpanBaseline(const std::uint8_t* p, int n) { return nonZeroSpanImpl(p, n); }
ByteSpan removedSpanBaseline(const std::uint8_t* after, const std::uint8_t* before, int n, bool& subset) {
  return removedSpanImpl(after, before, n, subset);
}

void rowExcessBaseline(const int* counts, int median, int min_excess, int row, const int* last_row, int n, int* excess,
                       int* sum) {
  rowExcessImpl(counts, median, min_excess, row, last_row, n, excess, sum);
}

bool kthSmallestBaseline(const int* counts, int n, int k, int previous, int max_steps, int& value) {
  return kthSmallestImpl(counts, n, k, previous, max_steps, value);
}

int kthSmallestBisectBaseline(const int* counts, int n, int k) { return kthSmallestBisectImpl(counts, n, k); }

void mirroredRowBaseline(const std::int32_t* w, const std::int32_t* m, const std::uint8_t* g, int axis, int n,
                         std::int32_t* sm, std::int32_t* sab) {
  mirroredRowImpl<I32x4, U8x4>(w, m, g, axis, n, sm, sab);
}

void markBaseline(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d0, int d1, int tol,
                  std::uint8_t* marks) {
  markImpl(left, right, x0, x1, d0, d1, tol, marks);
}

void featureRowBaseline(const std::uint8_t* pm, const std::uint8_t* p0, const std::uint8_t* pp, int w, int thr, int r,
                        std::uint8_t* scratch, std::uint8_t* out) {
  featureRowImpl(pm, p0, pp, w, thr, r, scratch, out);
}

void accumulateBaseline(const std::uint8_t* left, const std::uint8_t* skip, const std::uint8_t* right, int x0, int x1,
                        int offsets, int tol, int* counts) {
  dispatchAccumulate(left, skip, right, x0, x1, offsets, tol, counts);
}
void accumulateStripsBaseline(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int offsets,
                              int tol, const int* bounds, int strips, int* strip_counts, int* counts) {
  dispatchAccumulateStrips(left, right, x0, x1, offsets, tol, bounds, strips, strip_counts, counts);
}
void windowBaseline(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d_first, int count,
                    int tol, int* counts) {
  windowImpl(left, right, x0, x1, d_first, count, tol, counts);
}

float windowSumsBaseline(const float* lo, const float* mid, const float* hi, int n, float* out) {
  return windowSumsImpl<4>(lo, mid, hi, n, out);
}

bool useAvx2() {
#ifdef SG_SIMD_X86
  // SG_SIMD=baseline runs the baseline kernels on any processor (the tests run both builds).
  static const bool avx2 = [] {
    const char* choice = std::getenv("SG_SIMD");
    if (choice != nullptr && std::string_view(choice) == "baseline") return false;
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return avx2;
#else
  return false;
#endif
}

}  // namespace

void accumulateMatches(const std::uint8_t* left, const std::uint8_t* skip, const std::uint8_t* right, int x0, int x1,
                       int offsets, int grey_tolerance, int* counts) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return accumulateAvx2(left, skip, right, x0, x1, offsets, grey_tolerance, counts);
#endif
  accumulateBaseline(left, skip, right, x0, x1, offsets, grey_tolerance, counts);
}

void accumulateMatchesStrips(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int offsets,
                             int grey_tolerance, const int* bounds, int strips, int* strip_counts, int* counts) {
#ifdef SG_SIMD_X86
  if (useAvx2())
    return accumulateStripsAvx2(left, right, x0, x1, offsets, grey_tolerance, bounds, strips, strip_counts, counts);
#endif
  accumulateStripsBaseline(left, right, x0, x1, offsets, grey_tolerance, bounds, strips, strip_counts, counts);
}

void accumulateMatchesWindow(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d_first,
                             int count, int grey_tolerance, int* counts) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return windowAvx2(left, right, x0, x1, d_first, count, grey_tolerance, counts);
#endif
  windowBaseline(left, right, x0, x1, d_first, count, grey_tolerance, counts);
}

void featureRow(const std::uint8_t* pm, const std::uint8_t* p0, const std::uint8_t* pp, int width, int threshold,
                int radius, std::uint8_t* scratch, std::uint8_t* out) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return featureRowAvx2(pm, p0, pp, width, threshold, radius, scratch, out);
#endif
  featureRowBaseline(pm, p0, pp, width, threshold, radius, scratch, out);
}

void markMatches(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d0, int d1,
                 int grey_tolerance, std::uint8_t* marks) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return markAvx2(left, right, x0, x1, d0, d1, grey_tolerance, marks);
#endif
  markBaseline(left, right, x0, x1, d0, d1, grey_tolerance, marks);
}

void windowMatchRow(const std::uint8_t* left, const std::uint8_t* right, int width, int x0, int x1, int d0, int d1,
                    int grey_tolerance, int half, std::uint8_t* scratch, std::uint8_t* out) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return windowMatchAvx2(left, right, width, x0, x1, d0, d1, grey_tolerance, half, scratch, out);
#endif
  windowMatchBaseline(left, right, width, x0, x1, d0, d1, grey_tolerance, half, scratch, out);
}

void windowMatchRows(const std::uint8_t* left, std::size_t left_step, const std::uint8_t* right,
                     std::size_t right_step, int width, int rows, int x0, int x1, int d0, int d1, int grey_tolerance,
                     int half, std::uint8_t* scratch, std::uint8_t* out, std::size_t out_step) {
#ifdef SG_SIMD_X86
  if (useAvx2())
    return windowMatchRowsAvx2(left, left_step, right, right_step, width, rows, x0, x1, d0, d1, grey_tolerance, half,
                               scratch, out, out_step);
#endif
  windowMatchRowsBaseline(left, left_step, right, right_step, width, rows, x0, x1, d0, d1, grey_tolerance, half,
                          scratch, out, out_step);
}

void addBytes(const std::uint8_t* bytes, std::uint16_t* sums, int n) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return addBytesAvx2(bytes, sums, n);
#endif
  addBytesBaseline(bytes, sums, n);
}

void addBytesToBytes(const std::uint8_t* bytes, std::uint8_t* sums, int n) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return addBytesToBytesAvx2(bytes, sums, n);
#endif
  addBytesToBytesBaseline(bytes, sums, n);
}

void replaceRowExcess(const int* counts, int median, int min_excess, int row, const int* last_row, int n, int* excess,
                      int* sum) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return rowExcessAvx2(counts, median, min_excess, row, last_row, n, excess, sum);
#endif
  rowExcessBaseline(counts, median, min_excess, row, last_row, n, excess, sum);
}

bool kthSmallestFrom(const int* counts, int n, int k, int previous, int max_steps, int& value) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return kthSmallestAvx2(counts, n, k, previous, max_steps, value);
#endif
  return kthSmallestBaseline(counts, n, k, previous, max_steps, value);
}

ByteSpan nonZeroSpan(const std::uint8_t* p, int n) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return nonZeroSpanAvx2(p, n);
#endif
  return nonZeroSpanBaseline(p, n);
}

ByteSpan removedSpan(const std::uint8_t* after, const std::uint8_t* before, int n, bool& subset) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return removedSpanAvx2(after, before, n, subset);
#endif
  return removedSpanBaseline(after, before, n, subset);
}

int kthSmallest(const int* counts, int n, int k) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return kthSmallestBisectAvx2(counts, n, k);
#endif
  return kthSmallestBisectBaseline(counts, n, k);
}

void mirroredRowSums(const std::int32_t* w, const std::int32_t* m, const std::uint8_t* g, int axis, int n,
                     std::int32_t* sm, std::int32_t* sab) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return mirroredRowAvx2(w, m, g, axis, n, sm, sab);
#endif
  mirroredRowBaseline(w, m, g, axis, n, sm, sab);
}

float houghWindowSums(const float* lo, const float* mid, const float* hi, int n, float* out) {
#ifdef SG_SIMD_X86
  if (useAvx2()) return windowSumsAvx2(lo, mid, hi, n, out);
#endif
  return windowSumsBaseline(lo, mid, hi, n, out);
}

const char* kernelName() { return useAvx2() ? "avx2" : "baseline"; }

}  // namespace sg::simd
