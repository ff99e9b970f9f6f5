#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/matching/descriptor_matching.hpp>

using diachron::DescriptorMatch;
using diachron::DescriptorMatchOptions;
using diachron::DescriptorMatrix;
using diachron::DescriptorDistance;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double oracle_distance(const DescriptorMatrix& a, Eigen::Index i, const DescriptorMatrix& b, Eigen::Index j,
                       DescriptorDistance metric) {
  if (metric == DescriptorDistance::L2) {
    double s = 0;
    for (Eigen::Index c = 0; c < a.cols(); ++c) {
      const double d = static_cast<double>(a(i, c)) - b(j, c);
      s += d * d;
    }
    return std::sqrt(s);
  }
  double dot = 0, na = 0, nb = 0;
  for (Eigen::Index c = 0; c < a.cols(); ++c) {
    dot += static_cast<double>(a(i, c)) * b(j, c);
    na += static_cast<double>(a(i, c)) * a(i, c);
    nb += static_cast<double>(b(j, c)) * b(j, c);
  }
  if (na == 0 || nb == 0) return kInf;
  return std::sqrt(std::max(0.0, 2.0 - 2.0 * dot / std::sqrt(na * nb)));
}

struct Nn {
  Eigen::Index best = -1, second = -1;
  double d1 = kInf, d2 = kInf;
};

// Plain two-pass oracle: the nearest, then the nearest among the others (ties to the lower index).
Nn oracle_nn(const DescriptorMatrix& a, Eigen::Index i, const DescriptorMatrix& b, DescriptorDistance metric) {
  Nn r;
  for (Eigen::Index j = 0; j < b.rows(); ++j) {
    const double d = oracle_distance(a, i, b, j, metric);
    if (d < r.d1) {
      r.d1 = d;
      r.best = j;
    }
  }
  for (Eigen::Index j = 0; j < b.rows(); ++j) {
    if (j == r.best) continue;
    const double d = oracle_distance(a, i, b, j, metric);
    if (d < r.d2) {
      r.d2 = d;
      r.second = j;
    }
  }
  return r;
}

std::vector<DescriptorMatch> oracle_match(const DescriptorMatrix& q, const DescriptorMatrix& t,
                                          const DescriptorMatchOptions& o) {
  std::vector<DescriptorMatch> out;
  for (Eigen::Index i = 0; i < q.rows(); ++i) {
    const Nn f = oracle_nn(q, i, t, o.metric);
    if (f.best < 0 || f.d1 > o.max_distance) continue;
    if (o.ratio_test && !(f.d1 < o.ratio * f.d2)) continue;
    if (o.metric == DescriptorDistance::Cosine && 1.0 - 0.5 * f.d1 * f.d1 < o.min_similarity) continue;
    if (o.mutual || o.ratio_test_both_ways) {
      const Nn g = oracle_nn(t, f.best, q, o.metric);
      if (g.best != i) continue;
      if (o.ratio_test_both_ways && !(g.d1 < o.ratio * g.d2)) continue;
    }
    DescriptorMatch m;
    m.query = static_cast<std::size_t>(i);
    m.train = static_cast<std::size_t>(f.best);
    m.distance = f.d1;
    m.second_distance = f.d2;
    out.push_back(m);
  }
  return out;
}

DescriptorMatrix random_integer_descriptors(diachron::RandomStream& rng, int rows, int cols, int levels) {
  DescriptorMatrix m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = static_cast<float>(rng.uniform_index(static_cast<std::size_t>(levels)));
  return m;
}

void require_same(const std::vector<DescriptorMatch>& got, const std::vector<DescriptorMatch>& want,
                  double tol) {
  REQUIRE(got.size() == want.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    REQUIRE(got[k].query == want[k].query);
    REQUIRE(got[k].train == want[k].train);
    REQUIRE(got[k].distance == Approx(want[k].distance).margin(tol));
    if (std::isinf(want[k].second_distance))
      REQUIRE(std::isinf(got[k].second_distance));
    else
      REQUIRE(got[k].second_distance == Approx(want[k].second_distance).margin(tol));
  }
}

}  // namespace

TEST_CASE("match_descriptors: L2 equals a brute-force oracle, ties included", "[matching]") {
  diachron::RandomStream rng(11);
  for (int trial = 0; trial < 16; ++trial) {
    // Few integer levels in few dimensions: many exact ties, all distances exact in double. Some
    // sizes cross the 128-row query blocks and the 1024-row train blocks.
    const int nq = 1 + static_cast<int>(rng.uniform_index(trial % 4 == 0 ? 300 : 60));
    const int nt = 1 + static_cast<int>(rng.uniform_index(trial % 4 == 0 ? 1300 : 200));
    const int dims = 2 + static_cast<int>(rng.uniform_index(6));
    const DescriptorMatrix q = random_integer_descriptors(rng, nq, dims, 6);
    const DescriptorMatrix t = random_integer_descriptors(rng, nt, dims, 6);
    for (int variant = 0; variant < 4; ++variant) {
      DescriptorMatchOptions o;
      o.ratio_test = variant & 1;
      o.mutual = variant & 2;
      o.threads = 1 + static_cast<std::size_t>(trial % 3);
      INFO("trial " << trial << " variant " << variant);
      require_same(diachron::match_descriptors(q, t, o), oracle_match(q, t, o), 1e-9);
    }
  }
}

