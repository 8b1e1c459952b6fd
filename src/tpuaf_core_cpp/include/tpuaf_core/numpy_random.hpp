// numpy's random streams and sums, reproduced bit for bit so that the C++ runs draw and add
// as numpy does (the seeds come from numpy Generators).
#pragma once

#include <cstddef>
#include <cstdint>

namespace tpuaf {

// numpy's PCG64 bit generator (XSL-RR 128/64) and the Generator methods the runtimes use.
// Seeded from a numpy Generator's bit_generator.state, so both draw the same stream.
class NumpyPcg64 {
 public:
  NumpyPcg64(std::uint64_t state_hi, std::uint64_t state_lo, std::uint64_t inc_hi,
             std::uint64_t inc_lo, bool has_uint32 = false, std::uint32_t uinteger = 0);
  std::uint64_t next_uint64();
  std::uint32_t next_uint32();  // numpy's buffered half of a 64-bit draw
  double random();              // Generator.random(): [0, 1), 53 bits
  // Generator.integers(0, n) for 1 <= n <= 2^32 (Lemire's method on 32-bit draws, as numpy).
  std::int64_t integers(std::int64_t n);
  // (state_hi, state_lo, inc_hi, inc_lo, has_uint32, uinteger), to hand back to numpy.
  void get_state(std::uint64_t& state_hi, std::uint64_t& state_lo, std::uint64_t& inc_hi,
                 std::uint64_t& inc_lo, bool& has_uint32, std::uint32_t& uinteger) const;

 private:
  unsigned __int128 state_, inc_;
  bool has_uint32_;
  std::uint32_t uinteger_;
};

// np.sum of a contiguous double array bit for bit: pairwise summation over chunks of numpy's
// 8192-element buffer, added in order.
double numpy_pairwise_sum(const double* a, std::size_t n);
double numpy_sum(const double* a, std::size_t n);
inline double numpy_mean(const double* a, std::size_t n) {
  return numpy_sum(a, n) / static_cast<double>(n);
}

}  // namespace tpuaf
