// ProgressClock and progress_line: elapsed time and the time left per stage, on a clock the test
// moves by hand.

#include <cmath>
#include <string>

#include <catch2/catch.hpp>

#include <diachron/core/progress.hpp>

using namespace diachron;

TEST_CASE("ProgressClock: elapsed time and a linear estimate of the time left, per stage", "[core]") {
  double now = 100.0;
  ProgressClock clock([&now] { return now; });
  ProgressTimes t = clock({"pairs", 0, 10});
  CHECK(t.elapsed_s == 0.0);
  CHECK(std::isnan(t.left_s));  // nothing done yet: no estimate
  now = 104.0;
  t = clock({"pairs", 2, 10});
  CHECK(t.elapsed_s == 4.0);
  CHECK(t.left_s == Approx(16.0));  // 2 s per unit, 8 units left
  // Another stage keeps its own start.
  now = 105.0;
  CHECK(clock({"tiles", 0, 4}).elapsed_s == 0.0);
  now = 110.0;
  t = clock({"pairs", 5, 10});
  CHECK(t.elapsed_s == 10.0);
  CHECK(t.left_s == Approx(10.0));
  CHECK(clock({"tiles", 1, 4}).left_s == Approx(15.0));
  now = 120.0;
  t = clock({"pairs", 10, 10});
  CHECK(t.elapsed_s == 20.0);
  CHECK(t.left_s == 0.0);
  // The same stage name after its last unit is a new run of the stage.
  now = 130.0;
  CHECK(clock({"pairs", 0, 3}).elapsed_s == 0.0);
  now = 133.0;
  CHECK(clock({"pairs", 1, 3}).left_s == Approx(6.0));
}

TEST_CASE("progress_line and format_duration: what the programs print", "[core]") {
  CHECK(format_duration(0.2) == "0 s");
  CHECK(format_duration(42.4) == "42 s");
  CHECK(format_duration(185.0) == "3 min 05 s");
  CHECK(format_duration(3720.0) == "1 h 02 min");
  CHECK(format_duration(std::nan("")) == "?");
  CHECK(format_duration(-1.0) == "?");
  ProgressTimes t;
  t.elapsed_s = 62.0;
  CHECK(progress_line({"pairs", 0, 34}, t) == "pairs: 0/34, 1 min 02 s");
  t.left_s = 130.0;
  CHECK(progress_line({"pairs", 13, 34}, t) == "pairs: 13/34, 1 min 02 s, about 2 min 10 s left");
  t.elapsed_s = 178.0;
  CHECK(progress_line({"pairs", 34, 34}, t) == "pairs: 34/34 in 2 min 58 s");
}
