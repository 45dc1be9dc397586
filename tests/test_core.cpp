#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "detail/radix_sort.hpp"
#include "detail/sort_distinct.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/io/file.hpp"
#include "test_util.hpp"

#include <unistd.h>

using namespace rangeseg;

TEST(Plane, StrideIsPaddedAndRowsAreIndependent) {
  FloatPlane p(17, 3, 1.0f);
  EXPECT_EQ(p.stride(), 32);
  p(16, 1) = 5.0f;
  EXPECT_EQ(p.row(1)[16], 5.0f);
  EXPECT_EQ(p(0, 2), 1.0f);
  EXPECT_THROW(p.resize(-1, 2), std::invalid_argument);
}

namespace {
/// Resident pages of this process (Linux), or -1.
long resident_pages() {
  std::ifstream statm("/proc/self/statm");
  long size = 0, resident = -1;
  statm >> size >> resident;
  return statm ? resident : -1;
}
}  // namespace

// A large plane's pages are mapped when it is allocated, not page by page at first touch; small
// blocks are left alone.
TEST(Plane, LargeAllocationsAreMappedAtOnce) {
  constexpr std::size_t kBytes = std::size_t{8} << 20;
  const long page = sysconf(_SC_PAGESIZE);
  std::unique_ptr<std::uint8_t[]> block(new std::uint8_t[kBytes + 2 * page]);
  const long before = resident_pages();
  if (before < 0 || !detail::populate_pages(block.get(), kBytes)) {
    GTEST_SKIP() << "no /proc/self/statm or no MADV_POPULATE_WRITE (Linux < 5.14)";
  }
  EXPECT_GE(resident_pages() - before, static_cast<long>(kBytes / page) * 9 / 10);
  EXPECT_FALSE(detail::populate_pages(block.get(), 4096));
  FloatPlane plane(640, 480, 1.0f);  // allocated through it
  EXPECT_EQ(plane(639, 479), 1.0f);
}

TEST(Camera, DepthToCloudAndBackIsExact) {
  DepthImage depth(8, 6, 0);
  for (int v = 0; v < 6; ++v) {
    for (int u = 0; u < 8; ++u) {
      depth(u, v) = static_cast<std::uint16_t>((u + v) % 4 == 0 ? 0 : 500 + 37 * u + v);
    }
  }
  const CameraIntrinsics cam{.fx = 10, .fy = 12, .cx = 3.5, .cy = 2.5};
  const OrganizedCloud cloud = depth_to_cloud(depth.view(), cam, 0.001);
  ASSERT_EQ(cloud.width(), 8);
  ASSERT_EQ(cloud.height(), 6);
  for (int v = 0; v < 6; ++v) {
    for (int u = 0; u < 8; ++u) {
      if (depth(u, v) == 0) {
        EXPECT_FALSE(cloud.valid(u, v));
        continue;
      }
      const double z = depth(u, v) * 0.001;
      EXPECT_NEAR(cloud.z(u, v), z, 1e-6);
      EXPECT_NEAR(cloud.x(u, v), (u - 3.5) * z / 10, 1e-6);
      EXPECT_NEAR(cloud.y(u, v), (v - 2.5) * z / 12, 1e-6);
    }
  }
  const DepthImage back = cloud_to_depth(cloud, 0.001);
  for (int v = 0; v < 6; ++v) {
    for (int u = 0; u < 8; ++u) EXPECT_EQ(back(u, v), depth(u, v));
  }
  EXPECT_THROW(depth_to_cloud(depth.view(), CameraIntrinsics{.fx = 0}, 0.001),
               std::invalid_argument);
  EXPECT_THROW(depth_to_cloud(depth.view(), cam, -1.0), std::invalid_argument);
  try {  // a tiny wrong value keeps its digits ("%f" printed -0.000000)
    depth_to_cloud(depth.view(), cam, -1e-9);
    ADD_FAILURE() << "depth_scale -1e-9 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("got -1e-09"), std::string::npos) << e.what();
  }
  // The message says what is wrong, with every value.
  try {
    validate(CameraIntrinsics{.width = -1});
    ADD_FAILURE() << "width -1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("width and height must be >= 0"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("width -1"), std::string::npos) << e.what();
  }
  try {
    depth_to_cloud(depth.view(), CameraIntrinsics{.width = 320}, 0.001);
    ADD_FAILURE() << "a camera of another size accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("for a 320 x any image, the depth image is 8 x 6"),
              std::string::npos)
        << e.what();
  }
}

