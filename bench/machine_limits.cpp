// What this machine allows (issue 37, point 3): the ceilings bench/README.md sets each headline
// figure against. Two simple loops, as STREAM (McCalpin, "Memory Bandwidth and Machine Balance in
// Current High Performance Computers", IEEE TCCA Newsletter 1995) and a peak-FLOP kernel measure
// them:
//   - memory bandwidth: read (a sum), write (a fill), copy and triad (a = b + s c) over arrays of
//     256 MiB each, far beyond the caches, on 1 and on every core; bytes counted as STREAM counts
//     them (read + written, no write-allocate);
//   - compute: independent chains of fused multiply-adds on 8-float AVX2 vectors (the widest both
//     dsmplan's SGM kernels and Debian's -O2 code reach), and of saturating 16-bit adds and minima
//     (SGM's inner operations), on 1 and on every core.
// Each figure is the median of 5 runs (min-max), with the 1-minute load before them.
//   bench_machine_limits
#include <immintrin.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_kit.hpp"

namespace {

constexpr size_t kArrayBytes = size_t(256) << 20;
constexpr size_t kCount = kArrayBytes / sizeof(double);

// fn(begin, end) over [0, kCount) split into `threads` equal parts, one thread each.
template <class F>
void split(int threads, F&& fn) {
  tbb::parallel_for(0, threads, [&](int t) { fn(kCount * t / threads, kCount * (t + 1) / threads); });
}

struct Stream {
  std::vector<double> a, b, c;
  Stream() : a(kCount, 1.0), b(kCount, 2.0), c(kCount, 0.5) {}
  // GB/s of one kernel over `threads` threads; `bytes_per_element` as STREAM counts them.
  template <class Kernel>
  bench::Samples rate(int threads, double bytes_per_element, Kernel&& kernel) {
    bench::Samples rates;
    for (int run = 0; run < 5; ++run) {
      const double s = bench::timed([&] { split(threads, kernel); });
      rates.add(bytes_per_element * double(kCount) / s / 1e9);
    }
    return rates;
  }
};

volatile double sink = 0;  // keeps the sums alive

// The sum of [b, e) of `a` in four independent vector chains: bound by memory, not by the
// latency of one chain of additions (a plain loop read at 9.4 GB/s here, one add per 3 cycles).
__attribute__((target("avx2"))) double vector_sum(const double* a, size_t b, size_t e) {
  __m256d s[4] = {_mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd()};
  size_t i = b;
  for (; i + 16 <= e; i += 16)
    for (int k = 0; k < 4; ++k) s[k] = _mm256_add_pd(s[k], _mm256_loadu_pd(a + i + 4 * k));
  double out[4];
  _mm256_storeu_pd(out, _mm256_add_pd(_mm256_add_pd(s[0], s[1]), _mm256_add_pd(s[2], s[3])));
  double total = out[0] + out[1] + out[2] + out[3];
  for (; i < e; ++i) total += a[i];
  return total;
}

__attribute__((target("avx2,fma"))) double fma_chains(size_t iterations) {
  // 12 independent chains: enough to cover the FMA latency (4 cycles) on two FMA ports.
  __m256 acc[12];
  for (int k = 0; k < 12; ++k) acc[k] = _mm256_set1_ps(float(k));
  const __m256 m = _mm256_set1_ps(0.999999f), add = _mm256_set1_ps(1e-7f);
  for (size_t i = 0; i < iterations; ++i)
    for (int k = 0; k < 12; ++k) acc[k] = _mm256_fmadd_ps(acc[k], m, add);
  __m256 total = acc[0];
  for (int k = 1; k < 12; ++k) total = _mm256_add_ps(total, acc[k]);
  float out[8];
  _mm256_storeu_ps(out, total);
  return out[0];
}

__attribute__((target("avx2"))) double saturating_chains(size_t iterations) {
  // SGM's step: a saturating add of 16 uint16 lanes, then a minimum; 8 independent chains.
  __m256i acc[8];
  for (int k = 0; k < 8; ++k) acc[k] = _mm256_set1_epi16(short(k));
  const __m256i cost = _mm256_set1_epi16(3), cap = _mm256_set1_epi16(30000);
  for (size_t i = 0; i < iterations; ++i)
    for (int k = 0; k < 8; ++k) acc[k] = _mm256_min_epu16(_mm256_adds_epu16(acc[k], cost), cap);
  __m256i total = acc[0];
  for (int k = 1; k < 8; ++k) total = _mm256_max_epu16(total, acc[k]);
  return double(_mm256_extract_epi16(total, 0));
}

template <class Chains>
bench::Samples ops_rate(int threads, double ops_per_iteration, Chains&& chains) {
  constexpr size_t kIterations = 200'000'000;
  bench::Samples rates;
  for (int run = 0; run < 5; ++run) {
    const double s =
        bench::timed([&] { tbb::parallel_for(0, threads, [&](int) { sink = sink + chains(kIterations); }); });
    rates.add(ops_per_iteration * double(kIterations) * threads / s / 1e9);
  }
  return rates;
}

void line(const char* what, int threads, const bench::Samples& s, const char* unit) {
  std::printf("%-34s %d core%s  %8.1f (%.1f-%.1f) %s\n", what, threads, threads > 1 ? "s" : " ", s.median(), s.min(),
              s.max(), unit);
}

}  // namespace

int main() {
  const int cores = int(std::thread::hardware_concurrency());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, cores);
  std::printf("machine: %s, %d cores; 1-minute load before: %s\n", bench::cpu_model().c_str(), cores,
              bench::load_average().c_str());
  Stream m;
  for (const int threads : {1, cores}) {
    line("memory read (sum)", threads,
         m.rate(threads, 8, [&](size_t b, size_t e) { sink = sink + vector_sum(m.a.data(), b, e); }), "GB/s");
    line("memory write (fill)", threads,
         m.rate(threads, 8,
                [&](size_t b, size_t e) { std::memset(static_cast<void*>(&m.c[b]), 0, (e - b) * sizeof(double)); }),
         "GB/s");
    line("memory copy (a = b)", threads,
         m.rate(threads, 16, [&](size_t b, size_t e) { std::memcpy(&m.a[b], &m.b[b], (e - b) * sizeof(double)); }),
         "GB/s");
    line("memory triad (a = b + s c)", threads,
         m.rate(threads, 24,
                [&](size_t b, size_t e) {
                  for (size_t i = b; i < e; ++i) m.a[i] = m.b[i] + 0.5 * m.c[i];
                }),
         "GB/s");
  }
  for (const int threads : {1, cores}) {
    line("fp32 FMA, AVX2 (2 flops a lane)", threads, ops_rate(threads, 12 * 8 * 2, fma_chains), "GFLOP/s");
    line("uint16 add+min, AVX2 (2 ops a lane)", threads, ops_rate(threads, 8 * 16 * 2, saturating_chains), "Gop/s");
  }
  return 0;
}
