// pliant bench's table (perf::format_table): the round-trip column, and the note it adds when
// cases on 2 threads ran with their threads far apart (docs/performance.md, Tools).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pliant/perf/suite.hpp"

namespace pliant::perf {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

Record scene_case(int threads, double round_trip_ns) {
  Record r;
  r.case_name = "scene/box1k";
  r.kind = "scene";
  r.model = "corotational";
  r.precision = "float";
  r.tets = 1152;
  r.threads = threads;
  r.ns_per_tet = 11.6;
  r.step_p50_us = 13.4;
  r.round_trip_ns = round_trip_ns;
  return r;
}

TEST(BenchTable, SaysWhenTwoThreadCasesRanWithTheirThreadsFarApart) {
  const std::vector<Record> near{scene_case(1, kNone), scene_case(2, 110)};
  const std::string a = format_table(near);
  EXPECT_THAT(a, HasSubstr("rt ns"));
  EXPECT_THAT(a, HasSubstr(" 110\n"));  // the case's round trip, last column
  EXPECT_THAT(a, Not(HasSubstr("far apart")));
  const std::vector<Record> mixed{scene_case(1, kNone), scene_case(2, 110), scene_case(2, 450)};
  EXPECT_THAT(format_table(mixed), HasSubstr("note: 1 of the 2 cases on 2+ threads ran with a cache-line round trip over 250 ns"));
}

// The machine's tail beside the step's (column floor99): a case's floor_p99_us printed between
// its p99 and its max.
TEST(BenchTable, PrintsTheFloorBesideTheStepP99) {
  Record r = scene_case(2, 110);
  r.step_p99_us = 54.6;
  r.floor_p99_us = 50.4;
  r.step_max_us = 138.5;
  const std::string t = format_table({r});
  EXPECT_THAT(t, HasSubstr("p99 us   floor99    max us"));
  EXPECT_THAT(t, HasSubstr("54.6      50.4     138.5"));
}

}  // namespace
}  // namespace pliant::perf
