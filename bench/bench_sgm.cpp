// dsmplan's Semi-Global Matching (dsmplan/stereo.hpp) against OpenCV's StereoSGBM on the
// Middlebury Aloe pair (data/middlebury-aloe: 1282 x 1110, disparities 0..223), issue 16 points
// 3(a) and 4: throughput in million pixel-disparities per second on 2 threads, and bad-pixel
// rates against the ground truth.
//
// Sources: H. Hirschmüller, "Stereo Processing by Semiglobal Matching and Mutual Information",
// IEEE PAMI 30(2), 2008; D. Scharstein and R. Szeliski, "A taxonomy and evaluation of dense
// two-frame stereo correspondence algorithms", IJCV 47, 2002 (bad-pixel rate: share of pixels
// with |d - d_true| > threshold); OpenCV 4.6 StereoSGBM (calib3d/src/stereosgbm.cpp), whose
// modes are MODE_HH (8 paths, full cost volume) and MODE_SGBM_3WAY (its fast multi-threaded
// mode); parameters as in OpenCV's samples/cpp/stereo_match.cpp: P1 = 8·cn·bs², P2 = 32·cn·bs²,
// uniquenessRatio 10, disp12MaxDiff 1, preFilterCap 63, speckleWindowSize 100, speckleRange 1 (px,
// as ours). Tuned per mode as dsmplan's P1/P2 were (on this pair): blockSize 3, 5, 7 with
// (P1, P2) = (4, 32), (8, 32), (8, 64), (16, 64) x cn·bs², each run once, and the setting with the
// fewest pixels off by more than 1 px among the matched ones is timed.
//
// Timing: every round runs dsmplan, HH and 3WAY once each, in turn (A B C A B C ...), so that all
// see the shared machine in the same state; the median over the rounds is printed with min-max
// and the 1-minute load before and after, and each comparison as the median (min-max) of the
// per-round ratios of the two matchers' seconds (never a best-of). Each matcher object is made once and reused
// (OpenCV's keeps its buffers between calls, so does dsmplan::SgmMatcher). argv[1] = rounds (default 5); argv[2] =
// "dsmplan": dsmplan alone (no OpenCV tuning), for alternating runs of two builds.
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#ifdef DSMPLAN_HAVE_OPENCV
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#endif

#include "aloe_pair.hpp"
#include "bench_kit.hpp"
#include "dsmplan/stereo.hpp"