// The intrinsics of a cloud made from a depth image are found again; a cloud whose points are
// not on a pinhole camera's pixels, or with too few columns, has none.
TEST(Camera, FitIntrinsicsRecoversTheCameraOfADepthImage) {
  DepthImage depth(40, 30, 0);
  for (int v = 0; v < 30; ++v) {
    for (int u = 0; u < 40; ++u) {
      depth(u, v) = static_cast<std::uint16_t>((u * 7 + v * 3) % 11 == 0 ? 0 : 800 + 13 * u + v);
    }
  }
  const CameraIntrinsics truth{.fx = 57.5, .fy = 61.25, .cx = 18.3, .cy = 16.7};
  OrganizedCloud cloud = depth_to_cloud(depth.view(), truth, 0.001);
  CameraIntrinsics fitted;
  double off = -1;
  ASSERT_TRUE(fit_intrinsics(cloud, fitted, 0.05, &off));
  EXPECT_NEAR(fitted.fx, truth.fx, 1e-3);
  EXPECT_NEAR(fitted.fy, truth.fy, 1e-3);
  EXPECT_NEAR(fitted.cx, truth.cx, 1e-4);
  EXPECT_NEAR(fitted.cy, truth.cy, 1e-4);
  EXPECT_EQ(fitted.width, 40);
  EXPECT_EQ(fitted.height, 30);
  EXPECT_LT(off, 1e-3);

  // One point moved sideways by 0.2 px of its depth: off the camera's pixels.
  OrganizedCloud moved = cloud;
  moved.x(5, 5) += static_cast<float>(0.2 * moved.z(5, 5) / truth.fx);
  CameraIntrinsics untouched{.fx = 1};
  EXPECT_FALSE(fit_intrinsics(moved, untouched, 0.05, &off));
  EXPECT_GT(off, 0.15);
  EXPECT_EQ(untouched.fx, 1);
  EXPECT_TRUE(fit_intrinsics(moved, untouched, 0.5));

  // A scanner's grid, x / z falling along a row: no pinhole camera.
  OrganizedCloud mirrored = cloud;
  for (int v = 0; v < 30; ++v) {
    for (int u = 0; u < 40; ++u) mirrored.x(u, v) = -cloud.x(u, v);
  }
  EXPECT_FALSE(fit_intrinsics(mirrored, fitted, 0.05, &off));
  EXPECT_TRUE(std::isinf(off));

  // One column of points: its focal length along x is undetermined.
  OrganizedCloud column(1, 30);
  for (int v = 0; v < 30; ++v) {
    column.x(0, v) = 0.1f;
    column.y(0, v) = 0.01f * static_cast<float>(v);
    column.z(0, v) = 1.0f;
  }
  EXPECT_FALSE(fit_intrinsics(column, fitted));
}

TEST(Cloud, StatsCountOnlyFinitePoints) {
  OrganizedCloud c(3, 2);
  EXPECT_EQ(c.count_valid(), 0u);
  c.x(0, 0) = 0;
  c.y(0, 0) = 0;
  c.z(0, 0) = 2;
  c.x(1, 1) = 0;
  c.y(1, 1) = 0;
  c.z(1, 1) = 1;
  c.x(2, 1) = INFINITY;
  c.y(2, 1) = 0;
  c.z(2, 1) = 7;
  const CloudStats s = cloud_stats(c);
  EXPECT_EQ(s.valid, 2u);
  EXPECT_FLOAT_EQ(s.min_z, 1);
  EXPECT_FLOAT_EQ(s.max_z, 2);
  EXPECT_FLOAT_EQ(s.min_range, 1);
  EXPECT_FLOAT_EQ(s.max_range, 2);
  c.x(0, 1) = 3;  // beside and behind the sensor: a range of 5 at z = -4
  c.y(0, 1) = 0;
  c.z(0, 1) = -4;
  const CloudStats round = cloud_stats(c);
  EXPECT_FLOAT_EQ(round.min_z, -4);
  EXPECT_FLOAT_EQ(round.max_range, 5);
  EXPECT_THROW(require_organized(OrganizedCloud(5, 1), "test"), std::invalid_argument);
}

/// Points at the given azimuths [deg] round the z axis (a ring in the x-y plane, 5 m away), as
/// a row (unorganized) or two rows.
OrganizedCloud ring_of_points(double from_deg, double to_deg, int n, int rows = 1) {
  OrganizedCloud c(n / rows, rows);
  for (int i = 0; i < n; ++i) {
    const double a = (from_deg + (to_deg - from_deg) * i / n) * std::numbers::pi / 180;
    const int u = i % c.width(), v = i / c.width();
    c.x(u, v) = static_cast<float>(5 * std::cos(a));
    c.y(u, v) = static_cast<float>(5 * std::sin(a));
    c.z(u, v) = 0.3f;
  }
  return c;
}

