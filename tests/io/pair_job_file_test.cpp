// Pair job results (io/pair_job_file.hpp) and the files under them (io/atomic_file.hpp,
// io/input_fingerprint.hpp): exact round trip, refusals, atomic writes, the lock between processes,
// fingerprints that change with the files.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/io/atomic_file.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/input_fingerprint.hpp>
#include <diachron/io/pair_job_file.hpp>

using namespace diachron;
using Catch::Matchers::Contains;

namespace {

std::string pair_job_test_dir() {
  const std::string dir = "/tmp/diachron_pair_job_test_" + std::to_string(::getpid());
  make_folders(dir, "test");
  return dir;
}

std::string pair_job_test_read(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("pair job results: written and read back bit for bit", "[io]") {
  const std::string dir = pair_job_test_dir();
  PairJobRecord r;
  r.plan_id = "0123456789abcdef";
  r.index = 17;
  r.master_epoch = "1954";
  r.secondary_epoch = "2015 \"new\"";
  r.master_image = "a/b.tif";
  r.secondary_image = "c\\d.tif";
  r.master = 3;
  r.secondary = 5;
  r.message = "line 1\nline 2";
  r.tentative = 512;
  r.masked = 2;
  r.grounded = 180;
  r.seconds = {0.1, 9.25, 0.2, 1.0 / 3.0, 10.5};
  RandomStream rng(5);
  for (int k = 0; k < 300; ++k) {
    const double ay = rng.uniform(0.0, 12000.0), ax = rng.uniform(0.0, 12000.0);
    const double by = rng.uniform(-5.0, 9000.0), bx = rng.uniform(-5.0, 9000.0);
    r.matches.push_back({Eigen::Vector2d(ax, ay), Eigen::Vector2d(bx, by), rng.uniform(-1.0, 1.0)});
  }
  r.success = true;
  write_pair_job(dir + "/job.json", r);
  const PairJobRecord b = read_pair_job(dir + "/job.json");
  CHECK(b.plan_id == r.plan_id);
  CHECK(b.index == r.index);
  CHECK(b.secondary_epoch == r.secondary_epoch);
  CHECK(b.secondary_image == r.secondary_image);
  CHECK(b.message == r.message);
  CHECK(b.tentative == 512);
  CHECK(b.grounded == 180);
  CHECK(b.seconds.ncc == r.seconds.ncc);
  REQUIRE(b.matches.size() == r.matches.size());
  for (std::size_t k = 0; k < r.matches.size(); ++k) {
    CHECK(b.matches[k].a == r.matches[k].a);  // exactly: 17 significant digits
    CHECK(b.matches[k].b == r.matches[k].b);
    CHECK(b.matches[k].score == r.matches[k].score);
  }
  // No temporary file left beside it.
  CHECK(folder_entries(dir) == std::vector<std::string>{"job.json"});
  std::remove((dir + "/job.json").c_str());
  ::rmdir(dir.c_str());
}

TEST_CASE("pair job results: what is not one is refused, naming the file", "[io]") {
  const std::string dir = pair_job_test_dir();
  const std::string path = dir + "/bad.json";
  CHECK_THROWS_WITH(read_pair_job(path), Contains("cannot read"));
  PairJobRecord r;
  r.plan_id = "p";
  write_pair_job(path, r);
  CHECK_NOTHROW(read_pair_job(path));
  const std::string good = pair_job_test_read(path);
  const auto refused = [&](const std::string& text, const std::string& what) {
    write_file_atomically(path, text);
    CHECK_THROWS_WITH(read_pair_job(path), Contains(path) && Contains(what));
  };
  refused(good.substr(0, good.size() / 2), "line");  // cut short: not JSON
  std::string other = good;
  other.replace(other.find("pair job 1"), 10, "pair job 9");
  refused(other, "another format");
  std::string no_matches = good;
  no_matches.replace(no_matches.find("\"matches\""), 9, "\"matchez\"");
  refused(no_matches, "\"matches\"");
  std::string lies = good;
  lies.replace(lies.find("\"success\": false"), 16, "\"success\": true ");
  refused(lies, "\"success\"");
  std::string negative = good;
  negative.replace(negative.find("\"tentative\": 0"), 14, "\"tentative\": -1");
  refused(negative, "not a count");
  std::remove(path.c_str());
  ::rmdir(dir.c_str());
}

TEST_CASE("FileLock: one process at a time; released when its holder ends", "[io]") {
  const std::string dir = pair_job_test_dir();
  const std::string path = dir + "/job.lock";
  std::optional<FileLock> held = FileLock::try_lock(path);
  REQUIRE(held);
  // Another process cannot take it (record locks belong to processes: a child tries).
  const auto child_gets_lock = [&] {
    const pid_t pid = ::fork();
    if (pid == 0) ::_exit(FileLock::try_lock(path) ? 0 : 3);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
  };
  CHECK_FALSE(child_gets_lock());
  held->remove_and_release();
  CHECK_FALSE(is_regular_file(path));
  CHECK(child_gets_lock());
  ::unlink(path.c_str());
  ::rmdir(dir.c_str());
}

TEST_CASE("temporary_sibling: beside the file, per process, extension kept on request", "[io]") {
  const std::string t = temporary_sibling("/x/y/picture.jpg", ".jpg");
  CHECK(t.rfind("/x/y/picture.part-", 0) == 0);
  CHECK(t.size() > 4);
  CHECK(t.compare(t.size() - 4, 4, ".jpg") == 0);
  CHECK(t.find(std::to_string(::getpid())) != std::string::npos);
  CHECK(temporary_sibling("/x/a.json").rfind("/x/a.json.part-", 0) == 0);
}

TEST_CASE("files_fingerprint: changes with a file's size, time, presence", "[io]") {
  const std::string dir = pair_job_test_dir();
  const std::string a = dir + "/a.txt", b = dir + "/b.txt";
  write_file_atomically(a, "alpha");
  write_file_atomically(b, "beta");
  const std::string f0 = files_fingerprint({a, b});
  CHECK(f0.size() == 16);
  CHECK(files_fingerprint({a, b}) == f0);
  CHECK(files_fingerprint({b, a}) != f0);  // the order is the caller's
  write_file_atomically(b, "beta!");     // grown
  const std::string f1 = files_fingerprint({a, b});
  CHECK(f1 != f0);
  struct timespec times[2] = {{0, UTIME_OMIT}, {1000000, 5}};  // the same size, another time
  REQUIRE(::utimensat(AT_FDCWD, a.c_str(), times, 0) == 0);
  CHECK(files_fingerprint({a, b}) != f1);
  std::remove(b.c_str());
  CHECK(files_fingerprint({a, b}) != f1);  // gone
  CHECK(file_stamp(b).size == -1);
  CHECK(fingerprint_text("") == "cbf29ce484222325");  // FNV-1a 64 of nothing: its offset basis
  std::remove(a.c_str());
  ::rmdir(dir.c_str());
}
