// The registration library (src/cdff/registration/) below the DFIs: the process-wide sharing of a
// model's search structures, and the multi-scan hypothesis confirmation's decision rule through
// its interface alone (a scan is only a misfit of each pose and a short run from a start), and
// where the multi-start search starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <thread>
#include <vector>

#include "cdff/registration/hypothesis_confirmation.hpp"
#include "cdff/registration/multi_start.hpp"
#include "cdff/registration/shared_model_cache.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"

namespace cdff::registration {
namespace {

PointCloud model(std::uint64_t seed) {
  Result<PointCloud> cloud = sampleSurface(testing::satelliteMesh(), 20'000, seed);
  EXPECT_TRUE(cloud.isOk()) << cloud.status().toString();
  return std::move(cloud).value();
}

TEST(RegistrationLibrary, SharedModelCacheSharesTheIndexAndGridOfOneModelBuffer) {
  const PointCloud a = model(3);
  const PointCloud b = model(4);
  // Two registrations of two threads see the same buffer at once: one index between them.
  std::shared_ptr<const ModelIndex> first, second;
  std::thread t1([&] { first = SharedModelCache::index(a, nullptr).value(); });
  std::thread t2([&] { second = SharedModelCache::index(a, nullptr).value(); });
  t1.join();
  t2.join();
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first, second);
  EXPECT_TRUE(first->holds(a));
  // A registration's own index is returned as it is; another buffer gets its own.
  EXPECT_EQ(SharedModelCache::index(a, first).value(), first);
  const std::shared_ptr<const ModelIndex> other = SharedModelCache::index(b, first).value();
  EXPECT_NE(other, first);
  EXPECT_NE(other->builds, first->builds);

  // The grid is shared for equal options only, and off with a cell of 0.
  const NearestGridOptions options{0.05, 0.2};
  const std::shared_ptr<NearestGrid> grid = SharedModelCache::grid(*first, options);
  ASSERT_TRUE(grid);
  EXPECT_EQ(SharedModelCache::grid(*first, options), grid);
  EXPECT_NE(SharedModelCache::grid(*first, {0.1, 0.2}), grid);
  EXPECT_NE(SharedModelCache::grid(*other, options), grid);
  EXPECT_EQ(SharedModelCache::grid(*first, {0.0, 0.2}), nullptr);

  // An invalid model is an error, not a cached index.
  PointCloud no_normals = a;
  no_normals.normals = {};
  EXPECT_FALSE(SharedModelCache::index(no_normals, nullptr).isOk());
}

// Poses along x: the scan's misfit has a minimum of 0 at x = 0 (the truth) and one of 9 at x = 1
// (another pose that explains the scan almost as well), so a hypothesis in the second scores 9
// more per scan. Runs keep their start.
ScanEvidence scanAt(Timestamp stamp) {
  ScanEvidence scan;
  scan.stamp = stamp;
  scan.returns = 50;
  scan.misfit = [](const Eigen::Isometry3d& pose) {
    const double x = pose.translation().x();
    return std::min(100.0 * x * x, 100.0 * (x - 1.0) * (x - 1.0) + 9.0);
  };
  scan.run = [](const IcpRun& start) { return Result<IcpRun>(start); };
  return scan;
}

Start startAt(double x) {
  Start start;
  start.run.pose.translation().x() = x;
  start.quality.fitness = 1.0;
  return start;
}

ConfirmationOptions confirmationOptions() {
  ConfirmationOptions options;
  options.scans = 3;
  options.margin = 20;
  options.follow_shift_sigma = 10.0;  // a prior too wide to matter here
  options.follow_turn_sigma = 10.0;
  options.max_correspondence_distance = 3.0;
  return options;
}

TEST(RegistrationLibrary, ConfirmationDecidesOnTheSummedMisfitAfterEnoughScans) {
  HypothesisConfirmation confirmation;
  confirmation.configure(confirmationOptions());
  const Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();
  const std::vector<Start> starts = {startAt(0.0), startAt(1.0), startAt(1.01)};
  EXPECT_FALSE(confirmation.following(0));

  // Scan 1: a new set; the two starts 1 cm apart are one hypothesis, two are kept.
  Result<ConfirmationResult> r = confirmation.update(scanAt(0), guess, starts);
  ASSERT_OK(r.status());
  EXPECT_TRUE(r->ambiguous);
  ASSERT_TRUE(r->best);
  EXPECT_EQ(confirmation.hypotheses().size(), 2u);
  // Scans 2 and 3 follow the set (no new starts needed); the best leads by 9 per scan...
  for (int scan = 1; scan <= 2; ++scan) {
    const Timestamp stamp = scan * 100'000;
    ASSERT_TRUE(confirmation.following(stamp));
    r = confirmation.update(scanAt(stamp), guess, {});
    ASSERT_OK(r.status());
    ASSERT_TRUE(r->best);
    EXPECT_NEAR(r->best->pose.translation().x(), 0.0, 1e-9);
    // ... which is above the margin only after three scans (3 x 9 > 20), and three are needed.
    EXPECT_EQ(r->ambiguous, scan < 2) << "scan " << scan;
  }
  // Decided: the set is dropped, the next scan starts anew.
  EXPECT_TRUE(confirmation.hypotheses().empty());
  EXPECT_FALSE(confirmation.following(300'000));
}

TEST(RegistrationLibrary, ConfirmationDecidesALoneHypothesisAtOnceAndDropsAStaleSet) {
  HypothesisConfirmation confirmation;
  confirmation.configure(confirmationOptions());
  const Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();
  // Every start ended in one minimum: nothing for more scans to rule out.
  Result<ConfirmationResult> r =
      confirmation.update(scanAt(0), guess, std::vector<Start>{startAt(0.1), startAt(0.11)});
  ASSERT_OK(r.status());
  EXPECT_FALSE(r->ambiguous);
  ASSERT_TRUE(r->best);

  // An ambiguous set not followed within the timeout is stale.
  ASSERT_OK(confirmation.update(scanAt(0), guess, std::vector<Start>{startAt(0.0), startAt(1.0)})
                .status());
  EXPECT_TRUE(confirmation.following(500'000));
  EXPECT_FALSE(confirmation.following(1'500'000));
  // No start at all: ambiguous, no pose.
  r = confirmation.update(scanAt(1'500'000), guess, {});
  ASSERT_OK(r.status());
  EXPECT_TRUE(r->ambiguous);
  EXPECT_FALSE(r->best);
}

TEST(RegistrationLibrary, ConfirmationDecidesNoHypothesisThatLeavesTheScansUnexplained) {
  ConfirmationOptions options = confirmationOptions();
  options.max_unexplained = 0.25;  // at most 9 x 0.25 = 2.25 per return
  HypothesisConfirmation confirmation;
  confirmation.configure(options);
  const Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();
  // Every pose leaves 4 per return of the 50 returns unexplained: the starts missed the pose
  // that explains the scan. Even a lone hypothesis is not decided.
  const auto unexplained = [](Timestamp stamp) {
    ScanEvidence scan = scanAt(stamp);
    scan.misfit = [](const Eigen::Isometry3d& pose) {
      const double x = pose.translation().x();
      return 200.0 + 100.0 * x * x;
    };
    return scan;
  };
  Result<ConfirmationResult> r =
      confirmation.update(unexplained(0), guess, std::vector<Start>{startAt(0.0)});
  ASSERT_OK(r.status());
  EXPECT_TRUE(r->ambiguous);
  EXPECT_NEAR(r->misfit_per_return, 4.0, 1e-6);
  // Followed for `scans` scans, then dropped: the next scan searches anew.
  for (int scan = 1; scan <= 2; ++scan) {
    const Timestamp stamp = scan * 100'000;
    ASSERT_TRUE(confirmation.following(stamp)) << "scan " << scan;
    r = confirmation.update(unexplained(stamp), guess, {});
    ASSERT_OK(r.status());
    EXPECT_TRUE(r->ambiguous) << "scan " << scan;
  }
  EXPECT_FALSE(confirmation.following(300'000));

  // The same rule passes the right pose of scanAt(), which leaves nothing unexplained.
  r = confirmation.update(scanAt(300'000), guess, std::vector<Start>{startAt(0.0)});
  ASSERT_OK(r.status());
  EXPECT_FALSE(r->ambiguous);
  EXPECT_LT(r->misfit_per_return, 0.01);
}

TEST(RegistrationLibrary, DepthStartsSpanTheGuesssDepthUncertaintyAlongTheLineOfSight) {
  const Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();
  const Eigen::Vector3d position(0.0, 0.0, 15.0);
  // Depth sigma 0.8 m (along z, the line of sight), 0.1 m across it.
  const Eigen::Matrix3d covariance = Eigen::Vector3d(0.01, 0.01, 0.64).asDiagonal();
  const std::vector<Eigen::Vector3d> starts = depthStarts(position, covariance, viewpoint, 0.1);
  ASSERT_EQ(starts.size(), 5u);
  EXPECT_TRUE(starts.front().isApprox(position));
  std::vector<double> depths;
  for (const Eigen::Vector3d& p : starts) {
    EXPECT_NEAR(p.x(), 0.0, 1e-12);
    EXPECT_NEAR(p.y(), 0.0, 1e-12);
    depths.push_back(p.z());
  }
  std::sort(depths.begin(), depths.end());
  const std::vector<double> expected = {13.4, 14.2, 15.0, 15.8, 16.6};
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(depths[i], expected[i], 1e-9);
  // A depth known to within the starts' resolution needs no other start.
  EXPECT_EQ(depthStarts(position, Eigen::Matrix3d::Identity() * 0.0025, viewpoint, 0.1).size(), 1u);
}

}  // namespace
}  // namespace cdff::registration