TEST(Cloud, ScansRoundTheSensorAreToldFromACamerasCone) {
  EXPECT_TRUE(surrounds_its_sensor(ring_of_points(0, 360, 400)));     // mean unit vector ~0
  EXPECT_TRUE(surrounds_its_sensor(ring_of_points(0, 360, 400, 2)));  // every row counts
  EXPECT_TRUE(surrounds_its_sensor(ring_of_points(0, 240, 400)));     // 0.41 long
  EXPECT_FALSE(surrounds_its_sensor(ring_of_points(0, 200, 400)));    // 0.62
  EXPECT_FALSE(surrounds_its_sensor(ring_of_points(-30, 30, 400)));   // a camera's cone
  EXPECT_FALSE(surrounds_its_sensor(ring_of_points(0, 360, 99)));     // too few to tell
  // Points that are none (NaN, infinite, the origin) are skipped, not summed: a quarter of the
  // ring.
  OrganizedCloud holes = ring_of_points(0, 360, 400);
  for (int u = 0; u < 400; u += 4) {
    const int kind = u / 4 % 3;
    holes.x(u, 0) = kind == 0 ? NAN : kind == 1 ? INFINITY : 0.0f;
    if (kind == 2) holes.y(u, 0) = holes.z(u, 0) = 0;
  }
  EXPECT_TRUE(surrounds_its_sensor(holes));
  EXPECT_FALSE(surrounds_its_sensor(OrganizedCloud{}));
}

TEST(File, AtomicWriteLeavesNoTemporary) {
  const auto dir = rangeseg::test::scratch_dir("file");
  const std::string path = (dir / "a.bin").string();
  io::write_file_atomic(path, std::string("hello"));
  EXPECT_EQ(io::read_file(path).size(), 5u);
  EXPECT_THROW(io::write_file_atomic((dir / "missing" / "b.bin").string(), std::string("x")),
               std::runtime_error);
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);
  EXPECT_THROW(io::read_file((dir / "nope").string()), std::runtime_error);
  EXPECT_THROW(io::read_file(path, 2), std::runtime_error);
  EXPECT_EQ(io::extension("a/b.PCD"), ".pcd");
  // A name that fits, but not with the temporary's ".tmp.PID": the error says what to do.
  const std::string long_name = (dir / (std::string(250, 'n') + ".pcd")).string();
  try {
    io::write_file_atomic(long_name, std::string("x"));
    ADD_FAILURE() << "no error for a temporary's name over 255 bytes";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("shorten the name by"), std::string::npos) << e.what();
  }
}

// A group's files appear only together: a failure while writing one of them leaves every path
// with its earlier contents and no temporary behind.
TEST(File, AGroupOfFilesIsRenamedOnlyWhenAllAreWritten) {
  const auto dir = rangeseg::test::scratch_dir("file_group");
  const std::string a = (dir / "a.txt").string(), b = (dir / "b.txt").string();
  const auto text = [](const std::string& path) {
    const std::vector<std::uint8_t> bytes = io::read_file(path);
    return std::string(bytes.begin(), bytes.end());
  };
  const auto count = [&] {
    return std::distance(std::filesystem::directory_iterator(dir),
                         std::filesystem::directory_iterator());
  };
  io::write_file_atomic(a, std::string("old a"));
  io::write_file_atomic(b, std::string("old b"));
  {
    io::FileGroup group;
    io::write_file_atomic(a, std::string("new a"));
    EXPECT_EQ(text(a), "old a") << "renamed before the group's commit";
    EXPECT_EQ(count(), 3);  // a, b and a's temporary
    io::AtomicFile half(b);
    half.write("ne", 2);
    // an exception here: neither file is committed
  }
  EXPECT_EQ(text(a), "old a");
  EXPECT_EQ(text(b), "old b");
  EXPECT_EQ(count(), 2) << "a temporary was left behind";
  {
    io::FileGroup group;
    io::write_file_atomic(a, std::string("new a"));
    {
      io::FileGroup inner;  // dropped without its commit: only its own file is
      io::write_file_atomic(b, std::string("inner b"));
    }
    {
      io::FileGroup inner;  // committed: renamed with the outer group
      io::write_file_atomic(b, std::string("new b"));
      inner.commit();
    }
    EXPECT_EQ(text(b), "old b");
    group.commit();
    EXPECT_THROW(group.commit(), std::logic_error);
  }
  EXPECT_EQ(text(a), "new a");
  EXPECT_EQ(text(b), "new b");
  EXPECT_EQ(count(), 2);
  // A signal handler's clean-up removes a group's temporaries too; its commit then fails.
  io::FileGroup group;
  io::write_file_atomic(a, std::string("newer a"));
  EXPECT_EQ(count(), 3);
  io::remove_temporary_files();
  EXPECT_EQ(count(), 2);
  EXPECT_THROW(group.commit(), std::runtime_error);
  EXPECT_EQ(text(a), "new a");
}

