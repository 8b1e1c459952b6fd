// numpy's PCG64 and pairwise sum, bit for bit.
#include "tpuaf_core/numpy_random.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

// ------------------------------------------------------------------------------ NumpyPcg64

NumpyPcg64::NumpyPcg64(std::uint64_t state_hi, std::uint64_t state_lo, std::uint64_t inc_hi,
                       std::uint64_t inc_lo, bool has_uint32, std::uint32_t uinteger)
    : state_((static_cast<unsigned __int128>(state_hi) << 64) | state_lo),
      inc_((static_cast<unsigned __int128>(inc_hi) << 64) | inc_lo),
      has_uint32_(has_uint32),
      uinteger_(uinteger) {}

std::uint64_t NumpyPcg64::next_uint64() {
  // PCG XSL-RR 128/64 (numpy's PCG64): advance the LCG, then output from the new state.
  const unsigned __int128 mult =
      (static_cast<unsigned __int128>(0x2360ED051FC65DA4ULL) << 64) | 0x4385DF649FCCF645ULL;
  state_ = state_ * mult + inc_;
  const std::uint64_t hi = static_cast<std::uint64_t>(state_ >> 64);
  const std::uint64_t lo = static_cast<std::uint64_t>(state_);
  const std::uint64_t x = hi ^ lo;
  const unsigned rot = static_cast<unsigned>(hi >> 58);
  return (x >> rot) | (x << ((64u - rot) & 63u));
}

std::uint32_t NumpyPcg64::next_uint32() {
  if (has_uint32_) {
    has_uint32_ = false;
    return uinteger_;
  }
  const std::uint64_t next = next_uint64();
  has_uint32_ = true;
  uinteger_ = static_cast<std::uint32_t>(next >> 32);
  return static_cast<std::uint32_t>(next & 0xffffffffULL);
}

double NumpyPcg64::random() {
  return static_cast<double>(next_uint64() >> 11) * (1.0 / 9007199254740992.0);
}

std::int64_t NumpyPcg64::integers(std::int64_t n) {
  if (n < 1 || n > (std::int64_t{1} << 32)) {
    throw std::invalid_argument("integers(0, n) needs 1 <= n <= 2^32, got " + std::to_string(n));
  }
  const std::uint64_t rng = static_cast<std::uint64_t>(n - 1);
  if (rng == 0) return 0;
  if (rng == 0xffffffffULL) return next_uint32();
  // numpy's buffered_bounded_lemire_uint32
  const std::uint32_t rng_excl = static_cast<std::uint32_t>(rng) + 1u;
  std::uint64_t m = static_cast<std::uint64_t>(next_uint32()) * rng_excl;
  std::uint32_t leftover = static_cast<std::uint32_t>(m & 0xffffffffULL);
  if (leftover < rng_excl) {
    const std::uint32_t threshold =
        (std::numeric_limits<std::uint32_t>::max() - static_cast<std::uint32_t>(rng)) % rng_excl;
    while (leftover < threshold) {
      m = static_cast<std::uint64_t>(next_uint32()) * rng_excl;
      leftover = static_cast<std::uint32_t>(m & 0xffffffffULL);
    }
  }
  return static_cast<std::int64_t>(m >> 32);
}

void NumpyPcg64::get_state(std::uint64_t& state_hi, std::uint64_t& state_lo, std::uint64_t& inc_hi,
                           std::uint64_t& inc_lo, bool& has_uint32, std::uint32_t& uinteger) const {
  state_hi = static_cast<std::uint64_t>(state_ >> 64);
  state_lo = static_cast<std::uint64_t>(state_);
  inc_hi = static_cast<std::uint64_t>(inc_ >> 64);
  inc_lo = static_cast<std::uint64_t>(inc_);
  has_uint32 = has_uint32_;
  uinteger = uinteger_;
}

double numpy_pairwise_sum(const double* a, std::size_t n) {
  // numpy's DOUBLE_pairwise_sum: 8 accumulators up to 128 elements, halves above.
  if (n < 8) {
    double res = 0.;
    for (std::size_t i = 0; i < n; ++i) res += a[i];
    return res;
  }
  if (n <= 128) {
    double r[8];
    for (int j = 0; j < 8; ++j) r[j] = a[j];
    std::size_t i = 8;
    for (; i < n - (n % 8); i += 8) {
      for (int j = 0; j < 8; ++j) r[j] += a[i + j];
    }
    double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; ++i) res += a[i];
    return res;
  }
  std::size_t n2 = n / 2;
  n2 -= n2 % 8;
  return numpy_pairwise_sum(a, n2) + numpy_pairwise_sum(a + n2, n - n2);
}

double numpy_sum(const double* a, std::size_t n) {
  constexpr std::size_t kBuffer = 8192;  // numpy's default ufunc buffer size
  double res = 0.0;
  for (std::size_t i = 0; i < n; i += kBuffer)
    res += numpy_pairwise_sum(a + i, std::min(kBuffer, n - i));
  return res;
}

}  // namespace tpuaf
