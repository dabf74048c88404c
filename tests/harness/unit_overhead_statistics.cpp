// The statistics of the scheduling-overhead micro-benchmark (harness/micro/overhead_statistics.hpp)
// on samples whose mean, standard deviation, median and outliers are known by hand.
#include "harness/micro/overhead_statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace {

using clothbench::micro::OverheadSummary;
using clothbench::micro::per_chunk_overhead;
using clothbench::micro::summarize_overheads;

TEST(OverheadStatistics, MeanSampleSigmaAndInterval) {
  // Mean 3; squared deviations 4 + 1 + 0 + 1 + 4 = 10 over n - 1 = 4: sigma = sqrt(2.5).
  const OverheadSummary s = summarize_overheads({5.0, 1.0, 4.0, 2.0, 3.0});
  EXPECT_EQ(s.samples, 5);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  EXPECT_DOUBLE_EQ(s.sigma, std::sqrt(2.5));
  // Near zero the interval's low end loses digits to cancellation, and Clang contracts
  // mean - 1.96 sigma into one fused multiply-add: compare to an absolute 1e-12.
  EXPECT_NEAR(s.low95, 3.0 - 1.96 * std::sqrt(2.5), 1e-12);
  EXPECT_NEAR(s.high95, 3.0 + 1.96 * std::sqrt(2.5), 1e-12);
  EXPECT_DOUBLE_EQ(s.minimum, 1.0);
  EXPECT_DOUBLE_EQ(s.maximum, 5.0);
  EXPECT_EQ(s.outliers, 0);
}

TEST(OverheadStatistics, MedianOfOddAndEvenCounts) {
  EXPECT_DOUBLE_EQ(summarize_overheads({9.0, 1.0, 2.0}).median, 2.0);
  EXPECT_DOUBLE_EQ(summarize_overheads({9.0, 1.0, 2.0, 4.0}).median, 3.0);  // (2 + 4) / 2
  EXPECT_DOUBLE_EQ(summarize_overheads({7.0}).median, 7.0);
}

TEST(OverheadStatistics, OneSampleHasZeroSigmaAndNoOutlier) {
  const OverheadSummary s = summarize_overheads({7.0});
  EXPECT_DOUBLE_EQ(s.sigma, 0.0);
  EXPECT_DOUBLE_EQ(s.low95, 7.0);
  EXPECT_DOUBLE_EQ(s.high95, 7.0);
  EXPECT_EQ(s.outliers, 0);
}

TEST(OverheadStatistics, CountsSamplesBeyondThreeSigmaAsOutliers) {
  // 19 zeros and one 1: mean 0.05; sigma^2 = (19 x 0.0025 + 0.9025) / 19 = 0.05, sigma =
  // 0.2236, 3 sigma = 0.671. The 1 lies 0.95 from the mean (an outlier), the zeros 0.05.
  std::vector<double> samples(19, 0.0);
  samples.push_back(1.0);
  const OverheadSummary s = summarize_overheads(samples);
  EXPECT_DOUBLE_EQ(s.mean, 0.05);
  EXPECT_NEAR(s.sigma, std::sqrt(0.05), 1e-15);
  EXPECT_EQ(s.outliers, 1);
  EXPECT_DOUBLE_EQ(s.median, 0.0);
  // Ten samples of 0 and ten of 1: sigma = sqrt(5 / 19) = 0.513, every
  // sample lies 0.97 sigma from the mean, none is out.
  std::vector<double> halves(10, 0.0);
  halves.insert(halves.end(), 10, 1.0);
  EXPECT_EQ(summarize_overheads(halves).outliers, 0);
}

TEST(OverheadStatistics, RefusesNoSamples) {
  EXPECT_THROW(summarize_overheads({}), std::invalid_argument);
}

TEST(OverheadStatistics, PerChunkIsPerLoopOverOneThreadsChunks) {
  // 2048 chunks shared by 2 threads: 1024 dispatches on each thread's path.
  EXPECT_DOUBLE_EQ(per_chunk_overhead(8.0, 2048, 2), 8.0 / 1024.0);
  EXPECT_DOUBLE_EQ(per_chunk_overhead(8.0, 1024, 1), 8.0 / 1024.0);
  // static without a chunk: one chunk per thread, so one dispatch per loop.
  EXPECT_DOUBLE_EQ(per_chunk_overhead(5.0, 2, 2), 5.0);
  // Fewer chunks than threads still cost each chunk-holding thread one dispatch.
  EXPECT_DOUBLE_EQ(per_chunk_overhead(5.0, 1, 4), 5.0);
  EXPECT_THROW(per_chunk_overhead(5.0, 0, 2), std::invalid_argument);
  EXPECT_THROW(per_chunk_overhead(5.0, 2, 0), std::invalid_argument);
}

}  // namespace