// The radix sort must give exactly the order of a stable comparison sort of the float values,
// ties (including -0 against +0) in input order, also for negative and infinite keys.
TEST(RadixSort, EqualsStableSortOfTheFloatValues) {
  std::mt19937 random(7);
  for (const int n : {0, 1, 2, 5, 300, 5000}) {
    std::vector<float> values(static_cast<std::size_t>(n));
    std::uniform_real_distribution<float> uniform(-50.0f, 50.0f);
    for (float& v : values) {
      const auto pick = random() % 10;
      v = pick == 0   ? 0.0f
          : pick == 1 ? -0.0f
          : pick == 2 ? std::round(uniform(random))  // many ties
          : pick == 3 ? (random() % 2 == 0 ? INFINITY : -INFINITY)
          : pick == 4 ? uniform(random) * 1e-30f
                      : uniform(random);
    }
    std::vector<std::int32_t> expected(values.size());
    std::iota(expected.begin(), expected.end(), 0);
    std::stable_sort(expected.begin(), expected.end(),
                     [&](std::int32_t a, std::int32_t b) { return values[a] < values[b]; });
    std::vector<std::int32_t> items(values.size()), item_tmp;
    std::iota(items.begin(), items.end(), 0);
    std::vector<std::uint32_t> keys, key_tmp;
    for (const float v : values) keys.push_back(rangeseg::detail::float_order_key(v));
    rangeseg::detail::radix_sort_by_key(items, keys, item_tmp, key_tmp);
    EXPECT_EQ(items, expected) << n << " items";
    for (std::size_t j = 0; j < items.size(); ++j) {
      ASSERT_EQ(keys[j], rangeseg::detail::float_order_key(values[items[j]]));
    }
    // 64-bit keys: the value, then a small tie-breaker in the low bits.
    std::stable_sort(expected.begin(), expected.end(), [&](std::int32_t a, std::int32_t b) {
      return values[a] != values[b] ? values[a] < values[b] : a % 7 < b % 7;
    });
    std::iota(items.begin(), items.end(), 0);
    std::vector<std::uint64_t> wide, wide_tmp;
    for (std::size_t j = 0; j < values.size(); ++j) {
      wide.push_back(std::uint64_t{rangeseg::detail::float_order_key(values[j])} << 32 | j % 7);
    }
    rangeseg::detail::radix_sort_by_key(items, wide, item_tmp, wide_tmp);
    EXPECT_EQ(items, expected) << n << " items, 64-bit keys";
  }
  // The double key orders like the values, -0 and +0 alike.
  const double ordered[] = {-INFINITY, -1e300, -2.5, -1e-300, 0.0, 1e-300, 3.0, 1e300, INFINITY};
  for (std::size_t j = 0; j + 1 < std::size(ordered); ++j) {
    EXPECT_LT(rangeseg::detail::double_order_key(ordered[j]),
              rangeseg::detail::double_order_key(ordered[j + 1]));
  }
  EXPECT_EQ(rangeseg::detail::double_order_key(-0.0), rangeseg::detail::double_order_key(0.0));
}

// sort_distinct gives what std::sort + std::unique give: few distinct keys repeated many times
// (label pairs with the across-cut bit 63), all distinct, the empty-slot value ~0 among them,
// and a table reused from a larger call.
TEST(SortDistinct, EqualsSortAndUnique) {
  std::mt19937_64 random(11);
  std::vector<std::uint64_t> table;
  for (const int n : {5000, 0, 1, 2, 63, 64, 65, 300, 1000}) {
    for (const std::uint64_t distinct :
         {std::uint64_t{1}, std::uint64_t{7}, std::uint64_t{300}, ~std::uint64_t{0}}) {
      std::vector<std::uint64_t> keys(static_cast<std::size_t>(n));
      for (std::uint64_t& k : keys) {
        const std::uint64_t r = random() % distinct;
        k = distinct == ~std::uint64_t{0} ? random()
                                          : (r % 13) << 32 | (r / 13 + 20) | (r % 2) << 63;
        if (random() % 97 == 0) k = ~std::uint64_t{0};
      }
      std::vector<std::uint64_t> expected = keys;
      std::sort(expected.begin(), expected.end());
      expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
      rangeseg::detail::sort_distinct(keys, table);
      EXPECT_EQ(keys, expected) << n << " keys, " << distinct << " distinct values";
    }
  }
}