TEST_CASE("match_descriptors: cosine equals a brute-force oracle", "[matching]") {
  diachron::RandomStream rng(5);
  for (int trial = 0; trial < 4; ++trial) {
    DescriptorMatrix q(120, 32), t(300, 32);
    for (Eigen::Index i = 0; i < q.size(); ++i) q.data()[i] = static_cast<float>(rng.normal());
    for (Eigen::Index i = 0; i < t.size(); ++i) t.data()[i] = static_cast<float>(rng.normal());
    // Plant true correspondences: query k is a noisy copy of train 3k.
    for (Eigen::Index k = 0; k < 90; ++k)
      for (Eigen::Index c = 0; c < 32; ++c) q(k, c) = t(3 * k, c) * 2.0f + 0.2f * static_cast<float>(rng.normal());
    DescriptorMatchOptions o;
    o.metric = DescriptorDistance::Cosine;
    o.min_similarity = trial % 2 ? 0.9 : -1.0;
    o.ratio_test_both_ways = trial % 3 == 0;
    const auto got = diachron::match_descriptors(q, t, o);
    require_same(got, oracle_match(q, t, o), 1e-9);
    std::size_t planted = 0;
    for (const auto& m : got) {
      REQUIRE(m.score == Approx(1.0 - 0.5 * m.distance * m.distance));
      if (m.query < 90 && m.train == 3 * m.query) ++planted;
    }
    REQUIRE(planted >= 80);
  }
}

TEST_CASE("match_descriptors: the ratio test demotes the old best when the best changes late",
          "[matching]") {
  // Train rows at distances 5.5, 5, 100 from the query (1-D descriptors). The true second best is
  // 5.5 (ratio 0.91 > 0.8: ambiguous, rejected). MicMac's MatchOneWay never demotes 5.5 to second
  // and compares 5 with 100, accepting the match.
  DescriptorMatrix q(1, 1), t(3, 1);
  q << 0.0f;
  t << 5.5f, -5.0f, 100.0f;
  DescriptorMatchOptions o;
  o.mutual = false;
  REQUIRE(diachron::match_descriptors(q, t, o).empty());
  o.ratio_test = false;
  const auto all = diachron::match_descriptors(q, t, o);
  REQUIRE(all.size() == 1);
  REQUIRE(all[0].train == 1);
  REQUIRE(all[0].distance == 5.0);
  REQUIRE(all[0].second_distance == 5.5);
  // Distinct enough: accepted, whatever order the rows come in.
  t << 100.0f, 10.0f, -5.0f;
  o.ratio_test = true;
  const auto kept = diachron::match_descriptors(q, t, o);
  REQUIRE(kept.size() == 1);
  REQUIRE(kept[0].train == 2);
  REQUIRE(kept[0].second_distance == 10.0);
  REQUIRE(kept[0].score == -5.0);
}

TEST_CASE("match_descriptors: mutual nearest neighbours", "[matching]") {
  // q0 -> t0, but t0's nearest query is q1; q1 -> t0 is mutual.
  DescriptorMatrix q(2, 1), t(2, 1);
  q << 0.0f, 1.9f;
  t << 2.0f, 50.0f;
  DescriptorMatchOptions o;
  o.ratio_test = false;
  o.mutual = false;
  REQUIRE(diachron::match_descriptors(q, t, o).size() == 2);
  o.mutual = true;
  const auto m = diachron::match_descriptors(q, t, o);
  REQUIRE(m.size() == 1);
  REQUIRE(m[0].query == 1);
  REQUIRE(m[0].train == 0);
}

TEST_CASE("match_descriptors: two-way ratio test rejects train rows with two close queries",
          "[matching]") {
  // q0 and q1 are both close to t0; q0 is nearer, its own ratio test passes (t1 is far), but from
  // t0's side q0 and q1 are ambiguous.
  DescriptorMatrix q(2, 1), t(2, 1);
  q << 0.0f, 0.22f;
  t << 0.1f, 40.0f;
  DescriptorMatchOptions o;
  o.mutual = true;
  REQUIRE(diachron::match_descriptors(q, t, o).size() == 1);
  o.ratio_test_both_ways = true;
  REQUIRE(diachron::match_descriptors(q, t, o).empty());
}