namespace {

constexpr int threads = 2, num_disparities = 224;

struct Contender {
  std::string name, settings;
  std::function<std::vector<float>()> run;
  std::vector<double> seconds;
  aloe::Rates rates;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#ifdef DSMPLAN_HAVE_OPENCV
std::vector<float> opencv_disparity(cv::StereoSGBM& sgbm, const cv::Mat& left, const cv::Mat& right) {
  cv::Mat fixed;
  sgbm.compute(left, right, fixed);  // CV_16S, 16 x disparity, (minDisparity - 1) * 16 where invalid
  std::vector<float> out(static_cast<std::size_t>(fixed.rows) * fixed.cols);
  for (int y = 0; y < fixed.rows; ++y)
    for (int x = 0; x < fixed.cols; ++x) {
      const short v = fixed.at<short>(y, x);
      out[static_cast<std::size_t>(y) * fixed.cols + x] = v < 0 ? NAN : v / 16.0f;
    }
  return out;
}

struct SgbmSetting {
  int block_size, p1, p2;
};

cv::Ptr<cv::StereoSGBM> make_sgbm(int mode, const SgbmSetting& s) {
  return cv::StereoSGBM::create(0, num_disparities, s.block_size, s.p1, s.p2, 1, 63, 10, 100, 1, mode);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress shows when piped to a file
  const int rounds = argc > 1 ? std::max(5, std::atoi(argv[1])) : 7;
  const bool ours_alone = argc > 2 && std::string(argv[2]) == "dsmplan";
  const aloe::Pair pair = aloe::read_pair(DSMPLAN_DATA_DIR "/middlebury-aloe");
  const int width = pair.left.width, height = pair.left.height;
  const double work = double(width) * height * num_disparities;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  std::printf("SGM on Aloe %d x %d, %d disparities, %d threads, %s\n", width, height, num_disparities, threads,
              bench::cpu_model().c_str());

  std::vector<Contender> contenders;
  dsmplan::SgmOptions options;
  options.num_disparities = num_disparities, options.threads = threads;
  dsmplan::SgmMatcher ours(options);
  const dsmplan::ImageView left(pair.left.pixels.data(), width, height), right(pair.right.pixels.data(), width, height);
  contenders.push_back({"dsmplan SGM",
                        "census 9x7, 8 paths, P1 " + std::to_string(options.p1) + ", P2 " + std::to_string(options.p2) +
                            " adaptive, LR 1 px, speckle 100/1 px",
                        [&] { return ours.match(left, right).left; },
                        {},
                        {}});
#ifdef DSMPLAN_HAVE_OPENCV
  cv::setNumThreads(threads);
  const cv::Mat cv_left(height, width, CV_8UC1, const_cast<std::uint8_t*>(pair.left.pixels.data()));
  const cv::Mat cv_right(height, width, CV_8UC1, const_cast<std::uint8_t*>(pair.right.pixels.data()));
  std::vector<cv::Ptr<cv::StereoSGBM>> matchers;
  for (const auto& [mode, name] : {std::pair{int(cv::StereoSGBM::MODE_HH), "OpenCV MODE_HH"},
                                   std::pair{int(cv::StereoSGBM::MODE_SGBM_3WAY), "OpenCV MODE_SGBM_3WAY"}}) {
    if (ours_alone) break;
    SgbmSetting best{};
    double best_bad1 = 2;
    const int cn = 1;
    for (const int size : {3, 5, 7})
      for (const auto& [f1, f2] : {std::pair{4, 32}, std::pair{8, 32}, std::pair{8, 64}, std::pair{16, 64}}) {
        const SgbmSetting setting{size, f1 * cn * size * size, f2 * cn * size * size};
        const aloe::Rates r = aloe::rates(opencv_disparity(*make_sgbm(mode, setting), cv_left, cv_right), pair.truth);
        std::printf("  tuning %s blockSize %d P1 %d P2 %d: bad>1 %.2f %%, bad>2 %.2f %%, complete %.1f %%\n", name,
                    size, setting.p1, setting.p2, 100 * r.bad1, 100 * r.bad2, 100 * r.completeness);
        if (r.bad1 < best_bad1) best_bad1 = r.bad1, best = setting;
      }
    matchers.push_back(make_sgbm(mode, best));
    cv::StereoSGBM* sgbm = matchers.back().get();
    contenders.push_back({name,
                          "blockSize " + std::to_string(best.block_size) + ", P1 " + std::to_string(best.p1) + ", P2 " +
                              std::to_string(best.p2) + ", uniqueness 10, disp12MaxDiff 1, speckle 100/1 px",
                          [sgbm, &cv_left, &cv_right] { return opencv_disparity(*sgbm, cv_left, cv_right); },
                          {},
                          {}});
  }
#else
  (void)ours_alone;
  std::printf("OpenCV not found at configure time: dsmplan alone (apt-get install libopencv-dev)\n");
#endif

  for (Contender& c : contenders) c.rates = aloe::rates(c.run(), pair.truth);  // also warms up
  const std::string load_before = bench::load_average();
  for (int round = 0; round < rounds; ++round)
    for (Contender& c : contenders) {
      const auto start = std::chrono::steady_clock::now();
      c.run();
      c.seconds.push_back(bench::seconds_since(start));
    }
  const std::string load_after = bench::load_average();

  std::printf("\n%d interleaved rounds, load (1 min) %s before, %s after\n", rounds, load_before.c_str(),
              load_after.c_str());
  std::printf(
      "| matcher | Mpix·disp/s median (min–max) | s median | bad > 1 px | bad > 2 px | complete | "
      "unmatched or bad > 1 px |\n|---|---|---|---|---|---|---|\n");
  for (const Contender& c : contenders) {
    const double m = median(c.seconds);
    const auto [fastest, slowest] = std::minmax_element(c.seconds.begin(), c.seconds.end());
    std::printf("| %s | %.0f (%.0f–%.0f) | %.3f | %.2f %% | %.2f %% | %.1f %% | %.2f %% |\n", c.name.c_str(),
                work / m / 1e6, work / *slowest / 1e6, work / *fastest / 1e6, m, 100 * c.rates.bad1, 100 * c.rates.bad2,
                100 * c.rates.completeness, 100 * c.rates.unmatched_or_bad1);
  }
  if (contenders.size() > 1) {
    std::printf("\nper-round ratios (the other's seconds / dsmplan's in the same round), median (min-max):\n");
    bench::Samples ours_seconds;
    for (double s : contenders.front().seconds) ours_seconds.add(s);
    for (std::size_t k = 1; k < contenders.size(); ++k) {
      bench::Samples theirs;
      for (double s : contenders[k].seconds) theirs.add(s);
      std::printf("  dsmplan SGM vs %s: %sx\n", contenders[k].name.c_str(),
                  bench::ratios(theirs, ours_seconds).text("%.2f").c_str());
    }
  }
  std::printf("\nsettings:\n");
  for (const Contender& c : contenders) std::printf("  %s: %s\n", c.name.c_str(), c.settings.c_str());
  std::printf(
      "bad-pixel rates over the %zu pixels with ground truth that the matcher matched; 'complete' = "
      "matched / with ground truth\n",
      contenders.front().rates.truth_pixels);
  return 0;
}
