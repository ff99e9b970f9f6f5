// expect: Sample must be exactly std::array<Datum, kSampleSize>
// A std::vector Sample used to compile and write past the end of an empty vector in Ransac.
#include <cstddef>
#include <vector>

#include <diachron/core/static_vector.hpp>
#include <diachron/robust/ransac.hpp>

struct VectorSample {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::vector<Datum>;
  using Models = diachron::StaticVector<Model, kMaxModels>;
  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return datum - model; }
};

int main() { return diachron::Ransac<VectorSample>().options().seed == 0 ? 0 : 1; }