TEST_CASE("match_descriptors: thresholds, empty inputs and bad input", "[matching]") {
  DescriptorMatrix q(2, 2), t(2, 2);
  q << 0, 0, 10, 0;
  t << 0, 1, 10, 5;
  DescriptorMatchOptions o;
  o.ratio_test = false;
  o.max_distance = 2.0;
  const auto m = diachron::match_descriptors(q, t, o);
  REQUIRE(m.size() == 1);
  REQUIRE(m[0].query == 0);
  REQUIRE(diachron::match_descriptors(DescriptorMatrix(0, 2), t, o).empty());
  REQUIRE(diachron::match_descriptors(q, DescriptorMatrix(0, 2), o).empty());
  REQUIRE_THROWS_AS(diachron::match_descriptors(q, DescriptorMatrix(2, 3), o), diachron::Error);
  DescriptorMatrix bad = t;
  bad(1, 1) = std::numeric_limits<float>::quiet_NaN();
  REQUIRE_THROWS_AS(diachron::match_descriptors(q, bad, o), diachron::Error);
  o.ratio = 1.5;
  REQUIRE_THROWS_AS(diachron::match_descriptors(q, t, o), diachron::Error);
  // Cosine: a zero row matches nothing.
  DescriptorMatchOptions c;
  c.metric = DescriptorDistance::Cosine;
  DescriptorMatrix z(1, 2);
  z << 0, 0;
  REQUIRE(diachron::match_descriptors(z, t, c).empty());
}

TEST_CASE("match_descriptors: same output for 1, 2 and all threads", "[matching]") {
  diachron::RandomStream rng(2);
  DescriptorMatrix q(400, 16), t(1100, 16);
  for (Eigen::Index i = 0; i < q.size(); ++i) q.data()[i] = static_cast<float>(rng.uniform01());
  for (Eigen::Index i = 0; i < t.size(); ++i) t.data()[i] = static_cast<float>(rng.uniform01());
  DescriptorMatchOptions o;
  o.threads = 1;
  const auto one = diachron::match_descriptors(q, t, o);
  REQUIRE(!one.empty());
  for (std::size_t threads : {2u, 0u}) {
    o.threads = threads;
    const auto other = diachron::match_descriptors(q, t, o);
    REQUIRE(other.size() == one.size());
    for (std::size_t k = 0; k < one.size(); ++k) {
      REQUIRE(other[k].query == one[k].query);
      REQUIRE(other[k].train == one[k].train);
      REQUIRE(other[k].distance == one[k].distance);
      REQUIRE(other[k].second_distance == one[k].second_distance);
    }
  }
}

TEST_CASE("root_sift: L1-normalise then square root", "[matching]") {
  // Built from rows, not with <<: GCC's -O1 flags the comma initialiser's copy as maybe uninitialised.
  const DescriptorMatrix d{{1, 3, 0, 0}, {0, 0, 0, 0}, {4, 4, 4, 4}};
  const DescriptorMatrix r = diachron::root_sift(d);
  REQUIRE(r(0, 0) == Approx(0.5));
  REQUIRE(r(0, 1) == Approx(std::sqrt(0.75)));
  REQUIRE(r(0, 2) == 0.0f);
  REQUIRE(r.row(1).squaredNorm() == 0.0f);
  for (int c = 0; c < 4; ++c) REQUIRE(r(2, c) == Approx(0.5));
  REQUIRE(r.row(0).norm() == Approx(1.0));
  REQUIRE(r.row(2).norm() == Approx(1.0));
  // Hellinger: the L2 distance of RootSIFT rows is sqrt(2 - 2 * sum sqrt(p q)).
  const double bc = std::sqrt(0.25 * 0.25) + std::sqrt(0.75 * 0.25);
  REQUIRE((r.row(0) - r.row(2)).norm() == Approx(std::sqrt(2.0 - 2.0 * bc)));
  DescriptorMatrix neg(1, 2);
  neg << 1, -1;
  REQUIRE_THROWS_AS(diachron::root_sift(neg), diachron::Error);
}

TEST_CASE("to_point_matches: positions and scores carried across", "[matching]") {
  diachron::Features a, b;
  a.keypoints.resize(2);
  b.keypoints.resize(3);
  a.keypoints[1].position = {10, 20};
  b.keypoints[2].position = {30, 40};
  DescriptorMatch m;
  m.query = 1;
  m.train = 2;
  m.score = 0.9;
  const auto pm = diachron::to_point_matches({m}, a, b);
  REQUIRE(pm.size() == 1);
  REQUIRE(pm[0].a == Eigen::Vector2d(10, 20));
  REQUIRE(pm[0].b == Eigen::Vector2d(30, 40));
  REQUIRE(pm[0].score == 0.9);
  m.train = 3;
  REQUIRE_THROWS_AS(diachron::to_point_matches({m}, a, b), diachron::Error);
}
